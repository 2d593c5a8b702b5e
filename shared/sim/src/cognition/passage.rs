//! Before a wide body enters a junction: its way through clear of the bodies
//! standing still there.
//!
//! A truck or bus with little room in its lane sweeps the inside of its turn
//! over ground no junction rule gives it: the front of a truck waiting at
//! the stop line of the road it turns beside. The clearance check
//! (`clearance.rs`) stops it short of that body, but inside the junction,
//! where its own body then stands in the way of the one it stopped for: two
//! bodies each in the other's way, which only the jam valve undoes. So a
//! wide body waits before the junction, as "don't block the box" has it
//! wait for room on its exit, until the ground its body will sweep through
//! the junction is clear of bodies standing still. (Moving bodies are left
//! to the junction's rules and the clearance check: they leave the ground.)

use glam::DVec2;

use super::Snapshot;
use super::deadlock::STOPPED_SPEED;
use super::path::{lanes_ahead, point_on_path};
use crate::body_grid::{MARGIN, bodies_may_meet, is_wide};
use crate::geometry::Obb;
use crate::vehicle::{BODY_TOLERANCE, Vehicle};

/// Metres between the places the body is tried at along the way through:
/// its corners move little more than this from one to the next.
const STEP: f64 = 0.5;
/// Metres between the coarse places that find which standing bodies come
/// near the way at all; a body further than [`COARSE_SLACK`] from every
/// one of them is clear of the places between.
const COARSE_STEP: f64 = 2.0;
const COARSE_SLACK: f64 = 1.5;
/// Looked at from this far before the vehicle's stopping distance, metres:
/// nearer than that, it decides whether to go on into the junction.
const DECIDE_AHEAD: f64 = 10.0;
/// The coarse places kept on the stack: a way through of up to 120 m.
const MAX_COARSE: usize = 60;

/// A body standing in the way through the next junction of vehicle `i`:
/// metres to that junction's entry and the standing vehicle (an index).
pub fn blocked_by_standing(snap: &Snapshot, i: usize) -> Option<(f64, u32)> {
    let net = snap.net;
    let v = &snap.vehicles[i];
    if net.lane(v.path[0]).intersection || !is_wide(net, v) {
        return None;
    }
    // The first run of junction lanes ahead: from its entry to its end.
    let first = v.first_junction_lane?;
    let entry = first.start - v.s;
    let decide = v.speed * v.speed / (2.0 * snap.config.sudden_deceleration) + DECIDE_AHEAD;
    if entry > decide {
        return None;
    }
    let end = entry
        + v.path[first.k..]
            .iter()
            .map(|&l| net.lane(l))
            .take_while(|l| l.intersection)
            .map(|l| l.length())
            .sum::<f64>();
    // The body waiting at the entry, and through to its rear leaving.
    let (from, to) = (entry.max(0.0), end + v.length);
    if to > v.path_length - v.s {
        return None;
    }
    let waiting = body_at(snap, v, from);
    let (lo, hi) = way_bounds(snap, v, (from - v.length, to));
    let pad = DVec2::splat(0.5 * v.width + WAY_PAD);
    let way = (v.path[first.k], v.pose.z);
    let mut standing: Vec<u32> = Vec::new();
    snap.bodies.for_each_near(lo - pad, hi + pad, |j| {
        let other = &snap.vehicles[j as usize];
        let body = snap.bodies.body(j as usize);
        if j as usize != i
            && other.speed < STOPPED_SPEED
            && !v.path.contains(&other.path[0])
            && bodies_may_meet(net, way, (body.lane, body.z))
            // Already in the way of the body waiting at the entry: the
            // clearance check's, not a reason to wait here.
            && waiting.separation(&body.obb) > MARGIN
        {
            standing.push(j);
        }
    });
    if standing.is_empty() {
        return None;
    }
    let mut coarse = [(0.0, Obb::default()); MAX_COARSE];
    let mut n = 0;
    let mut t = from;
    loop {
        coarse[n] = (t, body_at(snap, v, t));
        n += 1;
        if t >= to || n == MAX_COARSE {
            break;
        }
        t = (t + COARSE_STEP).min(to);
    }
    let coarse = &coarse[..n];
    standing.sort_unstable_by_key(|&j| snap.vehicles[j as usize].id);
    for (k, (t0, near)) in coarse.iter().enumerate() {
        for &j in &standing {
            let other = &snap.bodies.body(j as usize).obb;
            if near.separation(other) > MARGIN + COARSE_SLACK {
                continue;
            }
            // Between the coarse places either side of this one.
            let (a, b) = (
                (t0 - COARSE_STEP).max(from),
                coarse.get(k + 1).map_or(*t0, |c| c.0),
            );
            let mut t = a;
            loop {
                if body_at(snap, v, t).separation(other) <= MARGIN {
                    return Some((from, j));
                }
                if t >= b {
                    break;
                }
                t = (t + STEP).min(b);
            }
        }
    }
    None
}

/// How far past the bounds of its path a body's box may reach beyond half
/// its width, metres: a bus's chord on a tight turn is shorter than the bus.
const WAY_PAD: f64 = 2.0;

/// The bounds of the vehicle's path from travel `a` to `b` (its vertices
/// and ends): every chord between two of its points lies within them.
fn way_bounds(snap: &Snapshot, v: &Vehicle, (a, b): (f64, f64)) -> (DVec2, DVec2) {
    let (mut lo, _) = point_on_path(snap.net, v, a);
    let mut hi = lo;
    let mut take = |p: DVec2| {
        lo = lo.min(p);
        hi = hi.max(p);
    };
    take(point_on_path(snap.net, v, b).0);
    for (_, lane, offset) in lanes_ahead(snap.net, v) {
        if offset >= b {
            break;
        }
        let line = &snap.net.lane(lane).line;
        if offset + line.length() <= a {
            continue;
        }
        for vertex in &line.vertices {
            let t = offset + vertex.cum;
            if t > a && t < b {
                take(vertex.point);
            }
        }
    }
    (lo, hi)
}

/// The body as the overlap check reads it, its front `travel` metres on
/// along its path.
fn body_at(snap: &Snapshot, v: &Vehicle, travel: f64) -> Obb {
    let (front, _) = point_on_path(snap.net, v, travel);
    let (back, _) = point_on_path(snap.net, v, travel - v.length);
    Obb::on_chord(back, front, (v.length, v.width), BODY_TOLERANCE)
}
