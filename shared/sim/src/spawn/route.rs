use std::sync::Arc;

use super::{SpawnLimit, SpawnProposal, TrafficSimulator};
use crate::network::{LaneId, LaneNetwork};
use crate::rng::SimRng;

/// Spawns vehicles that follow a fixed lane route, then continue at random.
pub struct RouteTrafficSimulator {
    route: Arc<[LaneId]>,
    kinds: Vec<usize>,
    limit: SpawnLimit,
    enabled: bool,
    pending: Option<usize>,
    rng: SimRng,
}

impl RouteTrafficSimulator {
    pub fn new(
        route: Vec<LaneId>,
        kinds: Vec<usize>,
        maximum_spawns: u32,
        enabled: bool,
        rng: SimRng,
    ) -> Self {
        RouteTrafficSimulator {
            route: route.into(),
            kinds,
            limit: SpawnLimit {
                maximum: maximum_spawns,
                spawned: 0,
            },
            enabled,
            pending: None,
            rng,
        }
    }
}

impl TrafficSimulator for RouteTrafficSimulator {
    fn is_enabled(&self) -> bool {
        self.enabled && !self.limit.reached() && !self.route.is_empty() && !self.kinds.is_empty()
    }

    fn propose(&mut self, _net: &LaneNetwork, _time: f64, out: &mut Vec<SpawnProposal>) {
        let kind = *self
            .pending
            .get_or_insert_with(|| self.kinds[self.rng.below(self.kinds.len())]);
        out.push(SpawnProposal {
            lane: self.route[0],
            kind,
            route: Some(super::Route {
                lanes: self.route.clone(),
                leave_at_end: false,
                depart: None,
            }),
            slot: 0,
        });
    }

    fn spawned(&mut self, _slot: usize) {
        self.pending = None;
        self.limit.spawned += 1;
    }
}
