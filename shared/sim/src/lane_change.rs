//! Lane changes that a route needs. The NPC model follows lanes and never
//! changes them, but a routed demand (SUMO's) may go on from the lane beside the
//! one a vehicle is on: its path then continues from a sibling lane of the same
//! road. The vehicle moves across at the first gap there, and stops before its
//! lane's end until it finds one; meanwhile those coming up behind on the other
//! lane leave it room (the lane index shows it there as a ghost).

use trafficmesh_model::NpcVehicleConfig;

use crate::decision::{MIN_FRONT_VEHICLE_DISTANCE, StopDistances};
use crate::lane_index::LaneIndex;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::Vehicle;

/// Siblings have lengths within this of each other and start within this far
/// apart, metres.
const SIBLING_TOLERANCE: f64 = 12.0;

/// What follows from the first two lanes of the path, kept up to date by
/// whatever changes them (lane following, a lane change): the lane change they
/// need and the turn signal they show.
pub fn refresh_first_lanes(net: &LaneNetwork, v: &mut Vehicle) {
    v.lane_change = pending_target(net, v);
    v.turn_signal = crate::visualization::turn_signal(net, v);
}

/// The lane the vehicle must move to: when path[1] does not follow path[0],
/// the sibling of path[0] that leads to it.
pub fn pending_target(net: &LaneNetwork, v: &Vehicle) -> Option<LaneId> {
    let (&here, &next) = (v.path.first()?, v.path.get(1)?);
    if net.lane(here).next.contains(&next) {
        return None;
    }
    sibling_towards(net, here, next)
}

/// A non-junction predecessor of `next` running beside `lane`: about as long,
/// and starting near it.
fn sibling_towards(net: &LaneNetwork, lane: LaneId, next: LaneId) -> Option<LaneId> {
    let l = net.lane(lane);
    net.lane(next)
        .prev
        .iter()
        .copied()
        .filter(|&p| p != lane && !net.lane(p).intersection)
        .filter(|&p| {
            let s = net.lane(p);
            (s.length() - l.length()).abs() < SIBLING_TOLERANCE
                && s.line.point(0).distance(l.line.point(0)) < SIBLING_TOLERANCE
        })
        .min_by(|&a, &b| {
            let d = |p: LaneId| net.lane(p).line.point(0).distance(l.line.point(0));
            d(a).total_cmp(&d(b))
        })
}

/// A lane change to make this tick.
pub struct Change {
    pub vehicle: usize,
    pub target: LaneId,
    /// The vehicle beside it that moves the other way at the same time, and
    /// its target.
    pub swap_with: Option<(usize, LaneId)>,
}

/// A body moved onto `lane` this tick: rear, front and speed.
pub struct Moved {
    lane: LaneId,
    rear: f64,
    front: f64,
    speed: f64,
}

impl Moved {
    pub fn of(v: &Vehicle, lane: LaneId) -> Self {
        Moved {
            lane,
            rear: v.rear_s(),
            front: v.s,
            speed: v.speed,
        }
    }
}

/// Vehicle `i`'s lane change this tick, if it needs one and has room (the
/// index is this tick's).
pub fn plan(
    index: &LaneIndex,
    vehicles: &[Vehicle],
    i: usize,
    config: &NpcVehicleConfig,
) -> Option<Change> {
    let v = &vehicles[i];
    // Wholly on its lane first, so that the body never spans two roads.
    if v.should_despawn || v.rear_s() < 0.0 {
        return None;
    }
    let target = v.lane_change?;
    let blockers = blockers(index, v, target, config);
    match blockers[..] {
        [] => Some(Change {
            vehicle: i,
            target,
            swap_with: None,
        }),
        // Side by side, each wanting the other's lane: swap.
        [j] => {
            let o = &vehicles[j as usize];
            let alongside = o.rear_s() < v.s && o.s > v.rear_s();
            let theirs = o.lane_change.filter(|&t| t == v.path[0])?;
            (alongside
                && o.rear_s() >= 0.0
                && blockers_except(index, o, theirs, config, i as u32).is_empty())
            .then_some(Change {
                vehicle: i,
                target,
                swap_with: Some((j as usize, theirs)),
            })
        }
        _ => None,
    }
}

/// The bodies on `target` too close to a body of `v`'s length at `v.s`: a gap
/// is enough when neither the vehicle nor its new follower, closing in at the
/// difference of their speeds, would need more than a sudden stop (never an
/// absolute one) to keep the Decision step's distance to the body ahead.
fn blockers(index: &LaneIndex, v: &Vehicle, target: LaneId, config: &NpcVehicleConfig) -> Vec<u32> {
    blockers_except(index, v, target, config, u32::MAX)
}

fn blockers_except(
    index: &LaneIndex,
    v: &Vehicle,
    target: LaneId,
    config: &NpcVehicleConfig,
    except: u32,
) -> Vec<u32> {
    index
        .on_lane(target)
        .iter()
        .filter(|o| !o.ghost && o.vehicle != except)
        .filter(|o| !clear(v, o.rear, o.front, o.speed, config))
        .map(|o| o.vehicle)
        .collect()
}

fn clear(v: &Vehicle, o_rear: f64, o_front: f64, o_speed: f64, config: &NpcVehicleConfig) -> bool {
    // The speed at which the one behind closes in.
    let needed = |closing: f64| {
        MIN_FRONT_VEHICLE_DISTANCE + StopDistances::at(closing.max(0.0), config).sudden
    };
    o_rear - v.s >= needed(v.speed - o_speed) || v.rear_s() - o_front >= needed(o_speed - v.speed)
}

/// Clear of the bodies already moved onto `target` this tick.
pub fn clear_of(moved: &[Moved], v: &Vehicle, target: LaneId, config: &NpcVehicleConfig) -> bool {
    moved
        .iter()
        .filter(|m| m.lane == target)
        .all(|m| clear(v, m.rear, m.front, m.speed, config))
}

/// Moves the vehicle onto `target` at the same arc length.
pub fn apply(net: &LaneNetwork, v: &mut Vehicle, target: LaneId) {
    let old = net.lane(v.path[0]).length();
    v.path[0] = target;
    v.path_length += net.lane(target).length() - old;
    v.first_junction_lane = crate::cognition::path::first_junction_lane(net, &v.path);
    // The target leads to path[1]: no further change is pending.
    refresh_first_lanes(net, v);
}
