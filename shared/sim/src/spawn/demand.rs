//! A timetable of departures (a SUMO demand): each vehicle is proposed from its
//! departure time on, at the start of its route, until it spawns; while its
//! first lane has no room it waits, and those behind it on that lane wait too
//! (SUMO's insertion backlog). A vehicle with equally good routes from other
//! lanes tries them in turn, tick by tick, and departs on the first with room
//! (SUMO's `departLane="best"`).

use std::collections::VecDeque;

use super::{SpawnProposal, TrafficSimulator};
use crate::network::{Departure, LaneId, LaneNetwork};

pub struct DemandSimulator {
    departures: Vec<Departure>,
    /// Departures before this index are due.
    released: usize,
    /// Due and not yet spawned, in departure order, with the route each
    /// tries next.
    waiting: VecDeque<(usize, usize)>,
}

impl DemandSimulator {
    /// `departures` sorted by time.
    pub fn new(departures: Vec<Departure>) -> Self {
        DemandSimulator {
            departures,
            released: 0,
            waiting: VecDeque::new(),
        }
    }
}

impl TrafficSimulator for DemandSimulator {
    fn is_enabled(&self) -> bool {
        self.released < self.departures.len() || !self.waiting.is_empty()
    }

    fn propose(&mut self, _net: &LaneNetwork, time: f64, out: &mut Vec<SpawnProposal>) {
        while self.released < self.departures.len()
            && self.departures[self.released].time <= time + 1e-9
        {
            self.waiting.push_back((self.released, 0));
            self.released += 1;
        }
        // The first waiting departure of each spawn lane; one spawn per lane
        // per tick. A departure proposed and still waiting found no room
        // there: next tick it tries its next route.
        let mut lanes: Vec<LaneId> = Vec::new();
        for (d, next) in self.waiting.iter_mut() {
            let departure = &self.departures[*d];
            let n = departure.routes.len();
            let Some(k) = (0..n)
                .map(|i| (*next + i) % n)
                .find(|&k| !lanes.contains(&departure.routes[k][0]))
            else {
                continue;
            };
            let route = &departure.routes[k];
            lanes.push(route[0]);
            *next = (k + 1) % n;
            out.push(SpawnProposal {
                lane: route[0],
                kind: departure.kind,
                route: Some(super::Route {
                    lanes: route.clone(),
                    leave_at_end: true,
                    depart: Some(departure.time),
                }),
                slot: *d,
            });
        }
    }

    fn backlog(&self) -> usize {
        self.waiting.len()
    }

    fn spawned(&mut self, slot: usize) {
        if let Some(k) = self.waiting.iter().position(|&(d, _)| d == slot) {
            self.waiting.remove(k);
        }
    }
}
