//! Every key of a cluster, declared once with the types it carries. A key is
//! a pattern below the cluster name; `{name}` stands for one chunk that the
//! user names (a light group, an area, a service). [`crate::Keys`] builds the
//! keys from these declarations, and a test holds docs/cluster.md's key table
//! to them.

use std::marker::PhantomData;

use trafficmesh_model::TrafficSpawnConfig;

use crate::wire::{
    AgentBatch, Answer, BlockedStopAnswer, BlockedStopQuery, Clock, CrosswalkOccupancy, EgoPose,
    EventBatch, Heartbeat, IntersectionView, LightOverride, LightState, LockstepTick,
    ProposalBatch, ProposalResult, RemoveAnswer, RemoveTarget, RestartAnswer, RestartRequest,
    Round, ServiceStatus, SessionObjects, SpawnAnswer, SpawnBatch, TickReport, VehicleBatch,
};

/// How a key is used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Samples put by its owner.
    Put,
    /// Samples put by its owner, and the current value answered on a query.
    PutAndQuery,
    /// A query with a request and an answer.
    Query,
    /// A liveliness token.
    Liveliness,
}

/// A key carrying `T`.
pub struct Topic<T> {
    pub pattern: &'static str,
    pub kind: Kind,
    payload: PhantomData<fn() -> T>,
}

// By hand: a derive would ask `T: Clone` of the payload type.
impl<T> Clone for Topic<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Topic<T> {}

impl<T> Topic<T> {
    const fn new(pattern: &'static str, kind: Kind) -> Self {
        Topic {
            pattern,
            kind,
            payload: PhantomData,
        }
    }

    fn declared(&self) -> Declared {
        Declared {
            pattern: self.pattern,
            kind: self.kind,
            payload: short_name::<T>(),
            answer: None,
        }
    }
}

/// A query key taking `Req` and answering `Resp`.
pub struct Call<Req, Resp> {
    pub pattern: &'static str,
    types: PhantomData<fn(Req) -> Resp>,
}

impl<Req, Resp> Call<Req, Resp> {
    const fn new(pattern: &'static str) -> Self {
        Call {
            pattern,
            types: PhantomData,
        }
    }

    fn declared(&self) -> Declared {
        Declared {
            pattern: self.pattern,
            kind: Kind::Query,
            payload: short_name::<Req>(),
            answer: Some(short_name::<Resp>()),
        }
    }
}

/// What every declaration has: its pattern.
pub trait Pattern {
    fn pattern(&self) -> &'static str;
}

impl<T> Pattern for Topic<T> {
    fn pattern(&self) -> &'static str {
        self.pattern
    }
}

impl<Req, Resp> Pattern for Call<Req, Resp> {
    fn pattern(&self) -> &'static str {
        self.pattern
    }
}

/// A declaration with its types by name, for tables and checks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Declared {
    pub pattern: &'static str,
    pub kind: Kind,
    pub payload: &'static str,
    pub answer: Option<&'static str>,
}

fn short_name<T>() -> &'static str {
    let full = std::any::type_name::<T>();
    full.rsplit("::").next().unwrap_or(full)
}

/// No payload (a query that asks without a body).
pub struct Empty;
/// A file's text (the branch-decision CSV, `text/csv`).
pub struct Text;
/// A JSON object described in docs/cluster.md (the spawn config's file name).
pub struct Json;

pub const CLOCK: Topic<Clock> = Topic::new("clock", Kind::Put);
pub const VEHICLES: Topic<VehicleBatch> = Topic::new("vehicles", Kind::Put);
pub const EVENTS: Topic<EventBatch> = Topic::new("events", Kind::Put);
pub const EGO: Topic<EgoPose> = Topic::new("ego", Kind::Put);
pub const STEPPER_SPAWN: Call<SpawnBatch, SpawnAnswer> = Call::new("stepper/spawn");
pub const STEPPER_REMOVE: Call<RemoveTarget, RemoveAnswer> = Call::new("stepper/remove");
pub const STEPPER_RESTART: Call<RestartRequest, RestartAnswer> = Call::new("stepper/restart");
pub const SPAWN_CONFIG: Topic<TrafficSpawnConfig> = Topic::new("spawner/config", Kind::PutAndQuery);
pub const SPAWN_CONFIG_SET: Call<TrafficSpawnConfig, TrafficSpawnConfig> =
    Call::new("spawner/config/set");
pub const SPAWN_CONFIG_SAVE: Call<Empty, Json> = Call::new("spawner/config/save");
pub const SPAWN_CONFIG_LOAD: Call<Empty, TrafficSpawnConfig> = Call::new("spawner/config/load");
pub const BRANCH_CSV: Call<Empty, Text> = Call::new("spawner/branch_csv");
pub const SPAWNER_REMOVE: Call<RemoveTarget, RemoveAnswer> = Call::new("spawner/remove");
pub const SPAWNER_RESTART: Call<RestartRequest, RestartAnswer> = Call::new("spawner/restart");
pub const PROPOSALS: Topic<ProposalBatch> = Topic::new("simulators/{name}/proposals", Kind::Put);
pub const PROPOSAL_RESULTS: Topic<ProposalResult> =
    Topic::new("simulators/{name}/results", Kind::Put);
pub const LIGHT_STATE: Topic<LightState> = Topic::new("lights/state/{group}", Kind::PutAndQuery);
pub const LIGHTS_HEARTBEAT: Topic<Heartbeat> = Topic::new("lights/heartbeat", Kind::Put);
pub const LIGHTS_OVERRIDE: Call<LightOverride, LightState> = Call::new("lights/override");
pub const AGENTS: Topic<AgentBatch> = Topic::new("agents/{source}", Kind::Put);
pub const OCCUPANCY: Topic<CrosswalkOccupancy> =
    Topic::new("crosswalks/occupancy/{area}", Kind::PutAndQuery);
pub const CROSSWALKS_HEARTBEAT: Topic<Heartbeat> = Topic::new("crosswalks/heartbeat", Kind::Put);
pub const BLOCKED_STOP: Call<BlockedStopQuery, BlockedStopAnswer> =
    Call::new("crosswalks/blocked_stop");
pub const INTERSECTION_ROUND: Call<Round, Answer> = Call::new("intersection/round");
pub const INTERSECTION_VIEW: Topic<IntersectionView> = Topic::new("intersection/view", Kind::Put);
pub const LOCKSTEP_STEP: Call<LockstepTick, TickReport> = Call::new("lockstep/step/{member}");
pub const LOCKSTEP_AGENTS: Call<LockstepTick, AgentBatch> = Call::new("lockstep/agents/{source}");
pub const TRAFFIC_SESSION: Topic<SessionObjects> =
    Topic::new("traffic/{session}/objects", Kind::Put);
pub const STATUS: Topic<ServiceStatus> = Topic::new("status/{service}", Kind::PutAndQuery);
pub const ALIVE: Topic<Empty> = Topic::new("alive/{service}", Kind::Liveliness);

/// Every key of a cluster.
pub fn all() -> Vec<Declared> {
    vec![
        CLOCK.declared(),
        VEHICLES.declared(),
        EVENTS.declared(),
        EGO.declared(),
        STEPPER_SPAWN.declared(),
        STEPPER_REMOVE.declared(),
        STEPPER_RESTART.declared(),
        SPAWN_CONFIG.declared(),
        SPAWN_CONFIG_SET.declared(),
        SPAWN_CONFIG_SAVE.declared(),
        SPAWN_CONFIG_LOAD.declared(),
        BRANCH_CSV.declared(),
        SPAWNER_REMOVE.declared(),
        SPAWNER_RESTART.declared(),
        PROPOSALS.declared(),
        PROPOSAL_RESULTS.declared(),
        LIGHT_STATE.declared(),
        LIGHTS_HEARTBEAT.declared(),
        LIGHTS_OVERRIDE.declared(),
        AGENTS.declared(),
        OCCUPANCY.declared(),
        CROSSWALKS_HEARTBEAT.declared(),
        BLOCKED_STOP.declared(),
        INTERSECTION_ROUND.declared(),
        INTERSECTION_VIEW.declared(),
        LOCKSTEP_STEP.declared(),
        LOCKSTEP_AGENTS.declared(),
        TRAFFIC_SESSION.declared(),
        STATUS.declared(),
        ALIVE.declared(),
    ]
}
