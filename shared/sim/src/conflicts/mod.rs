//! Conflict zones between lanes and the junctions they form.
//!
//! Two lanes conflict where their centrelines come within [`CONFLICT_DISTANCE`]:
//! two vehicles there could touch. Crossings, merges and diverges are all found
//! this way, once, at load time; at run time a vehicle only looks at the lanes
//! its own path conflicts with. Between two intersection lanes the junction's
//! right of way orders the vehicles. Maps that do not mark every junction
//! (`RoadConflicts::Everywhere`: Lanelet2 imports) also get "road" conflicts
//! between any lanes whose vehicles could touch, and maps whose streets may
//! lie closer than two trucks need to pass (`RoadConflicts::Opposing`: SUMO
//! imports) between road lanes running the other way: there the vehicle
//! nearer the zone goes first.

mod link;
mod sweep;

use glam::DVec2;
use rustc_hash::FxHashMap;
use trafficmesh_model::RoadConflicts;

use crate::geometry::segments_intersect;
use crate::network::{Lane, LaneId};
use link::{JOINT_SLACK, Link, link};
use sweep::{MAX_SWEEP, sweep};

/// Half a truck's width plus half a car's width, rounded up.
pub const CONFLICT_DISTANCE: f64 = 2.6;
/// Road conflicts reach further, to two trucks side by side; whether two
/// bodies fit past each other there is decided by their widths at run time
/// (see [`bodies_pass`]).
pub const ROAD_CONFLICT_DISTANCE: f64 = 3.1;
const SAMPLE_STEP: f64 = 0.5;
/// Road zones of one pair of lanes closer together than this along the lane
/// are one zone: a stretch between them shorter than a truck gives a vehicle
/// no room to wait there, and two bodies meeting there, each in a zone the
/// other is bound for, could neither go on nor back.
const ROAD_ZONE_JOIN: f64 = 10.0;
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
    /// Not between two intersection lanes: no right of way covers it.
    pub road: bool,
    /// Road conflicts: how close the two ways come, and what bodies swing
    /// out there (see [`bodies_pass`]). Zero for junction conflicts.
    pub gap: Gap,
}

/// What a road conflict leaves two bodies side by side, where it is
/// tightest (the least distance between the centrelines once the longest
/// bodies' swing on curves is taken off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gap {
    /// The distance between the two centrelines there.
    pub distance: f64,
    /// What the longest body swings out there on this lane, and on the other.
    pub sweep_here: f64,
    pub sweep_other: f64,
}

impl Gap {
    /// The same gap seen from the other lane.
    pub fn mirrored(self) -> Gap {
        Gap {
            sweep_here: self.sweep_other,
            sweep_other: self.sweep_here,
            ..self
        }
    }

    /// The room left for bodies of every size: the distance less both
    /// sweeps.
    fn room(self) -> f64 {
        (self.distance - self.sweep_here - self.sweep_other).max(0.0)
    }
}

/// One of two bodies meeting in a road conflict: its width and length, and
/// what it as drawn lies off its centreline on each side.
#[derive(Clone, Copy, Debug)]
pub struct Body {
    pub width: f64,
    pub length: f64,
    pub off_centreline: f64,
}

impl Body {
    /// A body about to be placed on its lane: on its centreline, taken to
    /// swing out as far as the longest.
    pub fn new_on_lane(width: f64) -> Body {
        Body {
            width,
            length: f64::INFINITY,
            off_centreline: 0.0,
        }
    }

    /// How far the body reaches from its centreline toward the other's in a
    /// conflict where the longest body on its lane swings out `sweep`: half
    /// its width, and the more of what it as drawn lies off the centreline
    /// now and what a body of its length swings out there (the same bend
    /// seen now and ahead, not added).
    fn reach(self, sweep: f64) -> f64 {
        self.width * 0.5 + self.off_centreline.max(sweep::swept(sweep, self.length))
    }
}

/// Do two bodies, `here` on this lane of a road conflict with this `gap`
/// and `other` on the other lane, pass each other? Their reaches toward each
/// other must fit in the distance between the centrelines.
pub fn bodies_pass(gap: Gap, here: Body, other: Body) -> bool {
    here.reach(gap.sweep_here) + other.reach(gap.sweep_other) < gap.distance
}

/// Intervals of lane a's arc length within CONFLICT_DISTANCE of lane b, with
/// the room between them; for road conflicts (`road`: no right of way keeps
/// the two vehicles apart, so their bodies must) within ROAD_CONFLICT_DISTANCE
/// widened by both lanes' sweep. Lanes that follow each other (`link`) are
/// close only away from their joint.
fn close_intervals(
    lanes: &[Lane],
    (ia, ib): (usize, usize),
    road: bool,
    link: Option<Link>,
    rules: ZoneRules,
) -> Vec<(f64, f64, Gap)> {
    let (a, b) = (&lanes[ia], &lanes[ib]);
    let len = a.length();
    let n = (len / SAMPLE_STEP).ceil().max(1.0) as usize;
    let mut out = Vec::new();
    // (start, the gap where the room is least)
    let mut open: Option<(f64, Gap)> = None;
    for k in 0..=n {
        let s = (k as f64 * SAMPLE_STEP).min(len);
        let p = a.line.point_at(s).0;
        let t = b.line.project(p);
        let distance = b.line.distance_to(p);
        let (reach, gap) = if road {
            let q = b.line.point_at(t).0;
            // Toward the other lane, or no side (a swing either way counts).
            let (here, other) = if rules.sided {
                (q - p, p - q)
            } else {
                (DVec2::ZERO, DVec2::ZERO)
            };
            let gap = Gap {
                distance,
                sweep_here: sweep(lanes, ia, s, here, rules.junction_turns),
                sweep_other: sweep(lanes, ib, t, other, rules.junction_turns),
            };
            (
                ROAD_CONFLICT_DISTANCE + gap.sweep_here + gap.sweep_other,
                gap,
            )
        } else {
            (CONFLICT_DISTANCE, Gap::default())
        };
        let apart = link.is_none_or(|l| l.along(len, b.length(), s, t) > distance + JOINT_SLACK);
        let close = apart && distance < reach;
        open = match (close, open) {
            (true, None) => Some((s, gap)),
            (true, Some((s0, least))) if gap.room() < least.room() => Some((s0, gap)),
            (true, kept) => kept,
            (false, Some((s0, gap))) => {
                out.push((s0, s, gap));
                None
            }
            (false, None) => None,
        };
    }
    if let Some((s0, gap)) = open {
        out.push((s0, len, gap));
    }
    if road && rules.join_near_zones {
        join_near_zones(&mut out);
    }
    out
}

/// Where road zones are looked for and how they are drawn, by the map's
/// kind of road conflicts.
#[derive(Clone, Copy, Debug)]
struct ZoneRules {
    /// Road zones at all (else only the junctions' own conflicts).
    roads: bool,
    /// Only between two road lanes running the other way.
    opposing_roads_only: bool,
    /// Junction lanes side by side that do not cross (a double turn) get a
    /// road zone where a long body swinging out reaches the other.
    double_turns: bool,
    /// The turn onto or off a junction lane widens a zone (see [`sweep`]).
    junction_turns: bool,
    /// A bend widens a zone only where it swings the body toward the other
    /// lane.
    sided: bool,
    /// Zones less than [`ROAD_ZONE_JOIN`] apart are one.
    join_near_zones: bool,
}

impl ZoneRules {
    /// Where junctions are guessed (Lanelet2), lanelets also cross, fold
    /// back and join outside them: every turn counts, either way, and the
    /// zones stay as found (breaking a gridlock there by squeezing past is
    /// measured on them). Where the map models its junctions (SUMO), the
    /// junction's rules see to the turns through it; the zones left are two
    /// ways of one street, where which way a bend swings a body is plain,
    /// and a truck waits for the whole narrow stretch.
    fn of(roads: RoadConflicts) -> ZoneRules {
        let guessed = roads == RoadConflicts::Everywhere;
        ZoneRules {
            roads: !roads.is_none(),
            opposing_roads_only: roads.between_roads_only(),
            double_turns: guessed,
            junction_turns: guessed,
            sided: !guessed,
            join_near_zones: !guessed,
        }
    }
}

/// Joins consecutive zones less than [`ROAD_ZONE_JOIN`] apart, keeping the
/// gap where the room is least.
fn join_near_zones(zones: &mut Vec<(f64, f64, Gap)>) {
    let mut joined: Vec<(f64, f64, Gap)> = Vec::with_capacity(zones.len());
    for &(s0, s1, gap) in zones.iter() {
        match joined.last_mut() {
            Some(last) if s0 - last.1 < ROAD_ZONE_JOIN => {
                last.1 = s1;
                if gap.room() < last.2.room() {
                    last.2 = gap;
                }
            }
            _ => joined.push((s0, s1, gap)),
        }
    }
    *zones = joined;
}

/// Do the centrelines come within `reach` anywhere? (Cheap: segment pairs,
/// before sampling.)
fn lanes_come_close(a: &Lane, b: &Lane, reach: f64) -> bool {
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
            .any(|y| seg_dist(x[0], x[1], y[0], y[1]) < reach)
    })
}

pub(super) fn heading_at(lane: &Lane, s: f64) -> DVec2 {
    lane.line.direction(lane.line.segment_at(s))
}

/// Grid cells of the lane's bounding box grown by `margin`.
fn bounding_cells(lane: &Lane, margin: f64) -> impl Iterator<Item = (i64, i64)> {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in lane.line.points() {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let c = |v: f64| (v / GRID_CELL).floor() as i64;
    let (x0, x1, y0, y1) = (
        c(lo.x - margin),
        c(hi.x + margin),
        c(lo.y - margin),
        c(hi.y + margin),
    );
    (x0..=x1).flat_map(move |x| (y0..=y1).map(move |y| (x, y)))
}

/// Fills every intersection lane's conflicts and junction id, and the road
/// conflicts that `roads` asks for; returns the junction count.
pub fn find_conflicts_and_junctions(lanes: &mut [Lane], roads: RoadConflicts) -> u32 {
    let rules = ZoneRules::of(roads);
    let inter: Vec<usize> = (0..lanes.len())
        .filter(|&i| lanes[i].intersection)
        .collect();
    let mut grid: FxHashMap<(i64, i64), Vec<usize>> = FxHashMap::default();
    let (candidates, margin): (Vec<usize>, f64) = if rules.roads {
        (
            (0..lanes.len()).collect(),
            ROAD_CONFLICT_DISTANCE + 2.0 * MAX_SWEEP,
        )
    } else {
        (inter.clone(), CONFLICT_DISTANCE)
    };
    for &i in &candidates {
        for cell in bounding_cells(&lanes[i], margin) {
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
        let mut road = !(la.intersection && lb.intersection);
        let opposing_only = road && rules.opposing_roads_only;
        if opposing_only && (la.intersection || lb.intersection) {
            continue;
        }
        let reach = if road || rules.double_turns {
            ROAD_CONFLICT_DISTANCE + 2.0 * MAX_SWEEP
        } else {
            CONFLICT_DISTANCE
        };
        if !lanes_come_close(la, lb, reach) {
            continue;
        }
        let link = link(lanes, a, b);
        let mut on_a = close_intervals(lanes, (a, b), road, link, rules);
        if on_a.is_empty() && !road && rules.double_turns {
            // Junction lanes side by side (a double turn): too far apart to
            // cross, not for a long body swinging out. No rule orders the two:
            // a road conflict, passed by bodies that fit.
            road = true;
            on_a = close_intervals(lanes, (a, b), road, link, rules);
        }
        if on_a.is_empty() {
            continue;
        }
        let on_b = close_intervals(lanes, (b, a), road, link.map(Link::reversed), rules);
        let mut found = Vec::new();
        for &(a0, a1, gap_a) in &on_a {
            let mid_a = la.line.point_at((a0 + a1) * 0.5).0;
            let Some(&(b0, b1, gap_b)) = on_b.iter().min_by(|x, y| {
                let dx = lb.line.point_at((x.0 + x.1) * 0.5).0.distance(mid_a);
                let dy = lb.line.point_at((y.0 + y.1) * 0.5).0.distance(mid_a);
                dx.total_cmp(&dy)
            }) else {
                continue;
            };
            let cos = heading_at(la, (a0 + a1) * 0.5).dot(heading_at(lb, (b0 + b1) * 0.5));
            let parallel = cos > std::f64::consts::FRAC_1_SQRT_2;
            if opposing_only && cos > -std::f64::consts::FRAC_1_SQRT_2 {
                continue;
            }
            // Where the room is least, seen from either lane.
            let gap = if gap_a.room() <= gap_b.room() {
                gap_a
            } else {
                gap_b.mirrored()
            };
            found.push((a0, a1, b0, b1, parallel, gap));
        }
        for (a0, a1, b0, b1, parallel, gap) in found {
            lanes[a].conflicts.push(Conflict {
                other: b as LaneId,
                a0,
                a1,
                b0,
                b1,
                parallel,
                road,
                gap,
            });
            lanes[b].conflicts.push(Conflict {
                other: a as LaneId,
                a0: b0,
                a1: b1,
                b0: a0,
                b1: a1,
                parallel,
                road,
                gap: gap.mirrored(),
            });
        }
        if !road {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra.max(rb)] = ra.min(rb);
        }
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
        lane.road_conflicts = lane.conflicts.iter().any(|c| c.road);
        lane.conflicts
            .sort_by(|x, y| x.a0.total_cmp(&y.a0).then(x.other.cmp(&y.other)));
    }
    ids.len() as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A car (Taxi) and a truck (Truck_2t), drawn `off` off their centrelines.
    fn car(off: f64) -> Body {
        Body {
            width: 1.94,
            length: 4.64,
            off_centreline: off,
        }
    }

    fn truck(off: f64) -> Body {
        Body {
            width: 3.08,
            length: 9.2,
            off_centreline: off,
        }
    }

    fn gap(distance: f64, sweep_here: f64, sweep_other: f64) -> Gap {
        Gap {
            distance,
            sweep_here,
            sweep_other,
        }
    }

    /// Two lanes 3 m apart in a bend where a truck swings 1.4 m out on
    /// each: two cars, each drawn 0.3 m off its centreline, pass (a car
    /// swings out a quarter as far, and its drawn offset is that same
    /// swing, counted once); a truck and a car do not.
    #[test]
    fn two_cars_meeting_in_a_bend_pass_where_a_truck_and_a_car_do_not() {
        let bend = gap(3.0, 1.4, 1.4);
        assert!(bodies_pass(bend, car(0.3), car(0.3)));
        assert!(!bodies_pass(bend, truck(0.3), car(0.3)));
        assert!(!bodies_pass(bend, car(0.3), truck(0.3)));
    }

    /// Each body's own swing counts on its own side: a truck on the straight
    /// lane beside a bend passes a car on the bend where it would not pass
    /// it with the sides swapped.
    #[test]
    fn each_body_swings_out_by_the_sweep_of_its_own_lane() {
        let beside_a_bend = gap(3.4, 0.0, 1.2);
        assert!(bodies_pass(beside_a_bend, truck(0.0), car(0.0)));
        assert!(!bodies_pass(beside_a_bend.mirrored(), truck(0.0), car(0.0)));
    }
}
