//! On each clock tick of the stepper: plan, ask the stepper, book the verdicts.

use std::sync::Arc;
use std::time::Duration;

use trafficmesh_model::wire::{Clock, ProposalResult, SpawnAnswer};

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
            .get::<_, SpawnAnswer>(&keys.stepper("spawn"), Some(&batch), Duration::from_secs(2))
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
        for (simulator, tag, id) in results {
            let result = ProposalResult {
                tag,
                id,
                time: c.time,
            };
            if let Err(e) = bus.put(&keys.proposal_results(&simulator), &result).await {
                tracing::warn!("cannot publish a proposal result: {e}");
            }
        }
    }
}
