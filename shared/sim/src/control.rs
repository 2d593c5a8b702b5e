//! Control: speed ramps toward the mode's target, then the pose along the path.
//!
//! The vehicle keeps to its lane's centreline: its progress is an arc length, and
//! its heading points from the rear axle to the front bumper, both on the path
//! (a pure-pursuit steer toward the path point one wheelbase ahead, without the
//! lateral error of AWSIM's yaw-rate integration).

use trafficmesh_model::{NpcVehicleConfig, SpeedLimitSource, SpeedMode};

use crate::cognition::path::point_on_path;
use crate::network::LaneNetwork;
use crate::vehicle::{Pose, Vehicle};

pub const SLOW_SPEED: f64 = 5.0;

/// (target speed, rate) for the mode.
pub fn speed_target(mode: SpeedMode, speed_limit: f64, c: &NpcVehicleConfig) -> (f64, f64) {
    match mode {
        SpeedMode::Normal => (speed_limit, c.acceleration),
        SpeedMode::Slow => (SLOW_SPEED.min(speed_limit), c.deceleration),
        SpeedMode::Stop => (0.0, c.deceleration),
        SpeedMode::SuddenStop => (0.0, c.sudden_deceleration),
        SpeedMode::AbsoluteStop => (0.0, c.absolute_deceleration),
    }
}

pub fn speed_limit(net: &LaneNetwork, v: &Vehicle, c: &NpcVehicleConfig) -> f64 {
    match c.speed_limit_source {
        SpeedLimitSource::FixedSpeedLimit => c.fixed_speed_limit,
        SpeedLimitSource::LaneletSpeedLimit => net.lane(v.path[0]).speed_limit,
    }
}

fn move_towards(current: f64, target: f64, max_delta: f64) -> f64 {
    if (target - current).abs() <= max_delta { target } else { current + max_delta * (target - current).signum() }
}

/// Updates speed and arc position.
pub fn step_speed(net: &LaneNetwork, v: &mut Vehicle, c: &NpcVehicleConfig, dt: f64) {
    let (target, rate) = speed_target(v.speed_mode, speed_limit(net, v, c), c);
    let new_speed = move_towards(v.speed, target, rate * dt).max(0.0);
    v.acceleration = (new_speed - v.speed) / dt;
    v.speed = new_speed;
    v.s += v.speed * dt;
    v.trip.distance += v.speed * dt;
}

/// Recomputes pose, front and back points from the arc position.
pub fn update_pose(net: &LaneNetwork, v: &mut Vehicle) {
    let (front, _) = point_on_path(net, v, 0.0);
    let (axle, z) = point_on_path(net, v, -v.front_offset);
    let heading = front - axle;
    let length = heading.length();
    if length > 1e-6 {
        v.heading = heading / length;
    }
    let yaw = v.heading.y.atan2(v.heading.x);
    v.pose = Pose { x: axle.x, y: axle.y, z, yaw };
    v.front = front;
    // The back bumper only feeds the right-of-way side tests: the body's axis is enough.
    v.back = axle - v.heading * (v.length - v.front_offset);
}
