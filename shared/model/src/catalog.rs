//! Vehicle kinds ("prefabs"): the bounding boxes of AWSIM's shipped NPC vehicles.

use serde::{Deserialize, Serialize};

/// A vehicle kind's footprint, in metres, in the vehicle frame whose origin is the
/// rear axle and whose +x points forward.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleKind {
    pub name: String,
    /// Distance from the origin to the front bumper.
    pub front: f64,
    /// Bumper-to-bumper length.
    pub length: f64,
    pub width: f64,
    /// This type's driver model; None takes the run's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub driver: Option<crate::DriverModel>,
}

/// (name, bounds centre z, extents x, extents z) of the shipped prefabs.
const BUILTIN: [(&str, f64, f64, f64); 5] = [
    ("Taxi", 1.12, 0.97, 2.32),
    ("Hatchback", 1.43, 0.97, 2.01),
    ("SmallCar", 1.12, 0.91, 1.74),
    ("Van", 1.12, 0.97, 2.32),
    ("Truck_2t", -0.01, 1.54, 4.60),
];

/// Names of the built-in kinds, in catalogue order.
pub fn builtin_names() -> impl Iterator<Item = &'static str> {
    BUILTIN.iter().map(|b| b.0)
}

/// The built-in kind with this name (case-insensitive), if any.
pub fn builtin_kind(name: &str) -> Option<VehicleKind> {
    BUILTIN.iter().find(|b| b.0.eq_ignore_ascii_case(name)).map(
        |&(name, center_z, ext_x, ext_z)| VehicleKind {
            name: name.to_string(),
            front: center_z + ext_z,
            length: 2.0 * ext_z,
            width: 2.0 * ext_x,
            driver: None,
        },
    )
}
