//! Plane geometry that both the importers and the simulation use.

use glam::DVec2;

/// Whether `p` lies inside the simple polygon `poly` (even-odd rule).
pub fn point_in_polygon(p: DVec2, poly: &[DVec2]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
    }
    inside
}

/// Inclusive segment intersection; parallel or collinear segments do not intersect.
pub fn segments_intersect(a1: DVec2, b1: DVec2, a2: DVec2, b2: DVec2) -> bool {
    let cross = |a: DVec2, b: DVec2| a.x * b.y - a.y * b.x;
    let d1 = b1 - a1;
    let d2 = b2 - a2;
    let denom = cross(d1, d2);
    if denom.abs() < 1e-12 {
        return false;
    }
    let t = cross(a2 - a1, d2) / denom;
    let u = cross(a2 - a1, d1) / denom;
    (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u)
}
