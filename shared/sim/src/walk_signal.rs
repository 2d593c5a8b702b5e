//! When walkers may step onto a signalised crosswalk. Maps seldom give
//! pedestrian signals, so they are derived as real junctions run them: the
//! walk shows while the through traffic that crosses the crosswalk stands at
//! red, in step with the traffic beside it; turning vehicles that cross then
//! yield to the walkers (the zebra rule). A crosswalk no signalised through
//! lane crosses is unsignalised: walkers go whenever they come.

use glam::DVec2;
use trafficmesh_model::LightColor;

use crate::geometry::{angle_between, segments_intersect};
use crate::network::Lane;

/// A junction lane turning less than this through its junction goes straight.
const STRAIGHT_TURN: f64 = 30.0 * std::f64::consts::PI / 180.0;

/// An approach's crosswalk may lie this far before its stop point (a stop
/// line drawn over the crosswalk's near edge).
const BEFORE_STOP: f64 = 2.0;

/// The light groups whose red lets walkers onto the crosswalk `polygon`:
/// those of the signalised lanes crossing it that carry through traffic (a
/// junction lane going straight, with its own light or its approach's, or a
/// signalised approach lane between its stop point and the junction; the
/// same road further back is another junction's approach, not this
/// crossing's). Sorted, without repeats.
pub fn walk_groups(lanes: &[Lane], polygon: &[DVec2]) -> Vec<u32> {
    let centre = polygon.iter().copied().sum::<DVec2>() / polygon.len().max(1) as f64;
    let mut groups: Vec<u32> = lanes
        .iter()
        .filter(|lane| crosses(lane, polygon))
        .filter_map(|lane| {
            if lane.intersection {
                let straight = angle_between(lane.line.start_heading(), lane.line.end_heading())
                    < STRAIGHT_TURN;
                let approach = || lane.prev.iter().find_map(|&p| lanes[p as usize].light());
                straight.then(|| lane.light().or_else(approach)).flatten()
            } else {
                let past_stop = lane.line.project(centre) >= lane.light_stop_s() - BEFORE_STOP;
                lane.light().filter(|_| past_stop)
            }
        })
        .collect();
    groups.sort_unstable();
    groups.dedup();
    groups
}

/// Walkers may start across a crosswalk whose through groups all show red.
pub fn may_walk(groups: &[u32], color: impl Fn(u32) -> LightColor) -> bool {
    groups.iter().all(|&g| color(g) == LightColor::Red)
}

fn crosses(lane: &Lane, polygon: &[DVec2]) -> bool {
    let n = polygon.len();
    let points: Vec<DVec2> = lane.line.points().collect();
    points.windows(2).any(|seg| {
        (0..n).any(|k| segments_intersect(seg[0], seg[1], polygon[k], polygon[(k + 1) % n]))
    })
}
