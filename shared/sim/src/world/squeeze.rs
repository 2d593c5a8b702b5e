//! Squeezing past: the gentler break of a gridlock, tried before one of
//! its members is moved on (see [`super::jams`]).

use super::jams::GRIDLOCK_PATIENCE;
use crate::cognition::deadlock::Wait;
use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

/// Where a gridlock stands with squeezing past: its members let past the
/// bodies beside their ways that road conflicts hold them for (two meeting
/// on a bend of a narrow two-way street, each judging the other's body too
/// near to pass), at a walking pace, with the clearance check alone keeping
/// bodies apart, as drivers inch past each other. Only where that fails is
/// a member moved on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Squeeze {
    /// No member waits for a body off its own lane with a road conflict on
    /// its way ahead: nothing to squeeze past.
    Pointless,
    /// Let the members squeeze past from now on.
    Begin,
    /// Squeezing now: give it its time.
    UnderWay,
    /// Squeezing ended and the gridlock stands.
    Failed,
}

/// Seconds the members of a gridlock may squeeze past bodies beside their way.
pub(super) const SQUEEZE_TIME: f64 = GRIDLOCK_PATIENCE;
/// The speed a vehicle squeezing past keeps under, m/s: a walking pace, at
/// which the clearance check's sweep of its body holds on the tightest bend.
pub(super) const SQUEEZE_SPEED: f64 = 1.5;
/// Lanes of a member's way looked along for road conflicts.
const SQUEEZE_LANES: usize = 3;

impl Squeeze {
    /// Squeezing is worth a try where a member waits for a body off its own
    /// lane (not a queue's leader) with a road conflict on its way ahead.
    pub(super) fn of(
        net: &LaneNetwork,
        vehicles: &[Vehicle],
        waits: &[Wait],
        cycle: &[usize],
        time: f64,
        patience: f64,
    ) -> Squeeze {
        let latest = cycle
            .iter()
            .map(|&i| vehicles[i].squeeze_until)
            .fold(f64::NEG_INFINITY, f64::max);
        if latest > time {
            return Self::UnderWay;
        }
        if latest >= time - patience {
            return Self::Failed;
        }
        let beside_its_way = |i: usize| {
            let v = &vehicles[i];
            let held_by = &vehicles[waits[i].0 as usize];
            !waits[i].1
                && held_by.path[0] != v.path[0]
                && v.path
                    .iter()
                    .take(SQUEEZE_LANES)
                    .any(|&l| net.lane(l).road_conflicts)
        };
        if cycle.iter().any(|&i| beside_its_way(i)) {
            Self::Begin
        } else {
            Self::Pointless
        }
    }
}
