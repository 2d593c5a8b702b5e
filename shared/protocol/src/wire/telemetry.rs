//! What the stepper publishes every tick: the clock, the vehicle batch, events.

use serde::{Deserialize, Serialize};

use trafficmesh_model::{SpeedMode, TurnSignal, YieldPhase};

/// `<cluster>/clock`: one per tick.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    pub tick: u64,
    /// Simulation time after the tick.
    pub time: f64,
    pub dt: f64,
    pub vehicles: usize,
    /// Wall time the tick's computation took, milliseconds.
    pub tick_ms: f64,
    /// Ticks per wall-clock second over the last second.
    pub tick_rate: f64,
}

/// `<cluster>/vehicles`: every vehicle after a tick.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleBatch {
    pub tick: u64,
    pub time: f64,
    /// Wall clock at publication, microseconds since the Unix epoch (for latency).
    pub sent_unix_us: u64,
    pub vehicles: Vec<VehicleState>,
}

/// One vehicle. Lanes and kinds are indices, into the map file's `lanes`
/// array and into the vehicle catalogue (the built-in kinds, then the map's
/// own), to keep a batch of 10,000 vehicles small.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleState {
    pub id: u64,
    pub kind: u16,
    pub lane: u32,
    /// Front-bumper arc length on `lane`, metres.
    pub s: f32,
    pub x: f32,
    pub y: f32,
    pub z: f32,
    pub yaw: f32,
    pub speed: f32,
    pub accel: f32,
    pub length: f32,
    pub width: f32,
    pub mode: SpeedMode,
    pub yield_phase: YieldPhase,
    pub signal: TurnSignal,
    /// IsZebraBlocked and DistanceToZebraStop.
    pub zebra_blocked: bool,
    /// Distance ahead the obstacle check covers this tick (the debug layer's ray).
    pub check_distance: f32,
    /// How far the front bumper lies ahead of (x, y) along the heading: (x, y)
    /// is the reference point (the rear axle, AWSIM's pose), so the box's
    /// centre is `front_offset - length / 2` ahead of it. NaN from a
    /// version-1 batch, which did not carry it.
    pub front_offset: f32,
}

/// `<cluster>/events`: what happened during one tick, when anything did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventBatch {
    pub tick: u64,
    pub time: f64,
    pub events: Vec<Event>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Event {
    Spawned {
        id: u64,
        kind: String,
        lane: String,
    },
    Despawned {
        id: u64,
        kind: String,
        reason: String,
        spawn_time: f64,
        distance: f64,
        stops: u32,
        time_stopped: f64,
    },
    ZebraStop {
        id: u64,
        vehicle: String,
        area: String,
        distance: f64,
    },
    ZebraClear {
        id: u64,
        vehicle: String,
        area: String,
    },
    /// `from` and `to` by name, for readers; `from_lane` and `to_lane` by
    /// index, for the spawner's statistics.
    BranchDecision {
        id: u64,
        from: String,
        to: String,
        from_lane: u32,
        to_lane: u32,
        mode: String,
        configured_weight: f64,
        probability: f64,
    },
}
