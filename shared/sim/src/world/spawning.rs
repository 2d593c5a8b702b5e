//! The spawn phase: proposals grouped by spawn point, then the AWSIM reference's decision
//! flow (ego distance, per-lane rate, priority, IsSpawnable, max count).

use glam::DVec2;

use super::World;
use crate::conflicts::Body;
use crate::control::update_pose;
use crate::decision::StopDistances;
use crate::events::SimEvent;
use crate::geometry::{Obb, box_corners, boxes_overlap};
use crate::network::LaneId;
use crate::rng::SimRng;
use crate::spawn::SpawnOutcome;
use crate::vehicle::{
    BODY_TOLERANCE, LanesBehind, Pose, RouteProgress, TripStats, Vehicle, VehicleId, ZebraState,
};

/// Why the owner of the vehicles refused a spawn request.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SpawnRejection {
    #[error("maximum vehicle count reached")]
    MaxVehicles,
    #[error("spawn point not clear")]
    NotSpawnable,
    #[error("unknown lane {0}")]
    UnknownLane(LaneId),
    #[error("unknown vehicle kind {0}")]
    UnknownKind(usize),
    #[error("the world restarted before the order's tick")]
    Restarted,
}

const CLEARANCE: f64 = 1.0;
/// How far before a conflict zone vehicles coming to it are looked for,
/// metres: beyond a stop from the highest speeds.
const APPROACH_LOOKBACK: f64 = 60.0;
/// Over at most this many lanes before it.
const APPROACH_LANES: usize = 6;
/// How far along its way a new body looks for a narrow stretch with a body
/// in it that it cannot pass, metres: put inside one end of such a stretch
/// (a two-way stub at a map's edge, too narrow for a truck and a car), it
/// would be committed through it, head on against that body.
const NARROW_AHEAD: f64 = 30.0;

/// A spawn order from outside the world (the spawner service's), admitted in
/// the next tick's spawn phase, after the world's own requests: the point of
/// the tick where a world that runs its own simulators spawns, so that the
/// cluster and `sim` spawn alike.
#[derive(Clone, Debug)]
pub struct QueuedSpawn {
    pub kind: usize,
    pub lane: LaneId,
    pub route: Option<crate::spawn::Route>,
    pub max_vehicles: usize,
}

impl World {
    /// `placed`: bodies put at lane starts earlier this tick (jammed vehicles
    /// moved on), which the spawns keep clear of.
    pub(super) fn spawn_phase(&mut self, placed: Vec<(DVec2, f64)>) {
        let requests = self.spawner.plan(
            &self.net,
            self.time,
            self.ego.as_ref(),
            self.config.spawn_distance_to_ego,
        );
        let mut spawned_here = placed;
        for request in &requests {
            let outcome = match self.admit_spawn(
                request.kind,
                request.lane,
                request.route.clone(),
                self.config.max_vehicles,
                &mut spawned_here,
            ) {
                Ok(_) => SpawnOutcome::Spawned,
                Err(SpawnRejection::MaxVehicles) => SpawnOutcome::MaxVehicles,
                Err(_) => SpawnOutcome::NotSpawnable,
            };
            self.spawner.resolve(request, outcome, self.time);
        }
        for order in std::mem::take(&mut self.queued_spawns) {
            let result = self.admit_spawn(
                order.kind,
                order.lane,
                order.route,
                order.max_vehicles,
                &mut spawned_here,
            );
            self.spawn_results.push(result);
        }
    }

    /// Queues a spawn order for the next tick's spawn phase.
    pub fn queue_spawn(&mut self, order: QueuedSpawn) {
        self.queued_spawns.push(order);
    }

    /// What became of the queued orders admitted so far, in queue order.
    pub fn take_spawn_results(&mut self) -> Vec<Result<VehicleId, SpawnRejection>> {
        std::mem::take(&mut self.spawn_results)
    }

    /// The final check of a spawn request against the vehicles (max count, then
    /// IsSpawnable) and the spawn itself, body on the lane with the rear bumper
    /// at its start. The world's own spawn phase and the stepper (for the
    /// spawner service's requests) both come here; requests of one tick go
    /// through in order, `spawned_here` carrying the earlier ones.
    pub fn admit_spawn(
        &mut self,
        kind: usize,
        lane: LaneId,
        route: Option<crate::spawn::Route>,
        max_vehicles: usize,
        spawned_here: &mut Vec<(DVec2, f64)>,
    ) -> Result<VehicleId, SpawnRejection> {
        if lane as usize >= self.net.lanes.len() {
            return Err(SpawnRejection::UnknownLane(lane));
        }
        if kind >= self.net.kinds.len() {
            return Err(SpawnRejection::UnknownKind(kind));
        }
        if self.vehicles.len() >= max_vehicles {
            return Err(SpawnRejection::MaxVehicles);
        }
        // Besides IsSpawnable's lanes: bodies of lanes that do not meet this
        // one as drawn, but a wide body at its start reaches (a truck at a
        // lane beginning beside a junction). A jammed vehicle moved on is
        // held to the bodies as they are instead (`body_fits`), its own
        // left out.
        let spawn_lane = self.net.lane(lane);
        if !self.is_spawnable(kind, lane, spawned_here)
            || !self.bodies.clear_of_moved(
                &self.net,
                &body_at_start(spawn_lane, &self.net.kinds[kind]),
                (lane, spawn_lane.line.point_at(0.0).1),
            )
        {
            return Err(SpawnRejection::NotSpawnable);
        }
        let length = self.net.kinds[kind].length;
        spawned_here.push((self.net.lane(lane).line.point(0), length));
        Ok(self.register(kind, lane, length, 0.0, route))
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
        // A lane shorter than the new body: it reaches onto the next lanes too.
        if self.ahead_taken(lane, front + CLEARANCE - l.length(), kind.width) {
            return false;
        }
        // Bodies of other lanes standing in this lane's conflict zones near its start.
        if self.index.blocked_zones(lane).iter().any(|z| {
            z.start < front + CLEARANCE
                && z.end > rear - CLEARANCE
                && !z.passable(Body::new_on_lane(kind.width))
        }) {
            return false;
        }
        if self.narrow_stretch_taken(lane, NARROW_AHEAD, kind.width) {
            return false;
        }
        // Vehicles about to drive onto the lane, or into a conflict zone the
        // new body stands in: crossing traffic may come over several short
        // lanes (a lane a metre long between two others hides nobody).
        if self.approaching(lane, 0.0, 1)
            || l.conflicts.iter().any(|c| {
                c.a0 < front + CLEARANCE && self.approaching(c.other, c.b0, APPROACH_LANES)
            })
        {
            return false;
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

    /// Is any of the first `overflow` metres after `lane` taken, by a body or
    /// by a body of another lane in a conflict zone there that a vehicle
    /// `width` wide cannot pass, on any lane that follows (however many lanes
    /// that spans)?
    fn ahead_taken(&self, lane: LaneId, overflow: f64, width: f64) -> bool {
        overflow > 0.0
            && self.net.lane(lane).next.iter().any(|&n| {
                self.index
                    .on_lane(n)
                    .iter()
                    .any(|o| o.rear < overflow && o.front > -CLEARANCE)
                    || self
                        .index
                        .blocked_zones(n)
                        .iter()
                        .any(|z| z.start < overflow && !z.passable(Body::new_on_lane(width)))
                    || self.ahead_taken(n, overflow - self.net.lane(n).length(), width)
            })
    }

    /// Does a road conflict zone that starts within `reach` metres of
    /// `lane`'s start (or on the lanes after it) hold a body that a vehicle
    /// `width` wide cannot pass?
    fn narrow_stretch_taken(&self, lane: LaneId, reach: f64, width: f64) -> bool {
        let l = self.net.lane(lane);
        self.index
            .blocked_zones(lane)
            .iter()
            .any(|z| z.road && z.start < reach && !z.passable(Body::new_on_lane(width)))
            || (reach > l.length()
                && l.next
                    .iter()
                    .any(|&n| self.narrow_stretch_taken(n, reach - l.length(), width)))
    }

    /// Does a vehicle on `lane`, or on up to `lanes_back` lanes before it,
    /// reach arc length `s` of `lane` before it could stop? The lanes before
    /// are looked along for at most [`APPROACH_LOOKBACK`] metres.
    fn approaching(&self, lane: LaneId, s: f64, lanes_back: usize) -> bool {
        let reaches = |front: f64, speed: f64| {
            let ahead = s - front;
            ahead >= 0.0 && ahead < StopDistances::at(speed, &self.config.vehicle).stop + CLEARANCE
        };
        self.index
            .on_lane(lane)
            .iter()
            .any(|o| reaches(o.front, o.speed))
            || (s < APPROACH_LOOKBACK
                && lanes_back > 0
                && self
                    .net
                    .lane(lane)
                    .prev
                    .iter()
                    .any(|&p| self.approaching(p, s + self.net.lane(p).length(), lanes_back - 1)))
    }

    /// Registers a new vehicle with its front bumper at `s` on `lane`.
    pub(super) fn register(
        &mut self,
        kind: usize,
        lane: LaneId,
        s: f64,
        speed: f64,
        route: Option<crate::spawn::Route>,
    ) -> VehicleId {
        let k = &self.net.kinds[kind];
        let depart = route.as_ref().and_then(|r| r.depart);
        let id = self.next_id;
        self.next_id += 1;
        let mut v = Vehicle {
            id,
            kind,
            front_offset: k.front,
            length: k.length,
            width: k.width,
            path: vec![lane],
            behind: LanesBehind::default(),
            path_length: self.net.lane(lane).length(),
            first_junction_lane: None,
            s,
            speed,
            acceleration: 0.0,
            route: route.map(|r| RouteProgress {
                lanes: r.lanes,
                index: 0,
                leave_at_end: r.leave_at_end,
            }),
            distance_to_front: f64::INFINITY,
            front_speed: 0.0,
            light_lane: None,
            distance_to_light: f64::INFINITY,
            passability: Default::default(),
            stops_at_light: false,
            yield_lane: None,
            yield_phase: Default::default(),
            yield_point: DVec2::ZERO,
            dominating: None,
            forced_through: None,
            squeeze_until: f64::NEG_INFINITY,
            grant: None,
            lane_change: None,
            zebra: ZebraState::default(),
            speed_mode: Default::default(),
            pose: Pose::default(),
            pose_at: (LaneId::MAX, f64::NAN),
            front: DVec2::ZERO,
            back: DVec2::ZERO,
            overhang: 0.0,
            rear_reach: 0.0,
            heading: DVec2::X,
            body_yaw: 0.0,
            sideways: Default::default(),
            shadow: None,
            turn_signal: Default::default(),
            should_despawn: false,
            despawn_reason: None,
            rng: SimRng::new(self.config.seed, (1 << 63) | id),
            trip: TripStats {
                spawn_time: self.time,
                depart: depart.unwrap_or(self.time),
                ..TripStats::default()
            },
        };
        v.first_junction_lane = crate::cognition::path::first_junction_lane(&self.net, &v.path);
        update_pose(&self.net, &mut v, crate::pose::Moved::NOT);
        self.events.push(SimEvent::Spawned {
            id,
            kind: k.name.clone(),
            lane,
            time: self.time,
        });
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
            leave_at_end: false,
        });
        Ok(id)
    }
}

/// The box a vehicle of `kind` placed at the start of `lane` is drawn as,
/// shrunk as the overlap check reads it: the chord from the lane start to
/// its front.
fn body_at_start(lane: &crate::network::Lane, kind: &trafficmesh_model::VehicleKind) -> Obb {
    let (back, front) = (lane.line.point(0), lane.line.point_at(kind.length).0);
    Obb::on_chord(back, front, (kind.length, kind.width), BODY_TOLERANCE)
}
