//! The spawn phase: proposals grouped by spawn point, then the seed's decision
//! flow (ego distance, per-lane rate, priority, IsSpawnable, max count).

use glam::DVec2;

use super::World;
use crate::control::update_pose;
use crate::decision::StopDistances;
use crate::events::SimEvent;
use crate::geometry::{box_corners, boxes_overlap};
use crate::network::LaneId;
use crate::rng::SimRng;
use crate::spawn::SpawnProposal;
use crate::vehicle::{Pose, RouteProgress, TripStats, Vehicle, VehicleId, ZebraState};

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

const CLEARANCE: f64 = 1.0;

impl World {
    pub(super) fn spawn_phase(&mut self) {
        let mut proposals: Vec<(usize, SpawnProposal)> = Vec::new();
        let mut buf = Vec::new();
        for (si, sim) in self.simulators.iter_mut().enumerate() {
            if sim.is_enabled() {
                buf.clear();
                sim.propose(&self.net, &mut buf);
                proposals.extend(buf.drain(..).map(|p| (si, p)));
            }
        }
        // Group by spawn point (the lane start), in first-insertion order.
        let mut groups: Vec<(LaneId, Vec<usize>)> = Vec::new();
        let mut group_of: rustc_hash::FxHashMap<LaneId, usize> = rustc_hash::FxHashMap::default();
        for (k, (_, p)) in proposals.iter().enumerate() {
            let g = *group_of.entry(p.lane).or_insert_with(|| {
                groups.push((p.lane, Vec::new()));
                groups.len() - 1
            });
            groups[g].1.push(k);
        }
        let mut spawned_here: Vec<(DVec2, f64)> = Vec::new();
        for (lane, members) in groups {
            let start = self.net.lane(lane).line.point(0);
            if let Some(ego) = &self.ego
                && ego.position().distance(start) < self.config.spawn_distance_to_ego
            {
                self.spawn_stats.too_close_to_ego += members.len() as u64;
                continue;
            }
            let rate = self.spawn_rates[lane as usize];
            if rate > 0.0 && self.time - self.last_spawn[lane as usize] < 60.0 / rate - 1e-9 {
                self.spawn_stats.rate_limited += members.len() as u64;
                continue;
            }
            // Highest priority wins; ties keep insertion order.
            let winner = *members
                .iter()
                .min_by_key(|&&k| (-self.priorities[proposals[k].0], k))
                .expect("groups are never empty");
            self.spawn_stats.lost_priority += members.len() as u64 - 1;
            let (si, proposal) = &proposals[winner];
            // The seed checks the cap after the space check; when already full the
            // outcome is the same, so skip the space check (it only moves the count).
            if self.vehicles.len() >= self.config.max_vehicles {
                self.spawn_stats.max_vehicles += 1;
                continue;
            }
            if !self.is_spawnable(proposal.kind, lane, &spawned_here) {
                self.spawn_stats.not_spawnable += 1;
                continue;
            }
            let kind = &self.net.kinds[proposal.kind];
            spawned_here.push((start, kind.length));
            // The whole body on the spawn lane: rear bumper at its start (AWSIM puts the
            // rear axle there, which leaves a long overhang in the junction behind).
            self.register(
                proposal.kind,
                lane,
                kind.length,
                0.0,
                proposal.route.clone(),
            );
            self.last_spawn[lane as usize] = self.time;
            if members.len() > 1 {
                for &k in &members {
                    self.priorities[proposals[k].0] += 1;
                }
                self.priorities[*si] = 0;
            }
            self.simulators[*si].spawned(proposal.slot);
        }
    }

    /// IsSpawnable: the vehicle's box at the lane start is clear of every vehicle,
    /// of the ego, and of vehicles about to drive onto the lane.
    pub(super) fn is_spawnable(
        &self,
        kind: usize,
        lane: LaneId,
        spawned_here: &[(DVec2, f64)],
    ) -> bool {
        let kind = &self.net.kinds[kind];
        let l = self.net.lane(lane);
        let (rear, front) = (0.0, kind.length);
        let overlaps = |r: f64, f: f64| r < front + CLEARANCE && f > rear - CLEARANCE;
        if self
            .index
            .on_lane(lane)
            .iter()
            .any(|o| overlaps(o.rear, o.front))
        {
            return false;
        }
        // Bodies of other lanes standing in this lane's conflict zones near its start.
        if self
            .index
            .blocked_zones(lane)
            .iter()
            .any(|z| z.start < front + CLEARANCE && z.end > rear - CLEARANCE)
        {
            return false;
        }
        for &p in &l.prev {
            let len = self.net.lane(p).length();
            let arriving = self.index.on_lane(p).iter().any(|o| {
                let v = &self.vehicles[o.vehicle as usize];
                len - o.front < StopDistances::at(v.speed, &self.config.vehicle).stop + CLEARANCE
            });
            if arriving {
                return false;
            }
        }
        let start = l.line.point(0);
        if spawned_here
            .iter()
            .any(|&(p, len)| p.distance(start) < len + kind.length)
        {
            return false;
        }
        if let Some(ego) = &self.ego {
            let dir = l.line.direction(0);
            let center = start + dir * (kind.length * 0.5);
            let yaw = dir.y.atan2(dir.x);
            let corners = box_corners(center, yaw, kind.length * 0.5 + CLEARANCE, kind.width * 0.5);
            if boxes_overlap(&corners, &ego.corners()) {
                return false;
            }
        }
        true
    }

    /// Registers a new vehicle with its front bumper at `s` on `lane`.
    pub(super) fn register(
        &mut self,
        kind: usize,
        lane: LaneId,
        s: f64,
        speed: f64,
        route: Option<std::sync::Arc<[LaneId]>>,
    ) -> VehicleId {
        let k = &self.net.kinds[kind];
        let id = self.next_id;
        self.next_id += 1;
        let mut v = Vehicle {
            id,
            kind,
            front_offset: k.front,
            length: k.length,
            width: k.width,
            path: vec![lane],
            prev_lane: None,
            path_length: self.net.lane(lane).length(),
            first_junction_lane: None,
            s,
            speed,
            acceleration: 0.0,
            route: route.map(|lanes| RouteProgress { lanes, index: 0 }),
            is_turning: false,
            distance_to_front: f64::INFINITY,
            light_lane: None,
            distance_to_light: f64::INFINITY,
            passability: Default::default(),
            yield_lane: None,
            yield_phase: Default::default(),
            yield_point: DVec2::ZERO,
            dominating: None,
            forced_through: None,
            zebra: ZebraState::default(),
            speed_mode: Default::default(),
            pose: Pose::default(),
            front: DVec2::ZERO,
            back: DVec2::ZERO,
            heading: DVec2::X,
            turn_signal: Default::default(),
            should_despawn: false,
            despawn_reason: None,
            rng: SimRng::new(self.config.seed, (1 << 63) | id),
            trip: TripStats {
                spawn_time: self.time,
                ..TripStats::default()
            },
        };
        v.first_junction_lane = crate::cognition::path::first_junction_lane(&self.net, &v.path);
        update_pose(&self.net, &mut v);
        self.events.push(SimEvent::Spawned {
            id,
            kind: k.name.clone(),
            lane,
            time: self.time,
        });
        self.spawn_stats.spawned += 1;
        self.vehicles.push(v);
        id
    }

    /// Places a vehicle directly (scenarios, tests, benchmarks): `kind` at
    /// front-bumper arc length `s` on `lane`, moving at `speed`. It bypasses
    /// the spawn checks but is otherwise an ordinary NPC.
    pub fn place_vehicle(
        &mut self,
        kind: &str,
        lane: &str,
        s: f64,
        speed: f64,
    ) -> Result<VehicleId, super::WorldError> {
        let lane_id = self
            .net
            .lane_id(lane)
            .ok_or_else(|| super::WorldError::UnknownLane(lane.into()))?;
        let length = self.net.lane(lane_id).length();
        if !(0.0..=length).contains(&s) {
            return Err(super::WorldError::OutsideLane {
                lane: lane.into(),
                s,
                length,
            });
        }
        let k = self
            .net
            .kind_index(kind)
            .ok_or_else(|| super::WorldError::UnknownKind(kind.into()))?;
        Ok(self.register(k, lane_id, s, speed, None))
    }

    /// Places a vehicle that follows `route` (lane names, the first is where it is).
    pub fn place_vehicle_on_route(
        &mut self,
        kind: &str,
        route: &[&str],
        s: f64,
        speed: f64,
    ) -> Result<VehicleId, super::WorldError> {
        let lanes: Vec<LaneId> = route
            .iter()
            .map(|n| {
                self.net
                    .lane_id(n)
                    .ok_or_else(|| super::WorldError::UnknownLane(n.to_string()))
            })
            .collect::<Result<_, _>>()?;
        let id = self.place_vehicle(kind, route[0], s, speed)?;
        let v = self.vehicles.last_mut().expect("just placed");
        v.route = Some(RouteProgress {
            lanes: lanes.into(),
            index: 0,
        });
        Ok(id)
    }
}
