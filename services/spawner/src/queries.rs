//! The spawner's queryables: the spawn config (get, set, save, load), the
//! branch CSV, RemoveVehiclesInRadius and Restart.

use std::sync::Arc;
use std::time::Duration;

use trafficmesh_bus::BusError;
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_protocol::wire::{RemoveAnswer, RemoveTarget, RestartAnswer, RestartRequest};
use zenoh::bytes::Encoding;
use zenoh::query::Query;

use crate::Spawner;

pub async fn start(spawner: Arc<Spawner>) -> Result<(), BusError> {
    let bus = spawner.bus.clone();
    let keys = bus.keys().clone();
    for command in [
        "config",
        "config/set",
        "config/save",
        "config/load",
        "branch_csv",
        "remove",
        "restart",
    ] {
        let queryable = bus.queryable(&keys.spawner(command)).await?;
        let s = spawner.clone();
        tokio::spawn(async move {
            while let Ok(query) = queryable.recv_async().await {
                let s = s.clone();
                // Forwarded commands wait for the stepper; answer each on its own.
                tokio::spawn(async move { answer(&s, command, &query).await });
            }
        });
    }
    Ok(())
}

async fn answer(s: &Spawner, command: &str, query: &Query) {
    let bus = &s.bus;
    match command {
        "config" => {
            let config = s.state().config.clone();
            bus.reply(query, &config).await;
        }
        "config/set" => {
            let Some(config) = bus.query_payload::<TrafficSpawnConfig>(query).await else {
                return;
            };
            let result = s.state().set_config(config);
            match result {
                Ok(()) => {
                    s.publish_config().await;
                    let config = s.state().config.clone();
                    bus.reply(query, &config).await;
                }
                Err(problems) => {
                    let message = format!("invalid spawn config: {}", problems.join("; "));
                    bus.reject(query.key_expr().as_str(), &message);
                    bus.reply_problems(query, &message, &problems).await;
                }
            }
        }
        "config/save" => {
            let config = s.state().config.clone();
            match trafficmesh_maps::save_spawn_config(&s.spawn_config_path, &config) {
                Ok(()) => {
                    tracing::info!("saved spawn config to {}", s.spawn_config_path.display());
                    bus.reply(query, &serde_json::json!({ "saved": s.spawn_config_path }))
                        .await
                }
                Err(e) => bus.reply_error(query, &e.to_string()).await,
            }
        }
        "config/load" => {
            let loaded = trafficmesh_maps::load_spawn_config(&s.spawn_config_path)
                .map_err(|e| vec![e.to_string()])
                .and_then(|c| s.state().set_config(c));
            match loaded {
                Ok(()) => {
                    tracing::info!("loaded spawn config {}", s.spawn_config_path.display());
                    s.publish_config().await;
                    let config = s.state().config.clone();
                    bus.reply(query, &config).await;
                }
                Err(problems) => {
                    let message = format!("cannot load the spawn config: {}", problems.join("; "));
                    bus.reply_problems(query, &message, &problems).await;
                }
            }
        }
        "branch_csv" => {
            let csv = s.state().branch_csv();
            bus.reply_text(query, csv, Encoding::TEXT_CSV).await;
        }
        "remove" => {
            let Some(target) = bus.query_payload::<RemoveTarget>(query).await else {
                return;
            };
            let key = bus.keys().stepper("remove");
            match bus
                .get::<_, RemoveAnswer>(&key, Some(&target), Duration::from_secs(3))
                .await
            {
                Ok(a) => bus.reply(query, &a).await,
                Err(e) => bus.reply_error(query, &e.to_string()).await,
            }
        }
        "restart" => {
            let Some(request) = bus.query_payload::<RestartRequest>(query).await else {
                return;
            };
            s.state().restart(request.max_vehicles, request.seed);
            let key = bus.keys().stepper("restart");
            match bus
                .get::<_, RestartAnswer>(&key, Some(&request), Duration::from_secs(3))
                .await
            {
                Ok(a) => {
                    tracing::info!("restarted with max {} vehicles", request.max_vehicles);
                    bus.reply(query, &a).await
                }
                Err(e) => bus.reply_error(query, &e.to_string()).await,
            }
        }
        _ => unreachable!("every declared command is answered"),
    }
}
