//! A traffic simulator living in another process: it publishes its proposals
//! with a priority; they stay pending until they spawn or are replaced.

use std::sync::Arc;

use super::{SpawnProposal, TrafficSimulator};
use crate::network::{LaneId, LaneNetwork};

#[derive(Clone, Debug, PartialEq)]
pub struct PendingProposal {
    pub tag: String,
    pub lane: LaneId,
    pub kind: usize,
    pub route: Option<Arc<[LaneId]>>,
}

#[derive(Debug, Default)]
pub struct ExternalSimulator {
    /// Spawned proposals leave a hole until the next round, so slots stay valid.
    pending: Vec<Option<PendingProposal>>,
    priority: i64,
    /// Tags that spawned since the last `take_spawned`.
    spawned: Vec<String>,
}

impl ExternalSimulator {
    /// Replaces the pending proposals and the declared priority.
    pub fn set_proposals(&mut self, priority: i64, proposals: Vec<PendingProposal>) {
        self.priority = priority;
        self.pending = proposals.into_iter().map(Some).collect();
    }

    pub fn take_spawned(&mut self) -> Vec<String> {
        std::mem::take(&mut self.spawned)
    }
}

impl TrafficSimulator for ExternalSimulator {
    fn is_enabled(&self) -> bool {
        self.pending.iter().any(Option::is_some)
    }

    fn propose(&mut self, _net: &LaneNetwork, _time: f64, out: &mut Vec<SpawnProposal>) {
        self.pending.retain(Option::is_some);
        out.extend(
            self.pending
                .iter()
                .flatten()
                .enumerate()
                .map(|(slot, p)| SpawnProposal {
                    lane: p.lane,
                    kind: p.kind,
                    route: p.route.clone().map(|lanes| super::Route {
                        lanes,
                        leave_at_end: false,
                        depart: None,
                    }),
                    slot,
                }),
        );
    }

    fn spawned(&mut self, slot: usize) {
        if let Some(p) = self.pending.get_mut(slot).and_then(Option::take) {
            self.spawned.push(p.tag);
        }
    }

    fn priority(&self) -> i64 {
        self.priority
    }
}

/// An external simulator shared between the spawn manager and the code that
/// feeds it from the bus.
#[derive(Clone, Debug, Default)]
pub struct SharedExternal(pub Arc<std::sync::Mutex<ExternalSimulator>>);

impl TrafficSimulator for SharedExternal {
    fn is_enabled(&self) -> bool {
        self.0.lock().expect("simulator lock").is_enabled()
    }
    fn propose(&mut self, net: &LaneNetwork, _time: f64, out: &mut Vec<SpawnProposal>) {
        self.0
            .lock()
            .expect("simulator lock")
            .propose(net, _time, out)
    }
    fn spawned(&mut self, slot: usize) {
        self.0.lock().expect("simulator lock").spawned(slot)
    }
    fn priority(&self) -> i64 {
        self.0.lock().expect("simulator lock").priority()
    }
}
