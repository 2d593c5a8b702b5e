//! The world: the network, the vehicles and everything around them, stepped
//! one tick at a time. This is the NPCVehicleSimulator and the TrafficManager's
//! spawn loop in one deterministic, I/O-free object.

mod awake;
mod follow;
mod jams;
mod motion;
mod phases;
mod red_lights;
mod regroup;
mod reservations;
mod snapshot;
mod spawning;
mod squeeze;
mod step;
mod walkers;

use glam::{DVec2, DVec3};
use thiserror::Error;
use trafficmesh_model::{NpcVehicleConfig, SpawnConfigError, TrafficSpawnConfig};

use crate::body_grid::BodyGrid;
use crate::branching::{BranchChoice, BranchPolicy, BranchStats};
use crate::cognition::Perception;
use crate::cognition::deadlock::Wait;
use crate::cognition::right_of_way::{JunctionBuckets, RowInfo};
use crate::crosswalk::{Occupancy, OccupancyChange, OccupantType};
use crate::ego::Ego;
use crate::events::{DespawnReason, SimEvent};
use crate::lane_index::LaneIndex;
use crate::lights::{LightControl, Lights};
use crate::network::LaneNetwork;
use crate::spawn::{SpawnManager, SpawnStats, TrafficSimulator};
use crate::trajectory::TrajectoryHash;
use crate::vehicle::{Vehicle, VehicleId};

pub use crate::parallel::MIN_VEHICLES_PER_TASK;
pub use jams::{GRIDLOCK_PATIENCE, STUCK_AFTER, WaitStats};
#[cfg(feature = "bench")]
pub use phases::{Phase, PhaseTimes};
pub use red_lights::{RED_GRACE, RedLightCrossing};
pub use spawning::{QueuedSpawn, SpawnRejection};

/// SUMO's default `time-to-teleport`, seconds.
pub const DEFAULT_JAM_TIMEOUT: f64 = 300.0;

/// maxVehicleCount unless one is given: the AWSIM reference's 40, and none in
/// practice (a million) for a timetable (a route file or SUMO scenario), so
/// that all its vehicles depart, as in SUMO.
pub fn default_max_vehicles(timetable: bool) -> usize {
    if timetable { 1_000_000 } else { 40 }
}

/// Run parameters, with the AWSIM reference's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldConfig {
    pub seed: u64,
    /// maxVehicleCount.
    pub max_vehicles: usize,
    /// spawnDistanceToEgo, metres.
    pub spawn_distance_to_ego: f64,
    /// Tick length, seconds.
    pub dt: f64,
    pub vehicle: NpcVehicleConfig,
    /// Ticks between regroupings of the vehicle list by lane (0: never). A
    /// matter of speed only: the trajectories are the same for any value.
    pub regroup_interval: u64,
    /// Seconds a vehicle may stand still before it is taken off the road as
    /// jammed (SUMO's `time-to-teleport`); 0 never does.
    pub jam_timeout: f64,
}

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig {
            seed: 0,
            max_vehicles: default_max_vehicles(false),
            spawn_distance_to_ego: 50.0,
            dt: 0.02,
            vehicle: NpcVehicleConfig::default(),
            regroup_interval: regroup::DEFAULT_INTERVAL,
            jam_timeout: DEFAULT_JAM_TIMEOUT,
        }
    }
}

#[derive(Debug, Error, PartialEq)]
pub enum WorldError {
    #[error("unknown lane '{0}'")]
    UnknownLane(String),
    #[error("unknown vehicle kind '{0}'")]
    UnknownKind(String),
    #[error("unknown crosswalk '{0}'")]
    UnknownCrosswalk(String),
    #[error("unknown light group '{0}'")]
    UnknownLightGroup(String),
    #[error("position {s} m is outside lane '{lane}' (0 to {length:.2} m)")]
    OutsideLane { lane: String, s: f64, length: f64 },
    #[error(transparent)]
    SpawnConfig(#[from] SpawnConfigError),
    #[error("the snapshot is of another map (fingerprint {theirs}, this one's {ours})")]
    AnotherMap { theirs: String, ours: String },
    #[error("the road is not empty ({0} vehicles): a snapshot is restored before the first tick")]
    NotEmpty(usize),
}

pub struct World {
    net: LaneNetwork,
    config: WorldConfig,
    time: f64,
    ticks: u64,
    /// Every vehicle's pose at every tick since the world was built.
    trajectory: TrajectoryHash,
    /// The next tick's lane following, done by the last motion pass for the
    /// vehicles before this index (see `motion.rs`); dropped by anything that
    /// would change it.
    prefollowed: Option<(usize, follow::Followed)>,
    /// Branch choices made ahead and not yet recorded when that was dropped.
    held_choices: Vec<(VehicleId, Vec<BranchChoice>)>,
    vehicles: Vec<Vehicle>,
    /// What others' right of way reads about each vehicle this tick, taken
    /// as it follows its lanes (kept for the allocation).
    row: Vec<RowInfo>,
    /// The considered vehicles of each junction (kept for the allocations).
    junctions: JunctionBuckets,
    /// Cognition's output and the deadlock waits (kept for the allocations).
    perceptions: Vec<Perception>,
    waits: Vec<Wait>,
    /// Log the stuck vehicles next tick (a debug aid).
    log_stuck: bool,
    index: LaneIndex,
    /// Every body by place, for the clearance check (kept for the allocations).
    bodies: BodyGrid,
    lights: Lights,
    occupancy: Occupancy,
    /// Some vehicle was stopped by a crosswalk after the last tick's cognition.
    zebra_blocked_last_tick: bool,
    ego: Option<Ego>,
    /// Bodies moved by someone else; NPCs stop for them as for the ego.
    foreign: Vec<Ego>,
    spawner: SpawnManager,
    /// Spawn orders from outside (the spawner service), for the next spawn phase.
    queued_spawns: Vec<spawning::QueuedSpawn>,
    /// What became of them, in order, until taken.
    spawn_results: Vec<Result<VehicleId, SpawnRejection>>,
    spawn_config: Option<TrafficSpawnConfig>,
    branch_policy: BranchPolicy,
    /// None where another process keeps them (the spawner service, from
    /// the BranchDecision events): one set of branch statistics per run.
    branch_stats: Option<BranchStats>,
    next_id: VehicleId,
    events: Vec<SimEvent>,
    phase_times: phases::PhaseTimes,
    wait_stats: jams::WaitStats,
    /// This tick's red-light crossings, and their count over the run.
    red_crossings: Vec<RedLightCrossing>,
    red_crossing_count: u64,
    /// The vehicles the jam timeout moved on this tick.
    relocated: Vec<VehicleId>,
    /// One head of each gridlock found, for the next look for jams.
    gridlocked: Vec<VehicleId>,
    /// Built-in walkers, when the world runs them itself (`sim`).
    walkers: Option<walkers::Walkers>,
    /// Who decides the ways through the reservation intersections: the
    /// world's own, or the intersection service's (see `use_intersection_manager`).
    intersections: Box<dyn crate::reservation::IntersectionManager>,
}

impl World {
    pub fn new(net: LaneNetwork, config: WorldConfig) -> Self {
        let lanes = net.lanes.len();
        let lights = Lights::new(net.light_groups.iter().map(|g| g.program));
        let occupancy = Occupancy::new(net.crosswalks.len());
        let spawner = SpawnManager::new(&net, config.seed, true);
        let index = LaneIndex::empty(lanes);
        let intersections = Box::new(crate::reservation::Intersections::of(&net));
        World {
            net,
            config,
            time: 0.0,
            ticks: 0,
            trajectory: TrajectoryHash::default(),
            prefollowed: None,
            held_choices: Vec::new(),
            vehicles: Vec::new(),
            row: Vec::new(),
            junctions: JunctionBuckets::default(),
            perceptions: Vec::new(),
            waits: Vec::new(),
            log_stuck: false,
            index,
            bodies: BodyGrid::default(),
            lights,
            occupancy,
            zebra_blocked_last_tick: false,
            ego: None,
            foreign: Vec::new(),
            spawner,
            queued_spawns: Vec::new(),
            spawn_results: Vec::new(),
            spawn_config: None,
            branch_policy: BranchPolicy::none(),
            branch_stats: Some(BranchStats::default()),
            next_id: 0,
            events: Vec::new(),
            phase_times: phases::PhaseTimes::default(),
            wait_stats: jams::WaitStats::default(),
            red_crossings: Vec::new(),
            relocated: Vec::new(),
            gridlocked: Vec::new(),
            red_crossing_count: 0,
            walkers: None,
            intersections,
        }
    }

    /// Index of a vehicle kind by name (case-insensitive, built-in catalogue).
    pub fn kind_index(&mut self, name: &str) -> Option<usize> {
        self.net.kind_index(name)
    }

    /// Index of a kind of the map's own (a route file's vType sent with a
    /// spawn order), added on first use.
    pub fn add_vehicle_kind(&mut self, kind: trafficmesh_model::VehicleKind) -> usize {
        self.net.add_kind(kind)
    }

    /// Time per tick phase, accumulated once enabled with [`World::phase_times_mut`].
    #[cfg(feature = "bench")]
    pub fn phase_times(&self) -> &PhaseTimes {
        &self.phase_times
    }

    #[cfg(feature = "bench")]
    pub fn phase_times_mut(&mut self) -> &mut PhaseTimes {
        &mut self.phase_times
    }

    pub fn network(&self) -> &LaneNetwork {
        &self.net
    }
    pub fn config(&self) -> &WorldConfig {
        &self.config
    }
    pub fn time(&self) -> f64 {
        self.time
    }
    pub fn ticks(&self) -> u64 {
        self.ticks
    }
    /// The [`TrajectoryHash`] of every tick since the world was built (the
    /// motion step takes it): same map, config and seed, same hash, whatever
    /// the thread count.
    pub fn trajectory_hash(&self) -> u64 {
        self.trajectory.finish()
    }
    /// The vehicles, grouped by lane for the tick's memory locality (see
    /// `world/regroup.rs`): not in id order. Nothing the simulation does
    /// depends on this order.
    pub fn vehicles(&self) -> &[Vehicle] {
        &self.vehicles
    }
    /// The vehicle `id`, found by a scan of the list.
    pub fn vehicle(&self, id: VehicleId) -> Option<&Vehicle> {
        self.vehicles.iter().find(|v| v.id == id)
    }
    pub fn lights(&self) -> &Lights {
        &self.lights
    }

    /// Stop lines crossed on red in the last tick (see [`RedLightCrossing`]).
    pub fn red_light_crossings_last_tick(&self) -> &[RedLightCrossing] {
        &self.red_crossings
    }

    /// The vehicles the jam timeout moved ahead along their way this tick
    /// (SUMO's teleports): they jump on purpose.
    pub fn relocated_last_tick(&self) -> &[VehicleId] {
        &self.relocated
    }

    /// Stop lines crossed on red over the run so far.
    pub fn red_light_crossings(&self) -> u64 {
        self.red_crossing_count
    }
    pub fn occupancy(&self) -> &Occupancy {
        &self.occupancy
    }
    /// The branch statistics, unless the world runs without simulators
    /// (then the spawner service keeps them).
    pub fn branch_stats(&self) -> Option<&BranchStats> {
        self.branch_stats.as_ref()
    }
    /// The branch-decision CSV (header and one row per from, to, mode);
    /// the header alone when the world keeps no statistics.
    pub fn branch_csv(&self) -> String {
        self.branch_stats.as_ref().map_or_else(
            || BranchStats::default().to_csv(&self.net),
            |s| s.to_csv(&self.net),
        )
    }
    pub fn spawn_stats(&self) -> &SpawnStats {
        self.spawner.stats()
    }

    /// Drops every simulator, the map's included: vehicles then only arrive
    /// through [`World::admit_spawn`] (the stepper's case, where the spawner
    /// service runs the simulators and keeps the branch statistics from the
    /// BranchDecision events; the world keeps none of its own).
    pub fn without_simulators(mut self) -> Self {
        self.spawner = SpawnManager::new(&self.net, self.config.seed, false);
        self.branch_stats = None;
        self
    }
    /// Events since the last call.
    pub fn drain_events(&mut self) -> std::vec::Drain<'_, SimEvent> {
        self.events.drain(..)
    }

    /// Sets the ego; `None` means the dummy ego, which blocks nothing.
    pub fn set_ego(&mut self, ego: Option<Ego>) {
        self.ego = ego;
    }
    /// Replaces the bodies that others move (a simulation runtime's ego and
    /// logged actors): NPCs stop short of them as of the ego.
    pub fn set_foreign_bodies(&mut self, bodies: Vec<Ego>) {
        self.foreign = bodies;
    }
    pub fn ego(&self) -> Option<&Ego> {
        self.ego.as_ref()
    }

    /// AddTrafficSimulator: joins the spawn loop and the priority system.
    pub fn add_traffic_simulator(&mut self, sim: Box<dyn TrafficSimulator>) {
        self.spawner.add(sim);
    }

    /// Applies a spawn config (rates and branch weights), after validating it
    /// against the map. On error nothing changes.
    pub fn set_spawn_config(&mut self, config: TrafficSpawnConfig) -> Result<(), WorldError> {
        config.validate(|name| self.net.lane_id(name).is_some())?;
        self.spawner.set_rates(&self.net, &config);
        self.branch_policy = BranchPolicy::from_config(&self.net, &config);
        self.spawn_config = Some(config);
        Ok(())
    }

    /// The spawn config in force (empty when none was loaded).
    pub fn spawn_config(&self) -> TrafficSpawnConfig {
        self.spawn_config.clone().unwrap_or_default()
    }

    /// Forces a light group to a colour or gives it a new program.
    pub fn set_light(&mut self, group: &str, control: LightControl) -> Result<(), WorldError> {
        let g = self
            .net
            .light_group(group)
            .ok_or_else(|| WorldError::UnknownLightGroup(group.into()))?;
        self.lights.set_control(g, control, self.time);
        Ok(())
    }

    /// Light states from the lights service: each group's colour, good until
    /// `valid_until` (simulation time), red after that, and when the service
    /// expects it to change (`None`: forced, or not known).
    pub fn set_remote_light(
        &mut self,
        group: &str,
        color: trafficmesh_model::LightColor,
        valid_until: f64,
        next_change: Option<f64>,
    ) -> Result<(), WorldError> {
        let ends = next_change.unwrap_or(f64::INFINITY);
        self.set_light(
            group,
            LightControl::Remote {
                color,
                valid_until,
                ends,
            },
        )
    }

    /// Hands the reservation intersections to another manager (the
    /// intersection service): no way is granted while it gives no answer.
    pub fn use_intersection_manager(
        &mut self,
        manager: Box<dyn crate::reservation::IntersectionManager>,
    ) {
        self.intersections = manager;
    }

    /// Hands every light group to a remote controller (the lights service):
    /// red until `set_remote_light` vouches for a colour.
    pub fn use_remote_lights(&mut self) {
        for g in 0..self.lights.len() {
            let red = LightControl::Remote {
                color: trafficmesh_model::LightColor::Red,
                valid_until: f64::NEG_INFINITY,
                ends: f64::INFINITY,
            };
            self.lights.set_control(g, red, self.time);
        }
    }

    /// Whether any remotely controlled light group has gone past its validity.
    pub fn lights_stale(&self) -> bool {
        (0..self.lights.len()).any(|g| {
            matches!(self.lights.control(g),
                LightControl::Remote { valid_until, .. } if self.time > valid_until)
        })
    }

    /// Extends the validity of every remotely controlled light group (the
    /// lights service's heartbeat) whose colour has not reached its announced
    /// end: one that has was due to change, and the change has not come (lost
    /// in a partition, say). A heartbeat must not vouch for a colour the
    /// group no longer shows: that one runs out and counts as red until the
    /// group's state comes again.
    pub fn extend_remote_lights(&mut self, valid_until: f64) {
        for g in 0..self.lights.len() {
            if let LightControl::Remote { color, ends, .. } = self.lights.control(g)
                && self.time < ends
            {
                let control = LightControl::Remote {
                    color,
                    valid_until,
                    ends,
                };
                self.lights.set_control(g, control, self.time);
            }
        }
    }

    /// An area's occupants as the crosswalks service published them.
    pub fn set_crosswalk_occupants(
        &mut self,
        area: &str,
        roots: std::collections::BTreeSet<String>,
    ) -> Result<bool, WorldError> {
        let a = self
            .net
            .crosswalk(area)
            .ok_or_else(|| WorldError::UnknownCrosswalk(area.into()))?;
        Ok(self.occupancy.set_occupants(a, roots))
    }

    /// Fail-safe for a silent crosswalks service: every area counts as blocked.
    pub fn set_crosswalks_stale(&mut self, stale: bool) {
        self.occupancy.set_stale(stale);
    }

    /// An occupant (pedestrian, cyclist, ...) enters a crosswalk area.
    pub fn crosswalk_enter(
        &mut self,
        area: &str,
        root: &str,
        kind: OccupantType,
    ) -> Result<OccupancyChange, WorldError> {
        let a = self
            .net
            .crosswalk(area)
            .ok_or_else(|| WorldError::UnknownCrosswalk(area.into()))?;
        let change = self.occupancy.enter(&self.net.crosswalks, a, root, kind);
        if change == OccupancyChange::Entered && self.net.crosswalks[a].debug_logs {
            tracing::info!("[Zebra] '{root}' entered '{area}'");
        }
        Ok(change)
    }

    /// An occupant leaves a crosswalk area.
    pub fn crosswalk_exit(
        &mut self,
        area: &str,
        root: &str,
    ) -> Result<OccupancyChange, WorldError> {
        let a = self
            .net
            .crosswalk(area)
            .ok_or_else(|| WorldError::UnknownCrosswalk(area.into()))?;
        let change = self.occupancy.exit(a, root);
        if change == OccupancyChange::Exited && self.net.crosswalks[a].debug_logs {
            tracing::info!("[Zebra] '{root}' exited '{area}'");
        }
        Ok(change)
    }

    /// RemoveVehiclesInRadius: flags every vehicle whose origin is within `radius`
    /// of `center` (3D) and returns how many; they are gone after the next tick.
    pub fn remove_vehicles_in_radius(&mut self, center: DVec3, radius: f64) -> usize {
        // A vehicle leaving is not followed, and the list will shift.
        self.drop_prefollowed();
        let mut count = 0;
        for v in &mut self.vehicles {
            let p = DVec3::new(v.pose.x, v.pose.y, v.pose.z);
            if !v.should_despawn && p.distance_squared(center) <= radius * radius {
                v.should_despawn = true;
                v.despawn_reason = Some(DespawnReason::Removed);
                count += 1;
            }
        }
        count
    }

    /// Removes one vehicle by id on the next tick; returns 1 if it existed.
    pub fn remove_vehicle(&mut self, id: VehicleId) -> usize {
        // A vehicle leaving is not followed, and the list will shift.
        self.drop_prefollowed();
        match self.vehicles.iter_mut().find(|v| v.id == id) {
            Some(v) if !v.should_despawn => {
                v.should_despawn = true;
                v.despawn_reason = Some(DespawnReason::Removed);
                1
            }
            _ => 0,
        }
    }

    /// RemoveVehiclesInRadius around the ego's position (its height
    /// included: on an elevated map a vehicle beside it is not 12 m away);
    /// None without an ego.
    pub fn remove_vehicles_around_ego(&mut self, radius: f64) -> Option<usize> {
        let p = self.ego.as_ref()?.pose;
        Some(self.remove_vehicles_in_radius(DVec3::new(p.x, p.y, p.z), radius))
    }

    /// RemoveVehiclesInRadius around a 2D point at height 0.
    pub fn remove_vehicles_near(&mut self, center: DVec2, radius: f64) -> usize {
        self.remove_vehicles_in_radius(center.extend(0.0), radius)
    }

    /// Restart: disposes of every vehicle, pending spawn and rate-limit state and
    /// starts again with a new maximum vehicle count. The ego, the spawn config,
    /// the branch statistics and added simulators are kept; ids keep counting.
    /// A new `seed` draws what follows from other random streams.
    pub fn restart(&mut self, max_vehicles: usize, seed: Option<u64>) {
        self.drop_prefollowed();
        let time = self.time;
        let trips = self
            .vehicles
            .drain(..)
            .map(|v| step::trip_record(&self.net, &v, time, DespawnReason::Restart))
            .collect();
        step::push_despawns(&mut self.events, trips);
        // Orders queued before the restart belong to the old run.
        let void = self
            .queued_spawns
            .drain(..)
            .map(|_| Err(SpawnRejection::Restarted));
        self.spawn_results.extend(void);
        self.spawner.restart(&self.net, seed);
        if let Some(seed) = seed {
            self.config.seed = seed;
        }
        self.config.max_vehicles = max_vehicles;
        self.index = LaneIndex::empty(self.net.lanes.len());
    }
}

/// An empty world on a generated `size` x `size` grid, for the crate's unit
/// tests.
#[cfg(test)]
pub(crate) fn test_grid_world(size: usize, config: WorldConfig) -> World {
    use trafficmesh_maps::{GridOptions, grid_map};
    let map = grid_map(&GridOptions {
        size,
        ..GridOptions::default()
    });
    World::new(LaneNetwork::build(&map).expect("grid map builds"), config)
}
