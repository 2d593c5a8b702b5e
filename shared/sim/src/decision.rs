//! Decision: the speed mode from the nearest of the four stop distances.

use trafficmesh_model::{NpcVehicleConfig, SpeedMode};

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

pub fn stop_candidates(v: &Vehicle) -> StopCandidates {
    let front_vehicle = v.distance_to_front - MIN_FRONT_VEHICLE_DISTANCE;
    // Cognition read the light, yellow rule included (`commits_through_yellow`).
    let traffic_light = if v.stops_at_light {
        v.distance_to_light
    } else {
        f64::INFINITY
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

/// How a vehicle can speed up: at its acceleration, up to the speed limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pickup {
    pub acceleration: f64,
    pub limit: f64,
}

impl Pickup {
    /// Metres covered in `t` seconds from `speed`.
    pub fn reach(&self, speed: f64, t: f64) -> f64 {
        let t = t.max(0.0);
        let a = self.acceleration.max(0.0);
        let speeding_up = if a > 0.0 {
            ((self.limit - speed) / a).clamp(0.0, t)
        } else {
            0.0
        };
        let top = speed + a * speeding_up;
        speed * speeding_up + 0.5 * a * speeding_up * speeding_up + top * (t - speeding_up)
    }
}

/// Yellow: go on when the vehicle could not stop in time (within the
/// sudden-stop distance, the reference's rule) and reaches the line before
/// red (`yellow_left` seconds), speeding up as it can; else stop. One too
/// slow or too far to make it stops, so no commitment carries a vehicle
/// across after red has begun, nor does one braking for the yellow change
/// its mind once it is near.
pub fn commits_through_yellow(
    speed: f64,
    distance: f64,
    yellow_left: f64,
    pickup: Pickup,
    d: &StopDistances,
) -> bool {
    distance < d.sudden && distance <= pickup.reach(speed, yellow_left)
}

/// `is_turning` is asked only when no stop point is near enough to decide:
/// the look along the path ahead costs more than the rest of the decision.
pub fn speed_mode(
    distance_to_stop: f64,
    is_turning: impl FnOnce() -> bool,
    d: &StopDistances,
) -> SpeedMode {
    if distance_to_stop <= d.absolute {
        SpeedMode::AbsoluteStop
    } else if distance_to_stop <= d.sudden {
        SpeedMode::SuddenStop
    } else if distance_to_stop <= d.stop {
        SpeedMode::Stop
    } else if distance_to_stop <= d.slow_down || is_turning() {
        SpeedMode::Slow
    } else {
        SpeedMode::Normal
    }
}

/// The speed mode, and the stop points it was chosen from (the realistic
/// driver model brakes for them itself).
pub fn decide(
    v: &Vehicle,
    c: &NpcVehicleConfig,
    is_turning: impl FnOnce() -> bool,
) -> (SpeedMode, StopCandidates) {
    let d = StopDistances::at(v.speed, c);
    let stops = stop_candidates(v);
    (speed_mode(stops.nearest(), is_turning, &d), stops)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reach_speeds_up_to_the_limit_and_no_further() {
        let pickup = Pickup {
            acceleration: 2.0,
            limit: 10.0,
        };
        // From standstill, 2 s at 2 m/s²: 4 m.
        assert!((pickup.reach(0.0, 2.0) - 4.0).abs() < 1e-9);
        // At the limit: the speed times the time.
        assert!((pickup.reach(10.0, 3.0) - 30.0).abs() < 1e-9);
        // From 6 m/s: 2 s to reach 10 m/s (16 m), then 1 s at 10 m/s.
        assert!((pickup.reach(6.0, 3.0) - 26.0).abs() < 1e-9);
        // A yellow that ended a hair ago (a remote state read a tick late).
        assert_eq!(pickup.reach(6.0, -1e-11), 0.0);
    }
}
