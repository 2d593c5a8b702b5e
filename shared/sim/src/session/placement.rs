//! Where a body stands on the lane network: the lane a logged actor is
//! driving on when it is handed over, and a vehicle's centre some metres
//! further along its path (its forecast).

use glam::{DVec2, DVec3};

use crate::network::{LaneId, LaneNetwork};

/// A body is on a lane when its front bumper is this near the lane's line,
/// metres...
const MAX_OFFSET: f64 = 2.0;
/// ...and it heads along the lane within this, radians (45°).
const MAX_HEADING_GAP: f64 = std::f64::consts::FRAC_PI_4;

/// Each lane's bounding box grown by [`MAX_OFFSET`], so that a match skips
/// the lanes that cannot hold a body at once.
pub struct LaneBoxes(Vec<(DVec2, DVec2)>);

impl LaneBoxes {
    pub fn new(net: &LaneNetwork) -> Self {
        LaneBoxes(
            net.lanes
                .iter()
                .map(|l| {
                    let (lo, hi) = l.line.vertices.iter().fold(
                        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
                        |(lo, hi), v| (lo.min(v.point), hi.max(v.point)),
                    );
                    (lo - MAX_OFFSET, hi + MAX_OFFSET)
                })
                .collect(),
        )
    }

    fn may_hold(&self, lane: usize, p: DVec2) -> bool {
        let (lo, hi) = self.0[lane];
        p.cmpge(lo).all() && p.cmple(hi).all()
    }
}

/// The lane (not a junction lane when a road lane fits) and front-bumper arc
/// length of a body whose front bumper is at `front`, heading `yaw`.
pub fn match_lane(
    net: &LaneNetwork,
    boxes: &LaneBoxes,
    front: DVec2,
    yaw: f64,
) -> Option<(LaneId, f64)> {
    let heading = DVec2::from_angle(yaw);
    let mut best: Option<(bool, f64, LaneId, f64)> = None;
    for (i, lane) in net.lanes.iter().enumerate() {
        if !boxes.may_hold(i, front) {
            continue;
        }
        let s = lane.line.project(front);
        let (p, _) = lane.line.point_at(s);
        let offset = p.distance(front);
        if offset > MAX_OFFSET || s <= 0.0 && lane.line.length() > 0.0 && offset > 0.5 {
            continue;
        }
        let ahead = lane.line.point_at((s + 0.5).min(lane.line.length())).0
            - lane.line.point_at((s - 0.5).max(0.0)).0;
        if ahead.length() == 0.0 || ahead.normalize().angle_to(heading).abs() > MAX_HEADING_GAP {
            continue;
        }
        let key = (lane.intersection, offset, i as LaneId, s);
        if best.is_none_or(|b| (key.0, key.1) < (b.0, b.1)) {
            best = Some(key);
        }
    }
    best.map(|(_, _, lane, s)| (lane, s))
}

/// The centres (with the lane's height) and unit headings of a body of
/// `length` whose front bumper is each of `aheads` (non-decreasing) metres
/// further along `path` than arc length `s` of its first lane; past the
/// path's end, straight on. One walk along the path serves them all.
pub fn along_path<'a>(
    net: &'a LaneNetwork,
    path: &'a [LaneId],
    s: f64,
    length: f64,
    aheads: impl IntoIterator<Item = f64> + 'a,
) -> impl Iterator<Item = (DVec3, DVec2)> + 'a {
    // The lane reached so far and the path's arc length where it starts.
    let mut k = 0;
    let mut start = 0.0;
    aheads.into_iter().map(move |ahead| {
        if path.is_empty() {
            return (DVec3::ZERO, DVec2::X);
        }
        let mut at = s + ahead - length * 0.5 - start;
        let mut line = &net.lane(path[k]).line;
        while at > line.length() && k + 1 < path.len() {
            at -= line.length();
            start += line.length();
            k += 1;
            line = &net.lane(path[k]).line;
        }
        let (p, z) = line.point_at(at);
        // The heading over a metre, so that a kink between two vertices
        // turns the body gradually; within one segment that is the
        // segment's own direction.
        let i = line.segment_at(at);
        let (a, b) = (&line.vertices[i], &line.vertices[i + 1]);
        let d = if a.cum <= at - 0.5 && at + 0.5 <= b.cum {
            b.point - a.point
        } else {
            line.point_at((at + 0.5).min(line.length())).0 - line.point_at((at - 0.5).max(0.0)).0
        };
        (p.extend(z), d.try_normalize().unwrap_or(DVec2::X))
    })
}
