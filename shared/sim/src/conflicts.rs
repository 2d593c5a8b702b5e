//! Conflict zones between intersection lanes and the junctions they form.
//!
//! Two lanes conflict where their centrelines come within [`CONFLICT_DISTANCE`]:
//! two vehicles there could touch. Crossings, merges and diverges are all found
//! this way, once, at load time; at run time a vehicle only looks at the lanes
//! its own path conflicts with.

use glam::DVec2;
use rustc_hash::FxHashMap;

use crate::geometry::segments_intersect;
use crate::network::{Lane, LaneId};

/// Half a truck's width plus half a car's width, rounded up.
pub const CONFLICT_DISTANCE: f64 = 2.6;
const SAMPLE_STEP: f64 = 0.5;
const GRID_CELL: f64 = 40.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conflict {
    pub other: LaneId,
    /// Zone on this lane, arc lengths.
    pub a0: f64,
    pub a1: f64,
    /// Zone on the other lane.
    pub b0: f64,
    pub b1: f64,
    /// Merge or diverge (headings within 45°) rather than a crossing.
    pub parallel: bool,
}

/// Intervals of lane a's arc length within CONFLICT_DISTANCE of lane b.
fn close_intervals(a: &Lane, b: &Lane) -> Vec<(f64, f64)> {
    let len = a.length();
    let n = (len / SAMPLE_STEP).ceil().max(1.0) as usize;
    let mut out = Vec::new();
    let mut start: Option<f64> = None;
    for k in 0..=n {
        let s = (k as f64 * SAMPLE_STEP).min(len);
        let close = b.line.distance_to(a.line.point_at(s).0) < CONFLICT_DISTANCE;
        match (close, start) {
            (true, None) => start = Some(s),
            (false, Some(s0)) => {
                out.push((s0, s));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s0) = start {
        out.push((s0, len));
    }
    out
}

/// Do the centrelines come within CONFLICT_DISTANCE anywhere? (Cheap: segment
/// pairs, before sampling.)
fn lanes_come_close(a: &Lane, b: &Lane) -> bool {
    let seg_dist = |p0: DVec2, p1: DVec2, q0: DVec2, q1: DVec2| -> f64 {
        if segments_intersect(p0, p1, q0, q1) {
            return 0.0;
        }
        let to = |x: DVec2, s0: DVec2, s1: DVec2| {
            let d = s1 - s0;
            let t = if d.length_squared() > 0.0 {
                ((x - s0).dot(d) / d.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            x.distance(s0 + d * t)
        };
        to(p0, q0, q1)
            .min(to(p1, q0, q1))
            .min(to(q0, p0, p1))
            .min(to(q1, p0, p1))
    };
    let pa: Vec<DVec2> = a.line.points().collect();
    let pb: Vec<DVec2> = b.line.points().collect();
    pa.windows(2).any(|x| {
        pb.windows(2)
            .any(|y| seg_dist(x[0], x[1], y[0], y[1]) < CONFLICT_DISTANCE)
    })
}

fn heading_at(lane: &Lane, s: f64) -> DVec2 {
    lane.line.direction(lane.line.segment_at(s))
}

fn bounding_cells(lane: &Lane) -> impl Iterator<Item = (i64, i64)> {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in lane.line.points() {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let c = |v: f64| (v / GRID_CELL).floor() as i64;
    let (x0, x1, y0, y1) = (
        c(lo.x - CONFLICT_DISTANCE),
        c(hi.x + CONFLICT_DISTANCE),
        c(lo.y - CONFLICT_DISTANCE),
        c(hi.y + CONFLICT_DISTANCE),
    );
    (x0..=x1).flat_map(move |x| (y0..=y1).map(move |y| (x, y)))
}

/// Fills every intersection lane's conflicts and junction id; returns the junction count.
pub fn find_conflicts_and_junctions(lanes: &mut [Lane]) -> u32 {
    let inter: Vec<usize> = (0..lanes.len())
        .filter(|&i| lanes[i].intersection)
        .collect();
    let mut grid: FxHashMap<(i64, i64), Vec<usize>> = FxHashMap::default();
    for &i in &inter {
        for cell in bounding_cells(&lanes[i]) {
            grid.entry(cell).or_default().push(i);
        }
    }
    let mut pairs: Vec<(usize, usize)> = grid
        .values()
        .flat_map(|ids| {
            ids.iter()
                .flat_map(move |&a| ids.iter().filter(move |&&b| a < b).map(move |&b| (a, b)))
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();

    let mut parent: Vec<usize> = (0..lanes.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (a, b) in pairs {
        let (la, lb) = (&lanes[a], &lanes[b]);
        if la.next.contains(&(b as LaneId)) || lb.next.contains(&(a as LaneId)) {
            continue;
        }
        if !lanes_come_close(la, lb) {
            continue;
        }
        let on_a = close_intervals(la, lb);
        if on_a.is_empty() {
            continue;
        }
        let on_b = close_intervals(lb, la);
        let mut found = Vec::new();
        for &(a0, a1) in &on_a {
            let mid_a = la.line.point_at((a0 + a1) * 0.5).0;
            let Some(&(b0, b1)) = on_b.iter().min_by(|x, y| {
                let dx = lb.line.point_at((x.0 + x.1) * 0.5).0.distance(mid_a);
                let dy = lb.line.point_at((y.0 + y.1) * 0.5).0.distance(mid_a);
                dx.total_cmp(&dy)
            }) else {
                continue;
            };
            let cos = heading_at(la, (a0 + a1) * 0.5).dot(heading_at(lb, (b0 + b1) * 0.5));
            found.push((a0, a1, b0, b1, cos > std::f64::consts::FRAC_1_SQRT_2));
        }
        for (a0, a1, b0, b1, parallel) in found {
            lanes[a].conflicts.push(Conflict {
                other: b as LaneId,
                a0,
                a1,
                b0,
                b1,
                parallel,
            });
            lanes[b].conflicts.push(Conflict {
                other: a as LaneId,
                a0: b0,
                a1: b1,
                b0: a0,
                b1: a1,
                parallel,
            });
        }
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra.max(rb)] = ra.min(rb);
    }
    // Lanes sharing an approach or an exit belong to the same junction too.
    for &i in &inter {
        for &p in &lanes[i].prev.clone() {
            for &sib in &lanes[p as usize].next.clone() {
                if lanes[sib as usize].intersection {
                    let (ra, rb) = (root(&mut parent, i), root(&mut parent, sib as usize));
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    let mut ids: FxHashMap<usize, u32> = FxHashMap::default();
    for &i in &inter {
        let r = root(&mut parent, i);
        let next = ids.len() as u32;
        let j = *ids.entry(r).or_insert(next);
        lanes[i].junction = Some(j);
    }
    for lane in lanes.iter_mut() {
        lane.conflict_span = lane
            .conflicts
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                (lo.min(c.a0), hi.max(c.a1))
            });
        lane.conflicts
            .sort_by(|x, y| x.a0.total_cmp(&y.a0).then(x.other.cmp(&y.other)));
    }
    ids.len() as u32
}
