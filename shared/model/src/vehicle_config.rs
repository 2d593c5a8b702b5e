//! NPCVehicleConfig: motion parameters shared by all NPC vehicles.

use serde::{Deserialize, Serialize};

/// Where the NORMAL-mode target speed comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum SpeedLimitSource {
    /// The lane's own speed limit.
    LaneletSpeedLimit,
    /// One speed for every lane: [`NpcVehicleConfig::fixed_speed_limit`].
    #[default]
    FixedSpeedLimit,
}

/// The AWSIM reference's NPCVehicleConfig, with its defaults.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct NpcVehicleConfig {
    /// Normal forward acceleration, m/s².
    pub acceleration: f64,
    /// Gentle braking, m/s².
    pub deceleration: f64,
    /// Obstacle braking, m/s².
    pub sudden_deceleration: f64,
    /// Physics-limit emergency braking, m/s².
    pub absolute_deceleration: f64,
    pub speed_limit_source: SpeedLimitSource,
    /// m/s; used when the source is FixedSpeedLimit (50 km/h).
    pub fixed_speed_limit: f64,
    /// The driver model of vehicle types that do not choose their own.
    pub driver_model: crate::DriverModel,
}

impl Default for NpcVehicleConfig {
    fn default() -> Self {
        Self {
            acceleration: 3.0,
            deceleration: 2.0,
            sudden_deceleration: 4.0,
            absolute_deceleration: 20.0,
            speed_limit_source: SpeedLimitSource::FixedSpeedLimit,
            fixed_speed_limit: 13.89,
            driver_model: crate::DriverModel::Awsim,
        }
    }
}

impl NpcVehicleConfig {
    /// Names the first parameter that is not a positive finite number.
    pub fn validate(&self) -> Result<(), String> {
        let fields = [
            ("acceleration", self.acceleration),
            ("deceleration", self.deceleration),
            ("suddenDeceleration", self.sudden_deceleration),
            ("absoluteDeceleration", self.absolute_deceleration),
            ("fixedSpeedLimit", self.fixed_speed_limit),
        ];
        for (name, value) in fields {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!(
                    "vehicle config: {name} must be a positive number, got {value}"
                ));
            }
        }
        if let crate::DriverModel::Realistic(idm) = &self.driver_model {
            idm.validate()?;
        }
        Ok(())
    }
}
