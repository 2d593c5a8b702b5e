//! The reservation intersections as the intersection service sees them, for
//! the live map: the rectangles reserved ahead in time and each approach's
//! head waiting for a way. (The round and answer themselves are
//! `trafficmesh_model::reservation`'s.)

use serde::{Deserialize, Serialize};

pub use trafficmesh_model::reservation::{Answer, Round};

/// Every reservation intersection at simulated time `time`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IntersectionView {
    pub time: f64,
    pub reserved: Vec<ReservedBox>,
    pub approaches: Vec<ApproachQueue>,
}

/// A rectangle reserved for `vehicle`, `ahead_s` seconds from `time`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReservedBox {
    pub intersection: u32,
    pub vehicle: u64,
    pub ahead_s: f64,
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
    pub length: f64,
    pub width: f64,
}

/// An approach lane (its index in the map) and how long its head has been
/// waiting for a way (0: none waits).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ApproachQueue {
    pub intersection: u32,
    pub lane: u32,
    pub head_waiting_s: f64,
}
