//! The TrafficManager's spawn decision flow, apart from the vehicles: collects
//! proposals from every simulator, groups them by spawn point and applies the AWSIM
//! reference's filters (ego distance, per-lane rate, priority). What is left becomes
//! [`SpawnRequest`]s; whoever owns the vehicles (the world in one process, the
//! stepper in the cluster) makes the final IsSpawnable and max-count check and
//! reports the [`SpawnOutcome`] back through [`SpawnManager::resolve`].

use rustc_hash::FxHashMap;
use trafficmesh_model::TrafficSpawnConfig;

use super::{SpawnProposal, TrafficSimulator, from_specs};
use crate::ego::Ego;
use crate::network::{LaneId, LaneNetwork};

/// Spawn attempts that did not spawn, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SpawnStats {
    pub spawned: u64,
    pub too_close_to_ego: u64,
    pub rate_limited: u64,
    pub lost_priority: u64,
    pub not_spawnable: u64,
    pub max_vehicles: u64,
}

/// The winner at one spawn point this tick.
#[derive(Clone, Debug, PartialEq)]
pub struct SpawnRequest {
    pub lane: LaneId,
    /// Index into the network's vehicle kinds.
    pub kind: usize,
    pub route: Option<super::Route>,
    /// The winning simulator and its proposal slot.
    pub simulator: usize,
    pub slot: usize,
    /// The simulators of the other proposals at this spawn point (one may
    /// appear more than once, the winner's too). Mostly empty, and then
    /// without an allocation: the per-tick request list is long when a map
    /// asks for hundreds of spawn attempts a tick.
    pub rivals: Vec<usize>,
}

/// What the owner of the vehicles did with a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpawnOutcome {
    Spawned,
    /// maxVehicleCount reached.
    MaxVehicles,
    /// IsSpawnable failed: something stands at the spawn point.
    NotSpawnable,
}

pub struct SpawnManager {
    seed: u64,
    generation: u64,
    /// Simulators of the map, then those added at run time.
    simulators: Vec<Box<dyn TrafficSimulator>>,
    map_simulators: usize,
    /// The AWSIM reference's anti-starvation counter: losers gain one, the winner resets.
    priorities: Vec<i64>,
    /// spawnsPerMinute per lane (0 = no limit) and the last accepted spawn time.
    spawn_rates: Vec<f64>,
    last_spawn: Vec<f64>,
    stats: SpawnStats,
    /// Spawn point (lane) to its group number while planning, kept for the
    /// allocation.
    group_of: FxHashMap<LaneId, usize>,
}

impl SpawnManager {
    /// The map's simulators (unless `with_map_simulators` is false), each with
    /// its own random stream from `seed`.
    /// Vehicles due to depart that have not found room yet, all simulators.
    pub fn backlog(&self) -> usize {
        self.simulators.iter().map(|s| s.backlog()).sum()
    }

    /// Whether any simulator may still propose a vehicle.
    pub fn any_enabled(&self) -> bool {
        self.simulators.iter().any(|s| s.is_enabled())
    }

    pub fn new(net: &LaneNetwork, seed: u64, with_map_simulators: bool) -> Self {
        let simulators = if with_map_simulators {
            from_specs(&net.simulators, seed, 0)
        } else {
            Vec::new()
        };
        let lanes = net.lanes.len();
        SpawnManager {
            seed,
            generation: 0,
            map_simulators: simulators.len(),
            priorities: vec![0; simulators.len()],
            simulators,
            spawn_rates: vec![0.0; lanes],
            last_spawn: vec![f64::NEG_INFINITY; lanes],
            stats: SpawnStats::default(),
            group_of: FxHashMap::default(),
        }
    }

    pub fn stats(&self) -> &SpawnStats {
        &self.stats
    }

    /// AddTrafficSimulator; returns its index.
    pub fn add(&mut self, sim: Box<dyn TrafficSimulator>) -> usize {
        self.simulators.push(sim);
        self.priorities.push(0);
        self.simulators.len() - 1
    }

    /// Takes the rates of a spawn config already validated against `net`.
    pub fn set_rates(&mut self, net: &LaneNetwork, config: &TrafficSpawnConfig) {
        self.spawn_rates.fill(0.0);
        for rate in &config.spawn_rates {
            if let Some(lane) = net.lane_id(&rate.lane) {
                self.spawn_rates[lane as usize] = rate.spawns_per_minute;
            }
        }
    }

    /// Restart: the map's simulators start over with fresh streams; added ones
    /// stay; priorities and rate-limit clocks are cleared.
    pub fn restart(&mut self, net: &LaneNetwork, seed: Option<u64>) {
        self.generation += 1;
        if let Some(seed) = seed {
            self.seed = seed;
        }
        let extra: Vec<_> = self
            .simulators
            .drain(..)
            .skip(self.map_simulators)
            .collect();
        if self.map_simulators > 0 {
            self.simulators = from_specs(&net.simulators, self.seed, self.generation);
        }
        self.simulators.extend(extra);
        self.priorities = vec![0; self.simulators.len()];
        self.last_spawn.fill(f64::NEG_INFINITY);
    }

    /// This tick's requests, one per spawn point at most, in first-proposal order.
    pub fn plan(
        &mut self,
        net: &LaneNetwork,
        time: f64,
        ego: Option<&Ego>,
        spawn_distance_to_ego: f64,
    ) -> Vec<SpawnRequest> {
        let mut proposals: Vec<(usize, SpawnProposal)> = Vec::new();
        let mut buf = Vec::new();
        for (si, sim) in self.simulators.iter_mut().enumerate() {
            if sim.is_enabled() {
                buf.clear();
                sim.propose(net, time, &mut buf);
                proposals.extend(buf.drain(..).map(|p| (si, p)));
            }
        }
        // Group by spawn point (the lane start), in first-insertion order: number
        // the groups as they first appear, then a stable sort by group keeps
        // the proposals of each group in order (no list per group).
        let group_of = &mut self.group_of;
        group_of.clear();
        let group: Vec<usize> = proposals
            .iter()
            .map(|(_, p)| {
                let next = group_of.len();
                *group_of.entry(p.lane).or_insert(next)
            })
            .collect();
        let mut order: Vec<usize> = (0..proposals.len()).collect();
        order.sort_by_key(|&k| group[k]);
        let mut requests = Vec::new();
        for members in order.chunk_by(|&a, &b| group[a] == group[b]) {
            let lane = proposals[members[0]].1.lane;
            let start = net.lane(lane).line.point(0);
            if let Some(ego) = ego
                && ego.position().distance(start) < spawn_distance_to_ego
            {
                self.stats.too_close_to_ego += members.len() as u64;
                continue;
            }
            let rate = self.spawn_rates[lane as usize];
            if rate > 0.0 && time - self.last_spawn[lane as usize] < 60.0 / rate - 1e-9 {
                self.stats.rate_limited += members.len() as u64;
                continue;
            }
            // Highest priority wins; ties keep insertion order.
            let priority = |si: usize| self.priorities[si] + self.simulators[si].priority();
            let winner = *members
                .iter()
                .min_by_key(|&&k| (-priority(proposals[k].0), k))
                .expect("groups are never empty");
            self.stats.lost_priority += members.len() as u64 - 1;
            let (si, p) = &proposals[winner];
            requests.push(SpawnRequest {
                lane,
                kind: p.kind,
                route: p.route.clone(),
                simulator: *si,
                slot: p.slot,
                rivals: members
                    .iter()
                    .filter(|&&k| k != winner)
                    .map(|&k| proposals[k].0)
                    .collect(),
            });
        }
        requests
    }

    /// Books the outcome of a request made at `time`.
    pub fn resolve(&mut self, request: &SpawnRequest, outcome: SpawnOutcome, time: f64) {
        match outcome {
            SpawnOutcome::MaxVehicles => self.stats.max_vehicles += 1,
            SpawnOutcome::NotSpawnable => self.stats.not_spawnable += 1,
            SpawnOutcome::Spawned => {
                self.stats.spawned += 1;
                self.last_spawn[request.lane as usize] = time;
                // The losers gain one, the winner starts over.
                if !request.rivals.is_empty() {
                    for &si in &request.rivals {
                        if let Some(p) = self.priorities.get_mut(si) {
                            *p += 1;
                        }
                    }
                    self.priorities[request.simulator] = 0;
                }
                if let Some(sim) = self.simulators.get_mut(request.simulator) {
                    sim.spawned(request.slot);
                }
            }
        }
    }
}
