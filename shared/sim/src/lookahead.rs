//! What the loops over vehicles ask for a few vehicles ahead: the lanes of
//! their paths, the vertices and conflict zones the pose update and the lane
//! index read, and the lane-index entries cognition reads (see
//! [`crate::prefetch`] for why).

use crate::lane_index::LaneIndex;
use crate::network::{Lane, LaneNetwork};
use crate::prefetch::{LANE_LINES, hint, line};
use crate::vehicle::Vehicle;

/// How many vehicles ahead the lanes are asked for; the path lists twice as far.
pub const AHEAD: usize = 8;

/// The first [`LANE_LINES`] 64-byte lines of a lane.
#[inline(always)]
pub fn lane(l: &Lane) {
    let p: *const u8 = (l as *const Lane).cast();
    for k in 0..LANE_LINES {
        hint(p.wrapping_add(64 * k));
    }
}

/// The path list of vehicle i + 2·AHEAD, for the lanes asked for AHEAD
/// iterations later.
#[inline(always)]
fn path_list(vehicles: &[Vehicle], i: usize) {
    if let Some(far) = vehicles.get(i + 2 * AHEAD)
        && let Some(first) = far.path.first()
    {
        line(first);
    }
}

/// The first `lanes` lanes of the path, and the lane the vehicle comes from.
#[inline(always)]
fn lanes_of(net: &LaneNetwork, v: &Vehicle, lanes: usize) {
    for id in v.path.iter().take(lanes).copied().chain(v.behind.latest()) {
        lane(net.lane(id));
    }
}

/// For a loop over `vehicles` at `i`: the path list of vehicle i + 2·AHEAD,
/// and the lane of vehicle i + AHEAD (whose list was asked for AHEAD
/// iterations ago) with the lane it comes from.
#[inline(always)]
pub fn paths_ahead(net: &LaneNetwork, vehicles: &[Vehicle], i: usize) {
    path_list(vehicles, i);
    if let Some(near) = vehicles.get(i + AHEAD) {
        lanes_of(net, near, 1);
    }
}

/// Half as far ahead as [`paths_ahead`], whose lanes have arrived by then:
/// the vertices around the front and rear of vehicle i + AHEAD/2 on curved
/// lanes (the pose update reads them), and the lane's conflict zones.
#[inline(always)]
pub fn vertices_and_conflicts_ahead(net: &LaneNetwork, vehicles: &[Vehicle], i: usize) {
    let Some(v) = vehicles.get(i + AHEAD / 2) else {
        return;
    };
    let lane = net.lane(v.path[0]);
    lane.line.prefetch_at(v.s);
    conflicts_of(lane);
    if v.rear_s() < 0.0
        && let Some(p) = v.behind.latest()
    {
        let behind = net.lane(p);
        behind.line.prefetch_at(behind.length() + v.rear_s());
    }
}

/// Half as far ahead as [`paths_ahead`]: the conflict zones of vehicle
/// i + AHEAD/2's lane.
#[inline(always)]
pub fn conflicts_ahead(net: &LaneNetwork, vehicles: &[Vehicle], i: usize) {
    if let Some(v) = vehicles.get(i + AHEAD / 2) {
        conflicts_of(net.lane(v.path[0]));
    }
}

/// The first conflict zone of a lane, where the lane-index items of a body
/// on it start (1% of a 10k tick, switched every four ticks in one process).
#[inline(always)]
fn conflicts_of(lane: &Lane) {
    if let Some(c) = lane.conflicts.first() {
        line(c);
    }
}

/// For cognition at `i`: the first two lanes of vehicle i + AHEAD's path and
/// the lane it comes from, with their lane-index entries. (Measured on
/// 2026-11-24 with the hints switched on and off every four ticks in one
/// process: asking for more here, such as a third lane, the index items, the
/// vertices or the facts of the other vehicles at the junction, cost more
/// instructions than it saved in waiting, 6% of the tick together.)
#[inline(always)]
pub fn cognition_ahead(net: &LaneNetwork, vehicles: &[Vehicle], index: &LaneIndex, i: usize) {
    const LANES: usize = 2;
    if let Some(near) = vehicles.get(i + AHEAD) {
        lanes_of(net, near, LANES);
        for &id in near.path.iter().take(LANES) {
            index.prefetch_lane(id);
        }
    }
}
