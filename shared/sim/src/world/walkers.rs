//! The built-in walkers and cyclists in a world that runs alone (`sim`): in
//! the cluster they are the pedestrians service's, and the crosswalks
//! service turns them into occupancy; here the world does both each tick, so
//! that zebra crossings stop traffic in a headless run too.

use super::World;
use crate::crosswalk_agents::AgentOccupancy;
use crate::pedestrians::{PedestrianConfig, Pedestrians};

/// The walkers and what they occupy.
pub(super) struct Walkers {
    people: Pedestrians,
    occupancy: AgentOccupancy,
}

/// The agent source the walkers report as (the pedestrians service's name).
const SOURCE: &str = "pedestrians";

impl World {
    /// Runs the built-in walkers and cyclists on the map's crosswalks,
    /// deterministic for the world's seed.
    pub fn enable_pedestrians(&mut self, config: PedestrianConfig) {
        self.walkers = Some(Walkers {
            people: Pedestrians::new(&self.net.crosswalks, config, self.config.seed),
            occupancy: AgentOccupancy::new(&self.net.crosswalks),
        });
    }

    /// Walkers and cyclists on the crosswalks now.
    pub fn pedestrian_count(&self) -> usize {
        self.walkers.as_ref().map_or(0, |w| w.people.count())
    }

    /// Moves the walkers on and updates the crosswalks' occupants.
    pub(super) fn step_walkers(&mut self) {
        let Some(w) = &mut self.walkers else {
            return;
        };
        let lights = &self.lights;
        w.people.step(self.time, self.config.dt, |g| {
            lights.state(g as usize).color
        });
        let agents = w.people.agents();
        w.occupancy
            .update_source(&self.net.crosswalks, &mut self.occupancy, SOURCE, &agents);
    }
}
