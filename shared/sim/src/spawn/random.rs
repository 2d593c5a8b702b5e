use super::{SpawnLimit, SpawnProposal, TrafficSimulator};
use crate::network::{LaneId, LaneNetwork};
use crate::rng::SimRng;

/// Spawns vehicles at the start of lanes drawn uniformly from its set.
pub struct RandomTrafficSimulator {
    lanes: Vec<LaneId>,
    kinds: Vec<usize>,
    limit: SpawnLimit,
    enabled: bool,
    /// Pending vehicle kind per attempt slot.
    pending: Vec<Option<usize>>,
    rng: SimRng,
}

impl RandomTrafficSimulator {
    pub fn new(
        lanes: Vec<LaneId>,
        kinds: Vec<usize>,
        maximum_spawns: u32,
        enabled: bool,
        attempts_per_tick: u32,
        rng: SimRng,
    ) -> Self {
        RandomTrafficSimulator {
            lanes,
            kinds,
            limit: SpawnLimit {
                maximum: maximum_spawns,
                spawned: 0,
            },
            enabled,
            pending: vec![None; attempts_per_tick.max(1) as usize],
            rng,
        }
    }
}

impl TrafficSimulator for RandomTrafficSimulator {
    fn is_enabled(&self) -> bool {
        self.enabled && !self.limit.reached() && !self.lanes.is_empty() && !self.kinds.is_empty()
    }

    fn propose(&mut self, net: &LaneNetwork, _time: f64, out: &mut Vec<SpawnProposal>) {
        for slot in 0..self.pending.len() {
            let kind = match self.pending[slot] {
                Some(k) => k,
                None => {
                    let k = self.kinds[self.rng.below(self.kinds.len())];
                    self.pending[slot] = Some(k);
                    k
                }
            };
            let lane = self.lanes[self.rng.below(self.lanes.len())];
            if !net.allows(lane, kind) {
                continue;
            }
            out.push(SpawnProposal {
                lane,
                kind,
                route: None,
                slot,
            });
        }
    }

    fn spawned(&mut self, slot: usize) {
        self.pending[slot] = None;
        self.limit.spawned += 1;
    }
}
