//! Queue-aware lane choice. A realistic driver held in a standing queue moves
//! to the lane beside it when traffic flows there, that lane holds clearly
//! fewer standing vehicles ahead, and it serves the driver's way: the
//! straight-on driver behind left turners waiting for their arrow takes the
//! free straight lane next to it, as SUMO's speed-gain lane change does. A
//! route fixes the roads to drive, not the lanes: the path is rewritten to a
//! way from the new lane, without lane changes, along the same roads until it
//! rejoins a planned lane (or to the route's end, where any lane will do).
//! The change is made only where the gap beside is free now, so a choice never
//! leaves a vehicle waiting for one. The reference's NPCs keep their lanes.

use trafficmesh_model::{DriverModel, NpcVehicleConfig};

use crate::lane_index::LaneIndex;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::Vehicle;

/// A standing vehicle ahead weighs this much in a lane's queue, a moving one
/// [`MOVING_WEIGHT`].
const STANDING_WEIGHT: f64 = 1.0;
const MOVING_WEIGHT: f64 = 0.25;
/// Slower than this, m/s, a vehicle counts as standing.
const STANDING_SPEED: f64 = 2.0;
/// The lane beside must be shorter by this many standing vehicles: a smaller
/// gain is not worth a change (and would let drivers swap back and forth).
const MARGIN: f64 = 4.0;
/// A lane beside flows when the nearest body ahead on it is this far, metres,
/// or this fast, m/s.
const FREE_AHEAD: f64 = 30.0;
const FLOWING_SPEED: f64 = 3.0;
/// Only a vehicle this near a slow one ahead is queued, metres and m/s.
const QUEUED_GAP: f64 = 30.0;
const QUEUED_SPEED: f64 = 2.0;
/// No choice this near the lane's end, metres: the driver is at the line.
const MIN_ROOM_LEFT: f64 = 8.0;
/// Junction lanes in a row between two roads.
const MAX_JUNCTION_LANES: usize = 3;
/// Planned lanes ahead the new way may take to rejoin the planned one.
const MAX_LANES_AHEAD: usize = 12;

/// A lane choice: the lane beside to move onto, and the lanes from it that
/// rejoin the planned way (see [`choose`]).
pub struct Choice {
    pub vehicle: usize,
    pub target: LaneId,
    /// The lanes after the target, up to and including the planned lane
    /// where the new way rejoins the old.
    pub via: Vec<LaneId>,
    /// Where that lane is among the lanes ahead (see [`Vehicle::way_ahead`]).
    pub rejoins: usize,
}

/// Seconds between a driver's looks at the lanes beside.
const LOOK_EVERY: f64 = 1.0;

/// Which drivers look at the lanes beside this tick: each once every
/// [`LOOK_EVERY`] seconds, spread over the ticks by id (drivers do not weigh
/// lanes 50 times a second, and neither need the simulation).
#[derive(Clone, Copy)]
pub struct Looking {
    tick: u64,
    period: u64,
}

impl Looking {
    pub fn at(tick: u64, dt: f64) -> Self {
        Looking {
            tick,
            period: ((LOOK_EVERY / dt).round() as u64).max(1),
        }
    }

    fn due(&self, v: &Vehicle) -> bool {
        (self.tick + v.id).is_multiple_of(self.period)
    }
}

/// Vehicle `i`'s lane choice this tick, if it looks now, is queued, and the
/// lane beside has a clearly shorter queue, a free gap now, and a way on
/// without lane changes that rejoins its planned way on a later road
/// (driving meanwhile on the lanes beside the planned ones).
pub fn choose(
    net: &LaneNetwork,
    index: &LaneIndex,
    vehicles: &[Vehicle],
    i: usize,
    config: &NpcVehicleConfig,
    looking: Looking,
) -> Option<Choice> {
    let v = &vehicles[i];
    // Every vehicle is asked every tick: the fields read by every pass first.
    let queued = v.distance_to_front < QUEUED_GAP && v.front_speed < QUEUED_SPEED;
    if !queued
        || v.lane_change.is_some()
        || v.shadow.is_some()
        || v.should_despawn
        || v.forced_through.is_some()
    {
        return None;
    }
    if !looking.due(v)
        || !matches!(
            crate::control::driver_model(net, v, config),
            DriverModel::Realistic(_)
        )
    {
        return None;
    }
    let here = *v.path.first()?;
    let lane = net.lane(here);
    if lane.intersection || v.rear_s() < 0.0 || lane.length() - v.s < MIN_ROOM_LEFT {
        return None;
    }
    let own = queue_ahead(index, here, v.s);
    if own < MARGIN {
        return None;
    }
    let shorter: Vec<(f64, LaneId)> = net
        .lanes_beside(here)
        .filter(|&s| net.allows(s, v.kind))
        .map(|s| (queue_ahead(index, s, v.s), s))
        .filter(|&(queue, s)| queue + MARGIN <= own && flowing(index, s, v.s))
        .collect();
    if shorter.is_empty() {
        return None;
    }
    let ahead: Vec<LaneId> = v
        .way_ahead()
        .map(|(lane, _)| lane)
        .take(MAX_LANES_AHEAD + 1)
        .collect();
    // Nothing binds the lanes after the last known one (the route ends there,
    // or there is none and the driver picks its way as it goes): a way may
    // end beside it.
    let open_end = ahead.len() <= MAX_LANES_AHEAD;
    shorter
        .into_iter()
        .filter_map(|(queue, s)| {
            let (via, rejoins) = rejoining_way(net, v.kind, s, &ahead, open_end)?;
            let gap_free = crate::lane_change::blockers(net, index, v, s, config).is_empty();
            gap_free.then_some((queue, s, via, rejoins))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, target, via, rejoins)| Choice {
            vehicle: i,
            target,
            via,
            rejoins,
        })
}

/// Does traffic move on `lane` ahead of arc length `s`: the nearest body ahead
/// is far, or moving?
fn flowing(index: &LaneIndex, lane: LaneId, s: f64) -> bool {
    // Sorted by rear: the first ahead is the nearest.
    index
        .on_lane(lane)
        .iter()
        .find(|o| o.rear > s)
        .is_none_or(|o| o.rear - s > FREE_AHEAD || o.speed > FLOWING_SPEED)
}

/// The weighted count of vehicles ahead of arc length `s` on `lane`.
fn queue_ahead(index: &LaneIndex, lane: LaneId, s: f64) -> f64 {
    index
        .on_lane(lane)
        .iter()
        .filter(|o| o.rear > s)
        .map(|o| {
            if o.speed < STANDING_SPEED {
                STANDING_WEIGHT
            } else {
                MOVING_WEIGHT
            }
        })
        .sum()
}

/// The way on from `from` without lane changes, through junction lanes and
/// along road lanes beside the planned ones, to the first planned road lane it
/// can reach: its lanes and that lane's place in `ahead`. With `open_end`, a
/// way beside the last planned road lane ends there (place `ahead.len()`).
fn rejoining_way(
    net: &LaneNetwork,
    kind: usize,
    from: LaneId,
    ahead: &[LaneId],
    open_end: bool,
) -> Option<(Vec<LaneId>, usize)> {
    let roads: Vec<usize> = (0..ahead.len())
        .filter(|&k| !net.lane(ahead[k]).intersection)
        .collect();
    // Ways so far, each with how many planned roads it has passed beside.
    let mut frontier: Vec<(Vec<LaneId>, usize)> = vec![(vec![from], 0)];
    for _ in 0..ahead.len() {
        let mut further = Vec::new();
        for (way, passed) in frontier {
            let last = *way.last().expect("a way is never empty");
            let junction_lanes = way
                .iter()
                .rev()
                .take_while(|&&l| net.lane(l).intersection)
                .count();
            for &n in &net.lane(last).next {
                if !net.allows(n, kind) {
                    continue;
                }
                let mut longer = way.clone();
                longer.push(n);
                if net.lane(n).intersection {
                    if junction_lanes < MAX_JUNCTION_LANES {
                        further.push((longer, passed));
                    }
                    continue;
                }
                let Some(&k) = roads.get(passed) else {
                    continue;
                };
                if n == ahead[k] {
                    longer.remove(0);
                    return Some((longer, k));
                }
                if net.beside(ahead[k], n) {
                    if open_end && passed + 1 == roads.len() {
                        longer.remove(0);
                        return Some((longer, ahead.len()));
                    }
                    further.push((longer, passed + 1));
                }
            }
        }
        // Lowest lane ids first, so that the way found does not depend on
        // the order lanes were listed in.
        further.sort();
        frontier = further;
        if frontier.is_empty() {
            break;
        }
    }
    None
}

/// Rewrites the path (and the route's progress) for a choice: the new way
/// replaces the planned lanes up to where it rejoins them (the vehicle then
/// changes onto the target as for any lane change its path needs).
pub fn reroute(net: &LaneNetwork, v: &mut Vehicle, c: &Choice) {
    // `rejoins` counts the path lanes after the first, then the route's.
    let in_path = v.path.len() - 1;
    if c.rejoins < in_path && c.via.last() == v.path.get(c.rejoins + 1) {
        v.path.splice(1..=c.rejoins + 1, c.via.iter().copied());
    } else {
        v.path.truncate(1);
        v.path.extend(c.via.iter().copied());
        if let Some(route) = &mut v.route {
            route.index = (route.index + c.rejoins + 1 - in_path).min(route.lanes.len() - 1);
        }
    }
    v.path_length = v.path.iter().map(|&l| net.lane(l).length()).sum();
}
