//! Traffic-light check: the first signalised stop line ahead and what it shows.

use trafficmesh_model::LightColor;

use super::Snapshot;
use super::path::lanes_ahead;
use crate::network::LaneId;
use crate::vehicle::Vehicle;

pub struct LightView {
    pub lane: Option<LaneId>,
    /// Along-path metres from the front bumper to the stop line.
    pub distance: f64,
    pub color: LightColor,
}

/// The first lane of the path whose signalised stop line is still ahead; a line
/// already passed no longer applies (the reference's "value < 0 becomes +inf").
pub fn check(snap: &Snapshot, v: &Vehicle) -> LightView {
    for (_, lane, offset) in lanes_ahead(snap.net, v) {
        let l = snap.net.lane(lane);
        let Some(group) = l.light else { continue };
        let distance = offset + l.light_stop_s();
        if distance < 0.0 {
            continue;
        }
        return LightView {
            lane: Some(lane),
            distance,
            color: snap.lights.state(group as usize).color,
        };
    }
    LightView {
        lane: None,
        distance: f64::INFINITY,
        color: LightColor::Green,
    }
}
