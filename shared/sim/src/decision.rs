//! Decision: the speed mode from the nearest of the four stop distances.

use trafficmesh_model::{LightColor, NpcVehicleConfig, SpeedMode};

use crate::vehicle::Vehicle;

pub const MIN_STOP_DISTANCE: f64 = 1.5;
pub const MIN_FRONT_VEHICLE_DISTANCE: f64 = 4.0;
const SLOW_DOWN_MARGIN: f64 = 6.0;

/// The speed-dependent thresholds of the reference's section 4.2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopDistances {
    pub absolute: f64,
    pub sudden: f64,
    pub stop: f64,
    pub slow_down: f64,
}

impl StopDistances {
    pub fn at(speed: f64, c: &NpcVehicleConfig) -> Self {
        let stoppable = |a: f64| speed * speed / (2.0 * a);
        let absolute = stoppable(c.absolute_deceleration) + MIN_STOP_DISTANCE;
        let sudden = stoppable(c.sudden_deceleration) + MIN_STOP_DISTANCE * 2.0;
        let stop = stoppable(c.deceleration) + MIN_STOP_DISTANCE * 3.0;
        StopDistances {
            absolute,
            sudden,
            stop,
            slow_down: stop + SLOW_DOWN_MARGIN,
        }
    }
}

/// The four stop-point candidates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopCandidates {
    pub front_vehicle: f64,
    pub traffic_light: f64,
    pub right_of_way: f64,
    pub zebra: f64,
}

impl StopCandidates {
    pub fn nearest(&self) -> f64 {
        self.front_vehicle
            .min(self.traffic_light)
            .min(self.right_of_way)
            .min(self.zebra)
    }
}

pub fn stop_candidates(v: &Vehicle, d: &StopDistances) -> StopCandidates {
    let front_vehicle = v.distance_to_front - MIN_FRONT_VEHICLE_DISTANCE;
    let traffic_light = match (v.light_lane, v.passability) {
        (None, _) | (_, LightColor::Green) => f64::INFINITY,
        // Yellow: commit when we could not stop in time, else stop.
        (Some(_), LightColor::Yellow) if v.distance_to_light < d.sudden => f64::INFINITY,
        (Some(_), _) => v.distance_to_light,
    };
    let right_of_way = if v.yield_phase.is_yielding() {
        v.signed_distance(v.yield_point)
    } else {
        f64::INFINITY
    };
    let zebra = if v.zebra.is_blocked {
        v.zebra.distance_to_stop
    } else {
        f64::INFINITY
    };
    StopCandidates {
        front_vehicle,
        traffic_light,
        right_of_way,
        zebra,
    }
}

pub fn speed_mode(distance_to_stop: f64, is_turning: bool, d: &StopDistances) -> SpeedMode {
    if distance_to_stop <= d.absolute {
        SpeedMode::AbsoluteStop
    } else if distance_to_stop <= d.sudden {
        SpeedMode::SuddenStop
    } else if distance_to_stop <= d.stop {
        SpeedMode::Stop
    } else if distance_to_stop <= d.slow_down || is_turning {
        SpeedMode::Slow
    } else {
        SpeedMode::Normal
    }
}

/// The speed mode, and the stop points it was chosen from (the realistic
/// driver model brakes for them itself).
pub fn decide(v: &Vehicle, c: &NpcVehicleConfig) -> (SpeedMode, StopCandidates) {
    let d = StopDistances::at(v.speed, c);
    let stops = stop_candidates(v, &d);
    (speed_mode(stops.nearest(), v.is_turning, &d), stops)
}
