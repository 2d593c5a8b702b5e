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
    /// This type's own parameters for the `realistic` model (a SUMO vType's
    /// accel, decel, minGap, tau and maxSpeed), used whenever it drives by it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub idm: Option<crate::IdmParams>,
    /// The vehicle class (SUMO's vClass) that lane permissions are checked
    /// against; None: `passenger`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
}

/// The class of a kind without one of its own.
pub const DEFAULT_VEHICLE_CLASS: &str = "passenger";

/// SUMO's class that may drive on every lane, whatever it allows.
pub const IGNORING_CLASS: &str = "ignoring";

/// May a vehicle of `class` drive on a lane that allows `allowed` (empty: all)?
pub fn class_allowed(allowed: &[String], class: &str) -> bool {
    allowed.is_empty() || class == IGNORING_CLASS || allowed.iter().any(|a| a == class)
}

/// The largest road vehicle a kind may describe, metres: beyond a road
/// train's length or a wide load's width it is a mistake in the file.
pub const MAX_VEHICLE_LENGTH: f64 = 60.0;
pub const MAX_VEHICLE_WIDTH: f64 = 6.0;

impl VehicleKind {
    /// What is wrong with this kind's size or driving parameters, if anything.
    pub fn problem(&self) -> Option<String> {
        let size = |v: f64, max: f64| v.is_finite() && v > 0.0 && v <= max;
        if !size(self.length, MAX_VEHICLE_LENGTH) {
            return Some(format!(
                "length {} m is not between 0 and {MAX_VEHICLE_LENGTH} m",
                self.length
            ));
        }
        if !size(self.width, MAX_VEHICLE_WIDTH) {
            return Some(format!(
                "width {} m is not between 0 and {MAX_VEHICLE_WIDTH} m",
                self.width
            ));
        }
        if !(self.front.is_finite() && self.front >= 0.0 && self.front <= self.length) {
            return Some(format!(
                "front {} m is not within the length {} m",
                self.front, self.length
            ));
        }
        self.idm.as_ref().and_then(|idm| idm.validate().err())
    }

    /// The vehicle class lane permissions are checked against.
    pub fn vehicle_class(&self) -> &str {
        self.class.as_deref().unwrap_or(DEFAULT_VEHICLE_CLASS)
    }
}

impl VehicleKind {
    /// A kind of its own size (a SUMO vType): the rear axle where the
    /// built-in kind nearest in length has it, in proportion.
    pub fn sized(name: &str, length: f64, width: f64) -> VehicleKind {
        let nearest = builtin_names()
            .filter_map(builtin_kind)
            .min_by(|a, b| {
                (a.length - length)
                    .abs()
                    .total_cmp(&(b.length - length).abs())
            })
            .expect("the catalogue is not empty");
        VehicleKind {
            name: name.to_string(),
            front: nearest.front / nearest.length * length,
            length,
            width,
            driver: None,
            idm: None,
            class: None,
        }
    }
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
            idm: None,
            class: None,
        },
    )
}
