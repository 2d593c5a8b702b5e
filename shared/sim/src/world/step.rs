//! One tick: spawn, Cognition, Decision, Control, Visualization, despawn.

use rayon::prelude::*;
use trafficmesh_model::NpcVehicleConfig;

use super::World;
use super::awake::with_workers_awake;
use super::phases::Phase;
use crate::branching::{BranchChoice, BranchPolicy};
use crate::cognition::path::advance_and_extend;
use crate::cognition::right_of_way::{JunctionBuckets, RowInfo};
use crate::cognition::{Perception, Snapshot, deadlock, perceive};
use crate::control::{step_speed, update_pose};
use crate::decision::decide;
use crate::events::{DespawnReason, SimEvent, TripRecord};
use crate::lane_change;
use crate::lane_index::ChunkFiller;
use crate::network::{LaneId, LaneNetwork};
use crate::prefetch;
use crate::trajectory::pose_digest;
use crate::vehicle::{Vehicle, VehicleId};
use crate::visualization::update_trip;

pub(super) fn trip_record(
    net: &LaneNetwork,
    v: &Vehicle,
    time: f64,
    reason: DespawnReason,
) -> TripRecord {
    TripRecord {
        id: v.id,
        kind: net.kinds[v.kind].name.clone(),
        spawn_time: v.trip.spawn_time,
        despawn_time: time,
        distance: v.trip.distance,
        stops: v.trip.stops,
        time_stopped: v.trip.time_stopped,
        reason,
    }
}

/// The name the seed's log lines use: `<prefab>(Clone)_<id>`.
pub fn vehicle_name(net: &LaneNetwork, v: &Vehicle) -> String {
    format!("{}(Clone)_{}", net.kinds[v.kind].name, v.id)
}

/// Vehicles below which a parallel phase runs on one thread: waking the other
/// threads for a few hundred vehicles costs more than it saves (a 1,000-vehicle
/// SUMO grid ran faster on one thread than on two).
pub const MIN_VEHICLES_PER_TASK: usize = 1024;

impl World {
    /// Advances the world by one tick of `config.dt` seconds.
    pub fn step(&mut self) {
        // Below one task's worth of vehicles every phase runs on one thread:
        // nothing for the other workers to wake for.
        if self.vehicles.len() < MIN_VEHICLES_PER_TASK {
            self.step_phases();
        } else {
            with_workers_awake(|| self.step_phases());
        }
    }

    fn step_phases(&mut self) {
        let dt = self.config.dt;
        self.phase_times.begin();
        self.lights.update(self.time);
        self.phase_times.lap(Phase::Lights);
        self.spawn_phase();
        self.phase_times.lap(Phase::Spawn);
        let leaving = self.follow_lanes();
        self.phase_times.lap(Phase::FollowLanes);
        // The lane-following pass took the items of both; the junctions'
        // grouping runs beside the lane index's (in a small world, on this
        // thread: the other workers sleep, and handing over costs more).
        let (net, index, junctions) = (&self.net, &mut self.index, &mut self.junctions);
        if self.vehicles.len() < MIN_VEHICLES_PER_TASK {
            index.group(net);
            junctions.group(net);
        } else {
            rayon::join(|| index.group(net), || junctions.group(net));
        }
        self.phase_times.lap(Phase::LaneIndex);
        if self.change_lanes() {
            self.index.rebuild(&self.net, &self.vehicles);
            self.junctions.rebuild(&self.net, &self.row);
        }
        self.phase_times.lap(Phase::LaneChanges);

        // This tick's buffers, handed back after the motion step for the next.
        let mut perceptions = std::mem::take(&mut self.perceptions);
        let mut waits = std::mem::take(&mut self.waits);
        self.cognition(&mut perceptions, &mut waits);
        self.phase_times.lap(Phase::Cognition);
        deadlock::break_cycles(&self.net, &self.vehicles, &waits, &mut perceptions);
        self.phase_times.lap(Phase::Deadlock);
        self.zebra_events(&perceptions);
        self.phase_times.lap(Phase::Zebra);
        // The motion pass also does the next tick's lane following while each
        // vehicle is at hand, for the vehicles that stay: at the index each
        // will have once those leaving at the end of this tick are gone.
        let n = self.vehicles.len();
        let staying = n - leaving.len();
        let chunk_count = n.div_ceil(MIN_VEHICLES_PER_TASK);
        let mut kept: Vec<usize> = (0..chunk_count)
            .map(|c| MIN_VEHICLES_PER_TASK.min(n - c * MIN_VEHICLES_PER_TASK))
            .collect();
        for &i in &leaving {
            kept[i / MIN_VEHICLES_PER_TASK] -= 1;
        }
        // Each chunk's stayers: where they start in the list that remains,
        // and their rows there.
        let mut starts = Vec::with_capacity(chunk_count);
        let mut chunk_rows = Vec::with_capacity(chunk_count);
        let mut rows_left: &mut [RowInfo] = &mut self.row[..staying];
        for &count in &kept {
            starts.push(staying - rows_left.len());
            let (rows, rest) = std::mem::take(&mut rows_left).split_at_mut(count);
            chunk_rows.push(rows);
            rows_left = rest;
        }
        let follow = Follow {
            net: &self.net,
            policy: &self.branch_policy,
            motion: &self.config.vehicle,
        };
        // In chunks, so that each loop can look at the vehicles ahead of it.
        // Takes the trajectory digests of the vehicles that stay on the way.
        let chunks: Vec<(u64, Followed)> = self
            .vehicles
            .par_chunks_mut(MIN_VEHICLES_PER_TASK)
            .zip(perceptions.par_chunks(MIN_VEHICLES_PER_TASK))
            .zip(chunk_rows)
            .zip(starts)
            .zip(self.junctions.chunk_lists(n))
            .zip(self.index.chunk_fillers(n))
            .map(
                |(((((vehicles, perceptions), rows), start), junction_list), mut index_items)| {
                    let (net, config) = (follow.net, follow.motion);
                    let mut digest_sum = 0u64;
                    let mut followed = Followed::default();
                    let mut stayed = 0;
                    for (k, p) in perceptions.iter().enumerate() {
                        prefetch::paths_ahead(net, vehicles, k);
                        prefetch::vertices_ahead(net, vehicles, k);
                        prefetch::conflicts_ahead(net, vehicles, k);
                        let v = &mut vehicles[k];
                        move_vehicle(net, config, dt, v, p);
                        if v.should_despawn {
                            continue;
                        }
                        digest_sum = digest_sum.wrapping_add(pose_digest(v));
                        let lists = (&mut rows[stayed], &mut *junction_list, &mut index_items);
                        follow.vehicle(v, start + stayed, lists, &mut followed);
                        stayed += 1;
                    }
                    (digest_sum, followed)
                },
            )
            .collect();
        let mut digest_sum = 0u64;
        let mut followed = Followed::default();
        for (digest, chunk) in chunks {
            digest_sum = digest_sum.wrapping_add(digest);
            followed.append(chunk);
        }
        self.row.truncate(staying);
        self.prefollowed = Some((staying, followed));
        (self.perceptions, self.waits) = (perceptions, waits);
        self.phase_times.lap(Phase::Motion);
        self.time += dt;
        self.ticks += 1;
        if !leaving.is_empty() {
            self.despawn(&leaving);
        }
        self.trajectory
            .add_tick_digest(self.vehicles.len(), digest_sum);
        self.phase_times.lap(Phase::Despawn);
    }

    /// Lane advance and branch choices: parallel (each vehicle draws from its own
    /// random stream), then recorded in vehicle order. Takes in the same pass,
    /// while each vehicle is at hand, its right-of-way facts, its junction
    /// membership and its lane-index items (a pass of their own each cost
    /// more: the vehicles' lines and paths read again). When the last motion
    /// pass did this for the vehicles it moved, only those added since are
    /// left. Returns whether any vehicle is flagged for despawn.
    fn follow_lanes(&mut self) -> Vec<usize> {
        let n = self.vehicles.len();
        self.row.resize(n, RowInfo::default());
        let follow = Follow {
            net: &self.net,
            policy: &self.branch_policy,
            motion: &self.config.vehicle,
        };
        let followed = match self.prefollowed.take() {
            Some((done, mut followed)) => {
                // After the others, in the last lists, so that the items stay
                // in vehicle order.
                for i in done..n {
                    let lists = (
                        &mut self.row[i],
                        self.junctions.last_list(),
                        &mut self.index.last_filler(),
                    );
                    follow.vehicle(&mut self.vehicles[i], i, lists, &mut followed);
                }
                followed
            }
            None => {
                let chunks: Vec<Followed> = self
                    .vehicles
                    .par_chunks_mut(MIN_VEHICLES_PER_TASK)
                    .zip(self.row.par_chunks_mut(MIN_VEHICLES_PER_TASK))
                    .zip(self.junctions.chunk_lists(n))
                    .zip(self.index.chunk_fillers(n))
                    .enumerate()
                    .map(
                        |(c, (((vehicles, rows), junction_list), mut index_items))| {
                            // In chunks, so that the loop can look at the vehicles ahead of it.
                            let mut followed = Followed::default();
                            for (k, row) in rows.iter_mut().enumerate() {
                                prefetch::paths_ahead(follow.net, vehicles, k);
                                prefetch::conflicts_ahead(follow.net, vehicles, k);
                                let i = c * MIN_VEHICLES_PER_TASK + k;
                                let lists = (row, &mut *junction_list, &mut index_items);
                                follow.vehicle(&mut vehicles[k], i, lists, &mut followed);
                            }
                            followed
                        },
                    )
                    .collect();
                let mut followed = Followed::default();
                for chunk in chunks {
                    followed.append(chunk);
                }
                followed
            }
        };
        for (id, made) in followed.decisions {
            for choice in made {
                self.branch_stats.record(&choice);
                self.events.push(SimEvent::BranchDecision { id, choice });
            }
        }
        followed.leaving
    }

    /// The lane changes routes need, where there is a gap (or where two
    /// vehicles side by side each want the other's lane: they swap). Planned
    /// against this tick's lane index, then made in vehicle order so that two
    /// vehicles never take the same gap. Returns whether any was made.
    fn change_lanes(&mut self) -> bool {
        let motion = self.config.vehicle;
        let (index, vehicles) = (&self.index, &self.vehicles);
        let candidates: Vec<lane_change::Change> = index
            .lane_changers()
            .iter()
            .filter_map(|&i| lane_change::plan(index, vehicles, i as usize, &motion))
            .collect();
        if candidates.is_empty() {
            return false;
        }
        let mut moved: Vec<lane_change::Moved> = Vec::new();
        let mut changed = vec![false; self.vehicles.len()];
        for c in candidates {
            let partner = c.swap_with.map(|(j, _)| j);
            if changed[c.vehicle] || partner.is_some_and(|j| changed[j]) {
                continue;
            }
            let v = &self.vehicles[c.vehicle];
            if !lane_change::clear_of(&moved, v, c.target, &motion) {
                continue;
            }
            moved.push(lane_change::Moved::of(v, c.target));
            self.change_lane(c.vehicle, c.target);
            changed[c.vehicle] = true;
            if let Some((j, their_target)) = c.swap_with {
                moved.push(lane_change::Moved::of(&self.vehicles[j], their_target));
                self.change_lane(j, their_target);
                changed[j] = true;
            }
        }
        !moved.is_empty()
    }

    /// Moves vehicle `i` onto `target`, with the right-of-way facts that follow.
    fn change_lane(&mut self, i: usize, target: LaneId) {
        lane_change::apply(&self.net, &mut self.vehicles[i], target);
        self.row[i] = RowInfo::of(&self.vehicles[i]);
    }

    /// Parallel perception of every vehicle from the same snapshot, with whom
    /// each is waiting for (for deadlock breaking), into the buffers given.
    fn cognition(&mut self, perceptions: &mut Vec<Perception>, waits: &mut Vec<deadlock::Wait>) {
        let net = &self.net;
        let row = &self.row;
        let snap = Snapshot {
            net,
            vehicles: &self.vehicles,
            index: &self.index,
            lights: &self.lights,
            occupancy: &self.occupancy,
            ego: self.ego.as_ref(),
            config: &self.config.vehicle,
            row,
            junctions: &self.junctions,
        };
        // The waits are written beside, not paired with, the perceptions: a
        // pair would copy each perception twice more.
        waits.clear();
        waits.resize(self.vehicles.len(), (deadlock::NOBODY, false));
        perceptions.clear();
        perceptions.par_extend(
            waits
                .par_iter_mut()
                .enumerate()
                .with_min_len(MIN_VEHICLES_PER_TASK)
                .map(|(i, wait)| {
                    prefetch::cognition_ahead(&snap, i);
                    let p = perceive(&snap, i);
                    *wait = deadlock::wait_of(snap.vehicles, &snap.vehicles[i], &p);
                    p
                }),
        );
    }

    /// The WasZebraBlocked transitions (before the new perceptions are applied, so
    /// the area that cleared is still known), with the seed's log lines.
    fn zebra_events(&mut self, perceptions: &[Perception]) {
        // A stop needs an occupied area now; a clear needs a vehicle blocked last tick.
        if self.occupancy.occupied_areas().is_empty() && !self.zebra_blocked_last_tick {
            return;
        }
        self.zebra_blocked_last_tick = perceptions.iter().any(|p| p.zebra.is_blocked);
        for (v, p) in self.vehicles.iter().zip(perceptions) {
            match (v.zebra.is_blocked, p.zebra.is_blocked) {
                (false, true) => {
                    let area = p.zebra.area.expect("blocked implies an area");
                    if self.net.crosswalks[area].debug_logs {
                        tracing::info!(
                            "[NPC Zebra] Vehicle '{}' stopping for zebra '{}' at ~{:.1}m.",
                            vehicle_name(&self.net, v),
                            self.net.crosswalks[area].name,
                            p.zebra.distance_to_stop
                        );
                    }
                    self.events.push(SimEvent::ZebraStop {
                        id: v.id,
                        area,
                        distance: p.zebra.distance_to_stop,
                    });
                }
                (true, false) => {
                    let area = v.zebra.area.expect("blocked implies an area");
                    if self.net.crosswalks[area].debug_logs {
                        tracing::info!(
                            "[NPC Zebra] Vehicle '{}' cleared zebra '{}'.",
                            vehicle_name(&self.net, v),
                            self.net.crosswalks[area].name
                        );
                    }
                    self.events.push(SimEvent::ZebraClear { id: v.id, area });
                }
                _ => {}
            }
        }
    }

    /// Removes the vehicles at `leaving` (ascending indices): those flagged
    /// when this tick followed the lanes. (Those the motion pass flagged for
    /// the next tick stay until then.)
    fn despawn(&mut self, leaving: &[usize]) {
        let time = self.time;
        let net = &self.net;
        let events = &mut self.events;
        let mut i = 0;
        let mut next = leaving.iter().peekable();
        self.vehicles.retain(|v| {
            let leaves = next.next_if_eq(&&i).is_some();
            i += 1;
            if leaves {
                let reason = v.despawn_reason.unwrap_or(DespawnReason::DeadEnd);
                events.push(SimEvent::Despawned(trip_record(net, v, time, reason)));
            }
            !leaves
        });
    }
}

/// What lane following reads besides the vehicle.
struct Follow<'a> {
    net: &'a LaneNetwork,
    policy: &'a BranchPolicy,
    motion: &'a NpcVehicleConfig,
}

/// What lane following of some vehicles brings back: the branch choices
/// made (only the vehicles that made one, in vehicle order, so that the
/// serial recording costs the choices, not the vehicles) and whether any
/// vehicle is flagged for despawn.
#[derive(Default)]
pub(super) struct Followed {
    decisions: Vec<(VehicleId, Vec<BranchChoice>)>,
    /// Indices of the vehicles flagged for despawn, ascending.
    leaving: Vec<usize>,
}

impl Followed {
    fn append(&mut self, mut later: Followed) {
        self.decisions.append(&mut later.decisions);
        self.leaving.append(&mut later.leaving);
    }
}

impl Follow<'_> {
    /// Lane following of vehicle `i`, with what the tick takes in the same
    /// pass: its right-of-way facts, junction membership and lane-index items.
    fn vehicle(
        &self,
        v: &mut Vehicle,
        i: usize,
        (row, junction_list, index_items): (&mut RowInfo, &mut Vec<(u32, u32)>, &mut ChunkFiller),
        followed: &mut Followed,
    ) {
        let made = follow_lanes_of(self.net, self.policy, self.motion, v);
        if v.should_despawn {
            followed.leaving.push(i);
        }
        // Also for a vehicle about to leave: it is still perceived, and seen
        // by others, this tick.
        *row = RowInfo::of(v);
        JunctionBuckets::note(junction_list, i, row);
        index_items.add(self.net, v, i);
        if !made.is_empty() {
            followed.decisions.push((v.id, made));
        }
    }
}

/// Lane advance and branch choices of one vehicle (none for one already
/// leaving), with what follows from them; returns the choices made.
fn follow_lanes_of(
    net: &LaneNetwork,
    policy: &BranchPolicy,
    motion: &NpcVehicleConfig,
    v: &mut Vehicle,
) -> Vec<BranchChoice> {
    let mut made = Vec::new();
    if v.should_despawn {
        return made;
    }
    let before = (v.path[0], v.path.get(1).copied());
    advance_and_extend(net, policy, v, motion, &mut made);
    if before != (v.path[0], v.path.get(1).copied()) {
        lane_change::refresh_first_lanes(net, v);
    }
    if v.should_despawn && v.despawn_reason.is_none() {
        v.despawn_reason = Some(DespawnReason::DeadEnd);
    }
    if v.forced_through.is_some()
        && !net.lane(v.path[0]).intersection
        && v.prev_lane.is_some_and(|p| net.lane(p).intersection)
    {
        v.forced_through = None;
    }
    made
}

/// Decision, Control and Visualization of one vehicle, after its perception.
fn move_vehicle(
    net: &LaneNetwork,
    config: &NpcVehicleConfig,
    dt: f64,
    v: &mut Vehicle,
    p: &Perception,
) {
    p.apply(v);
    if v.should_despawn {
        return;
    }
    v.speed_mode = decide(v, config);
    step_speed(net, v, config, dt);
    update_pose(net, v);
    update_trip(v, dt);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lane_index::LaneIndex;
    use crate::populate::populate;
    use crate::{World, WorldConfig};
    use trafficmesh_maps::{GridOptions, grid_map};

    /// The lane index and the junction members a tick takes in its
    /// lane-following pass are those a pass of their own would take.
    #[test]
    fn the_items_taken_while_following_lanes_match_a_rebuild() {
        let map = grid_map(&GridOptions {
            size: 6,
            ..GridOptions::default()
        });
        let net = LaneNetwork::build(&map).expect("grid map builds");
        let config = WorldConfig {
            max_vehicles: 3000,
            ..WorldConfig::default()
        };
        let mut world = World::new(net, config);
        // More than one chunk of vehicles, so that the chunks are joined.
        populate(&mut world, 2 * MIN_VEHICLES_PER_TASK + 100);
        assert!(world.vehicles.len() > 2 * MIN_VEHICLES_PER_TASK);
        let (mut checked_later_chunks, mut fused_ticks, mut spawned) = (false, 0, 0);
        for tick in 0..2000 {
            world.step();
            if tick % 500 != 499 {
                continue;
            }
            // What the next tick's cognition would read, taken by the last
            // motion pass when it could, and else by a pass of its own.
            fused_ticks += usize::from(world.prefollowed.is_some());
            // Vehicles spawned after the motion pass are followed on their own.
            let before = world.vehicles.len();
            world.spawn_phase();
            spawned += world.vehicles.len() - before;
            for _ in 0..2 {
                world.follow_lanes();
                assert_the_index_and_junctions_match_a_rebuild(&mut world);
                world.prefollowed = None;
            }
            checked_later_chunks |= junction_members_beyond_the_first_chunk(&world);
        }
        assert!(fused_ticks > 0, "the motion pass followed the lanes");
        assert!(spawned > 0, "vehicles spawned after the motion pass");
        assert!(
            checked_later_chunks,
            "junction members beyond the first chunk"
        );
    }

    fn junction_members_beyond_the_first_chunk(world: &World) -> bool {
        (0..world.net.junction_count)
            .flat_map(|j| world.junctions.of(Some(j)))
            .any(|&i| i as usize >= MIN_VEHICLES_PER_TASK)
    }

    fn assert_the_index_and_junctions_match_a_rebuild(world: &mut World) {
        let (net, vehicles) = (&world.net, &world.vehicles);
        world.index.group(net);
        world.junctions.group(net);
        let mut index = LaneIndex::empty(net.lanes.len());
        index.rebuild(net, vehicles);
        let mut junctions = JunctionBuckets::default();
        junctions.rebuild(net, &world.row);
        for lane in 0..net.lanes.len() as LaneId {
            assert_eq!(
                index.on_lane(lane),
                world.index.on_lane(lane),
                "lane {lane}"
            );
            assert_eq!(
                index.blocked_zones(lane),
                world.index.blocked_zones(lane),
                "lane {lane}"
            );
        }
        assert_eq!(index.lane_changers(), world.index.lane_changers());
        for j in 0..net.junction_count {
            assert_eq!(
                junctions.of(Some(j)),
                world.junctions.of(Some(j)),
                "junction {j}"
            );
        }
    }
}
