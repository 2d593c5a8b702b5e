//! Reservation intersections in the tick (see `crate::reservation`): before
//! cognition, a vehicle through its intersection, late on its plan, or gone
//! gives its way back, and the head of each approach lane near one asks for
//! a way. Serial, in id order (the intersections' queues order the rest).

use rustc_hash::FxHashMap;
use trafficmesh_model::{DriverModel, SpeedLimitSource};

use super::World;
use crate::reservation::plan::{Approach, Margins};
use crate::reservation::{Driving, Intersection, Request};
use crate::vehicle::VehicleId;

/// Metres before its intersection within which the head of an approach
/// lane asks for a way.
const ASK_WITHIN: f64 = 60.0;

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

    /// A vehicle whose rear has left its intersection, whose way no longer
    /// leads through the lane granted, or that fell behind its plan before
    /// entering, gives its way back; so do vehicles no longer on the map.
    fn give_back_ways(&mut self) {
        let net = &self.net;
        let margin = Margins::default().time;
        let mut holding: FxHashMap<VehicleId, ()> = FxHashMap::default();
        for v in &mut self.vehicles {
            let (rear, first) = (v.rear_s(), v.first_junction_lane);
            let here = net.lane(v.path[0]).reservation;
            let Some(grant) = v.grant.as_mut() else {
                continue;
            };
            grant.entered |= here == Some(grant.intersection);
            let through = grant.entered && here != Some(grant.intersection) && rear >= 0.0;
            let off_way = !grant.entered && first.is_none_or(|f| f.lane != grant.lane);
            if through || off_way || grant.late(margin) {
                let intersection = grant.intersection as usize;
                self.intersections[intersection].release(v.id);
                v.grant = None;
            } else {
                holding.insert(v.id, ());
            }
        }
        for intersection in &mut self.intersections {
            intersection.retain_granted(|id| holding.contains_key(&id));
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
            let Some(reservation) = lane.reservation else {
                continue;
            };
            let to_entry = first.start - v.s;
            if to_entry > ASK_WITHIN {
                continue;
            }
            let from = v.path[0];
            let ahead_of_others = heads
                .iter()
                .position(|(_, _, r)| r.from == from)
                .map(|k| (k, self.vehicles[heads[k].1].s < v.s));
            let accel = match crate::control::driver_model(net, v, config) {
                DriverModel::Awsim => config.acceleration,
                DriverModel::Realistic(idm) => idm.accel,
            };
            let max_speed = match config.speed_limit_source {
                SpeedLimitSource::FixedSpeedLimit => config.fixed_speed_limit,
                SpeedLimitSource::LaneletSpeedLimit => lane.speed_limit,
            };
            let request = Request {
                vehicle: v.id,
                lane: first.lane,
                from,
                approach: Approach {
                    to_entry: to_entry.max(0.0),
                    speed: v.speed,
                    accel,
                    max_speed,
                    length: v.length,
                    width: v.width,
                },
                emergency: false,
            };
            match ahead_of_others {
                None => heads.push((reservation, i, request)),
                Some((k, true)) => heads[k] = (reservation, i, request),
                Some((_, false)) => {}
            }
        }
        heads
    }
}
