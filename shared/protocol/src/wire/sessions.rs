//! The traffic service's sessions on the bus, for viewers: each answer's
//! actors (`traffic/{session}/objects`).

use serde::{Deserialize, Serialize};

/// One session's actors at the time a runtime asked for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SessionObjects {
    pub session: String,
    pub map_id: String,
    pub time_us: u64,
    pub objects: Vec<SessionObject>,
}

/// An actor's box: centre in the map frame, heading, size, and who moves it
/// (`log` before handover, `model` after, `client` when the runtime sends
/// its poses, `static`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SessionObject {
    pub id: String,
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub yaw: f64,
    pub length: f64,
    pub width: f64,
    pub height: f64,
    pub driver: String,
}
