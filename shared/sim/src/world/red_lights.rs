//! Red-light crossings, counted where they happen: a front bumper that goes
//! `PAST_LINE` beyond a signalised stop line while its group has been red
//! for more than [`RED_GRACE`]. Zero is expected: the yellow rule
//! (`decision::commits_through_yellow`, read by `cognition::light`) lets a
//! vehicle cross only within the yellow time.

use trafficmesh_model::LightColor;

use crate::cognition::light::PAST_LINE;
use crate::lights::Lights;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::{Vehicle, VehicleId};

/// Seconds of red before a crossing counts: one that was in hand when
/// yellow ended finishes within it.
pub const RED_GRACE: f64 = 0.5;

/// One crossing on red.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RedLightCrossing {
    pub vehicle: VehicleId,
    /// The lane whose stop line was crossed.
    pub lane: LaneId,
    /// Seconds the group had been red.
    pub into_red: f64,
}

/// Did the front, which was at `s_before` on path[0] before this tick's
/// move, go past a stop line on red?
pub(super) fn crossed_on_red(
    net: &LaneNetwork,
    lights: &Lights,
    time: f64,
    v: &Vehicle,
    s_before: f64,
) -> Option<RedLightCrossing> {
    // Cognition saw no stop line ahead, nor did it last tick (the line at
    // the end of the lane just left, whose mark lies at most PAST_LINE into
    // this one): none to cross.
    let behind = v.behind.latest().filter(|_| s_before < PAST_LINE);
    if v.light_lane.is_none() && behind.is_none_or(|b| net.lane(b).light().is_none()) {
        return None;
    }
    let mut start = behind.map_or(0.0, |b| -net.lane(b).length());
    for lane in behind.into_iter().chain(v.path.iter().copied()) {
        if start > v.s {
            break;
        }
        let l = net.lane(lane);
        if let Some(group) = l.light() {
            let mark = start + l.light_stop_s() + PAST_LINE;
            let state = lights.state(group as usize);
            let into_red = time - state.since;
            if s_before < mark
                && mark <= v.s
                && state.color == LightColor::Red
                && into_red > RED_GRACE
            {
                return Some(RedLightCrossing {
                    vehicle: v.id,
                    lane,
                    into_red,
                });
            }
        }
        start += l.length();
    }
    None
}
