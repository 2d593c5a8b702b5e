//! Crosswalk stop points for imported maps: where a lane's centreline enters a
//! crosswalk's polygon, set back a metre, with the lane's heading there.

use glam::DVec2;
use trafficmesh_model::geometry::point_in_polygon;
use trafficmesh_model::map::{Point, StopPointDef};

/// Vehicles stop this far before a crosswalk's edge, metres.
const STOP_BACK: f64 = 1.0;
/// Entries this close (metres) and this aligned (cosine) are one stop point:
/// lanes that share their start (a junction's turns) need it only once.
const SAME_STOP_DISTANCE: f64 = 0.5;
const SAME_STOP_COS: f64 = 0.985;

type Xyz = [f64; 3];

/// Even-odd rule on the horizontal plane (the simulation's own test).
fn inside(polygon: &[Xyz], p: Xyz) -> bool {
    let flat: Vec<DVec2> = polygon.iter().map(|q| DVec2::new(q[0], q[1])).collect();
    point_in_polygon(DVec2::new(p[0], p[1]), &flat)
}

/// One stop point per centreline that enters the polygon from outside (its
/// first entry), near-duplicates merged.
pub fn stop_points<'a>(
    polygon: &[Xyz],
    centrelines: impl IntoIterator<Item = &'a [Xyz]>,
) -> Vec<StopPointDef> {
    let mut stops: Vec<(Xyz, [f64; 2])> = Vec::new();
    for line in centrelines {
        let Some((entry, dir)) = first_entry(polygon, line) else {
            continue;
        };
        let at = [
            entry[0] - dir[0] * STOP_BACK,
            entry[1] - dir[1] * STOP_BACK,
            entry[2],
        ];
        let duplicate = stops.iter().any(|(p, d)| {
            (p[0] - at[0]).hypot(p[1] - at[1]) < SAME_STOP_DISTANCE
                && d[0] * dir[0] + d[1] * dir[1] > SAME_STOP_COS
        });
        if !duplicate {
            stops.push((at, dir));
        }
    }
    stops
        .into_iter()
        .map(|(at, dir)| StopPointDef {
            position: Point(at),
            heading_deg: Some(dir[1].atan2(dir[0]).to_degrees()),
        })
        .collect()
}

/// Where the line first crosses into the polygon, and its unit direction
/// there. Imported lanes often end and start exactly on a crossing's edge, so
/// entries are found where a segment meets an edge (ends included) and the line
/// goes on inside; a line that starts inside, not on an edge, never enters.
fn first_entry(polygon: &[Xyz], line: &[Xyz]) -> Option<(Xyz, [f64; 2])> {
    const EPS: f64 = 1e-6;
    for (k, w) in line.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len < EPS {
            continue;
        }
        let dir = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let at = |t: f64| [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t);
        let mut ts = edge_hits(polygon, a, b);
        if k == 0 && inside(polygon, a) && !ts.iter().any(|t| t.abs() < EPS) {
            return None;
        }
        ts.sort_by(f64::total_cmp);
        let step = EPS / len;
        if let Some(&t) = ts
            .iter()
            .find(|&&t| inside(polygon, at(t + step)) && !inside(polygon, at(t - step)))
        {
            return Some((at(t), dir));
        }
    }
    None
}

/// Parameters along a->b (0 to 1, ends included) where it meets polygon edges.
fn edge_hits(polygon: &[Xyz], a: Xyz, b: Xyz) -> Vec<f64> {
    let n = polygon.len();
    let r = [b[0] - a[0], b[1] - a[1]];
    let mut ts = Vec::new();
    for i in 0..n {
        let (c, d) = (polygon[i], polygon[(i + 1) % n]);
        let s = [d[0] - c[0], d[1] - c[1]];
        let denom = r[0] * s[1] - r[1] * s[0];
        if denom.abs() < 1e-12 {
            continue;
        }
        let q = [c[0] - a[0], c[1] - a[1]];
        let t = (q[0] * s[1] - q[1] * s[0]) / denom;
        let u = (q[0] * r[1] - q[1] * r[0]) / denom;
        if (-1e-9..=1.0 + 1e-9).contains(&t) && (-1e-9..=1.0 + 1e-9).contains(&u) {
            ts.push(t.clamp(0.0, 1.0));
        }
    }
    ts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lane_entering_the_area_stops_a_metre_before_it_once() {
        let square = [
            [0.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [4.0, 4.0, 0.0],
            [0.0, 4.0, 0.0],
        ];
        let east: &[Xyz] = &[[-10.0, 2.0, 0.0], [10.0, 2.0, 0.0]];
        let east_again: &[Xyz] = &[[-8.0, 2.1, 0.0], [10.0, 2.1, 0.0]];
        let west: &[Xyz] = &[[10.0, 1.0, 0.0], [-10.0, 1.0, 0.0]];
        let beside: &[Xyz] = &[[-10.0, 8.0, 0.0], [10.0, 8.0, 0.0]];
        // Ends on the edge, then its successor goes on inside: one entry.
        let to_edge: &[Xyz] = &[[2.0, 20.0, 0.0], [2.0, 4.0, 0.0]];
        let from_edge: &[Xyz] = &[[2.0, 4.0, 0.0], [2.0, -20.0, 0.0]];
        // Starts inside: never enters.
        let within: &[Xyz] = &[[3.0, 3.0, 0.0], [3.0, 20.0, 0.0]];
        let stops = stop_points(
            &square,
            [east, east_again, west, beside, to_edge, from_edge, within],
        );
        assert_eq!(stops.len(), 3, "{stops:?}");
        let south = &stops[2];
        assert!((south.position.0[1] - 5.0).abs() < 1e-6, "{south:?}");
        assert!((south.heading_deg.unwrap() + 90.0).abs() < 1e-9);
        let (e, w) = (&stops[0], &stops[1]);
        assert!((e.position.0[0] + 1.0).abs() < 1e-6 && (e.position.0[1] - 2.0).abs() < 1e-9);
        assert!(e.heading_deg.unwrap().abs() < 1e-9);
        assert!((w.position.0[0] - 5.0).abs() < 1e-6);
        assert!((w.heading_deg.unwrap().abs() - 180.0).abs() < 1e-9);
    }
}
