//! How far a long body swings out of its lane's corridor on curves: road
//! conflicts are widened by it.

use super::heading_at;
use crate::network::Lane;

/// Half the longest vehicle's length (the truck's): how far a body reaches
/// along its lane from the point it stands on.
const HALF_BODY: f64 = 4.6;
/// The most a road conflict is widened for a body swinging out on a curve.
pub(super) const MAX_SWEEP: f64 = 2.0;

/// How far a long body on lane `id` at `s` can swing out of the lane's
/// corridor: a rigid body does not bend with the lane, so on a curve (or where
/// the lane joins a sharply turning one) its ends leave the centreline by
/// about the chord's offset over the body's length.
pub(super) fn sweep(lanes: &[Lane], id: usize, s: f64) -> f64 {
    let lane = &lanes[id];
    let len = lane.length();
    let headings = |lane: &Lane, s: f64| heading_at(lane, s.clamp(0.0, lane.length()));
    let here = headings(lane, s);
    let mut turn = here
        .dot(headings(lane, s - HALF_BODY))
        .min(here.dot(headings(lane, s + HALF_BODY)));
    if s + HALF_BODY > len {
        for &n in &lane.next {
            let n = &lanes[n as usize];
            turn = turn.min(here.dot(headings(n, s + HALF_BODY - len)));
        }
    }
    if s < HALF_BODY {
        for &p in &lane.prev {
            let p = &lanes[p as usize];
            turn = turn.min(here.dot(headings(p, p.length() + s - HALF_BODY)));
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
