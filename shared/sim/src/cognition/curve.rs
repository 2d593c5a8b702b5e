//! Curve detection: the heading change summed over the next 40 m.

use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

const CURVE_LOOKAHEAD: f64 = 40.0;
const CURVE_THRESHOLD_DEG: f64 = 45.0;

/// IsTurning: the absolute heading changes of the path segments that start within
/// 40 m ahead of the front bumper, starting from the vehicle's own heading, exceed 45°.
pub fn is_turning(net: &LaneNetwork, v: &Vehicle) -> bool {
    let mut heading = v.forward();
    let mut total = 0.0;
    let mut offset = -v.s;
    for &lane in &v.path {
        let line = &net.lane(lane).line;
        for i in 0..line.points.len() - 1 {
            let start = offset + line.cum[i];
            let end = offset + line.cum[i + 1];
            if end <= 0.0 || line.cum[i + 1] - line.cum[i] < 1e-6 {
                continue;
            }
            if start >= CURVE_LOOKAHEAD {
                return total > CURVE_THRESHOLD_DEG.to_radians();
            }
            let dir = line.direction(i);
            total += heading.angle_to(dir).abs();
            heading = dir;
        }
        offset += line.length();
    }
    total > CURVE_THRESHOLD_DEG.to_radians()
}
