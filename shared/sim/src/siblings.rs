//! Lanes of the same road: those running beside a lane, found once when the
//! network is built. A realistic driver without a route may change onto one
//! to take a turn its own lane does not make.

use std::collections::HashMap;

use glam::DVec2;

use crate::network::{Lane, LaneId};

/// Siblings start within this of each other and have lengths within this of
/// each other, metres (as the lane changes a route needs take them).
const SIBLING_TOLERANCE: f64 = 12.0;
/// And run the same way: the cosine of the angle between their first
/// segments is at least this.
const SAME_WAY: f64 = 0.8;

/// For each lane, the road lanes beside it (none for junction lanes), in
/// lane order.
pub fn find(lanes: &[Lane]) -> Vec<Vec<LaneId>> {
    let cell = |p: DVec2| {
        (
            (p.x / SIBLING_TOLERANCE).floor() as i64,
            (p.y / SIBLING_TOLERANCE).floor() as i64,
        )
    };
    let mut starts: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (i, l) in lanes.iter().enumerate() {
        if !l.intersection {
            starts.entry(cell(l.line.point(0))).or_default().push(i);
        }
    }
    lanes
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if l.intersection {
                return Vec::new();
            }
            let start = l.line.point(0);
            let way = DVec2::from_angle(l.line.start_heading());
            let (cx, cy) = cell(start);
            let mut found: Vec<LaneId> = (-1..=1)
                .flat_map(|dx| (-1..=1).map(move |dy| (cx + dx, cy + dy)))
                .filter_map(|c| starts.get(&c))
                .flatten()
                .copied()
                .filter(|&j| {
                    let o = &lanes[j];
                    j != i
                        && o.line.point(0).distance(start) < SIBLING_TOLERANCE
                        && (o.length() - l.length()).abs() < SIBLING_TOLERANCE
                        && DVec2::from_angle(o.line.start_heading()).dot(way) >= SAME_WAY
                })
                .map(|j| j as LaneId)
                .collect();
            found.sort_unstable();
            found
        })
        .collect()
}
