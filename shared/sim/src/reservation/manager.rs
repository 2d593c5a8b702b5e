//! The intersection manager's seam: the world sends one [`Round`] a tick and
//! drives by the [`Answer`]. [`Intersections`] answers in the same process
//! (`sim`, the tests); the cluster's stepper hands the round to the
//! intersection service over the bus, and gets no answer while that service
//! cannot be reached: then nothing is granted and the vehicles wait, and the
//! ways already granted stay apart as they were planned.

use trafficmesh_model::reservation::{Answer, Granted, Member, Round};

use super::plan::Margins;
use super::{Grant, Intersection};
use crate::network::LaneNetwork;
use crate::vehicle::VehicleId;

/// Who decides the ways through a network's reservation intersections.
pub trait IntersectionManager: Send {
    /// One tick's round; `None` when the manager could not be reached.
    fn round(&mut self, round: &Round) -> Option<Answer>;
}

/// Every reservation intersection of a network, in the network's order.
#[derive(Clone, Debug, Default)]
pub struct Intersections {
    list: Vec<Intersection>,
}

impl Intersections {
    /// The network's reservation intersections, for bodies as wide as its
    /// widest kind.
    pub fn of(net: &LaneNetwork) -> Self {
        let widest = net.kinds.iter().map(|k| k.width).fold(2.0, f64::max);
        let list = net
            .reservation_junctions
            .iter()
            .map(|&j| Intersection::of(net, j, widest, Margins::default()))
            .collect();
        Intersections { list }
    }

    pub fn list(&self) -> &[Intersection] {
        &self.list
    }

    /// The answer to `round`: the ways given back, planned again and taken
    /// over first, then each intersection's decisions on its requests.
    pub fn answer(&mut self, round: &Round) -> Answer {
        let now = round.time;
        let mut answer = Answer::default();
        for m in &round.finished {
            if let Some(x) = self.list.get_mut(m.intersection as usize) {
                x.finish(m.vehicle);
            }
        }
        for m in &round.released {
            if let Some(x) = self.list.get_mut(m.intersection as usize) {
                x.release(m.vehicle);
            }
        }
        // Planned again: those behind their plans inside, and those whose
        // grants this manager does not know (it started after them).
        let mut met: Vec<Member> = Vec::new();
        for h in &round.holding {
            let Some(x) = self.list.get_mut(h.intersection as usize) else {
                continue;
            };
            if !h.replan && x.grant(h.vehicle).is_some() {
                continue;
            }
            if let Some((grant, by)) = x.replan(h.vehicle, h.lane, now, h.approach) {
                answer
                    .granted
                    .push(granted(h.intersection, h.vehicle, grant, true));
                met.extend(by.into_iter().map(|vehicle| Member {
                    intersection: h.intersection,
                    vehicle,
                }));
            }
        }
        // Those it meets that can still stop ask again.
        for h in &round.holding {
            let member = Member {
                intersection: h.intersection,
                vehicle: h.vehicle,
            };
            let replanned = answer.granted.iter().any(|g| g.vehicle == h.vehicle);
            if h.revocable && !replanned && met.contains(&member) {
                self.list[h.intersection as usize].release(h.vehicle);
                answer.revoked.push(member);
            }
        }
        for (k, x) in self.list.iter_mut().enumerate() {
            let k = k as u32;
            x.retain_granted(|id| holds(round, &answer.revoked, k, id));
            let asking: Vec<_> = round
                .requests
                .iter()
                .filter(|r| r.intersection == k)
                .copied()
                .collect();
            for id in x.decide(now, &asking) {
                let grant = x.grant(id).expect("just granted");
                answer.granted.push(granted(k, id, grant, false));
            }
        }
        answer
    }
}

impl IntersectionManager for Intersections {
    fn round(&mut self, round: &Round) -> Option<Answer> {
        Some(self.answer(round))
    }
}

/// Does vehicle `id` still hold its way through intersection `k`?
fn holds(round: &Round, revoked: &[Member], k: u32, id: VehicleId) -> bool {
    let member = Member {
        intersection: k,
        vehicle: id,
    };
    round
        .holding
        .iter()
        .any(|h| h.intersection == k && h.vehicle == id)
        && !revoked.contains(&member)
}

fn granted(intersection: u32, vehicle: VehicleId, grant: &Grant, again: bool) -> Granted {
    Granted {
        intersection,
        vehicle,
        lane: grant.lane,
        speeds: grant.plan.speeds.clone(),
        step: grant.step,
        again,
    }
}
