//! Lane changes that a path needs. The reference's NPC model follows lanes and
//! never changes them, but a routed demand (SUMO's) may go on from the lane
//! beside the one a vehicle is on, and so may a realistic driver's random way
//! on (see `cognition::path::extend_path`): its path then continues from a
//! sibling lane of the same road. The vehicle moves across at the first gap there, and stops before its
//! lane's end until it finds one; meanwhile those coming up behind on the other
//! lane leave it room (the lane index shows it there as a ghost).

use trafficmesh_model::{DriverModel, NpcVehicleConfig};

use crate::decision::MIN_FRONT_VEHICLE_DISTANCE;
use crate::lane_index::LaneIndex;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::Vehicle;

/// Seconds the one behind takes to react to a car moving in ahead of it.
const REACTION_TIME: f64 = 1.0;

/// What follows from the first two lanes of the path, kept up to date by
/// whatever changes them (lane following, a lane change): the lane change they
/// need and the turn signal they show.
pub fn refresh_first_lanes(net: &LaneNetwork, v: &mut Vehicle) {
    v.lane_change = pending_target(net, v);
    v.turn_signal = crate::visualization::turn_signal(net, v);
}

/// The lane the vehicle must move to: when path[1] does not follow path[0],
/// the lane beside path[0] toward the sibling that leads to it. A change
/// crosses one lane at a time, so that the body drawn across is a body on
/// each lane it reaches into; the path keeps path[1], and the next change
/// follows from the lane reached.
pub fn pending_target(net: &LaneNetwork, v: &Vehicle) -> Option<LaneId> {
    let (&here, &next) = (v.path.first()?, v.path.get(1)?);
    if net.lane(here).next.contains(&next) {
        return None;
    }
    let goal = sibling_towards(net, here, next)?;
    if net.beside(here, goal) {
        return Some(goal);
    }
    starting_nearest(net, net.lanes_beside(here), net.lane(goal).line.point(0))
}

/// The sibling of `lane` (see [`crate::siblings`]) that leads to `next`; of
/// several, the one starting nearest to it.
fn sibling_towards(net: &LaneNetwork, lane: LaneId, next: LaneId) -> Option<LaneId> {
    let siblings = net.lane(lane).siblings.iter().copied();
    let leading = siblings.filter(|s| net.lane(next).prev.contains(s));
    starting_nearest(net, leading, net.lane(lane).line.point(0))
}

/// Of `lanes`, the one that starts nearest to `point`.
fn starting_nearest(
    net: &LaneNetwork,
    lanes: impl Iterator<Item = LaneId>,
    point: glam::DVec2,
) -> Option<LaneId> {
    lanes.min_by(|&a, &b| {
        let d = |l: LaneId| net.lane(l).line.point(0).distance(point);
        d(a).total_cmp(&d(b))
    })
}

/// A lane change to make this tick.
pub struct Change {
    pub vehicle: usize,
    pub target: LaneId,
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
    net: &LaneNetwork,
    index: &LaneIndex,
    vehicles: &[Vehicle],
    i: usize,
    config: &NpcVehicleConfig,
) -> Option<Change> {
    let v = &vehicles[i];
    // Wholly on its lane first, so that the body never spans two roads, and
    // done with the last change (its body no longer reaches back).
    if v.should_despawn || v.rear_s() < 0.0 || v.shadow.is_some() {
        return None;
    }
    let target = v.lane_change?;
    blockers(net, index, v, target, config)
        .is_empty()
        .then_some(Change { vehicle: i, target })
}

/// What a gap beside must hold for a vehicle to move into it: the distance
/// kept at standstill and the Decision step's stop distances.
#[derive(Clone, Copy)]
pub struct Gaps<'c> {
    standstill: f64,
    config: &'c NpcVehicleConfig,
}

impl<'c> Gaps<'c> {
    /// At standstill a realistic driver keeps its own minimum gap (it closes
    /// to it from above, so a little less is room enough), the reference's
    /// NPCs their minimum front distance.
    pub fn of(net: &LaneNetwork, v: &Vehicle, config: &'c NpcVehicleConfig) -> Self {
        let standstill = match crate::control::driver_model(net, v, config) {
            DriverModel::Awsim => MIN_FRONT_VEHICLE_DISTANCE,
            DriverModel::Realistic(idm) => 0.8 * idm.min_gap,
        };
        Gaps { standstill, config }
    }

    /// The room needed ahead of the one behind, closing in at `closing` m/s:
    /// after a second's reaction, no more than a sudden stop (never an
    /// absolute one) keeps the standstill gap. Between two standing bodies the
    /// standstill gap is enough: a queue that lets a car in leaves just that.
    fn needed(&self, closing: f64) -> f64 {
        let closing = closing.max(0.0);
        self.standstill
            + closing * REACTION_TIME
            + closing * closing / (2.0 * self.config.sudden_deceleration)
    }
}

/// Metres a lane change may move the front bumper along the new lane to be
/// abreast of where it was (more means the projection found another part of
/// a winding lane).
const MAX_ABREAST_SHIFT: f64 = 3.0;
/// Metres a vehicle swinging out of a queue keeps from the body ahead on the
/// lane it leaves, passing beside that body's corner.
const SWING_OUT_CLEARANCE: f64 = 0.5;

/// How much closer than behind it in a queue a vehicle swinging out of it may
/// come to the body ahead on the lane it leaves: the gap it keeps at
/// standstill (a realistic driver's minimum gap, the reference's 4 m) less
/// [`SWING_OUT_CLEARANCE`].
pub fn swing_out_allowance(net: &LaneNetwork, v: &Vehicle, config: &NpcVehicleConfig) -> f64 {
    let kept = match crate::control::driver_model(net, v, config) {
        DriverModel::Awsim => MIN_FRONT_VEHICLE_DISTANCE,
        DriverModel::Realistic(idm) => idm.min_gap,
    };
    (kept - SWING_OUT_CLEARANCE).max(0.0)
}

/// A waiting lane changer slower than this, m/s, is given a gap.
const URGENT_SPEED: f64 = 3.0;
/// A waiting lane changer this near its lane's end, metres, is given a gap.
const URGENT_DISTANCE: f64 = 50.0;
/// Metres more than to a body that a vehicle stays behind a lane-change
/// ghost, so that the gap it leaves is enough for the waiting car to move in.
const GHOST_MARGIN: f64 = 2.0;

/// Where `follower`, on the lane `changer` waits to move onto, stops for it
/// (along its path, `rear` being the changer's rear there), or None when it
/// drives on. Once the change is urgent (the changer slowed for want of a gap,
/// or near its lane's end) a follower that can stop short of it, braking as
/// for a car cutting in (a realistic driver's comfortable deceleration, the
/// reference's sudden one), stays [`GHOST_MARGIN`] further back than behind a
/// car: SUMO's cooperative lane change, which lets a waiting car into a queue
/// starting up. One already beside it, or too near to leave it room, drives on.
///
/// Two that each want the other's lane cannot both move across side by side:
/// the one behind (of two abreast, the later id) stays back until the other
/// has room to move in ahead of it, and moves across behind it.
pub fn stop_for_ghost(
    net: &LaneNetwork,
    config: &NpcVehicleConfig,
    follower: &Vehicle,
    changer: &Vehicle,
    rear: f64,
) -> Option<f64> {
    if follower.lane_change == Some(changer.path[0]) {
        let changer_ahead = (changer.s, std::cmp::Reverse(changer.id))
            > (follower.s, std::cmp::Reverse(follower.id));
        return changer_ahead
            .then(|| rear - Gaps::of(net, changer, config).needed(0.0) - GHOST_MARGIN);
    }
    let urgent = changer.speed < URGENT_SPEED
        || net.lane(changer.path[0]).length() - changer.s < URGENT_DISTANCE;
    let decel = match crate::control::driver_model(net, follower, config) {
        DriverModel::Awsim => config.sudden_deceleration,
        DriverModel::Realistic(idm) => idm.decel,
    };
    let braking = follower.speed * follower.speed / (2.0 * decel);
    (urgent && rear >= GHOST_MARGIN + braking).then_some(rear - GHOST_MARGIN)
}

/// The bodies on `target` too close to a body of `v`'s length at `v.s`: a gap
/// is enough when neither the vehicle nor its new follower, closing in at the
/// difference of their speeds, would need more than a sudden stop to keep
/// its distance at standstill to the body ahead.
pub fn blockers(
    net: &LaneNetwork,
    index: &LaneIndex,
    v: &Vehicle,
    target: LaneId,
    config: &NpcVehicleConfig,
) -> Vec<u32> {
    let gaps = Gaps::of(net, v, config);
    index
        .on_lane(target)
        .iter()
        .filter(|o| !o.ghost)
        .filter(|o| !clear(v, o.rear, o.front, o.speed, gaps))
        .map(|o| o.vehicle)
        .collect()
}

fn clear(v: &Vehicle, o_rear: f64, o_front: f64, o_speed: f64, gaps: Gaps) -> bool {
    o_rear - v.s >= gaps.needed(v.speed - o_speed)
        || v.rear_s() - o_front >= gaps.needed(o_speed - v.speed)
}

/// Clear of the bodies already moved onto `target` this tick.
pub fn clear_of(moved: &[Moved], v: &Vehicle, target: LaneId, gaps: Gaps) -> bool {
    moved
        .iter()
        .filter(|m| m.lane == target)
        .all(|m| clear(v, m.rear, m.front, m.speed, gaps))
}

/// Moves the vehicle onto `target`, its front bumper where it is abreast
/// (lanes beside each other on a bend differ in length), and places its body
/// there for those who look from now on; the body drawn eases across as it
/// drives on, a body on the lane it left meanwhile (see [`crate::pose`]).
pub fn apply(net: &LaneNetwork, v: &mut Vehicle, target: LaneId) {
    let from = v.path[0];
    let old = net.lane(from).length();
    v.path[0] = target;
    v.path_length += net.lane(target).length() - old;
    let abreast = net.lane(target).line.project(v.front);
    if (abreast - v.s).abs() < MAX_ABREAST_SHIFT {
        // Wholly on the lane it changed from, wholly on the new one.
        v.s = abreast.max(v.length.min(v.s));
    }
    crate::control::place_body(net, v, false);
    crate::pose::start_sideways(v, from);
    v.first_junction_lane = crate::cognition::path::first_junction_lane(net, &v.path);
    // Whether a further change is pending (two lanes across).
    refresh_first_lanes(net, v);
}
