//! Reservation intersections in the tick (see `crate::reservation`): before
//! cognition, a vehicle through its intersection, late on its plan, or gone
//! gives its way back, and the head of each approach lane near one asks for
//! a way. Serial, in id order (the intersections' queues order the rest).

use rustc_hash::FxHashSet;
use trafficmesh_model::SpeedLimitSource;

use super::World;
use crate::control::{comfortable_rates, driver_model};
use crate::reservation::plan::{Approach, Margins};
use crate::reservation::{Driving, Intersection, Request};
use crate::vehicle::VehicleId;

impl World {
    /// The network's reservation intersections, for bodies as wide as its
    /// widest kind.
    pub(super) fn reservation_intersections(net: &crate::LaneNetwork) -> Vec<Intersection> {
        let widest = net.kinds.iter().map(|k| k.width).fold(2.0, f64::max);
        net.reservation_junctions
            .iter()
            .map(|&j| Intersection::of(net, j, widest, Margins::default()))
            .collect()
    }

    /// Gives back the ways no longer driven, then lets the heads of the
    /// approaches ask.
    pub(super) fn reserve_ways(&mut self) {
        if self.intersections.is_empty() {
            return;
        }
        self.give_back_ways();
        let requests = self.requests();
        for (k, intersection) in self.intersections.iter_mut().enumerate() {
            let asking: Vec<Request> = requests
                .iter()
                .filter(|(r, _, _)| *r == k as u32)
                .map(|(_, _, request)| *request)
                .collect();
            for id in intersection.decide(self.time, &asking) {
                let grant = intersection.grant(id).expect("just granted");
                let (_, i, _) = requests
                    .iter()
                    .find(|(_, _, r)| r.vehicle == id)
                    .expect("granted vehicles asked");
                self.vehicles[*i].grant = Some(Box::new(Driving::of(k as u32, grant)));
            }
        }
    }

    /// A vehicle whose rear has left its intersection, or whose way no
    /// longer leads through the lane granted, gives its way back; so does
    /// one behind its plan that can still stop comfortably before its
    /// entry (it asks again), and vehicles no longer on the map. One behind
    /// its plan inside is planned again from where it is.
    fn give_back_ways(&mut self) {
        let net = &self.net;
        let config = &self.config.vehicle;
        let now = self.time;
        let mut holding: FxHashSet<VehicleId> = FxHashSet::default();
        let mut revoked: Vec<(usize, VehicleId)> = Vec::new();
        for v in &mut self.vehicles {
            let Some(grant) = v.grant.as_ref() else {
                continue;
            };
            let k = grant.intersection as usize;
            let margin = self.intersections[k].margins().time;
            let here = net.lane(v.path[0]).reservation();
            let entered = grant.entered || here == Some(grant.intersection);
            // Through once its rear has left the intersection and the reach
            // of the exit its plan covers.
            let on_exit = net.lane(grant.lane).next.contains(&v.path[0]);
            let through = entered
                && here != Some(grant.intersection)
                && (!on_exit || v.rear_s() >= crate::reservation::EXIT_REACH);
            let off_way = !entered && v.first_junction_lane.is_none_or(|f| f.lane != grant.lane);
            let late = grant.behind_plan(margin);
            if through {
                self.intersections[k].finish(v.id);
                v.grant = None;
                continue;
            }
            if off_way || (late && !entered && can_stop_before_entry(net, config, v)) {
                self.intersections[k].release(v.id);
                v.grant = None;
                continue;
            }
            if late && entered {
                let approach = approach_of(
                    net,
                    config,
                    v,
                    grant.lane,
                    -along_movement(net, v, grant.lane),
                );
                if let Some((g, met)) = self.intersections[k].replan(v.id, now, approach) {
                    let mut driving = Driving::of(k as u32, g);
                    driving.entered = true;
                    v.grant = Some(Box::new(driving));
                    revoked.extend(met.into_iter().map(|id| (k, id)));
                }
            } else if let Some(g) = v.grant.as_mut() {
                g.entered = entered;
            }
            holding.insert(v.id);
        }
        // Those whose ways a replanned vehicle now crosses, while they can
        // still stop before their entry, ask again.
        for (k, id) in revoked {
            let Some(v) = self.vehicles.iter_mut().find(|v| v.id == id) else {
                continue;
            };
            let not_in = v.grant.as_ref().is_some_and(|g| !g.entered);
            if not_in && can_stop_before_entry(net, config, v) {
                self.intersections[k].release(id);
                v.grant = None;
                holding.remove(&id);
            }
        }
        for intersection in &mut self.intersections {
            intersection.retain_granted(|id| holding.contains(&id));
        }
    }

    /// (intersection, vehicle index, request) of the head of each approach
    /// lane within [`ASK_WITHIN`] of a reservation intersection, without a
    /// way yet.
    fn requests(&self) -> Vec<(u32, usize, Request)> {
        let net = &self.net;
        let config = &self.config.vehicle;
        let mut heads: Vec<(u32, usize, Request)> = Vec::new();
        for (i, v) in self.vehicles.iter().enumerate() {
            if v.grant.is_some() || v.should_despawn {
                continue;
            }
            let Some(first) = v.first_junction_lane.filter(|f| f.k == 1) else {
                continue;
            };
            let lane = net.lane(first.lane);
            let Some(reservation) = lane.reservation() else {
                continue;
            };
            let to_entry = first.start - v.s;
            if to_entry > crate::reservation::ask_distance(v.speed) {
                continue;
            }
            let from = v.path[0];
            let ahead_of_others = heads
                .iter()
                .position(|(_, _, r)| r.from == from)
                .map(|k| (k, self.vehicles[heads[k].1].s < v.s));
            let request = Request {
                vehicle: v.id,
                lane: first.lane,
                from,
                approach: approach_of(net, config, v, first.lane, to_entry.max(0.0)),
                emergency: false,
            };
            match ahead_of_others {
                None => heads.push((reservation, i, request)),
                Some((k, true)) => heads[k] = (reservation, i, request),
                Some((_, false)) => {}
            }
        }
        // An emergency vehicle waiting anywhere on an approach lane gives
        // that lane's head its priority.
        let with_emergency: FxHashSet<crate::LaneId> = self
            .vehicles
            .iter()
            .filter(|v| v.grant.is_none() && is_emergency(net, v))
            .map(|v| v.path[0])
            .collect();
        for (_, _, request) in &mut heads {
            request.emergency = with_emergency.contains(&request.from);
        }
        heads
    }
}

/// What vehicle `v`, its front `to_entry` metres before the start of
/// movement `lane` (negative: inside), tells the intersection: its
/// speed, its driver model's acceleration, the limit in force and its body.
fn approach_of(
    net: &crate::LaneNetwork,
    config: &trafficmesh_model::NpcVehicleConfig,
    v: &crate::Vehicle,
    lane: crate::LaneId,
    to_entry: f64,
) -> Approach {
    let (accel, _) = comfortable_rates(driver_model(net, v, config), config);
    let max_speed = match config.speed_limit_source {
        SpeedLimitSource::FixedSpeedLimit => config.fixed_speed_limit,
        SpeedLimitSource::LaneletSpeedLimit => net.lane(lane).speed_limit,
    };
    Approach {
        to_entry,
        speed: v.speed,
        accel,
        max_speed,
        length: v.length,
        width: v.width,
    }
}

/// How far the front has driven along movement `lane`: on it, its arc
/// position; past it, the movement's length and how far it has gone on.
fn along_movement(net: &crate::LaneNetwork, v: &crate::Vehicle, lane: crate::LaneId) -> f64 {
    if v.path[0] == lane {
        return v.s;
    }
    let behind = v.behind.latest().filter(|&b| b == lane);
    behind.map_or(v.s, |b| net.lane(b).length() + v.s)
}

/// Can vehicle `v` still stop comfortably (and a metre short) before its
/// first junction lane?
fn can_stop_before_entry(
    net: &crate::LaneNetwork,
    config: &trafficmesh_model::NpcVehicleConfig,
    v: &crate::Vehicle,
) -> bool {
    let to_entry = v.first_junction_lane.map_or(0.0, |f| f.start - v.s);
    let (_, comfortable) = comfortable_rates(driver_model(net, v, config), config);
    to_entry > v.speed * v.speed / (2.0 * comfortable) + 1.0
}

/// Is `v` an emergency vehicle (its kind's class SUMO's `emergency`)?
fn is_emergency(net: &crate::LaneNetwork, v: &crate::Vehicle) -> bool {
    net.kinds[v.kind].class.as_deref() == Some(EMERGENCY_CLASS)
}

/// The vehicle class of emergency vehicles (SUMO's vClass).
pub const EMERGENCY_CLASS: &str = "emergency";
