//! Lane following: advancing along followingLanes and extending it with branch choices.

use glam::DVec2;

use trafficmesh_model::NpcVehicleConfig;

use crate::branching::{BranchChoice, BranchPolicy};
use crate::decision::StopDistances;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::{FirstJunctionLane, Vehicle};

/// Lanes of the vehicle's path with the along-path distance from its front bumper
/// to each lane's start (negative for the lane it is on).
pub fn lanes_ahead<'a>(
    net: &'a LaneNetwork,
    v: &'a Vehicle,
) -> impl Iterator<Item = (usize, LaneId, f64)> + 'a {
    let mut offset = -v.s;
    v.path.iter().enumerate().map(move |(k, &lane)| {
        let here = offset;
        offset += net.lane(lane).length();
        (k, lane, here)
    })
}

/// Along-path distance from the front bumper to the end of the known path.
pub fn known_distance_ahead(v: &Vehicle) -> f64 {
    v.path_length - v.s
}

fn push_lane(net: &LaneNetwork, v: &mut Vehicle, lane: LaneId) {
    let l = net.lane(lane);
    if v.first_junction_lane.is_none() && l.intersection {
        v.first_junction_lane = Some(FirstJunctionLane {
            k: v.path.len(),
            lane,
            junction: l.junction,
            entry: l.line.point(0),
            start: v.path_length,
        });
    }
    v.path.push(lane);
    v.path_length += l.length();
}

/// Drops the current lane (the front has left it).
fn pop_lane(net: &LaneNetwork, v: &mut Vehicle, len: f64) {
    v.s -= len;
    v.path_length -= len;
    v.behind.push(v.path.remove(0));
    v.first_junction_lane = match v.first_junction_lane {
        Some(f) if f.k > 0 => Some(FirstJunctionLane {
            k: f.k - 1,
            start: f.start - len,
            ..f
        }),
        _ => first_junction_lane(net, &v.path),
    };
}

/// Scans a path for its first junction lane.
pub fn first_junction_lane(net: &LaneNetwork, path: &[LaneId]) -> Option<FirstJunctionLane> {
    let mut start = 0.0;
    for (k, &lane) in path.iter().enumerate() {
        let l = net.lane(lane);
        if l.intersection {
            return Some(FirstJunctionLane {
                k,
                lane,
                junction: l.junction,
                entry: l.line.point(0),
                start,
            });
        }
        start += l.length();
    }
    None
}

/// Point (and height) at along-path offset `ds` from the front bumper; negative
/// offsets reach back along the lanes the vehicle came by: extended straight
/// past the previous lane instead, the body of a car that just left a tight
/// turn would point back along the turn's first segment, across the lanes
/// beside it.
pub fn point_on_path(net: &LaneNetwork, v: &Vehicle, ds: f64) -> (DVec2, f64) {
    let mut s = v.s + ds;
    if s < 0.0 {
        let mut behind = v.behind.iter();
        let Some(mut lane) = behind.next() else {
            return net.lane(v.path[0]).line.point_at(s);
        };
        s += net.lane(lane).length();
        while s < 0.0 {
            let Some(before) = behind.next() else {
                break;
            };
            lane = before;
            s += net.lane(lane).length();
        }
        return net.lane(lane).line.point_at(s);
    }
    for (k, &lane) in v.path.iter().enumerate() {
        let line = &net.lane(lane).line;
        if s <= line.length() || k + 1 == v.path.len() {
            return line.point_at(s);
        }
        s -= line.length();
    }
    unreachable!("a vehicle's path is never empty")
}

/// The path cannot be extended: its last lane has no successor.
#[derive(Debug)]
pub struct DeadEnd;

/// Road lanes shorter than this offer no turns from the lanes beside them: no
/// room to wait for a gap there, metres.
const ROOM_TO_CHANGE: f64 = 20.0;

/// Appends one lane to the path: the route's next lane, else a branch choice.
/// Returns the choice made, if it was a choice between branches. With
/// `turns_beside`, a lane that goes on only one way also offers the other
/// turns of the lanes beside it, taken with a lane change on the way: a
/// driver without a route is not held to its lane for ever (on a ring road
/// the inner lane never leads off it; from a closed loop it takes those
/// turns only).
pub fn extend_path(
    net: &LaneNetwork,
    policy: &BranchPolicy,
    v: &mut Vehicle,
    turns_beside: bool,
) -> Result<Option<BranchChoice>, DeadEnd> {
    if let Some(route) = &mut v.route
        && route.index + 1 < route.lanes.len()
    {
        route.index += 1;
        let lane = route.lanes[route.index];
        push_lane(net, v, lane);
        return Ok(None);
    }
    if v.route.as_ref().is_some_and(|r| r.leave_at_end) {
        v.despawn_reason = Some(crate::events::DespawnReason::RouteEnd);
        return Err(DeadEnd);
    }
    let last = *v.path.last().expect("path is never empty");
    let all = &net.lane(last).next;
    // Lanes closed to the vehicle's class (bus lanes) are no option.
    let allowed: Vec<LaneId>;
    let options = if all.iter().all(|&n| net.allows(n, v.kind)) {
        all
    } else {
        allowed = all
            .iter()
            .copied()
            .filter(|&n| net.allows(n, v.kind))
            .collect();
        &allowed
    };
    let widened: Vec<LaneId>;
    let options = if turns_beside && options.len() == 1 {
        let beside = other_turns(net, v, last, options);
        let leads_off = |&b: &LaneId| !net.lane(b).in_closed_loop;
        // Where its own lane only goes round a closed loop, the driver
        // takes a way off it.
        widened = if net.lane(options[0]).in_closed_loop && beside.iter().any(leads_off) {
            beside.into_iter().filter(leads_off).collect()
        } else {
            options.iter().copied().chain(beside).collect()
        };
        &widened
    } else {
        options
    };
    match options.len() {
        0 => Err(DeadEnd),
        1 => {
            push_lane(net, v, options[0]);
            Ok(None)
        }
        _ => {
            let choice = policy.choose(last, options, &mut v.rng);
            push_lane(net, v, choice.to);
            Ok(Some(choice))
        }
    }
}

/// Seconds a driver without a route stands at its lane's end waiting for a
/// gap on the lane beside before it gives that turn up and goes on the way
/// its own lane leads: a driver who cannot get into the turning lane drives
/// round the block, and does not hold up the lane it stands on for ever.
const GIVE_UP_TURN_AFTER: f64 = 45.0;
/// A driver this near its lane's end, metres, waits there for its gap.
const AT_LANE_END: f64 = 10.0;

/// Has vehicle `v` waited at its lane's end long enough for a gap it will not
/// get, on a lane that goes on somewhere open to it? Routed vehicles keep
/// their route (SUMO's: the jam timeout moves them), and where the lane ends
/// the change is the only way on.
pub fn gives_up_turn(net: &LaneNetwork, v: &Vehicle) -> bool {
    v.lane_change.is_some()
        && v.route.is_none()
        && v.trip.wait >= GIVE_UP_TURN_AFTER
        && net.lane(v.path[0]).length() - v.s < AT_LANE_END
        && net
            .lane(v.path[0])
            .next
            .iter()
            .any(|&n| net.allows(n, v.kind))
}

/// Drops the way planned past the vehicle's lane and chooses again among the
/// ways the lane itself goes on (no lane change), as [`extend_path`] does;
/// returns the choice made, if it was one between branches.
pub fn give_up_turn(
    net: &LaneNetwork,
    policy: &BranchPolicy,
    v: &mut Vehicle,
) -> Option<BranchChoice> {
    v.path.truncate(1);
    v.path_length = net.lane(v.path[0]).length();
    v.first_junction_lane = first_junction_lane(net, &v.path);
    extend_path(net, policy, v, false).ok().flatten()
}

/// The junction lanes after the siblings of road lane `last` that turn a way
/// none of `own` does and that the vehicle may use, one per way.
fn other_turns(net: &LaneNetwork, v: &Vehicle, last: LaneId, own: &[LaneId]) -> Vec<LaneId> {
    let lane = net.lane(last);
    if lane.intersection || lane.length() < ROOM_TO_CHANGE {
        return Vec::new();
    }
    let mut ways: Vec<_> = own.iter().map(|&n| net.lane(n).turn).collect();
    let mut found = Vec::new();
    for sibling in net.lanes_beside(last) {
        for &n in &net.lane(sibling).next {
            let turn = net.lane(n).turn;
            if net.allows(n, v.kind) && !ways.contains(&turn) {
                ways.push(turn);
                found.push(n);
            }
        }
    }
    found
}

/// How far ahead the path must be known: beyond the slow-down distance nothing
/// changes the decision, so look that far and a margin more.
pub fn needed_lookahead(speed: f64, config: &NpcVehicleConfig) -> f64 {
    (StopDistances::at(speed, config).slow_down + 10.0).max(60.0)
}

/// Moves the vehicle onto the next lane when its front passes the end of the
/// current one, and keeps at least three lanes (and the look-ahead) known.
/// Flags the vehicle for despawn at the end of a dead-end lane.
pub fn advance_and_extend(
    net: &LaneNetwork,
    policy: &BranchPolicy,
    v: &mut Vehicle,
    config: &NpcVehicleConfig,
    decisions: &mut Vec<BranchChoice>,
) {
    // The reference's NPCs keep their lanes; a realistic driver does not.
    let turns_beside = matches!(
        crate::control::driver_model(net, v, config),
        trafficmesh_model::DriverModel::Realistic(_)
    );
    loop {
        let len = net.lane(v.path[0]).length();
        if v.s <= len {
            break;
        }
        if v.path.len() < 2 {
            match extend_path(net, policy, v, turns_beside) {
                Ok(choice) => decisions.extend(choice),
                Err(DeadEnd) => {
                    v.should_despawn = true;
                    return;
                }
            }
        }
        pop_lane(net, v, len);
    }
    let lookahead = needed_lookahead(v.speed, config);
    while v.path.len() < 3 || known_distance_ahead(v) < lookahead {
        match extend_path(net, policy, v, turns_beside) {
            Ok(choice) => decisions.extend(choice),
            Err(DeadEnd) => break,
        }
    }
}
