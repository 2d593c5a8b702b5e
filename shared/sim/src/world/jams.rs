//! Gridlock's last resort and the figures a traffic engineer reads about
//! waiting: a vehicle that has stood still for the jam timeout (SUMO's
//! `time-to-teleport`) is taken off the road and counted.

use trafficmesh_model::LightColor;

use super::World;
use crate::events::DespawnReason;
use crate::vehicle::Vehicle;

/// Ticks between looks for jammed vehicles: a timeout is minutes long, and
/// the look reads every vehicle.
const JAM_CHECK_INTERVAL: u64 = 50;
/// Standing this long (away from a red light) makes a vehicle stuck.
pub const STUCK_AFTER: f64 = 60.0;

/// What the world has seen of waiting, for `sim --json` and the stepper status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WaitStats {
    /// Vehicles taken off the road by the jam timeout.
    pub jam_resolutions: u64,
    /// The longest standstill any vehicle has had so far, seconds.
    pub max_wait: f64,
}

impl World {
    /// Every JAM_CHECK_INTERVAL ticks: notes the longest wait and flags each
    /// vehicle that has stood for the jam timeout to leave at the next tick.
    /// A vehicle held by a red light is waiting its turn, not jammed.
    pub(super) fn resolve_jams(&mut self) {
        if !self.ticks.is_multiple_of(JAM_CHECK_INTERVAL) {
            return;
        }
        let timeout = self.config.jam_timeout;
        let mut jammed = false;
        for v in &mut self.vehicles {
            self.wait_stats.max_wait = self.wait_stats.max_wait.max(v.trip.wait);
            if timeout > 0.0 && v.trip.wait >= timeout && !at_red(v) && !v.should_despawn {
                v.should_despawn = true;
                v.despawn_reason = Some(DespawnReason::Jammed);
                self.wait_stats.jam_resolutions += 1;
                jammed = true;
            }
        }
        if jammed {
            // A vehicle leaving is not followed, and the list will shift.
            self.drop_prefollowed();
        }
    }

    pub fn wait_stats(&self) -> WaitStats {
        let mut stats = self.wait_stats;
        for v in &self.vehicles {
            stats.max_wait = stats.max_wait.max(v.trip.wait);
        }
        stats
    }

    /// Vehicles that have stood still for [`STUCK_AFTER`] seconds or more,
    /// not counting those held by a red light.
    pub fn stuck_vehicles(&self) -> usize {
        self.vehicles.iter().filter(|v| is_stuck(v)).count()
    }

    /// Vehicles due to depart that have not found room on the road yet.
    pub fn insertion_backlog(&self) -> usize {
        self.spawner.backlog()
    }
}

fn at_red(v: &Vehicle) -> bool {
    v.light_lane.is_some() && v.passability == LightColor::Red
}

fn is_stuck(v: &Vehicle) -> bool {
    v.trip.wait >= STUCK_AFTER && !at_red(v)
}
