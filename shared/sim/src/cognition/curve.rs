//! Curve detection: the heading change summed over the next 40 m.

use crate::geometry::angle_between;
use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

const CURVE_LOOKAHEAD: f64 = 40.0;
const CURVE_THRESHOLD_DEG: f64 = 45.0;

/// IsTurning: the absolute heading changes along the path segments that start
/// within 40 m ahead of the front bumper, starting from the vehicle's own
/// heading, exceed 45°. Within a lane the sum comes from the precomputed
/// cumulative turning, so the cost does not grow with the waypoint count.
pub fn is_turning(net: &LaneNetwork, v: &Vehicle) -> bool {
    let threshold = CURVE_THRESHOLD_DEG.to_radians();
    let mut heading = v.body_yaw;
    let mut total = 0.0;
    let mut offset = -v.s;
    for &lane in &v.path {
        if offset >= CURVE_LOOKAHEAD {
            break;
        }
        let line = &net.lane(lane).line;
        if offset >= 0.0 && offset + line.length() <= CURVE_LOOKAHEAD || line.is_straight() {
            // The whole lane is ahead and inside the window: its inline summary is enough.
            total += angle_between(heading, line.start_heading()) + line.total_turn();
            if total > threshold {
                return true;
            }
            heading = line.end_heading();
            offset += line.length();
            continue;
        }
        // First segment still ahead of the front bumper, last one starting inside the window.
        let first = line.segment_at(-offset);
        let last = line.segment_at(CURVE_LOOKAHEAD - offset);
        let (a, b) = (&line.vertices[first], &line.vertices[last]);
        total += angle_between(heading, a.heading) + b.turn_cum - a.turn_cum;
        if total > threshold {
            return true;
        }
        heading = b.heading;
        offset += line.length();
    }
    total > threshold
}
