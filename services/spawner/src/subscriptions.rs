//! The ego, the stepper's branch decisions and external simulators' proposals.

use std::sync::Arc;

use trafficmesh_bus::{Bus, BusError};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::Event;

use crate::Spawner;

pub async fn start(spawner: Arc<Spawner>, bus: &Arc<Bus>) -> Result<(), BusError> {
    let ego = bus.subscribe_to(&topics::EGO).await?;
    let (s, b) = (spawner.clone(), bus.clone());
    tokio::spawn(async move {
        while let Some((_, pose)) = ego.next(&b).await {
            if let Some(problem) = pose.problem() {
                b.reject(&b.keys().key(&topics::EGO), &problem);
                continue;
            }
            s.state().ego = Some(trafficmesh_service::ego_of(&pose));
        }
    });

    let events = bus.subscribe_to(&topics::EVENTS).await?;
    let (s, b) = (spawner.clone(), bus.clone());
    tokio::spawn(async move {
        while let Some((_, batch)) = events.next(&b).await {
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
                    b.reject(&b.keys().key(&topics::EVENTS), &problem);
                }
            }
        }
    });

    let proposals = bus.subscribe_to(&topics::PROPOSALS).await?;
    let (s, b) = (spawner, bus.clone());
    tokio::spawn(async move {
        while let Some((simulator, batch)) = proposals.next(&b).await {
            if let Err(problem) = s.state().set_proposals(&simulator, batch) {
                b.reject(&b.keys().key_at(&topics::PROPOSALS, &simulator), &problem);
            }
        }
    });
    Ok(())
}
