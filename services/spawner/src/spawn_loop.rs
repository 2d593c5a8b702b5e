//! The spawn decisions, each tick: plan, have the stepper admit the orders,
//! book the verdicts. Free-running, on the stepper's clock with a spawn query
//! per tick; in lockstep, on the stepper's questions, which carry the
//! verdicts on the orders of the tick before.

use std::sync::Arc;
use std::time::Duration;

use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{Clock, ProposalResult, TickReport};
use trafficmesh_sim::spawn::SpawnRequest;

use crate::Spawner;

pub async fn run(spawner: Arc<Spawner>) {
    let bus = spawner.bus.clone();
    let keys = bus.keys().clone();
    let clock = match bus.subscribe(&keys.clock()).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!("cannot subscribe to the clock: {e}");
            return;
        }
    };
    let mut warned = false;
    while let Some(c) = bus.next_latest::<Clock>(&clock).await {
        let (requests, batch) = {
            let mut s = spawner.state();
            s.time = c.time;
            s.plan()
        };
        if requests.is_empty() {
            continue;
        }
        let answer = bus
            .call(&topics::STEPPER_SPAWN, &batch, Duration::from_secs(2))
            .await;
        let answer = match answer {
            Ok(a) if a.verdicts.len() == requests.len() => a,
            Ok(_) => {
                tracing::warn!("stepper answered a different number of spawn verdicts");
                continue;
            }
            Err(e) => {
                if !warned {
                    tracing::warn!("spawn request failed: {e}");
                    warned = true;
                }
                continue;
            }
        };
        warned = false;
        let results = spawner.state().resolve(&requests, &answer.verdicts, c.time);
        announce(&spawner, results, c.time).await;
    }
}

/// In lockstep: each question books the verdicts on the last orders, then
/// plans this tick's, as a world that runs its own simulators does in its
/// spawn phase.
pub async fn run_in_step(spawner: Arc<Spawner>) {
    let bus = spawner.bus.clone();
    let key = bus.keys().lockstep_member("spawner");
    // The last orders and the time they were planned at.
    let mut pending: (Vec<SpawnRequest>, f64) = (Vec::new(), 0.0);
    let served = bus
        .answer_ticks(&key, |tick| {
            let (results, report) = {
                let mut s = spawner.state();
                let (requests, planned_at) = std::mem::take(&mut pending);
                let results = if requests.len() == tick.spawn_verdicts.len() {
                    s.resolve(&requests, &tick.spawn_verdicts, planned_at)
                } else {
                    // A restarted stepper or spawner: those orders are void.
                    tracing::warn!(
                        "lockstep: {} verdicts on {} orders; the orders are dropped",
                        tick.spawn_verdicts.len(),
                        requests.len()
                    );
                    Vec::new()
                };
                s.time = tick.time;
                let (requests, orders) = s.plan();
                pending = (requests, tick.time);
                let config = s.take_config_change();
                (results, TickReport::Spawner { orders, config })
            };
            let spawner = spawner.clone();
            async move {
                announce(&spawner, results, tick.time).await;
                report
            }
        })
        .await;
    if let Err(e) = served {
        tracing::error!("cannot serve {key}: {e}");
    }
}

/// Tells each external simulator which of its proposals spawned.
async fn announce(spawner: &Spawner, results: Vec<(String, String, u64)>, time: f64) {
    let bus = &spawner.bus;
    for (simulator, tag, id) in results {
        let result = ProposalResult { tag, id, time };
        if let Err(e) = bus
            .publish_at(&topics::PROPOSAL_RESULTS, &simulator, &result)
            .await
        {
            tracing::warn!("cannot publish a proposal result: {e}");
        }
    }
}
