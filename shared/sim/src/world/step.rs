//! One tick: spawn, lane following, the lane index, Cognition, deadlock
//! breaking, the motion pass (`motion.rs`), despawn, and now and then
//! regrouping the list (`regroup.rs`).

use rayon::prelude::*;

use super::World;
use super::awake::with_workers_awake;
use super::phases::Phase;
use crate::cognition::right_of_way::RowInfo;
use crate::cognition::{Perception, Snapshot, deadlock, perceive};
use crate::control::reach;
use crate::events::{DespawnReason, SimEvent, TripRecord};
use crate::lane_change;
use crate::lane_choice;
use crate::lookahead;
use crate::network::{LaneId, LaneNetwork};
use crate::parallel::{
    MIN_VEHICLES_PER_TASK, chunk_len, join_if, light_pass_len, light_pass_parallel,
};
use crate::pose::TURN_RADIUS;
use crate::vehicle::Vehicle;

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
        depart: v.trip.depart,
        despawn_time: time,
        time_loss: v.trip.time_loss,
        distance: v.trip.distance,
        stops: v.trip.stops,
        time_stopped: v.trip.time_stopped,
        reason,
    }
}

/// Despawn events in id order, whatever the vehicles' order in the list.
pub(super) fn push_despawns(events: &mut Vec<SimEvent>, mut trips: Vec<TripRecord>) {
    trips.sort_by_key(|t| t.id);
    events.extend(trips.into_iter().map(SimEvent::Despawned));
}

/// The name the AWSIM reference's log lines use: `<prefab>(Clone)_<id>`.
pub fn vehicle_name(net: &LaneNetwork, v: &Vehicle) -> String {
    format!("{}(Clone)_{}", net.kinds[v.kind].name, v.id)
}

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
        self.step_walkers();
        self.phase_times.lap(Phase::Lights);
        // On the same lane index as spawning: a jammed vehicle is moved to
        // where a new one could spawn, and the spawns then keep clear of it.
        let placed = self.resolve_jams();
        self.spawn_phase(placed);
        self.phase_times.lap(Phase::Spawn);
        let leaving = self.follow_lanes();
        self.phase_times.lap(Phase::FollowLanes);
        // The lane-following pass took the items of both; the junctions'
        // grouping runs beside the lane index's.
        let parallel = light_pass_parallel(self.vehicles.len());
        let (net, index, junctions) = (&self.net, &mut self.index, &mut self.junctions);
        let (vehicles, bodies) = (&self.vehicles, &mut self.bodies);
        let (motion, dt) = (&self.config.vehicle, dt);
        join_if(
            parallel,
            || index.group(net, vehicles),
            || {
                junctions.group(net);
                bodies.rebuild(net, vehicles, |v| reach(net, motion, v, dt), TURN_RADIUS);
            },
        );
        self.phase_times.lap(Phase::LaneIndex);
        if self.change_lanes() {
            self.index.rebuild(&self.net, &self.vehicles);
            self.junctions.rebuild(&self.net, &self.row);
        }
        self.phase_times.lap(Phase::LaneChanges);
        self.reserve_ways();

        // This tick's buffers, handed back after the motion step for the next.
        let mut perceptions = std::mem::take(&mut self.perceptions);
        let mut waits = std::mem::take(&mut self.waits);
        self.cognition(&mut perceptions, &mut waits);
        self.phase_times.lap(Phase::Cognition);
        deadlock::break_cycles(&self.net, &self.vehicles, &waits, &mut perceptions);
        self.note_gridlocks(&waits);
        if std::mem::take(&mut self.log_stuck) {
            self.log_stuck_vehicles(&waits);
        }
        self.phase_times.lap(Phase::Deadlock);
        self.zebra_events(&perceptions);
        self.phase_times.lap(Phase::Zebra);
        // A tick that ends by regrouping the list leaves the next tick's lane
        // following to it: done ahead, it would be at the old places.
        let regroup = self.regroup_due();
        let digest_sum = self.move_and_follow(&perceptions, &leaving, !regroup);
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
        if regroup {
            self.regroup_by_lane();
        }
        self.phase_times.lap(Phase::Regroup);
    }

    /// The lane changes routes need, where there is a gap. Planned
    /// against this tick's lane index, then made in id order so that two
    /// vehicles never take the same gap. Returns whether any was made.
    fn change_lanes(&mut self) -> bool {
        let motion = self.config.vehicle;
        let (net, index, vehicles) = (&self.net, &self.index, &self.vehicles);
        let mut candidates: Vec<lane_change::Change> = index
            .lane_changers()
            .iter()
            .filter_map(|&i| lane_change::plan(net, index, vehicles, i as usize, &motion))
            .collect();
        let looking = lane_choice::Looking::at(self.ticks, self.config.dt);
        // Every vehicle is asked: on the pool, in list order.
        let mut choices: Vec<lane_choice::Choice> = (0..vehicles.len())
            .into_par_iter()
            .with_min_len(light_pass_len(vehicles.len()))
            .filter_map(|i| lane_choice::choose(net, index, vehicles, i, &motion, looking))
            .collect();
        if candidates.is_empty() && choices.is_empty() {
            return false;
        }
        candidates.sort_by_key(|c| vehicles[c.vehicle].id);
        choices.sort_by_key(|c| vehicles[c.vehicle].id);
        // The needed ones first, then the optional ones into the gaps they
        // left. No vehicle is in both: a driver with a change pending makes
        // no choice.
        let needed = candidates.into_iter().map(|c| (c.vehicle, c.target, None));
        let optional = choices.into_iter().map(|c| (c.vehicle, c.target, Some(c)));
        let mut moved: Vec<lane_change::Moved> = Vec::new();
        for (i, target, choice) in needed.chain(optional) {
            if !self.gap_still_free(&moved, i, target) {
                continue;
            }
            moved.push(lane_change::Moved::of(&self.vehicles[i], target));
            if let Some(c) = choice {
                lane_choice::reroute(&self.net, &mut self.vehicles[i], &c);
            }
            self.change_lane(i, target);
        }
        !moved.is_empty()
    }

    /// Is vehicle `i`'s gap on `target` clear of the bodies already moved
    /// onto it this tick?
    fn gap_still_free(&self, moved: &[lane_change::Moved], i: usize, target: LaneId) -> bool {
        let v = &self.vehicles[i];
        let gaps = lane_change::Gaps::of(&self.net, v, &self.config.vehicle);
        lane_change::clear_of(moved, v, target, gaps)
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
            time: self.time,
            occupancy: &self.occupancy,
            ego: self.ego.as_ref(),
            foreign: &self.foreign,
            config: &self.config.vehicle,
            row,
            junctions: &self.junctions,
            bodies: &self.bodies,
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
                .with_min_len(chunk_len(self.vehicles.len()))
                .map(|(i, wait)| {
                    lookahead::cognition_ahead(snap.net, snap.vehicles, snap.index, i);
                    let p = perceive(&snap, i);
                    *wait = deadlock::wait_of(&snap, i, &p);
                    p
                }),
        );
    }

    /// The WasZebraBlocked transitions (before the new perceptions are applied, so
    /// the area that cleared is still known), with the AWSIM reference's log lines.
    fn zebra_events(&mut self, perceptions: &[Perception]) {
        // A stop needs an occupied area now; a clear needs a vehicle blocked last tick.
        if self.occupancy.occupied_areas().is_empty() && !self.zebra_blocked_last_tick {
            return;
        }
        self.zebra_blocked_last_tick = perceptions.iter().any(|p| p.zebra.is_blocked);
        // In id order, whatever the vehicles' order in the list.
        let mut changed: Vec<usize> = (0..self.vehicles.len())
            .filter(|&i| self.vehicles[i].zebra.is_blocked != perceptions[i].zebra.is_blocked)
            .collect();
        changed.sort_by_key(|&i| self.vehicles[i].id);
        for i in changed {
            let (v, p) = (&self.vehicles[i], &perceptions[i]);
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
        let mut trips = Vec::with_capacity(leaving.len());
        let mut i = 0;
        let mut next = leaving.iter().peekable();
        self.vehicles.retain(|v| {
            let leaves = next.next_if_eq(&&i).is_some();
            i += 1;
            if leaves {
                let reason = v.despawn_reason.unwrap_or(DespawnReason::DeadEnd);
                trips.push(trip_record(net, v, time, reason));
            }
            !leaves
        });
        push_despawns(&mut self.events, trips);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cognition::right_of_way::JunctionBuckets;
    use crate::lane_index::LaneIndex;
    use crate::populate::populate;
    use crate::world::test_grid_world;
    use crate::{World, WorldConfig};

    /// The lane index and the junction members a tick takes in its
    /// lane-following pass are those a pass of their own would take.
    #[test]
    fn the_items_taken_while_following_lanes_match_a_rebuild() {
        let config = WorldConfig {
            max_vehicles: 3000,
            // A tick that ends by regrouping follows nothing ahead; this test
            // is about the ticks that do (regrouping: tests/list_order.rs).
            regroup_interval: 0,
            ..WorldConfig::default()
        };
        let mut world = test_grid_world(6, config);
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
            world.spawn_phase(Vec::new());
            spawned += world.vehicles.len() - before;
            for _ in 0..2 {
                world.follow_lanes();
                assert_the_index_and_junctions_match_a_rebuild(&mut world);
                world.drop_prefollowed();
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
            .any(|m| m.index as usize >= chunk_len(world.vehicles.len()))
    }

    fn assert_the_index_and_junctions_match_a_rebuild(world: &mut World) {
        let (net, vehicles) = (&world.net, &world.vehicles);
        world.index.group(net, vehicles);
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
