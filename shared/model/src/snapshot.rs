//! A world's road as saved by the stepper to resume after a restart: the
//! time, and each vehicle where it stood, by the names of its lanes and
//! kind, so that a snapshot outlives the process and names what it means.

use serde::{Deserialize, Serialize};

/// The road at one tick.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoadSnapshot {
    /// The fingerprint of the map (16 hex digits): a snapshot of another
    /// map is refused.
    pub map: String,
    pub tick: u64,
    /// Simulation time, seconds.
    pub time: f64,
    /// The id the next new vehicle gets.
    pub next_id: u64,
    pub vehicles: Vec<VehicleSnapshot>,
}

/// One vehicle: its lanes from the one it is on through those it has chosen
/// ahead, where its front bumper is on the first, its speed, and its route.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleSnapshot {
    pub id: u64,
    pub kind: String,
    pub path: Vec<String>,
    /// The lanes its body still covers behind `path[0]`, the latest first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub behind: Vec<String>,
    /// Front bumper arc length on `path[0]`, metres.
    pub s: f64,
    pub speed: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub route: Option<RouteSnapshot>,
}

/// A vehicle's route: its lanes, the index of the last one put on its path,
/// and whether it leaves at the route's end.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RouteSnapshot {
    pub lanes: Vec<String>,
    pub index: usize,
    pub leave_at_end: bool,
}
