//! The reservation intersections' manager as the intersection service: each
//! tick's round goes to it as a query and the tick waits for the answer. No
//! answer within [`ROUND_TIMEOUT`] (the service is down, frozen or not
//! started yet) grants nothing that tick: vehicles wait at the stop lines,
//! and those already granted keep to plans that were made apart.

use std::sync::Arc;
use std::time::Duration;

use trafficmesh_bus::Bus;
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{Answer, Round};
use trafficmesh_sim::reservation::IntersectionManager;

use crate::inputs::Shared;

/// How long a tick waits for the intersection service's answer.
pub const ROUND_TIMEOUT: Duration = Duration::from_millis(250);

pub struct RemoteIntersections {
    bus: Arc<Bus>,
    runtime: tokio::runtime::Handle,
    shared: Arc<Shared>,
    /// Whether the last round was answered (None before the first).
    answered: Option<bool>,
}

impl RemoteIntersections {
    pub fn new(bus: Arc<Bus>, runtime: tokio::runtime::Handle, shared: Arc<Shared>) -> Self {
        RemoteIntersections {
            bus,
            runtime,
            shared,
            answered: None,
        }
    }

    /// Logs and reports a change between answered and not.
    fn answered(&mut self, now: bool, time: f64, why: impl FnOnce() -> String) {
        if self.answered == Some(now) {
            return;
        }
        if now {
            tracing::info!("the intersection service answers at t={time:.2}: ways are granted");
        } else {
            tracing::warn!(
                "no answer from the intersection service at t={time:.2} ({}): no way is granted, vehicles wait at reservation intersections",
                why()
            );
        }
        self.answered = Some(now);
        self.shared
            .status
            .lock()
            .expect("status lock")
            .intersections_unanswered = !now;
    }
}

impl IntersectionManager for RemoteIntersections {
    fn round(&mut self, round: &Round) -> Option<Answer> {
        let asked = self.runtime.block_on(self.bus.call(
            &topics::INTERSECTION_ROUND,
            round,
            ROUND_TIMEOUT,
        ));
        match asked {
            Ok(answer) => {
                self.answered(true, round.time, String::new);
                Some(answer)
            }
            Err(e) => {
                self.answered(false, round.time, || e.to_string());
                None
            }
        }
    }
}
