//! Joints between lanes that no car can drive. At a geometry node a SUMO
//! network may end a lane past the point where the next one turns off, so
//! that the next lane starts heading back over the one before (a switchback
//! of a metre or so). A body spanning that joint, drawn as the chord between
//! its bumpers, folds to half its length and reaches back into the vehicle
//! behind. Where one lane leads only into the other, the joint moves back
//! along both until the way turns by at most a right angle there, as a
//! driver cuts such a corner.

use std::collections::HashMap;

use trafficmesh_model::map::{LaneDef, Point, ground_length};

/// Metres the joint moves back per try...
const STEP: f64 = 0.25;
/// ... and at most.
const MOST: f64 = 3.0;
/// What each lane keeps at least, metres.
const KEEP: f64 = 0.1;
/// The headings either side of a joint are measured over this, metres.
const REACH: f64 = 0.5;

/// Moves back the joints that fold back (see the module); returns how many.
/// `links` are the (from, to) lane pairs of the network.
pub fn cut_switchbacks(
    lanes: &mut [LaneDef],
    index: &HashMap<String, usize>,
    links: &[(String, String)],
) -> usize {
    let mut entering: HashMap<&str, usize> = HashMap::new();
    for (_, to) in links {
        *entering.entry(to.as_str()).or_default() += 1;
    }
    let mut cut = 0;
    for (from, to) in links {
        let (Some(&f), Some(&t)) = (index.get(from), index.get(to)) else {
            continue;
        };
        if f == t || lanes[f].next.len() != 1 || entering.get(to.as_str()) != Some(&1) {
            continue;
        }
        if let Some((before, after)) = cut_joint(&lanes[f].waypoints, &lanes[t].waypoints) {
            lanes[f].waypoints = before;
            lanes[t].waypoints = after;
            cut += 1;
        }
    }
    cut
}

/// The two polylines with their joint moved back where it folds back, or
/// None where it does not (or cannot be mended within [`MOST`]).
fn cut_joint(before: &[Point], after: &[Point]) -> Option<(Vec<Point>, Vec<Point>)> {
    if !folds_back(before, after) {
        return None;
    }
    let (len_b, len_a) = (ground_length(before), ground_length(after));
    let most = MOST.min(len_b - KEEP).min(len_a - KEEP);
    let mut d = STEP;
    while d <= most {
        let (p, q) = (at(before, len_b - d), at(after, d));
        let joint = Point([0, 1, 2].map(|i| 0.5 * (p[i] + q[i])));
        let mut b = up_to(before, len_b - d);
        *b.last_mut()? = joint;
        let mut a = from(after, d);
        a[0] = joint;
        if !folds_back(&b, &a) {
            return Some((b, a));
        }
        d += STEP;
    }
    None
}

/// Whether the way turns by more than a right angle where `before` ends and
/// `after` starts (both measured over [`REACH`]).
fn folds_back(before: &[Point], after: &[Point]) -> bool {
    let joint = after[0].0;
    let u = sub(joint, at(before, ground_length(before) - REACH));
    let w = sub(at(after, REACH), joint);
    u[0] * w[0] + u[1] * w[1] < 0.0
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The point `s` metres along the polyline (its ends beyond it).
fn at(points: &[Point], s: f64) -> [f64; 3] {
    let mut left = s;
    for w in points.windows(2) {
        let l = w[0].ground_distance(w[1]);
        if left <= l && l > 0.0 {
            let k = left / l;
            return [0, 1, 2].map(|i| w[0].0[i] + (w[1].0[i] - w[0].0[i]) * k);
        }
        left -= l;
    }
    if s <= 0.0 {
        points[0].0
    } else {
        points[points.len() - 1].0
    }
}

/// The polyline up to `s` metres along, ending at that point.
fn up_to(points: &[Point], s: f64) -> Vec<Point> {
    let mut out = vec![points[0]];
    let mut walked = 0.0;
    for w in points.windows(2) {
        let l = w[0].ground_distance(w[1]);
        if walked + l >= s {
            break;
        }
        walked += l;
        out.push(w[1]);
    }
    out.push(Point(at(points, s)));
    out
}

/// The polyline from `s` metres along, starting at that point.
fn from(points: &[Point], s: f64) -> Vec<Point> {
    let mut out = vec![Point(at(points, s))];
    let mut walked = 0.0;
    for w in points.windows(2) {
        walked += w[0].ground_distance(w[1]);
        if walked > s {
            out.push(w[1]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(points: &[(f64, f64)]) -> Vec<Point> {
        points.iter().map(|&(x, y)| Point([x, y, 0.0])).collect()
    }

    #[test]
    fn a_lane_that_overshoots_the_turn_is_cut_back_to_a_drivable_joint() {
        // North for 16 m, one metre past the road turning east; the next lane
        // starts heading back south-east (bologna_acosta, junction 47).
        let before = line(&[(0.0, 0.0), (0.0, 16.0)]);
        let after = line(&[
            (0.0, 16.0),
            (0.3, 15.4),
            (0.7, 15.0),
            (1.2, 14.9),
            (1.8, 15.0),
        ]);
        let (b, a) = cut_joint(&before, &after).expect("a switchback is cut");
        assert_eq!(b.last(), a.first(), "the lanes still join");
        let joint = a[0].0;
        assert!(joint[1] < 15.6, "the joint moved back: {joint:?}");
        assert!(folds_back(&before, &after));
        assert!(
            !folds_back(&b, &a),
            "the way turns by a right angle at most"
        );
        assert_eq!(
            a.last(),
            after.last(),
            "the next lane still ends where it did"
        );
        assert_eq!(b[0], before[0], "the lane still starts where it did");
    }

    #[test]
    fn smooth_joints_and_right_angles_are_left_alone() {
        let before = line(&[(0.0, 0.0), (0.0, 10.0)]);
        assert!(cut_joint(&before, &line(&[(0.0, 10.0), (0.0, 20.0)])).is_none());
        assert!(cut_joint(&before, &line(&[(0.0, 10.0), (5.0, 10.0)])).is_none());
    }
}
