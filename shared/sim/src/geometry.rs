//! Plane geometry on polylines: arc length, interpolation, projection, intersection.

use glam::DVec2;
pub use trafficmesh_model::geometry::{point_in_polygon, segments_intersect};

/// One polyline vertex with everything the per-tick code reads about it, in one
/// place so that a look-up touches one cache line rather than five arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    pub point: DVec2,
    /// Height (the map's z), interpolated for poses.
    pub z: f64,
    /// Arc length from the first vertex.
    pub cum: f64,
    /// Heading of the segment starting here, radians (the last vertex repeats the
    /// previous one).
    pub heading: f64,
    /// Summed absolute heading change from the first segment to this one.
    pub turn_cum: f64,
}

/// A polyline with arc lengths, headings and turning precomputed.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Polyline {
    /// Inline copies for the common single-segment lane, so that per-tick code
    /// on a straight lane never touches the vertex array.
    start: Vertex,
    end: Vertex,
    length: f64,
    straight: bool,
    pub vertices: Vec<Vertex>,
}

impl Polyline {
    /// At least two points.
    pub fn new(points: Vec<DVec2>, heights: Vec<f64>) -> Self {
        let n = points.len();
        let mut vertices: Vec<Vertex> = Vec::with_capacity(n);
        let (mut cum, mut turn) = (0.0, 0.0);
        for i in 0..n {
            if i > 0 {
                cum += points[i].distance(points[i - 1]);
            }
            let seg = if i + 1 < n { i } else { i - 1 };
            let d = points[seg + 1] - points[seg];
            let heading = d.y.atan2(d.x);
            if i > 0 && i + 1 < n {
                turn += angle_between(vertices[i - 1].heading, heading);
            }
            vertices.push(Vertex {
                point: points[i],
                z: heights[i],
                cum,
                heading,
                turn_cum: turn,
            });
        }
        let (start, end) = (vertices[0], vertices[n - 1]);
        Polyline {
            vertices,
            length: cum,
            start,
            end,
            straight: n == 2,
        }
    }

    pub fn length(&self) -> f64 {
        self.length
    }

    pub fn point_count(&self) -> usize {
        self.vertices.len()
    }

    pub fn point(&self, i: usize) -> DVec2 {
        if i == 0 {
            self.start.point
        } else {
            self.vertices[i].point
        }
    }

    /// One straight segment.
    pub fn is_straight(&self) -> bool {
        self.straight
    }

    /// Heading of the first segment, radians.
    pub fn start_heading(&self) -> f64 {
        self.start.heading
    }

    /// Heading of the last segment, radians.
    pub fn end_heading(&self) -> f64 {
        self.end.heading
    }

    /// Summed absolute heading change along the whole polyline, radians.
    pub fn total_turn(&self) -> f64 {
        self.end.turn_cum
    }

    pub fn points(&self) -> impl Iterator<Item = DVec2> + '_ {
        self.vertices.iter().map(|v| v.point)
    }

    /// Index i of the segment [i, i+1] containing arc length s (clamped to the ends).
    pub fn segment_at(&self, s: f64) -> usize {
        let last = self.vertices.len() - 2;
        // Most lanes are one straight segment: no search needed.
        if last == 0 {
            return 0;
        }
        // Start from the proportional guess and walk: on evenly sampled curves
        // (the grid's, most imported ones) that reads one or two vertices where
        // a binary search reads four, each a cache line on a cold lane.
        let v = &self.vertices;
        let mut i = ((s / self.length) * (last + 1) as f64).clamp(0.0, last as f64) as usize;
        while i > 0 && v[i].cum > s {
            i -= 1;
        }
        while i < last && v[i + 1].cum <= s {
            i += 1;
        }
        i
    }

    /// Asks for the vertices [`Polyline::point_at`] will read at `s` (see
    /// [`crate::prefetch`]); a straight polyline has them inline.
    #[inline]
    pub fn prefetch_at(&self, s: f64) {
        if self.straight {
            return;
        }
        let last = self.vertices.len() - 2;
        let i = ((s / self.length) * (last + 1) as f64).clamp(0.0, last as f64) as usize;
        crate::prefetch::line(&self.vertices[i]);
        crate::prefetch::line(&self.vertices[i + 1]);
    }

    /// Unit direction of segment i.
    pub fn direction(&self, i: usize) -> DVec2 {
        (self.vertices[i + 1].point - self.vertices[i].point).normalize_or_zero()
    }

    /// Point and height at arc length s; beyond the ends the end segments are extended.
    pub fn point_at(&self, s: f64) -> (DVec2, f64) {
        let (a, b) = if self.straight {
            (&self.start, &self.end)
        } else {
            let i = self.segment_at(s);
            (&self.vertices[i], &self.vertices[i + 1])
        };
        let seg = b.cum - a.cum;
        let t = if seg > 0.0 { (s - a.cum) / seg } else { 0.0 };
        (
            a.point.lerp(b.point, t),
            a.z + (b.z - a.z) * t.clamp(0.0, 1.0),
        )
    }

    /// Arc length of the point of the polyline closest to p.
    pub fn project(&self, p: DVec2) -> f64 {
        let mut best = (f64::INFINITY, 0.0);
        for w in self.vertices.windows(2) {
            let (a, b) = (w[0].point, w[1].point);
            let ab = b - a;
            let len2 = ab.length_squared();
            let t = if len2 > 0.0 {
                ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let d = p.distance_squared(a + ab * t);
            if d < best.0 {
                best = (d, w[0].cum + t * len2.sqrt());
            }
        }
        best.1
    }

    /// Distance from p to the polyline.
    pub fn distance_to(&self, p: DVec2) -> f64 {
        let (q, _) = self.point_at(self.project(p));
        q.distance(p)
    }
}

/// 2D cross product (z of the 3D cross): positive when b is to the left of a.
pub fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Smallest absolute difference between two headings, radians in [0, π].
pub fn angle_between(a: f64, b: f64) -> f64 {
    use std::f64::consts::TAU;
    let mut d = (a - b).abs();
    // Headings come from atan2, so one wrap is enough; fmod only for the rest.
    if d > TAU {
        d %= TAU;
    }
    d.min(TAU - d)
}

/// Corners of an oriented box centred at c with heading yaw and half extents (hl, hw).
pub fn box_corners(c: DVec2, yaw: f64, hl: f64, hw: f64) -> [DVec2; 4] {
    Obb {
        centre: c,
        axis: DVec2::from_angle(yaw),
        half_length: hl,
        half_width: hw,
    }
    .corners()
}

/// Separating-axis overlap test of two convex quadrilaterals.
pub fn boxes_overlap(a: &[DVec2; 4], b: &[DVec2; 4]) -> bool {
    for poly in [a, b] {
        for i in 0..4 {
            let edge = poly[(i + 1) % 4] - poly[i];
            let axis = edge.perp();
            let (amin, amax) = extent(a, axis);
            let (bmin, bmax) = extent(b, axis);
            if amax <= bmin || bmax <= amin {
                return false;
            }
        }
    }
    true
}

fn extent(poly: &[DVec2; 4], axis: DVec2) -> (f64, f64) {
    poly.iter()
        .map(|p| p.dot(axis))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

/// An oriented box: a centre, the unit axis along its length, and half its
/// length and width.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Obb {
    pub centre: DVec2,
    pub axis: DVec2,
    pub half_length: f64,
    pub half_width: f64,
}

impl Obb {
    /// A body `length` by `width` drawn on the chord from its back bumper to
    /// its front one (centred on it, as `pose` draws bodies), shrunk by
    /// `margin` on every side.
    pub fn on_chord(back: DVec2, front: DVec2, (length, width): (f64, f64), margin: f64) -> Self {
        Obb {
            centre: 0.5 * (back + front),
            axis: (front - back).try_normalize().unwrap_or(DVec2::X),
            half_length: 0.5 * length - margin,
            half_width: 0.5 * width - margin,
        }
    }

    pub fn corners(&self) -> [DVec2; 4] {
        let (f, l) = (
            self.axis * self.half_length,
            self.axis.perp() * self.half_width,
        );
        let c = self.centre;
        [c + f + l, c + f - l, c - f - l, c - f + l]
    }

    /// Its half extent along `axis` (a unit vector).
    pub fn half_shadow(&self, axis: DVec2) -> f64 {
        self.half_length * self.axis.dot(axis).abs()
            + self.half_width * self.axis.perp().dot(axis).abs()
    }

    /// Signed separation of two boxes: the widest gap between their
    /// shadows on the four axes. Positive: they lie at least that far apart.
    /// Zero or negative: they touch or overlap, about that deep.
    pub fn separation(&self, other: &Obb) -> f64 {
        let d = other.centre - self.centre;
        [self.axis, self.axis.perp(), other.axis, other.axis.perp()]
            .into_iter()
            .map(|axis| d.dot(axis).abs() - self.half_shadow(axis) - other.half_shadow(axis))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// The smallest and largest corner of its axis-aligned bounds.
    pub fn bounds(&self) -> (DVec2, DVec2) {
        let half = DVec2::new(self.half_shadow(DVec2::X), self.half_shadow(DVec2::Y));
        (self.centre - half, self.centre + half)
    }
}

/// Whether two simple polygons (convex or not) overlap: an edge crossing or
/// one holding a vertex of the other.
pub fn polygons_overlap(a: &[DVec2], b: &[DVec2]) -> bool {
    if a.len() < 3 || b.len() < 3 {
        return false;
    }
    let edges = |poly: &[DVec2]| {
        let n = poly.len();
        (0..n)
            .map(move |i| (poly[i], poly[(i + 1) % n]))
            .collect::<Vec<_>>()
    };
    let (ea, eb) = (edges(a), edges(b));
    ea.iter().any(|&(a1, a2)| {
        eb.iter()
            .any(|&(b1, b2)| segments_intersect(a1, a2, b1, b2))
    }) || point_in_polygon(a[0], b)
        || point_in_polygon(b[0], a)
}

#[cfg(test)]
mod tests {
    use super::{Polyline, angle_between};
    use glam::DVec2;
    use std::f64::consts::{PI, TAU};

    #[test]
    fn segment_at_finds_the_last_vertex_at_or_before_s_on_uneven_spacing() {
        // Uneven segments and a zero-length one (two vertices at 4 m).
        let xs = [0.0, 0.5, 4.0, 4.0, 4.2, 9.0, 30.0];
        let line = Polyline::new(
            xs.iter().map(|&x| DVec2::new(x, 0.0)).collect(),
            vec![0.0; xs.len()],
        );
        let last = xs.len() - 2;
        for k in -20..=340 {
            let s = k as f64 * 0.1;
            let expected = line
                .vertices
                .partition_point(|v| v.cum <= s)
                .saturating_sub(1)
                .min(last);
            assert_eq!(line.segment_at(s), expected, "s = {s}");
        }
    }

    #[test]
    fn angle_between_takes_the_short_way_round() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(angle_between(0.5, 0.2), 0.3));
        assert!(close(angle_between(-0.2, 0.5), 0.7));
        assert!(close(angle_between(3.0, -3.0), TAU - 6.0));
        assert!(close(angle_between(PI, -PI), 0.0));
        assert!(close(angle_between(0.1, 0.1 + 3.0 * TAU), 0.0));
        assert!(close(angle_between(0.0, PI / 2.0 - 5.0 * TAU), PI / 2.0));
    }
}
