//! What happened during a tick, for telemetry, logs and the trip CSV.

use crate::branching::BranchChoice;
use crate::vehicle::VehicleId;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DespawnReason {
    /// Drove off the end of a lane with no successor.
    DeadEnd,
    /// Reached the end of a route that leaves the map there (a SUMO demand).
    RouteEnd,
    /// RemoveVehiclesInRadius.
    Removed,
    /// Restart disposed of it.
    Restart,
    /// Stood still for the jam timeout and was taken off the road (SUMO's
    /// teleport as the last resort against gridlock).
    Jammed,
}

impl DespawnReason {
    pub fn as_str(self) -> &'static str {
        match self {
            DespawnReason::DeadEnd => "dead_end",
            DespawnReason::RouteEnd => "route_end",
            DespawnReason::Removed => "removed",
            DespawnReason::Restart => "restart",
            DespawnReason::Jammed => "jammed",
        }
    }
}

/// One row of the trip CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct TripRecord {
    pub id: VehicleId,
    pub kind: String,
    pub spawn_time: f64,
    /// When it was due to depart; the departure delay is `spawn_time - depart`.
    pub depart: f64,
    pub despawn_time: f64,
    /// Seconds lost against driving at the lanes' speed limits throughout.
    pub time_loss: f64,
    pub distance: f64,
    pub stops: u32,
    pub time_stopped: f64,
    pub reason: DespawnReason,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SimEvent {
    Spawned {
        id: VehicleId,
        kind: String,
        lane: u32,
        time: f64,
    },
    Despawned(TripRecord),
    ZebraStop {
        id: VehicleId,
        area: usize,
        distance: f64,
    },
    ZebraClear {
        id: VehicleId,
        area: usize,
    },
    BranchDecision {
        id: VehicleId,
        choice: BranchChoice,
    },
}
