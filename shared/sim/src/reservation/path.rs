//! A movement's path through a reservation intersection: the intersection
//! lane's waypoints smoothed into a curve a car drives (quadratic Bezier
//! pieces cornering at each inner waypoint, joined at the midpoints of the
//! lane's segments, so that heading never jumps), sampled densely.

use glam::DVec2;

use crate::geometry::Polyline;

/// Points per Bezier piece: the heading of a right-angle corner turns by
/// under 5 degrees from one sample to the next.
const SAMPLES_PER_PIECE: usize = 24;

/// The smoothed path through `waypoints` (at least two), from the first to
/// the last: a straight lane stays as it is.
pub fn smoothed(waypoints: &[DVec2]) -> Polyline {
    let n = waypoints.len();
    let mut points = vec![waypoints[0]];
    if n > 2 {
        // Piece k runs from the midpoint before waypoint k to the one after
        // it (the ends themselves at the first and last piece), bending
        // towards waypoint k.
        for k in 1..n - 1 {
            let start = if k == 1 {
                waypoints[0]
            } else {
                0.5 * (waypoints[k - 1] + waypoints[k])
            };
            let end = if k == n - 2 {
                waypoints[n - 1]
            } else {
                0.5 * (waypoints[k] + waypoints[k + 1])
            };
            for i in 1..=SAMPLES_PER_PIECE {
                let t = i as f64 / SAMPLES_PER_PIECE as f64;
                points.push(quadratic(start, waypoints[k], end, t));
            }
        }
    } else {
        points.push(waypoints[n - 1]);
    }
    points.dedup_by(|a, b| a.distance_squared(*b) < 1e-12);
    if points.len() < 2 {
        points.push(points[0] + DVec2::X * 1e-3);
    }
    let heights = vec![0.0; points.len()];
    Polyline::new(points, heights)
}

fn quadratic(a: DVec2, control: DVec2, b: DVec2, t: f64) -> DVec2 {
    let u = 1.0 - t;
    u * u * a + 2.0 * u * t * control + t * t * b
}

/// The least distance between two paths, sampled every `step` metres along
/// each: paths further apart than two bodies' half widths never meet.
pub fn least_distance(a: &Polyline, b: &Polyline, step: f64) -> f64 {
    let samples = |p: &Polyline| {
        let n = (p.length() / step).ceil().max(1.0) as usize;
        (0..=n)
            .map(|i| p.point_at(p.length() * i as f64 / n as f64).0)
            .collect::<Vec<_>>()
    };
    let (sa, sb) = (samples(a), samples(b));
    let to_b = sa.iter().map(|&p| b.distance_to(p));
    let to_a = sb.iter().map(|&p| a.distance_to(p));
    to_b.chain(to_a).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_lane_stays_straight() {
        let p = smoothed(&[DVec2::ZERO, DVec2::new(20.0, 0.0)]);
        assert!((p.length() - 20.0).abs() < 1e-9);
        assert_eq!(p.point_count(), 2);
    }

    #[test]
    fn a_right_angle_turn_is_rounded_off_and_keeps_its_ends() {
        // A corner at (10, 0): the curve passes inside it.
        let corner = [DVec2::ZERO, DVec2::new(10.0, 0.0), DVec2::new(10.0, 10.0)];
        let p = smoothed(&corner);
        assert_eq!(p.point(0), corner[0]);
        assert_eq!(p.point(p.point_count() - 1), corner[2]);
        let mid = p.point_at(0.5 * p.length()).0;
        assert!((mid - DVec2::new(7.5, 2.5)).length() < 0.1, "{mid}");
        assert!(p.length() < 20.0 && p.length() > 15.7, "{}", p.length());
        // The heading turns by under 5 degrees from sample to sample.
        let headings: Vec<f64> = (0..p.point_count() - 1)
            .map(|i| p.direction(i).to_angle())
            .collect();
        for w in headings.windows(2) {
            assert!((w[1] - w[0]).abs() < 0.09, "{} -> {}", w[0], w[1]);
        }
    }

    #[test]
    fn crossing_paths_meet_and_parallel_ones_keep_apart() {
        let east = smoothed(&[DVec2::new(-10.0, 0.0), DVec2::new(10.0, 0.0)]);
        let north = smoothed(&[DVec2::new(0.0, -10.0), DVec2::new(0.0, 10.0)]);
        let beside = smoothed(&[DVec2::new(-10.0, 3.5), DVec2::new(10.0, 3.5)]);
        assert!(least_distance(&east, &north, 0.5) < 1e-9);
        assert!((least_distance(&east, &beside, 0.5) - 3.5).abs() < 1e-9);
    }
}
