//! The ego, the stepper's branch decisions and external simulators' proposals.

use std::sync::Arc;

use trafficmesh_bus::BusError;
use trafficmesh_protocol::Keys;
use trafficmesh_protocol::wire::{EgoPose, Event, EventBatch, ProposalBatch};

use crate::Spawner;

pub async fn start(spawner: Arc<Spawner>) -> Result<(), BusError> {
    let bus = spawner.bus().clone();
    let keys = bus.keys().clone();

    let ego = bus.subscribe(&keys.ego()).await?;
    let s = spawner.clone();
    tokio::spawn(async move {
        while let Ok(sample) = ego.recv_async().await {
            let Some(pose) = s.bus().decode::<EgoPose>(&sample) else {
                continue;
            };
            if let Some(problem) = pose.problem() {
                s.bus().reject(sample.key_expr().as_str(), &problem);
                continue;
            }
            s.state().ego = Some(trafficmesh_service::ego_of(&pose));
        }
    });

    let events = bus.subscribe(&keys.events()).await?;
    let s = spawner.clone();
    tokio::spawn(async move {
        while let Ok(sample) = events.recv_async().await {
            let Some(batch) = s.bus().decode::<EventBatch>(&sample) else {
                continue;
            };
            let mut state = s.state();
            for e in batch.events {
                if let Event::BranchDecision {
                    from_lane,
                    to_lane,
                    mode,
                    configured_weight,
                    probability,
                    ..
                } = e
                    && let Err(problem) = state.record_branch(
                        from_lane,
                        to_lane,
                        &mode,
                        configured_weight,
                        probability,
                    )
                {
                    s.bus().reject(sample.key_expr().as_str(), &problem);
                }
            }
        }
    });

    let proposals = bus.subscribe(&keys.all_proposals()).await?;
    let s = spawner.clone();
    tokio::spawn(async move {
        while let Ok(sample) = proposals.recv_async().await {
            let key = sample.key_expr().as_str();
            let Some(batch) = s.bus().decode::<ProposalBatch>(&sample) else {
                continue;
            };
            let Some(name) = Keys::simulator_of(key) else {
                continue;
            };
            if let Err(problem) = s.state().set_proposals(name, batch) {
                s.bus().reject(key, &problem);
            }
        }
    });
    Ok(())
}
