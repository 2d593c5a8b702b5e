//! The spawn decisions, each tick: plan, have the stepper admit the orders,
//! book the verdicts. Free-running, on the stepper's clock with a spawn query
//! per tick; in lockstep, on the stepper's questions, which carry the
//! verdicts on the orders of the tick before.

use std::sync::atomic::Ordering;
use std::time::Duration;

use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{Clock, LockstepTick, ProposalResult, TickReport};

use trafficmesh_bus::Bus;

use crate::Spawner;

/// One clock tick: plan, and ask the stepper to spawn the winners.
pub async fn on_clock(spawner: &Spawner, bus: &Bus, c: Clock) {
    let (requests, batch) = {
        let mut s = spawner.state();
        s.time = c.time;
        s.plan()
    };
    if requests.is_empty() {
        return;
    }
    let answer = bus
        .call(&topics::STEPPER_SPAWN, &batch, Duration::from_secs(2))
        .await;
    let answer = match answer {
        Ok(a) if a.verdicts.len() == requests.len() => a,
        Ok(_) => {
            tracing::warn!("stepper answered a different number of spawn verdicts");
            return;
        }
        Err(e) => {
            if !spawner.warned.swap(true, Ordering::Relaxed) {
                tracing::warn!("spawn request failed: {e}");
            }
            return;
        }
    };
    spawner.warned.store(false, Ordering::Relaxed);
    let results = spawner.state().resolve(&requests, &answer.verdicts, c.time);
    announce(bus, results, c.time).await;
}

/// In lockstep: each question books the verdicts on the last orders, then
/// plans this tick's, as a world that runs its own simulators does in its
/// spawn phase.
pub async fn on_tick(spawner: &Spawner, bus: &Bus, tick: LockstepTick) -> TickReport {
    let (results, report) = {
        let mut s = spawner.state();
        let mut pending = spawner.pending.lock().expect("pending orders lock");
        let (requests, planned_at) = std::mem::take(&mut *pending);
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
        *pending = (requests, tick.time);
        let config = s.take_config_change();
        (results, TickReport::Spawner { orders, config })
    };
    announce(bus, results, tick.time).await;
    report
}

/// Tells each external simulator which of its proposals spawned.
async fn announce(bus: &Bus, results: Vec<(String, String, u64)>, time: f64) {
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
