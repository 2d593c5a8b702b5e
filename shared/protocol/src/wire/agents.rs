//! Pedestrians and cyclists on the bus, and the blocked-stop query.

use serde::{Deserialize, Serialize};

/// `<cluster>/agents/<source>`: every agent of one source; an agent missing
/// from the next batch of its source is gone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AgentBatch {
    pub time: f64,
    pub agents: Vec<Agent>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Agent {
    pub id: String,
    /// The character's root object name (counted once however many colliders).
    pub root: String,
    /// One of the AWSIM reference's detected component types (NPCPedestrian,
    /// SimpleCyclistMovement, BicycleMoveRotate, ClearWaypointFollower,
    /// WaypointFollower); anything else is not counted.
    #[serde(rename = "type")]
    pub kind: String,
    /// Footprint polygon in the map frame, at least three points.
    pub footprint: Vec<[f64; 2]>,
}

impl Agent {
    pub fn problem(&self) -> Option<String> {
        if self.footprint.len() < 3 {
            return Some(format!(
                "agent '{}': footprint needs at least 3 points",
                self.id
            ));
        }
        if self.footprint.iter().flatten().any(|c| !c.is_finite()) {
            return Some(format!(
                "agent '{}': footprint has a coordinate that is not a finite number",
                self.id
            ));
        }
        None
    }
}

/// Query payload of `<cluster>/crosswalks/blocked_stop` (TryGetBlockedStop).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlockedStopQuery {
    pub x: f64,
    pub y: f64,
    /// Forward direction as a yaw (radians).
    pub yaw: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockedStopAnswer {
    pub blocked: bool,
    /// Distance to the stop point minus the buffer (absent when not blocked).
    pub distance: Option<f64>,
    pub area: Option<String>,
}
