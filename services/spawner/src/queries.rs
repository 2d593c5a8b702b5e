//! The spawner's queryables: the spawn config (get, set, save, load), the
//! branch CSV, RemoveVehiclesInRadius and Restart.

use std::sync::Arc;
use std::time::Duration;

use trafficmesh_bus::{Bus, BusError};
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_protocol::wire::{RemoveTarget, RestartRequest};
use trafficmesh_protocol::{Keys, topics};
use zenoh::bytes::Encoding;
use zenoh::query::Query;

use crate::Spawner;

/// The queries the spawner answers, each on its declared key.
#[derive(Clone, Copy)]
enum Command {
    Config,
    SetConfig,
    SaveConfig,
    LoadConfig,
    BranchCsv,
    Remove,
    Restart,
}

impl Command {
    const ALL: [Command; 7] = [
        Command::Config,
        Command::SetConfig,
        Command::SaveConfig,
        Command::LoadConfig,
        Command::BranchCsv,
        Command::Remove,
        Command::Restart,
    ];

    fn key(self, keys: &Keys) -> String {
        match self {
            Command::Config => keys.key(&topics::SPAWN_CONFIG),
            Command::SetConfig => keys.key(&topics::SPAWN_CONFIG_SET),
            Command::SaveConfig => keys.key(&topics::SPAWN_CONFIG_SAVE),
            Command::LoadConfig => keys.key(&topics::SPAWN_CONFIG_LOAD),
            Command::BranchCsv => keys.key(&topics::BRANCH_CSV),
            Command::Remove => keys.key(&topics::SPAWNER_REMOVE),
            Command::Restart => keys.key(&topics::SPAWNER_RESTART),
        }
    }
}

pub async fn start(spawner: Arc<Spawner>, bus: &Arc<Bus>) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    for command in Command::ALL {
        let queryable = bus.queryable(&command.key(&keys)).await?;
        let (s, b) = (spawner.clone(), bus.clone());
        tokio::spawn(async move {
            while let Ok(query) = queryable.recv_async().await {
                let (s, b) = (s.clone(), b.clone());
                // Forwarded commands wait for the stepper; answer each on its own.
                tokio::spawn(async move { answer(&s, &b, command, &query).await });
            }
        });
    }
    Ok(())
}

async fn answer(s: &Spawner, bus: &Bus, command: Command, query: &Query) {
    match command {
        Command::Config => {
            let config = s.state().config.clone();
            bus.reply(query, &config).await;
        }
        Command::SetConfig => {
            let Some(config) = bus.query_payload::<TrafficSpawnConfig>(query).await else {
                return;
            };
            let result = s.state().set_config(config);
            match result {
                Ok(()) => {
                    s.publish_config(bus).await;
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
        Command::SaveConfig => {
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
        Command::LoadConfig => {
            let loaded = trafficmesh_maps::load_spawn_config(&s.spawn_config_path)
                .map_err(|e| vec![e.to_string()])
                .and_then(|c| s.state().set_config(c));
            match loaded {
                Ok(()) => {
                    tracing::info!("loaded spawn config {}", s.spawn_config_path.display());
                    s.publish_config(bus).await;
                    let config = s.state().config.clone();
                    bus.reply(query, &config).await;
                }
                Err(problems) => {
                    let message = format!("cannot load the spawn config: {}", problems.join("; "));
                    bus.reply_problems(query, &message, &problems).await;
                }
            }
        }
        Command::BranchCsv => {
            let csv = s.state().branch_csv();
            bus.reply_text(query, csv, Encoding::TEXT_CSV).await;
        }
        Command::Remove => {
            let Some(target) = bus.query_payload::<RemoveTarget>(query).await else {
                return;
            };
            match bus
                .call(&topics::STEPPER_REMOVE, &target, Duration::from_secs(3))
                .await
            {
                Ok(a) => bus.reply(query, &a).await,
                Err(e) => bus.reply_error(query, &e.to_string()).await,
            }
        }
        Command::Restart => {
            let Some(request) = bus.query_payload::<RestartRequest>(query).await else {
                return;
            };
            s.state().restart(request.max_vehicles, request.seed);
            match bus
                .call(&topics::STEPPER_RESTART, &request, Duration::from_secs(3))
                .await
            {
                Ok(a) => {
                    tracing::info!("restarted with max {} vehicles", request.max_vehicles);
                    bus.reply(query, &a).await
                }
                Err(e) => bus.reply_error(query, &e.to_string()).await,
            }
        }
    }
}
