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
//! get a way the next ones try; once the head has waited
//! [`PRIORITY_AFTER`] seconds, the next ones are granted only ways that keep
//! clear of the one it asks for, until it is granted; while an
//! emergency vehicle waits in a lane, only that lane and the lanes whose
//! movements never come near its movement are served, until it is granted.
//!
//! Below the world: it knows the network's lanes and nothing of vehicles
//! beyond what they tell it.

pub mod book;
pub mod manager;
pub mod path;
pub mod plan;

use std::collections::HashMap;

use crate::geometry::Polyline;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::VehicleId;
use book::Book;
pub use manager::{IntersectionManager, Intersections};
use plan::{Approach, Margins, Plan};

/// Seconds the head of the queue waits before it is served alone.
pub const PRIORITY_AFTER: f64 = 10.0;
/// The head of an approach lane asks for a way once it is this many
/// seconds from the intersection at its speed, and at the latest
/// [`ASK_WITHIN`] metres before it; farther away the entry is no red light
/// to it yet, so that it comes on at its speed and a way granted at once
/// costs it nothing.
pub const ASK_AHEAD: f64 = 4.0;
pub const ASK_WITHIN: f64 = 60.0;

/// Metres before the intersection within which a vehicle at `speed` asks.
pub fn ask_distance(speed: f64) -> f64 {
    ASK_WITHIN.max(ASK_AHEAD * speed)
}

/// Metres of the lane after a movement that its path goes on over: ways
/// that merge into one exit are kept apart there too, where the driver
/// model takes over again and keeps its own headway.
pub const EXIT_REACH: f64 = 30.0;

/// The points of the lane after intersection lane `lane` (its only one, or
/// none where it has several) up to [`EXIT_REACH`] along it, after its first.
fn exit_points(net: &LaneNetwork, lane: LaneId) -> Vec<glam::DVec2> {
    let [exit] = net.lane(lane).next[..] else {
        return Vec::new();
    };
    let line = &net.lane(exit).line;
    let reach = EXIT_REACH.min(line.length());
    let mut points: Vec<_> = line
        .points()
        .skip(1)
        .take_while(|p| line.project(*p) < reach)
        .collect();
    points.push(line.point_at(reach).0);
    points
}

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

pub use trafficmesh_model::reservation::{Granted, Request};

/// A way granted: when, where, and the plan the vehicle is to drive.
#[derive(Clone, Debug)]
pub struct Grant {
    pub at: f64,
    pub lane: LaneId,
    pub plan: Plan,
    pub step: f64,
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
    /// The way `granted`, from the round's time on.
    pub fn of(granted: Granted) -> Self {
        Driving {
            intersection: granted.intersection,
            lane: granted.lane,
            speeds: granted.speeds,
            step: granted.step,
            elapsed: 0.0,
            travelled: 0.0,
            entered: false,
        }
    }

    /// The granted speed now: the plan's at this step, its last after it.
    pub fn speed(&self) -> f64 {
        self.speeds[self.step_now().min(self.speeds.len() - 1)]
    }

    /// The plan's step now (beyond its last once it has run out).
    fn step_now(&self) -> usize {
        (self.elapsed / self.step + 1e-9).floor().max(0.0) as usize
    }

    /// The speed to drive, given the driver model's (`model`): the plan's,
    /// for its rectangles are reserved for those times, never faster; slower
    /// only where the driver must stop or brake for something (`held`: a
    /// body ahead nearer than [`Driving::room_needed`], a red light, a
    /// crosswalk in use), as the driver model says.
    pub fn keep_to(&self, model: f64, held: bool) -> f64 {
        let planned = self.speed();
        if held { model.min(planned) } else { planned }
    }

    /// The room ahead a granted vehicle needs to drive its plan: what the
    /// time margin leaves behind a body ahead that keeps to its own plan,
    /// and [`MIN_ROOM`] more. (A body nearer is off its plan, or no
    /// granted one: the driver model brakes for it.)
    pub fn room_needed(&self, time_margin: f64) -> f64 {
        self.speed() * time_margin + MIN_ROOM
    }

    /// How far the plan has driven by now, metres.
    pub fn planned_travel(&self) -> f64 {
        let whole = self.step_now();
        let last = self.speeds.len() - 1;
        let done: f64 = self.speeds.iter().take(whole.min(last + 1)).sum::<f64>() * self.step;
        let rest = self.elapsed - whole as f64 * self.step;
        done + self.speeds[whole.min(last)] * rest.max(0.0)
    }

    /// Has it fallen behind its plan by more than the time margin (at the
    /// plan's speed now, or 1 m/s)?
    pub fn behind_plan(&self, time_margin: f64) -> bool {
        self.planned_travel() - self.travelled > time_margin * self.speed().max(1.0)
    }
}

/// Metres a granted vehicle keeps at least from a body ahead, beside the
/// time margin's room: under the 3 m two rectangles' end margins keep
/// between two bodies on their plans, so that a follower on its plan does
/// not brake for a leader on its own.
pub const MIN_ROOM: f64 = 2.0;

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
                let mut points: Vec<_> = lane.line.points().collect();
                points.extend(exit_points(net, l));
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

    /// Each approach lane (in lane order) with how long its head has waited
    /// for a way at `now` (0: none waits), for the live map.
    pub fn approaches(&self, now: f64) -> Vec<(LaneId, f64)> {
        let mut lanes: Vec<LaneId> = self
            .movements
            .iter()
            .flat_map(|m| m.from.iter().copied())
            .collect();
        lanes.sort_unstable();
        lanes.dedup();
        lanes
            .into_iter()
            .map(|lane| {
                let waited = self
                    .waiting
                    .iter()
                    .filter(|w| w.request.from == lane)
                    .map(|w| now - w.since)
                    .fold(0.0, f64::max);
                (lane, waited)
            })
            .collect()
    }

    /// The reservations ahead of `now`, for the live map.
    pub fn reserved_ahead(
        &self,
        now: f64,
    ) -> impl Iterator<Item = (f64, VehicleId, &crate::geometry::Obb)> {
        self.book.ahead(now)
    }

    /// Vehicle `id`, holding a way along movement `lane` (inside and behind
    /// its plan, or granted by a manager before this one), is planned again
    /// from where it is: its rectangles then say where it will be. Reserved
    /// whatever they meet (it may be inside and must get out); returns the
    /// new grant and the vehicles whose grants its new rectangles meet
    /// (those not yet inside are to give theirs back; the clearance check
    /// keeps the others apart).
    pub fn replan(
        &mut self,
        id: VehicleId,
        lane: LaneId,
        now: f64,
        approach: Approach,
    ) -> Option<(&Grant, Vec<VehicleId>)> {
        let m = self.movement(lane)?;
        let plan = plan::plan(&self.movements[m].path, &approach, &self.margins)?;
        self.book.release(id);
        let met = self.book.met_by(now, &plan.steps, self.margins.time);
        self.book.reserve(id, now, &plan.steps);
        let grant = Grant {
            at: now,
            lane,
            plan,
            step: self.margins.step,
        };
        self.granted.insert(id, grant);
        Some((self.granted.get(&id)?, met))
    }

    pub fn margins(&self) -> &Margins {
        &self.margins
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

    /// Vehicle `id` is through: its grant goes, its rectangles stay until
    /// their time has passed (those on the exit keep the next ones apart
    /// from it there).
    pub fn finish(&mut self, id: VehicleId) {
        self.granted.remove(&id);
        self.waiting.retain(|w| w.request.vehicle != id);
    }

    /// Vehicle `id` gives its way back (or left the map): its grant and
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
        let served = self.served();
        let prioritised = self
            .waiting
            .first()
            .is_some_and(|head| now - head.since >= PRIORITY_AFTER);
        // The way a prioritised head was refused, kept clear for it.
        let mut kept_clear: Option<Book> = None;
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
            let clear = self.book.is_clear(now, &plan.steps, self.margins.time)
                && kept_clear
                    .as_ref()
                    .is_none_or(|b| b.is_clear(now, &plan.steps, self.margins.time));
            if !clear {
                if k == 0 && prioritised {
                    let mut book = Book::new(self.margins.step);
                    book.reserve(request.vehicle, now, &plan.steps);
                    kept_clear = Some(book);
                }
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
    fn served(&self) -> Vec<usize> {
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
        all.collect()
    }
}

#[cfg(test)]
mod tests;
