//! Reservation-based intersections (autonomous intersection management, the
//! product's document 004): a vehicle approaching the intersection asks for
//! a way through; the intersection drives the vehicle's future positions
//! along the smoothed path of its movement ([`plan`]) and grants the way
//! only if none of its rectangles overlaps one already granted for the same
//! time ([`book`]). A vehicle without a grant stops at the stop line and asks
//! again.
//!
//! Queue policy, of the vehicles at the head of each approach lane, in the
//! order they first asked: first come, first served, and when one cannot
//! get a way the next ones try; a head that has waited
//! [`PRIORITY_AFTER`] seconds is tried alone until it is granted; while an
//! emergency vehicle waits in a lane, only that lane and the lanes whose
//! movements never come near its movement are served, until it is granted.
//!
//! Below the world: it knows the network's lanes and nothing of vehicles
//! beyond what they tell it.

pub mod book;
pub mod path;
pub mod plan;

use std::collections::HashMap;

use crate::geometry::Polyline;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::VehicleId;
use book::Book;
use plan::{Approach, Margins, Plan};

/// Seconds the head of the queue waits before it is served alone.
pub const PRIORITY_AFTER: f64 = 10.0;
/// Paths sampled every this many metres to find which movements meet.
const MEETING_SAMPLE: f64 = 0.5;
/// Seconds of reservations kept behind the present (a vehicle a little late
/// on its plan still holds its rectangles).
const KEEP_BEHIND: f64 = 2.0;

/// One way through: an intersection lane, the lane it is entered from, and
/// the smoothed path.
#[derive(Clone, Debug)]
pub struct Movement {
    pub lane: LaneId,
    pub from: Vec<LaneId>,
    pub path: Polyline,
}

/// A request for a way through, from the vehicle at the head of its
/// approach lane.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    pub vehicle: VehicleId,
    /// The intersection lane it drives.
    pub lane: LaneId,
    /// The approach lane it waits on.
    pub from: LaneId,
    pub approach: Approach,
    /// It is an emergency vehicle, or one waits behind it in its lane.
    pub emergency: bool,
}

/// A way granted: when, where, and the plan the vehicle is to drive.
#[derive(Clone, Debug)]
pub struct Grant {
    pub at: f64,
    pub lane: LaneId,
    pub plan: Plan,
    pub step: f64,
}

impl Grant {
    /// The granted speed `elapsed` seconds after the grant: the plan's at
    /// that step, its last after it.
    pub fn speed_at(&self, elapsed: f64) -> f64 {
        let k = ((elapsed / self.step).floor().max(0.0) as usize).min(self.plan.speeds.len() - 1);
        self.plan.speeds[k]
    }
}

/// What a vehicle carries of its grant while it drives it: the speeds to
/// keep to, and whether it has entered yet.
#[derive(Clone, Debug, PartialEq)]
pub struct Driving {
    /// Its index among the network's reservation junctions.
    pub intersection: u32,
    pub lane: LaneId,
    pub speeds: Vec<f64>,
    pub step: f64,
    /// Seconds since the grant.
    pub elapsed: f64,
    /// Metres driven since the grant.
    pub travelled: f64,
    pub entered: bool,
}

impl Driving {
    pub fn of(intersection: u32, grant: &Grant) -> Self {
        Driving {
            intersection,
            lane: grant.lane,
            speeds: grant.plan.speeds.clone(),
            step: grant.step,
            elapsed: 0.0,
            travelled: 0.0,
            entered: false,
        }
    }

    /// The granted speed now: the plan's at this step, its last after it.
    pub fn speed(&self) -> f64 {
        let k = (self.elapsed / self.step + 1e-9).floor().max(0.0) as usize;
        self.speeds[k.min(self.speeds.len() - 1)]
    }

    /// The speed to drive, given the driver model's (`model`): the plan's,
    /// for its rectangles are reserved for those times, never faster; slower
    /// only where the driver must stop or brake for something (`held`: a
    /// body ahead nearer than [`Driving::room_needed`], a red light, a
    /// crosswalk in use), as the driver model says; the plan's time margin
    /// takes up the delay.
    pub fn keep_to(&self, model: f64, held: bool) -> f64 {
        let planned = self.speed();
        if held { model.min(planned) } else { planned }
    }

    /// How far the plan has driven by now, metres.
    pub fn planned_travel(&self) -> f64 {
        let whole = (self.elapsed / self.step + 1e-9).floor().max(0.0) as usize;
        let last = self.speeds.len() - 1;
        let done: f64 = self.speeds.iter().take(whole.min(last + 1)).sum::<f64>() * self.step;
        let rest = self.elapsed - whole as f64 * self.step;
        done + self.speeds[whole.min(last)] * rest.max(0.0)
    }

    /// Has it fallen so far behind its plan before entering that it would
    /// come after its rectangles' times (less their margin)?
    pub fn late(&self, time_margin: f64) -> bool {
        !self.entered
            && self.planned_travel() - self.travelled > time_margin * self.speed().max(1.0)
    }

    /// The room ahead a granted vehicle needs to drive its plan: a
    /// comfortable stop from the plan's speed now and [`FREE_AHEAD`] more.
    pub fn room_needed(&self, comfortable: f64) -> f64 {
        let planned = self.speed();
        planned * planned / (2.0 * comfortable) + FREE_AHEAD
    }
}

/// Metres beyond a comfortable stop within which a body ahead makes a
/// granted vehicle brake below its plan.
pub const FREE_AHEAD: f64 = 10.0;

/// A vehicle waiting for a way, since it first asked.
#[derive(Clone, Copy, Debug)]
struct Waiting {
    since: f64,
    request: Request,
}

/// One reservation intersection: its movements, which of them meet, the
/// reservations, and the vehicles waiting.
#[derive(Clone, Debug)]
pub struct Intersection {
    movements: Vec<Movement>,
    /// `meets[a][b]`: movements a and b come near enough for two bodies to touch.
    meets: Vec<Vec<bool>>,
    margins: Margins,
    book: Book,
    waiting: Vec<Waiting>,
    granted: HashMap<VehicleId, Grant>,
}

impl Intersection {
    /// The intersection of junction `junction`'s lanes; movements whose paths
    /// come within `widest` (the widest body that may drive them) and the
    /// space margins of each other meet.
    pub fn of(net: &LaneNetwork, junction: u32, widest: f64, margins: Margins) -> Self {
        let movements: Vec<Movement> = (0..net.lanes.len() as LaneId)
            .filter(|&l| net.lane(l).junction == Some(junction))
            .map(|l| {
                let lane = net.lane(l);
                let points: Vec<_> = lane.line.points().collect();
                Movement {
                    lane: l,
                    from: lane.prev.clone(),
                    path: path::smoothed(&points),
                }
            })
            .collect();
        let reach = widest + 2.0 * margins.space;
        let meets = movements
            .iter()
            .map(|a| {
                movements
                    .iter()
                    .map(|b| path::least_distance(&a.path, &b.path, MEETING_SAMPLE) < reach)
                    .collect()
            })
            .collect();
        Intersection {
            movements,
            meets,
            margins,
            book: Book::new(margins.step),
            waiting: Vec::new(),
            granted: HashMap::new(),
        }
    }

    fn movement(&self, lane: LaneId) -> Option<usize> {
        self.movements.iter().position(|m| m.lane == lane)
    }

    pub fn movements(&self) -> &[Movement] {
        &self.movements
    }

    /// The grant vehicle `id` holds, if any.
    pub fn grant(&self, id: VehicleId) -> Option<&Grant> {
        self.granted.get(&id)
    }

    /// The reservations ahead of `now`, for the live map.
    pub fn reserved_ahead(
        &self,
        now: f64,
    ) -> impl Iterator<Item = (f64, VehicleId, &crate::geometry::Obb)> {
        self.book.ahead(now)
    }

    /// Vehicles waiting per approach lane, for the live map.
    pub fn waiting_per_lane(&self) -> Vec<(LaneId, usize)> {
        let mut lanes: Vec<(LaneId, usize)> = Vec::new();
        for w in &self.waiting {
            match lanes.iter_mut().find(|(l, _)| *l == w.request.from) {
                Some((_, n)) => *n += 1,
                None => lanes.push((w.request.from, 1)),
            }
        }
        lanes
    }

    /// Keeps the grants of the vehicles `holds` says still hold theirs.
    pub fn retain_granted(&mut self, holds: impl Fn(VehicleId) -> bool) {
        let gone: Vec<VehicleId> = self
            .granted
            .keys()
            .copied()
            .filter(|&id| !holds(id))
            .collect();
        for id in gone {
            self.release(id);
        }
    }

    /// Vehicle `id` has left the intersection (or the map): its grant and
    /// rectangles go.
    pub fn release(&mut self, id: VehicleId) {
        if self.granted.remove(&id).is_some() {
            self.book.release(id);
        }
        self.waiting.retain(|w| w.request.vehicle != id);
    }

    /// One round of decisions at simulated time `now`, on this tick's
    /// requests (a vehicle not asking any more leaves the queue). Returns
    /// the vehicles granted a way this round, in the order granted.
    pub fn decide(&mut self, now: f64, requests: &[Request]) -> Vec<VehicleId> {
        self.book.expire(now, KEEP_BEHIND);
        self.update_queue(now, requests);
        let served = self.served(now);
        let mut granted = Vec::new();
        for k in served {
            let Waiting { request, .. } = self.waiting[k];
            let Some(m) = self.movement(request.lane) else {
                continue;
            };
            let Some(plan) = plan::plan(&self.movements[m].path, &request.approach, &self.margins)
            else {
                continue;
            };
            if !self.book.is_clear(now, &plan.steps, self.margins.time) {
                continue;
            }
            self.book.reserve(request.vehicle, now, &plan.steps);
            self.granted.insert(
                request.vehicle,
                Grant {
                    at: now,
                    lane: request.lane,
                    plan,
                    step: self.margins.step,
                },
            );
            granted.push(request.vehicle);
        }
        self.waiting
            .retain(|w| !self.granted.contains_key(&w.request.vehicle));
        granted
    }

    /// Keeps the waiting list in the order vehicles first asked (then by
    /// id), with this tick's requests.
    fn update_queue(&mut self, now: f64, requests: &[Request]) {
        let asking = |id| requests.iter().find(|r| r.vehicle == id);
        self.waiting.retain(|w| asking(w.request.vehicle).is_some());
        for w in &mut self.waiting {
            w.request = *asking(w.request.vehicle).expect("kept only those asking");
        }
        for r in requests {
            let known = self.waiting.iter().any(|w| w.request.vehicle == r.vehicle);
            if !known && !self.granted.contains_key(&r.vehicle) {
                self.waiting.push(Waiting {
                    since: now,
                    request: *r,
                });
            }
        }
        self.waiting.sort_by(|a, b| {
            a.since
                .total_cmp(&b.since)
                .then(a.request.vehicle.cmp(&b.request.vehicle))
        });
    }

    /// The waiting vehicles to try this round, in queue order.
    fn served(&self, now: f64) -> Vec<usize> {
        let all = 0..self.waiting.len();
        if let Some(e) = self.waiting.iter().find(|w| w.request.emergency) {
            let lane = e.request.from;
            let Some(em) = self.movement(e.request.lane) else {
                return all.collect();
            };
            // Its own lane, and the lanes none of whose movements come near its way.
            let clear_of_it = |from: LaneId| {
                self.movements
                    .iter()
                    .enumerate()
                    .filter(|(_, m)| m.from.contains(&from))
                    .all(|(k, _)| !self.meets[em][k])
            };
            return all
                .filter(|&k| {
                    let from = self.waiting[k].request.from;
                    from == lane || clear_of_it(from)
                })
                .collect();
        }
        match self.waiting.first() {
            Some(head) if now - head.since >= PRIORITY_AFTER => vec![0],
            _ => all.collect(),
        }
    }
}

#[cfg(test)]
mod tests;
