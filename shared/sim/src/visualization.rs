//! Visualization: turn signals from the upcoming lanes, trip bookkeeping.

use trafficmesh_model::{TurnDirection, TurnSignal};

use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

/// Below this speed a vehicle counts as stopped (AWSIM's brake-light threshold).
pub const STOPPED_SPEED: f64 = 0.03;

/// The current lane's turn, else the next lane's; kept when only one lane is known.
/// A function of the first two path lanes: kept up to date by
/// [`crate::lane_change::refresh_first_lanes`].
pub fn turn_signal(net: &LaneNetwork, v: &Vehicle) -> TurnSignal {
    if v.path.len() < 2 {
        return v.turn_signal;
    }
    let signal = |d| match d {
        TurnDirection::Left => Some(TurnSignal::Left),
        TurnDirection::Right => Some(TurnSignal::Right),
        TurnDirection::Straight => None,
    };
    signal(net.lane(v.path[0]).turn)
        .or_else(|| signal(net.lane(v.path[1]).turn))
        .unwrap_or(TurnSignal::Off)
}

/// Below this speed a vehicle is waiting (SUMO's waiting-time threshold).
pub const WAITING_SPEED: f64 = 0.1;

/// Trip accounting after the tick's motion; `speed_limit` is the lane's.
pub fn update_trip(v: &mut Vehicle, dt: f64, speed_limit: f64) {
    let stopped = v.speed < STOPPED_SPEED;
    if stopped {
        if !v.trip.stopped {
            v.trip.stops += 1;
        }
        v.trip.time_stopped += dt;
    }
    v.trip.stopped = stopped;
    if v.speed < WAITING_SPEED {
        v.trip.wait += dt;
    } else {
        v.trip.wait = 0.0;
    }
    if v.speed < crate::cognition::right_of_way::CRAWL_SPEED
        && v.yield_phase.is_yielding_due_to_rules()
    {
        v.trip.held_by_rule += dt;
    }
    if speed_limit > 0.0 {
        v.trip.time_loss += dt * (1.0 - v.speed / speed_limit).max(0.0);
    }
}
