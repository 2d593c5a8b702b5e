//! How far a long body swings out of its lane's corridor on curves: road
//! conflicts are widened by it.

use glam::DVec2;

use super::heading_at;
use crate::network::Lane;

/// Half the longest vehicle's length (the truck's): how far a body reaches
/// along its lane from the point it stands on.
const HALF_BODY: f64 = 4.6;
/// The most a road conflict is widened for a body swinging out on a curve.
pub(super) const MAX_SWEEP: f64 = 2.0;
/// Below this (the sine of a turn, or the other lane's offset over its
/// distance) there is no side to tell.
const TURN_EPSILON: f64 = 1e-6;

/// How far a long body on lane `id` at `s` can swing out of the lane's
/// corridor toward `toward` (where the other lane lies; zero: toward either
/// side): a rigid body does not bend with the lane, so on a curve (or
/// where the lane joins a sharply turning one) its middle cuts the inside of
/// the turn by about the chord's offset over the body's length. A turn away
/// from the other lane swings the body away from it. `into_junctions`: the
/// turn onto or off a junction lane counts too.
pub(super) fn sweep(lanes: &[Lane], id: usize, s: f64, toward: DVec2, into_junctions: bool) -> f64 {
    let lane = &lanes[id];
    let len = lane.length();
    let headings = |lane: &Lane, s: f64| heading_at(lane, s.clamp(0.0, lane.length()));
    let here = headings(lane, s);
    let side = here.perp_dot(toward);
    // The cosine of a turn from one heading to the next, where it cuts
    // toward the other lane (its inside on the other lane's side, or no side
    // to tell); 1 (no turn) where it cuts away.
    let cut = |from: DVec2, to: DVec2| {
        let turn = from.perp_dot(to);
        if turn * side >= 0.0 || turn.abs() < TURN_EPSILON || side.abs() < TURN_EPSILON {
            from.dot(to)
        } else {
            1.0
        }
    };
    let mut turn =
        cut(headings(lane, s - HALF_BODY), here).min(cut(here, headings(lane, s + HALF_BODY)));
    if s + HALF_BODY > len {
        for n in lane.next.iter().map(|&n| &lanes[n as usize]) {
            if n.intersection && !into_junctions {
                continue;
            }
            turn = turn.min(cut(here, headings(n, s + HALF_BODY - len)));
        }
    }
    if s < HALF_BODY {
        for p in lane.prev.iter().map(|&p| &lanes[p as usize]) {
            if p.intersection && !into_junctions {
                continue;
            }
            turn = turn.min(cut(headings(p, p.length() + s - HALF_BODY), here));
        }
    }
    let angle = turn.clamp(-1.0, 1.0).acos();
    (HALF_BODY * (angle * 0.5).sin()).min(MAX_SWEEP)
}

/// Of a sweep taken for the longest body, what a body `length` long swings
/// out. On a bend of radius r a body's ends leave the centreline by about
/// the sagitta of its half length h, h² / 2r: a car half a truck's length
/// swings out a quarter as far.
pub(super) fn swept(sweep: f64, length: f64) -> f64 {
    let h = (0.5 * length / HALF_BODY).min(1.0);
    sweep * h * h
}
