//! Lockstep: the stepper asks every member for its inputs before each tick
//! and starts the tick only when they have answered, so that the cluster runs
//! as one deterministic simulation at any speed (docs/cluster.md, "Lockstep").

use serde::{Deserialize, Serialize};

use super::{CrosswalkOccupancy, Heartbeat, LightState, SpawnBatch, SpawnVerdict};
use trafficmesh_model::TrafficSpawnConfig;

/// Query payload of `<cluster>/lockstep/step/*` (stepper → members) and
/// `<cluster>/lockstep/agents/*` (crosswalks → agent sources, which answer
/// with their `AgentBatch` after that tick's step): the tick about to start,
/// at `time`, `dt` long.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LockstepTick {
    pub tick: u64,
    pub time: f64,
    pub dt: f64,
    /// The verdicts on the spawner's orders of the tick before, in order.
    #[serde(default)]
    pub spawn_verdicts: Vec<SpawnVerdict>,
}

/// A member's answer on `<cluster>/lockstep/step/<member>`: what the stepper
/// applies before the tick. A member's states reach the stepper only this way
/// while it keeps in step (its ordinary publications are for everyone else).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TickReport {
    /// The groups whose colour changed, and the heartbeat when one is due
    /// (every validity/4, as on `lights/heartbeat`).
    Lights {
        changed: Vec<LightState>,
        #[serde(default)]
        heartbeat: Option<Heartbeat>,
    },
    /// The areas whose occupants changed, and the heartbeat when one is due.
    Crosswalks {
        changed: Vec<CrosswalkOccupancy>,
        #[serde(default)]
        heartbeat: Option<Heartbeat>,
    },
    /// This tick's spawn orders, and the spawn config when it changed since
    /// the last answer (always in the first).
    Spawner {
        orders: SpawnBatch,
        #[serde(default)]
        config: Option<TrafficSpawnConfig>,
    },
    /// Any other process that keeps in step (an external simulator): the
    /// stepper only waits for it.
    Ready,
}
