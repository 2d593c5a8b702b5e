//! Spawn requests, external proposals, removal and restart.

use serde::{Deserialize, Serialize};

/// Query payload of `<cluster>/stepper/spawn`: this tick's winners, in order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpawnBatch {
    pub max_vehicles: usize,
    pub orders: Vec<SpawnOrder>,
}

/// One spawn. Lanes go by their index in the map, as on the whole bus:
/// every service reports its map's fingerprint, and one on another map
/// stops instead of naming other lanes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpawnOrder {
    pub lane: u32,
    pub kind: String,
    /// The lanes of its way, the spawn lane first.
    #[serde(default)]
    pub route: Option<Vec<u32>>,
    /// Leave the map at the route's end (a SUMO demand) instead of driving on.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub leave_at_route_end: bool,
    /// The kind itself when it is not a built-in one (a route file's vType),
    /// so that the stepper need not read the route files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind_def: Option<trafficmesh_model::VehicleKind>,
    /// A timetable's departure time, for the departure delay.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depart: Option<f64>,
}

/// The stepper's answer: one verdict per order, same order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpawnAnswer {
    pub verdicts: Vec<SpawnVerdict>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum SpawnVerdict {
    Spawned { id: u64 },
    MaxVehicles,
    NotSpawnable,
    Invalid { reason: String },
}

/// `<cluster>/simulators/<name>/proposals`: an external traffic simulator's
/// current proposals (GetRandomSpawnInfo). Each message replaces the last;
/// a proposal stays pending until it spawns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProposalBatch {
    /// Added to the anti-starvation counter when proposals compete for a lane.
    #[serde(default)]
    pub priority: i64,
    pub proposals: Vec<ExternalProposal>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalProposal {
    /// The simulator's own tag, echoed in the result.
    pub tag: String,
    pub lane: String,
    pub kind: String,
    #[serde(default)]
    pub route: Option<Vec<String>>,
}

/// `<cluster>/simulators/<name>/results`: a proposal of that simulator spawned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProposalResult {
    pub tag: String,
    pub id: u64,
    pub time: f64,
}

/// Query payload of `<cluster>/spawner/remove` and `<cluster>/stepper/remove`
/// (RemoveVehiclesInRadius).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "around", rename_all = "snake_case", deny_unknown_fields)]
pub enum RemoveTarget {
    Point {
        x: f64,
        y: f64,
        #[serde(default)]
        z: f64,
        radius: f64,
    },
    Ego {
        radius: f64,
    },
    Vehicle {
        id: u64,
    },
}

impl RemoveTarget {
    pub fn problem(&self) -> Option<String> {
        let bad = |fields: &[(&'static str, f64)]| {
            super::first_non_finite(fields).map(|n| format!("{n} is not a finite number"))
        };
        match *self {
            RemoveTarget::Point { x, y, z, radius } => {
                bad(&[("x", x), ("y", y), ("z", z), ("radius", radius)])
                    .or_else(|| (radius < 0.0).then(|| "radius must not be negative".into()))
            }
            RemoveTarget::Ego { radius } => bad(&[("radius", radius)])
                .or_else(|| (radius < 0.0).then(|| "radius must not be negative".into())),
            RemoveTarget::Vehicle { .. } => None,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RemoveAnswer {
    pub removed: usize,
}

/// Query payload of `<cluster>/spawner/restart` and `<cluster>/stepper/restart`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RestartRequest {
    pub max_vehicles: usize,
    /// A new random seed for what follows; None keeps the run's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RestartAnswer {
    pub disposed: usize,
    pub max_vehicles: usize,
    /// The last tick before the restart: clocks and batches of this tick or
    /// earlier show the old run.
    #[serde(default)]
    pub after_tick: u64,
}
