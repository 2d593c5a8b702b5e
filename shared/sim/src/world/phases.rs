//! Optional wall-clock time per tick phase, for `bench tick --phases`: where a
//! tick's time goes, and how much of it runs on one thread only. Only the
//! `bench` feature can turn it on; without it no clock is ever read.

use std::time::{Duration, Instant};

/// The phases of one tick, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    Lights,
    Spawn,
    FollowLanes,
    LaneIndex,
    LaneChanges,
    Cognition,
    Deadlock,
    Zebra,
    Motion,
    Despawn,
    Regroup,
}

impl Phase {
    pub const ALL: [Phase; 11] = [
        Phase::Lights,
        Phase::Spawn,
        Phase::FollowLanes,
        Phase::LaneIndex,
        Phase::LaneChanges,
        Phase::Cognition,
        Phase::Deadlock,
        Phase::Zebra,
        Phase::Motion,
        Phase::Despawn,
        Phase::Regroup,
    ];

    #[cfg(feature = "bench")]
    pub fn name(self) -> &'static str {
        match self {
            Phase::Regroup => "regroup",
            Phase::Lights => "lights",
            Phase::Spawn => "spawn",
            Phase::FollowLanes => "follow_lanes",
            Phase::LaneIndex => "lane_index",
            Phase::LaneChanges => "lane_changes",
            Phase::Cognition => "cognition",
            Phase::Deadlock => "deadlock",
            Phase::Zebra => "zebra",
            Phase::Motion => "motion",
            Phase::Despawn => "despawn",
        }
    }

    /// Whether the phase runs on the thread pool (the others run on one thread).
    #[cfg(feature = "bench")]
    pub fn parallel(self) -> bool {
        matches!(self, Phase::FollowLanes | Phase::Cognition | Phase::Motion)
    }
}

/// Accumulated time per phase; off (and free) unless enabled.
#[derive(Clone, Debug, Default)]
pub struct PhaseTimes {
    enabled: bool,
    lap_start: Option<Instant>,
    totals: [Duration; Phase::ALL.len()],
    ticks: u64,
}

impl PhaseTimes {
    #[cfg(feature = "bench")]
    pub fn enable(&mut self) {
        self.enabled = true;
    }

    /// Milliseconds per timed tick spent in each phase, since timing was
    /// enabled or reset.
    #[cfg(feature = "bench")]
    pub fn ms_per_tick(&self) -> impl Iterator<Item = (Phase, f64)> + '_ {
        let ticks = self.ticks.max(1) as f64;
        Phase::ALL
            .iter()
            .map(move |&p| (p, self.totals[p as usize].as_secs_f64() * 1e3 / ticks))
    }

    /// The share of the timed ticks spent in phases that run on one thread.
    #[cfg(feature = "bench")]
    pub fn serial_share(&self) -> f64 {
        let (mut serial, mut all) = (0.0, 0.0);
        for &p in &Phase::ALL {
            let t = self.totals[p as usize].as_secs_f64();
            all += t;
            if !p.parallel() {
                serial += t;
            }
        }
        serial / all.max(f64::MIN_POSITIVE)
    }

    #[cfg(feature = "bench")]
    pub fn reset(&mut self) {
        self.totals = Default::default();
        self.ticks = 0;
    }

    pub(super) fn begin(&mut self) {
        // Without the `bench` feature nothing can enable it: no clock is read.
        if cfg!(feature = "bench") && self.enabled {
            self.lap_start = Some(Instant::now());
            self.ticks += 1;
        }
    }

    /// Charges the time since the last lap to `phase`.
    pub(super) fn lap(&mut self, phase: Phase) {
        if let Some(start) = self.lap_start {
            let now = Instant::now();
            self.totals[phase as usize] += now - start;
            self.lap_start = Some(now);
        }
    }
}
