//! Reservation intersections in the tick (see `crate::reservation`): before
//! cognition, a vehicle through its intersection, late on its plan, or gone
//! gives its way back, and the head of each approach lane near one asks for
//! a way; the manager's answer sets the grants. Serial, in vehicle order
//! (the intersections' queues order the rest).

use rustc_hash::{FxHashMap, FxHashSet};
use trafficmesh_model::SpeedLimitSource;
use trafficmesh_model::reservation::{Holding, Member, Round};

use super::World;
use crate::control::{comfortable_rates, driver_model};
use crate::reservation::plan::{Approach, Margins};
use crate::reservation::{Driving, Request};
use crate::vehicle::VehicleId;

impl World {
    /// Tells the manager which ways are given back and which are held, lets
    /// the heads of the approaches ask, and drives by its answer.
    pub(super) fn reserve_ways(&mut self) {
        if self.net.reservation_junctions.is_empty() {
            return;
        }
        let mut round = Round {
            time: self.time,
            ..Round::default()
        };
        self.give_back_ways(&mut round);
        round.requests = self.requests();
        let Some(answer) = self.intersections.round(&round) else {
            return;
        };
        // Most ticks change no grant: no index of every vehicle then.
        if answer.granted.is_empty() && answer.revoked.is_empty() {
            return;
        }
        let at: FxHashMap<VehicleId, usize> = self
            .vehicles
            .iter()
            .enumerate()
            .map(|(i, v)| (v.id, i))
            .collect();
        for m in answer.revoked {
            if let Some(&i) = at.get(&m.vehicle) {
                self.vehicles[i].grant = None;
            }
        }
        for g in answer.granted {
            let Some(&i) = at.get(&g.vehicle) else {
                continue;
            };
            let v = &mut self.vehicles[i];
            let entered = g.again && v.grant.as_ref().is_some_and(|d| d.entered);
            let mut driving = Driving::of(g);
            driving.entered = entered;
            v.grant = Some(Box::new(driving));
        }
    }

    /// A vehicle whose rear has left its intersection, or whose way no
    /// longer leads through the lane granted, gives its way back; so does
    /// one behind its plan that can still stop comfortably before its
    /// entry (it asks again). One behind its plan inside is to be planned
    /// again from where it is; every other keeps its way.
    fn give_back_ways(&mut self, round: &mut Round) {
        let net = &self.net;
        let config = &self.config.vehicle;
        let margin = Margins::default().time;
        for v in &mut self.vehicles {
            let Some(grant) = v.grant.as_deref() else {
                continue;
            };
            let member = Member {
                intersection: grant.intersection,
                vehicle: v.id,
            };
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
            let lane = grant.lane;
            if through {
                round.finished.push(member);
                v.grant = None;
                continue;
            }
            let can_stop = !entered && can_stop_before_entry(net, config, v);
            if off_way || (late && can_stop) {
                round.released.push(member);
                v.grant = None;
                continue;
            }
            if let Some(grant) = v.grant.as_mut() {
                grant.entered = entered;
            }
            let to_entry = if entered {
                -along_movement(net, v, lane)
            } else {
                v.first_junction_lane.map_or(0.0, |f| f.start - v.s)
            };
            round.holding.push(Holding {
                intersection: member.intersection,
                vehicle: v.id,
                lane,
                approach: approach_of(net, config, v, lane, to_entry),
                replan: late && entered,
                revocable: can_stop,
            });
        }
        // Vehicles taken off the map are in no list: the manager lets their
        // ways go with those of every vehicle not holding one.
    }

    /// The request of the head of each approach lane within
    /// [`crate::reservation::ask_distance`] of a reservation intersection,
    /// without a way yet.
    fn requests(&self) -> Vec<Request> {
        let net = &self.net;
        let config = &self.config.vehicle;
        // Each approach lane's head: its request and its place on the lane.
        let mut heads: Vec<(Request, f64)> = Vec::new();
        for v in &self.vehicles {
            if v.grant.is_some() || v.should_despawn {
                continue;
            }
            let Some(first) = v.first_junction_lane.filter(|f| f.k == 1) else {
                continue;
            };
            let Some(intersection) = net.lane(first.lane).reservation() else {
                continue;
            };
            let to_entry = first.start - v.s;
            if to_entry > crate::reservation::ask_distance(v.speed) {
                continue;
            }
            let from = v.path[0];
            let request = Request {
                intersection,
                vehicle: v.id,
                lane: first.lane,
                from,
                approach: approach_of(net, config, v, first.lane, to_entry.max(0.0)),
                emergency: false,
            };
            match heads.iter_mut().find(|(r, _)| r.from == from) {
                None => heads.push((request, v.s)),
                Some(head) if head.1 < v.s => *head = (request, v.s),
                Some(_) => {}
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
        heads
            .into_iter()
            .map(|(mut request, _)| {
                request.emergency = with_emergency.contains(&request.from);
                request
            })
            .collect()
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
