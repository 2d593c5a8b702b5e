//! Driver models: how a vehicle turns the stop points it perceives into an
//! acceleration. Chosen per vehicle type, with a default per run.

use serde::{Deserialize, Serialize};

/// The car-following model of a vehicle type.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", tag = "model")]
pub enum DriverModel {
    /// The AWSIM reference's speed modes (NORMAL, SLOW, STOP, SUDDEN_STOP,
    /// ABSOLUTE_STOP) with their fixed rates: what an AWSIM user expects.
    #[default]
    Awsim,
    /// The Intelligent Driver Model (Treiber, Hennecke and Helbing, 2000):
    /// smooth following with a time headway, which discharges a queue at a
    /// green light at the rate real drivers do.
    Realistic(IdmParams),
}

impl DriverModel {
    /// `awsim`, or `realistic` with the IDM's defaults.
    pub fn by_name(name: &str) -> Option<DriverModel> {
        match name {
            "awsim" => Some(DriverModel::Awsim),
            "realistic" => Some(DriverModel::Realistic(IdmParams::default())),
            _ => None,
        }
    }

    /// The tick a run of these drivers takes unless told otherwise, seconds:
    /// the reference's 50 Hz fixed update for its own drivers; 10 Hz for the
    /// IDM, its usual step, which gives the traffic of 20 Hz (on Bologna's
    /// Acosta district as shipped, mean trip durations within 2%) in half the
    /// time.
    pub fn default_tick(&self) -> f64 {
        match self {
            DriverModel::Awsim => 0.02,
            DriverModel::Realistic(_) => 0.1,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            DriverModel::Awsim => "awsim",
            DriverModel::Realistic(_) => "realistic",
        }
    }
}

/// `awsim` or `realistic`, as command lines and configs name them.
impl std::str::FromStr for DriverModel {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, Self::Err> {
        DriverModel::by_name(name)
            .ok_or_else(|| format!("unknown driver model '{name}' (awsim or realistic)"))
    }
}

/// The IDM's parameters; SUMO's vType attributes of the same meaning are
/// noted beside each.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdmParams {
    /// Maximum acceleration, m/s² (`accel`).
    pub accel: f64,
    /// Comfortable deceleration, m/s² (`decel`).
    pub decel: f64,
    /// Bumper-to-bumper gap kept at standstill, m (`minGap`).
    pub min_gap: f64,
    /// Desired time headway, s (`tau`).
    pub headway: f64,
    /// The vehicle's own top speed, m/s (`maxSpeed`); lanes may set less.
    pub max_speed: f64,
}

impl Default for IdmParams {
    /// SUMO's passenger-car defaults for accel, decel, minGap and tau.
    fn default() -> Self {
        IdmParams {
            accel: 2.6,
            decel: 4.5,
            min_gap: 2.5,
            headway: 1.0,
            max_speed: 55.55,
        }
    }
}

impl IdmParams {
    /// Names the first parameter that is not a positive finite number.
    pub fn validate(&self) -> Result<(), String> {
        // Upper bounds far past any road vehicle's: larger values are
        // mistakes in the file, and would overflow the model's arithmetic.
        for (name, value, max) in [
            ("accel", self.accel, 50.0),
            ("decel", self.decel, 100.0),
            ("min_gap", self.min_gap, 100.0),
            ("headway", self.headway, 60.0),
            ("max_speed", self.max_speed, 200.0),
        ] {
            if !(value.is_finite() && value > 0.0 && value <= max) {
                return Err(format!(
                    "driver model: {name} must be a positive number up to {max}, got {value}"
                ));
            }
        }
        Ok(())
    }
}
