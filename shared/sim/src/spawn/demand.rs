//! A timetable of departures (a SUMO demand): each vehicle is proposed from its
//! departure time on, at the start of its route, until it spawns; while its
//! first lane has no room it waits, and those behind it on that lane wait too
//! (SUMO's insertion backlog).

use std::collections::VecDeque;
use std::sync::Arc;

use super::{SpawnProposal, TrafficSimulator};
use crate::network::{LaneId, LaneNetwork};

pub struct DemandSimulator {
    departures: Vec<(f64, Arc<[LaneId]>, usize)>,
    /// Departures before this index are due.
    released: usize,
    /// Due and not yet spawned, in departure order.
    waiting: VecDeque<usize>,
}

impl DemandSimulator {
    /// `departures` sorted by time: (time, route, kind).
    pub fn new(departures: Vec<(f64, Arc<[LaneId]>, usize)>) -> Self {
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
            && self.departures[self.released].0 <= time + 1e-9
        {
            self.waiting.push_back(self.released);
            self.released += 1;
        }
        // The first waiting departure of each spawn lane; one spawn per lane per tick.
        let mut lanes: Vec<LaneId> = Vec::new();
        for &d in &self.waiting {
            let (depart, route, kind) = &self.departures[d];
            if lanes.contains(&route[0]) {
                continue;
            }
            lanes.push(route[0]);
            out.push(SpawnProposal {
                lane: route[0],
                kind: *kind,
                route: Some(super::Route {
                    lanes: route.clone(),
                    leave_at_end: true,
                    depart: Some(*depart),
                }),
                slot: d,
            });
        }
    }

    fn backlog(&self) -> usize {
        self.waiting.len()
    }

    fn spawned(&mut self, slot: usize) {
        if let Some(k) = self.waiting.iter().position(|&d| d == slot) {
            self.waiting.remove(k);
        }
    }
}
