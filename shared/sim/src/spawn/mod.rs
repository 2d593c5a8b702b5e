//! Traffic simulators (the AWSIM reference's ITrafficSimulator) and what they propose.
//!
//! The world's spawn phase collects proposals from every enabled simulator, groups
//! them by spawn point and decides which spawn (ego distance, per-lane rate,
//! priority, IsSpawnable, max vehicle count). A user-defined simulator implements
//! [`TrafficSimulator`] and is added with `World::add_traffic_simulator`.

mod demand;
mod external;
mod manager;
mod random;
mod route;

use std::sync::Arc;

pub use demand::DemandSimulator;
pub use external::{ExternalSimulator, PendingProposal, SharedExternal};
pub use manager::{SpawnManager, SpawnOutcome, SpawnRequest, SpawnStats};
pub use random::RandomTrafficSimulator;
pub use route::RouteTrafficSimulator;

use crate::network::{LaneId, LaneNetwork, SimulatorSpec};
use crate::rng::SimRng;

/// Lanes a spawned vehicle follows (the first is the spawn lane), and what it
/// does after the last: leave the map (a SUMO demand's vehicle at its route's
/// end) or go on choosing branches (AWSIM's route simulator).
#[derive(Clone, Debug, PartialEq)]
pub struct Route {
    pub lanes: Arc<[LaneId]>,
    pub leave_at_end: bool,
    /// The timetable's departure time, for a demand's vehicle (its departure
    /// delay is counted from it); None where a vehicle spawns when it can.
    pub depart: Option<f64>,
}

/// One spawn proposal: a vehicle kind at the start of a lane.
#[derive(Clone, Debug, PartialEq)]
pub struct SpawnProposal {
    pub lane: LaneId,
    /// Index into the network's vehicle kinds.
    pub kind: usize,
    pub route: Option<Route>,
    /// The simulator's own tag for the proposal, handed back in `spawned`.
    pub slot: usize,
}

pub trait TrafficSimulator: Send {
    /// Enabled, and its spawn limit not reached.
    fn is_enabled(&self) -> bool;
    /// GetRandomSpawnInfo: this tick's proposals at simulation time `time`. A
    /// proposal's vehicle kind stays pending until it actually spawns, so small
    /// cars do not always win.
    fn propose(&mut self, net: &LaneNetwork, time: f64, out: &mut Vec<SpawnProposal>);
    /// The proposal with this slot spawned.
    fn spawned(&mut self, slot: usize);
    /// A fixed priority added to the AWSIM reference's anti-starvation counter when
    /// proposals compete for one spawn point (0 for the built-in simulators).
    fn priority(&self) -> i64 {
        0
    }
    /// Vehicles due to depart that have not found room yet (SUMO's insertion
    /// backlog); 0 for simulators without a timetable.
    fn backlog(&self) -> usize {
        0
    }
}

/// Spawn count against `maximum_spawns` (0 = unlimited).
#[derive(Clone, Copy, Debug, Default)]
pub struct SpawnLimit {
    pub maximum: u32,
    pub spawned: u32,
}

impl SpawnLimit {
    pub fn reached(&self) -> bool {
        self.maximum > 0 && self.spawned >= self.maximum
    }
}

/// Builds the simulators of the scene, each with its own random stream.
pub fn from_specs(
    specs: &[SimulatorSpec],
    seed: u64,
    generation: u64,
) -> Vec<Box<dyn TrafficSimulator>> {
    specs
        .iter()
        .enumerate()
        .map(|(i, spec)| {
            let rng = SimRng::new(seed, (generation << 32) | i as u64);
            let sim: Box<dyn TrafficSimulator> = match spec {
                SimulatorSpec::Random {
                    lanes,
                    kinds,
                    maximum_spawns,
                    enabled,
                    attempts_per_tick,
                } => Box::new(RandomTrafficSimulator::new(
                    lanes.clone(),
                    kinds.clone(),
                    *maximum_spawns,
                    *enabled,
                    *attempts_per_tick,
                    rng,
                )),
                SimulatorSpec::Route {
                    route,
                    kinds,
                    maximum_spawns,
                    enabled,
                } => Box::new(RouteTrafficSimulator::new(
                    route.clone(),
                    kinds.clone(),
                    *maximum_spawns,
                    *enabled,
                    rng,
                )),
                SimulatorSpec::Demand { departures } => {
                    Box::new(DemandSimulator::new(departures.clone()))
                }
            };
            sim
        })
        .collect()
}
