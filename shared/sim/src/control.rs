//! Control: speed ramps toward the mode's target, then the pose along the path.
//!
//! The vehicle keeps to its lane's centreline: its progress is an arc length and
//! it steers toward the path ahead so that both bumpers stay on the path (AWSIM
//! integrates a yaw rate aimed at the next waypoint instead, which leaves a
//! lateral error on curves).

use trafficmesh_model::{DriverModel, IdmParams, NpcVehicleConfig, SpeedLimitSource, SpeedMode};

use crate::cognition::curve::is_turning;
use crate::cognition::path::point_on_path;
use crate::decision::StopCandidates;
use crate::network::LaneNetwork;
use crate::pose::Moved;
use crate::vehicle::Vehicle;

pub const SLOW_SPEED: f64 = 5.0;
/// The `realistic` model's top speed on a curve or a turn (30 km/h).
pub const TURN_SPEED: f64 = 8.33;

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
    if (target - current).abs() <= max_delta {
        target
    } else {
        current + max_delta * (target - current).signum()
    }
}

/// The driver model of the vehicle's type, else the run's; a type with
/// parameters of its own drives the realistic model by them.
pub fn driver_model(net: &LaneNetwork, v: &Vehicle, c: &NpcVehicleConfig) -> DriverModel {
    let kind = &net.kinds[v.kind];
    match (kind.driver.unwrap_or(c.driver_model), kind.idm) {
        (DriverModel::Realistic(_), Some(own)) => DriverModel::Realistic(own),
        (model, _) => model,
    }
}

/// A driver model's acceleration and gentle braking, m/s²: the reference's
/// `acceleration` and `deceleration`, a realistic driver's own.
pub fn comfortable_rates(model: DriverModel, c: &NpcVehicleConfig) -> (f64, f64) {
    match model {
        DriverModel::Awsim => (c.acceleration, c.deceleration),
        DriverModel::Realistic(idm) => (idm.accel, idm.decel),
    }
}

/// Updates speed and arc position by the vehicle's driver model, from the
/// Decision step's speed mode and stop points and the lane's speed limit.
pub fn step_speed(
    net: &LaneNetwork,
    v: &mut Vehicle,
    c: &NpcVehicleConfig,
    stops: &StopCandidates,
    speed_limit: f64,
    dt: f64,
) {
    let model = driver_model(net, v, c);
    // With every lane's own limit in force, the lower limits ahead.
    let ahead = (c.speed_limit_source == SpeedLimitSource::LaneletSpeedLimit).then(|| {
        let (_, decel) = comfortable_rates(model, c);
        LimitsAhead::of(net, v, speed_limit, decel, dt)
    });
    let new_speed = match model {
        DriverModel::Awsim => {
            let (target, rate) = speed_target(v.speed_mode, speed_limit, c);
            move_towards(v.speed, target, rate * dt).max(0.0)
        }
        DriverModel::Realistic(idm) => {
            let desired = ahead.map_or(speed_limit, |a| a.now);
            realistic_speed(net, v, c, &idm, stops, desired, dt)
        }
    };
    // Never braking harder than the absolute deceleration for it (a lane
    // just added to the path may ask for more).
    let new_speed = ahead.map_or(new_speed, |a| {
        new_speed.min(a.after_tick.max(v.speed - c.absolute_deceleration * dt))
    });
    let new_speed = match &mut v.grant {
        Some(grant) => {
            let margin = crate::reservation::plan::Margins::default().time;
            let held = v.distance_to_front < grant.room_needed(margin)
                || v.stops_at_light
                || v.zebra.is_blocked;
            let keep = grant.keep_to(new_speed, held);
            grant.elapsed += dt;
            grant.travelled += keep * dt;
            keep
        }
        None => new_speed,
    };
    v.acceleration = (new_speed - v.speed) / dt;
    v.speed = new_speed;
    v.s += v.speed * dt;
    v.trip.distance += v.speed * dt;
}

/// How far a vehicle can drive this tick (at its driver model's highest
/// acceleration).
pub fn reach(net: &LaneNetwork, c: &NpcVehicleConfig, v: &Vehicle, dt: f64) -> f64 {
    let (accel, _) = comfortable_rates(driver_model(net, v, c), c);
    (v.speed + accel * dt) * dt
}

/// Holds the tick's travel (from `s_before`) to `cap`, the furthest the
/// vehicle may drive short of a body in its way, at the speed that covers it.
pub fn cap_travel(v: &mut Vehicle, s_before: f64, cap: f64, dt: f64) {
    let travelled = v.s - s_before;
    if travelled <= cap {
        return;
    }
    let cap = cap.max(0.0);
    let speed_before = v.speed - v.acceleration * dt;
    v.s = s_before + cap;
    v.speed = cap / dt;
    v.acceleration = (v.speed - speed_before) / dt;
    v.trip.distance -= travelled - cap;
}

/// The IDM's next speed toward `desired`: the lower acceleration of
/// following the body ahead and stopping at the nearest stop line (light,
/// yield point, zebra) that the reference's rules say to stop at, braking no
/// harder than the absolute deceleration.
fn realistic_speed(
    net: &LaneNetwork,
    v: &Vehicle,
    c: &NpcVehicleConfig,
    idm: &IdmParams,
    stops: &StopCandidates,
    desired: f64,
    dt: f64,
) -> f64 {
    let mut desired = desired.min(idm.max_speed);
    // One speed for every lane knows no turns; with every lane's own limit
    // in force the map gives the turn speeds (netconvert's on SUMO junctions,
    // the importer's on Lanelet2 ones), as SUMO takes them.
    if c.speed_limit_source == SpeedLimitSource::FixedSpeedLimit && is_turning(net, v) {
        desired = desired.min(TURN_SPEED);
    }
    let follow =
        crate::idm::acceleration(idm, v.speed, desired, v.distance_to_front, v.front_speed);
    let stop_line = stops.traffic_light.min(stops.right_of_way).min(stops.zebra);
    // A stop line is a standing obstacle whose gap ends the margin before it.
    let stop = crate::idm::acceleration(
        idm,
        v.speed,
        desired,
        stop_line - crate::idm::STOP_LINE_MARGIN + idm.min_gap,
        0.0,
    );
    let a = follow.min(stop).max(-c.absolute_deceleration);
    (v.speed + a * dt).max(0.0)
}

/// With every lane's own limit in force: the highest speeds from which each
/// lower limit on the path ahead (within the look-ahead) is met, braking at
/// a given deceleration, where its lane begins. Drivers slow for a turn
/// before they reach it, as SUMO's do, instead of braking hard once on it.
#[derive(Clone, Copy, Debug)]
struct LimitsAhead {
    /// From where the vehicle is: the realistic model's desired speed.
    now: f64,
    /// From where it will be after the tick: a hard bound on the speed it
    /// ends the tick with, so that no vehicle enters a lane faster than the
    /// lane allows (the IDM's gentle approach to its desired speed alone
    /// does not ensure it).
    after_tick: f64,
}

impl LimitsAhead {
    fn of(net: &LaneNetwork, v: &Vehicle, speed_limit: f64, decel: f64, dt: f64) -> Self {
        let mut limits = LimitsAhead {
            now: speed_limit,
            after_tick: speed_limit,
        };
        let step = v.speed * dt;
        let mut distance = net.lane(v.path[0]).length() - v.s;
        for &lane in &v.path[1..] {
            if distance > LIMIT_LOOKAHEAD {
                break;
            }
            let l = net.lane(lane);
            let limit = l.speed_limit;
            // A limit at or above the speeds allowed so far cannot lower them.
            if limit < limits.now {
                let allowed = |d: f64| (limit * limit + 2.0 * decel * d.max(0.0)).sqrt();
                limits.now = limits.now.min(allowed(distance));
                limits.after_tick = limits.after_tick.min(allowed(distance - step));
            }
            distance += l.length();
        }
        limits
    }
}

/// How far ahead a lower lane limit is slowed for, metres.
const LIMIT_LOOKAHEAD: f64 = 100.0;
/// The lane's direction at the rear bumper is read over this, metres.
const REAR_TANGENT: f64 = 0.5;

/// Recomputes the body from the arc position ([`place_body`]), then the pose
/// drawn ([`crate::pose::draw`]), the body having `moved` since.
///
/// A function of the lane and arc position alone, so a vehicle standing
/// where it stood last tick (queued, or held at a light) keeps it, unless it
/// is finishing a lane change in place ([`crate::pose::finishing_across`]).
pub fn update_pose(net: &LaneNetwork, v: &mut Vehicle, moved: Moved) {
    if v.pose_at == (v.path[0], v.s) {
        if crate::pose::finishing_across(v) {
            crate::pose::draw(v, Moved::NOT, false, v.pose.z);
        }
        return;
    }
    let fresh = v.pose_at.1.is_nan();
    let z = place_body(net, v, fresh);
    crate::pose::draw(v, moved, fresh, z);
}

/// Front and back points, the body's heading and its angle from the arc
/// position (noted in `pose_at`); returns the body's height. Both bumpers
/// sit on the path and the body is the chord between them, so a long vehicle
/// cuts a curve slightly on the inside instead of swinging its tail into the
/// next lane. `fresh`: placed just now, with no heading before.
pub fn place_body(net: &LaneNetwork, v: &mut Vehicle, fresh: bool) -> f64 {
    v.pose_at = (v.path[0], v.s);
    let (front, z_front) = point_on_path(net, v, 0.0);
    let (back, z_back) = point_on_path(net, v, -v.length);
    let body = front - back;
    let length = body.length();
    let before = v.heading;
    if length > 1e-6 {
        v.heading = body / length;
    }
    v.front = front;
    v.back = back;
    v.overhang = (0.5 * (v.length - length)).max(0.0);
    // The same heading (a body moving along a straight lane) has the same
    // angle and reach without another atan2 or look along the lane.
    if v.heading != before || fresh {
        v.body_yaw = v.heading.y.atan2(v.heading.x);
        // Along the lane at the back (over the last half metre there).
        let (further, _) = point_on_path(net, v, -v.length - REAR_TANGENT);
        let lane_back = (back - further).normalize_or_zero();
        let across = v.heading.perp_dot(lane_back).abs();
        v.rear_reach = (v.overhang * v.heading.dot(lane_back) + 0.5 * v.width * across).max(0.0);
    }
    0.5 * (z_front + z_back)
}
