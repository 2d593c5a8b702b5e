//! The spawner's state: the spawn manager of `shared/sim`, the spawn config,
//! the branch statistics, the external simulators and the ego.

use std::collections::BTreeMap;
use std::sync::Arc;

use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_protocol::wire::{ProposalBatch, SpawnBatch, SpawnOrder, SpawnVerdict};
use trafficmesh_sim::branching::{BranchChoice, BranchStats, SelectionMode};
use trafficmesh_sim::spawn::{
    PendingProposal, SharedExternal, SpawnManager, SpawnOutcome, SpawnRequest,
};
use trafficmesh_sim::{Ego, LaneNetwork};

pub struct SpawnerState {
    pub net: LaneNetwork,
    pub manager: SpawnManager,
    pub config: TrafficSpawnConfig,
    pub stats: BranchStats,
    pub max_vehicles: usize,
    pub spawn_distance_to_ego: f64,
    pub ego: Option<Ego>,
    pub time: f64,
    /// The config changed since the lockstep answer last carried it.
    config_unsent: bool,
    externals: BTreeMap<String, SharedExternal>,
    /// Simulator index -> external name, for the results.
    external_names: BTreeMap<usize, String>,
}

impl SpawnerState {
    pub fn new(
        net: LaneNetwork,
        seed: u64,
        max_vehicles: usize,
        spawn_distance_to_ego: f64,
    ) -> Self {
        let manager = SpawnManager::new(&net, seed, true);
        SpawnerState {
            net,
            manager,
            config: TrafficSpawnConfig::default(),
            stats: BranchStats::default(),
            max_vehicles,
            spawn_distance_to_ego,
            ego: None,
            time: 0.0,
            config_unsent: true,
            externals: BTreeMap::new(),
            external_names: BTreeMap::new(),
        }
    }

    /// Validates against the map and applies; on error nothing changes.
    pub fn set_config(&mut self, config: TrafficSpawnConfig) -> Result<(), Vec<String>> {
        config
            .validate(|name| self.net.lane_id(name).is_some())
            .map_err(|e| e.problems)?;
        self.manager.set_rates(&self.net, &config);
        self.config = config;
        self.config_unsent = true;
        Ok(())
    }

    /// The config in force if it changed since the last call (for the
    /// stepper, with the next lockstep answer).
    pub fn take_config_change(&mut self) -> Option<TrafficSpawnConfig> {
        std::mem::take(&mut self.config_unsent).then(|| self.config.clone())
    }

    /// This tick's spawn requests, as orders for the stepper.
    pub fn plan(&mut self) -> (Vec<SpawnRequest>, SpawnBatch) {
        let requests = self.manager.plan(
            &self.net,
            self.time,
            self.ego.as_ref(),
            self.spawn_distance_to_ego,
        );
        let orders = requests
            .iter()
            .map(|r| SpawnOrder {
                lane: r.lane,
                kind: self.net.kinds[r.kind].name.clone(),
                route: r.route.as_ref().map(|route| route.lanes.to_vec()),
                leave_at_route_end: r.route.as_ref().is_some_and(|route| route.leave_at_end),
                kind_def: Some(&self.net.kinds[r.kind])
                    .filter(|k| trafficmesh_model::builtin_kind(&k.name).is_none())
                    .cloned(),
                depart: r.route.as_ref().and_then(|route| route.depart),
            })
            .collect();
        (
            requests,
            SpawnBatch {
                max_vehicles: self.max_vehicles,
                orders,
            },
        )
    }

    /// Books the stepper's verdicts; returns (external simulator, tag, vehicle id)
    /// for each external proposal that spawned.
    pub fn resolve(
        &mut self,
        requests: &[SpawnRequest],
        verdicts: &[SpawnVerdict],
        time: f64,
    ) -> Vec<(String, String, u64)> {
        let mut results = Vec::new();
        for (request, verdict) in requests.iter().zip(verdicts) {
            let outcome = match verdict {
                SpawnVerdict::Spawned { .. } => SpawnOutcome::Spawned,
                SpawnVerdict::MaxVehicles => SpawnOutcome::MaxVehicles,
                SpawnVerdict::NotSpawnable | SpawnVerdict::Invalid { .. } => {
                    SpawnOutcome::NotSpawnable
                }
            };
            if let SpawnVerdict::Invalid { reason } = verdict {
                tracing::warn!("stepper refused a spawn order: {reason}");
            }
            self.manager.resolve(request, outcome, time);
            if let (SpawnVerdict::Spawned { id }, Some(name)) =
                (verdict, self.external_names.get(&request.simulator))
                && let Some(ext) = self.externals.get(name)
            {
                for tag in ext.0.lock().expect("simulator lock").take_spawned() {
                    results.push((name.clone(), tag, *id));
                }
            }
        }
        results
    }

    /// An external simulator's proposals (AddTrafficSimulator across processes).
    pub fn set_proposals(&mut self, simulator: &str, batch: ProposalBatch) -> Result<(), String> {
        let mut pending = Vec::with_capacity(batch.proposals.len());
        for p in batch.proposals {
            let lane = self
                .net
                .lane_id(&p.lane)
                .ok_or_else(|| format!("proposal '{}': unknown lane '{}'", p.tag, p.lane))?;
            let kind = self.net.kind_index(&p.kind).ok_or_else(|| {
                format!("proposal '{}': unknown vehicle kind '{}'", p.tag, p.kind)
            })?;
            let route = match p.route {
                None => None,
                Some(names) => Some(
                    names
                        .iter()
                        .map(|n| {
                            self.net.lane_id(n).ok_or_else(|| {
                                format!("proposal '{}': unknown route lane '{n}'", p.tag)
                            })
                        })
                        .collect::<Result<Arc<[_]>, _>>()?,
                ),
            };
            pending.push(PendingProposal {
                tag: p.tag,
                lane,
                kind,
                route,
            });
        }
        let ext = match self.externals.get(simulator) {
            Some(e) => e.clone(),
            None => {
                let e = SharedExternal::default();
                let index = self.manager.add(Box::new(e.clone()));
                self.external_names.insert(index, simulator.to_string());
                self.externals.insert(simulator.to_string(), e.clone());
                tracing::info!("external traffic simulator '{simulator}' joined");
                e
            }
        };
        ext.0
            .lock()
            .expect("simulator lock")
            .set_proposals(batch.priority, pending);
        Ok(())
    }

    /// A branch decision the stepper reported, its lanes by index.
    pub fn record_branch(
        &mut self,
        from: u32,
        to: u32,
        mode: &str,
        configured_weight: f64,
        probability: f64,
    ) -> Result<(), String> {
        let lanes = self.net.lanes.len();
        let lane = |l: u32| {
            ((l as usize) < lanes)
                .then_some(l)
                .ok_or_else(|| format!("unknown lane {l} (the map has {lanes})"))
        };
        let choice = BranchChoice {
            from: lane(from)?,
            to: lane(to)?,
            mode: SelectionMode::parse(mode)
                .ok_or_else(|| format!("unknown selection mode '{mode}'"))?,
            configured_weight,
            probability,
        };
        self.stats.record(&choice);
        Ok(())
    }

    pub fn branch_csv(&self) -> String {
        self.stats.to_csv(&self.net)
    }

    /// Restart: the simulators start over with a new maximum.
    pub fn restart(&mut self, max_vehicles: usize, seed: Option<u64>) {
        self.manager.restart(&self.net, seed);
        self.max_vehicles = max_vehicles;
    }
}
