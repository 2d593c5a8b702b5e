//! Traffic-light check: the signalised stop line ahead that the vehicle must
//! stop at, or else the first one, and what it shows.

use trafficmesh_model::LightColor;

use super::Snapshot;
use super::path::lanes_ahead;
use crate::control::speed_limit;
use crate::decision::{Pickup, StopDistances, commits_through_yellow};
use crate::network::{LaneId, StopControl};
use crate::vehicle::Vehicle;

pub struct LightView {
    pub lane: Option<LaneId>,
    /// Along-path metres from the front bumper to the stop line.
    pub distance: f64,
    pub color: LightColor,
    /// The vehicle must stop at it: red, or a yellow it is not committed to
    /// (the Decision step reads this, not the colour).
    pub stops: bool,
}

impl LightView {
    const NONE: LightView = LightView {
        lane: None,
        distance: f64::INFINITY,
        color: LightColor::Green,
        stops: false,
    };
}

/// Does a yellow that turns red in `yellow_left` seconds, `distance` ahead,
/// let the vehicle go on? (See [`commits_through_yellow`].)
fn commits(snap: &Snapshot, v: &Vehicle, distance: f64, yellow_left: f64) -> bool {
    let stops = StopDistances::at(v.speed, snap.config);
    let pickup = Pickup {
        acceleration: snap.config.acceleration,
        limit: speed_limit(snap.net, v, snap.config),
    };
    commits_through_yellow(v.speed, distance, yellow_left, pickup, &stops)
}

/// A front this far past a stop line has crossed it, metres; less is a stop
/// that overshot (for the car ahead, a full exit, or a light seen late).
pub const PAST_LINE: f64 = 0.5;
/// Slower than this a vehicle counts as standing, m/s.
const STANDING: f64 = 1.0;

/// Every signalised stop line of the path still ahead is obeyed: the first
/// one that makes the vehicle stop, else the first one. (A line already
/// passed no longer applies, the reference's "value < 0 becomes +inf",
/// except to a vehicle standing on it, also where it ends the lane just
/// left: at red it stays, however it came to stand there. Two lines close
/// together, or at one point for two signal groups, are both looked at, not
/// only the nearer.)
pub fn check(snap: &Snapshot, v: &Vehicle) -> LightView {
    let mut first = None;
    // A line at the end of the lane just left is still under a front that
    // stopped a hair past it.
    let behind = (v.s < PAST_LINE)
        .then(|| v.behind.latest())
        .flatten()
        .map(|b| (b, -v.s - snap.net.lane(b).length()));
    let ahead = lanes_ahead(snap.net, v).map(|(_, lane, offset)| (lane, offset));
    for (lane, offset) in behind.into_iter().chain(ahead) {
        let l = snap.net.lane(lane);
        let group = match l.control {
            StopControl::Free => continue,
            StopControl::Light(group) => group,
            StopControl::Reservation(k) => {
                // Red at the intersection's entry until a way is granted
                // through it, from where the vehicle asks.
                let distance = offset + l.stop_s.unwrap_or(0.0);
                if distance < 0.0 || distance > crate::reservation::ask_distance(v.speed) {
                    continue;
                }
                let granted = v.grant.as_ref().is_some_and(|g| g.intersection == k);
                let view = LightView {
                    lane: Some(lane),
                    distance,
                    color: if granted {
                        LightColor::Green
                    } else {
                        LightColor::Red
                    },
                    stops: !granted,
                };
                if view.stops {
                    return view;
                }
                first.get_or_insert(view);
                continue;
            }
        };
        let distance = offset + l.light_stop_s();
        let state = snap.lights.state(group as usize);
        if distance < 0.0 {
            let standing_on_it = distance > -PAST_LINE && v.speed < STANDING;
            if !(standing_on_it && state.color == LightColor::Red) {
                continue;
            }
        }
        let distance = distance.max(0.0);
        let stops = match state.color {
            LightColor::Green => false,
            // A remote state may end a hair before the tick it is read in.
            LightColor::Yellow => !commits(snap, v, distance, (state.ends - snap.time).max(0.0)),
            _ => true,
        };
        let view = LightView {
            lane: Some(lane),
            distance,
            color: state.color,
            stops,
        };
        if stops {
            return view;
        }
        first.get_or_insert(view);
    }
    first.unwrap_or(LightView::NONE)
}
