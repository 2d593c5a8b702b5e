//! States the lights and crosswalks services publish, the ego pose, overrides
//! and every service's status.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use trafficmesh_model::{LightColor, LightProgram};

/// `<cluster>/lights/state/<group>`: published when the colour changes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightState {
    pub group: String,
    pub color: LightColor,
    /// Simulation time of the next change; `null` when forced.
    pub next_change: Option<f64>,
    /// Until when this state may be used; after it, a stepper counts the group red.
    pub valid_until: f64,
    pub forced: bool,
    /// The program an override put the group on; absent while it runs the
    /// map's own (or is forced). Lets other services that follow the
    /// signals (the walkers' walk signals) keep to the same program.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub program: Option<LightProgram>,
}

/// `<cluster>/lights/heartbeat` and `<cluster>/crosswalks/heartbeat`: extends the
/// validity of every state the service published.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Heartbeat {
    pub time: f64,
    pub valid_until: f64,
}

/// Query payload of `<cluster>/lights/override`: force a colour, give a new
/// program, or (both absent) go back to the map's program.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightOverride {
    pub group: String,
    #[serde(default)]
    pub color: Option<LightColor>,
    #[serde(default)]
    pub program: Option<LightProgram>,
}

/// `<cluster>/crosswalks/occupancy/<area>`: published when the occupant set changes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CrosswalkOccupancy {
    pub area: String,
    pub occupied: bool,
    /// Counted occupant roots (one per character, whitelisted, detected types).
    pub occupants: Vec<String>,
    pub valid_until: f64,
}

/// `<cluster>/ego`: the ego vehicle's rear-axle pose and footprint.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EgoPose {
    pub x: f64,
    pub y: f64,
    #[serde(default)]
    pub z: f64,
    pub yaw: f64,
    #[serde(default = "default_ego_length")]
    pub length: f64,
    #[serde(default = "default_ego_width")]
    pub width: f64,
    /// Rear axle to front bumper.
    #[serde(default = "default_ego_front")]
    pub front_offset: f64,
}

fn default_ego_length() -> f64 {
    4.9
}
fn default_ego_width() -> f64 {
    1.9
}
fn default_ego_front() -> f64 {
    3.8
}

impl EgoPose {
    /// The first field that is not a finite number, or a size that is not positive.
    pub fn problem(&self) -> Option<String> {
        let fields = [
            ("x", self.x),
            ("y", self.y),
            ("z", self.z),
            ("yaw", self.yaw),
            ("length", self.length),
            ("width", self.width),
            ("front_offset", self.front_offset),
        ];
        if let Some(name) = super::first_non_finite(&fields) {
            return Some(format!("{name} is not a finite number"));
        }
        if self.length <= 0.0 || self.width <= 0.0 {
            return Some("length and width must be positive".into());
        }
        None
    }
}

/// `<cluster>/status/<service>`: once a second, and as the answer to a get.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ServiceStatus {
    pub service: String,
    /// The host it runs on (its hostname).
    #[serde(default)]
    pub host: String,
    pub pid: u32,
    /// Simulation time the service last saw.
    pub time: f64,
    /// Payloads dropped because they could not be used, in total and by key.
    pub bad_payloads: u64,
    pub bad_payloads_by_key: BTreeMap<String, u64>,
    /// Service-specific counters.
    #[serde(default)]
    pub details: serde_json::Value,
    /// The fingerprint of the map the service runs (16 hex digits), for
    /// services that address lanes; services refuse a stepper with another.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
    /// The Zenoh sessions it is linked to, by id: `router <zid>` or `peer <zid>`.
    #[serde(default)]
    pub peers: Vec<String>,
}
