//! Bus inputs: each key's samples are decoded, checked against the map and
//! handed to the tick thread as commands. Bad payloads are logged with their
//! key, counted and dropped.

use std::collections::HashSet;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::de::DeserializeOwned;
use tokio::sync::oneshot;
use trafficmesh_bus::{Bus, BusError};
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_model::wire::{
    CrosswalkOccupancy, EgoPose, Heartbeat, LightState, RemoveTarget, RestartRequest, SpawnBatch,
};
use trafficmesh_sim::LaneNetwork;

use crate::commands::{Command, CommandSender};

/// Counters the tick thread updates and the status reports.
#[derive(Debug, Default, serde::Serialize, Clone)]
pub struct StepperStatus {
    pub tick: u64,
    pub time: f64,
    pub vehicles: usize,
    pub tick_ms: f64,
    pub tick_rate: f64,
    pub spawned: u64,
    pub despawned: u64,
    pub spawn_rejected_max_vehicles: u64,
    pub spawn_rejected_not_spawnable: u64,
    pub spawn_rejected_invalid: u64,
    pub batches_dropped: u64,
    pub lights_stale: bool,
    pub crosswalks_stale: bool,
}

#[derive(Debug, Default)]
pub struct Shared {
    pub status: Mutex<StepperStatus>,
}

impl Shared {
    pub fn status(&self) -> (f64, serde_json::Value) {
        let s = self.status.lock().expect("status lock").clone();
        (s.time, serde_json::to_value(&s).expect("status serialises"))
    }
}

/// Names the map knows, to refuse payloads about things that do not exist.
struct Names {
    groups: HashSet<String>,
    areas: HashSet<String>,
}

pub async fn start(
    bus: Arc<Bus>,
    net: &LaneNetwork,
    tx: CommandSender,
    _shared: Arc<Shared>,
) -> Result<(), BusError> {
    let names = Arc::new(Names {
        groups: net.light_groups.iter().map(|g| g.name.clone()).collect(),
        areas: net.crosswalks.iter().map(|c| c.name.clone()).collect(),
    });
    let keys = bus.keys().clone();

    let n = names.clone();
    forward(
        &bus,
        &keys.light_states(),
        tx.clone(),
        move |s: LightState| {
            if !n.groups.contains(&s.group) {
                return Err(format!("unknown light group '{}'", s.group));
            }
            if !s.valid_until.is_finite() && s.valid_until != f64::INFINITY {
                return Err("valid_until is not a number".into());
            }
            Ok(Command::Light(s))
        },
    )
    .await?;
    forward(
        &bus,
        &keys.lights_heartbeat(),
        tx.clone(),
        |b: Heartbeat| {
            heartbeat_ok(&b)?;
            Ok(Command::LightsHeartbeat(b))
        },
    )
    .await?;
    let n = names.clone();
    forward(
        &bus,
        &keys.occupancies(),
        tx.clone(),
        move |o: CrosswalkOccupancy| {
            if !n.areas.contains(&o.area) {
                return Err(format!("unknown crosswalk '{}'", o.area));
            }
            Ok(Command::Occupancy(o))
        },
    )
    .await?;
    forward(
        &bus,
        &keys.crosswalks_heartbeat(),
        tx.clone(),
        |b: Heartbeat| {
            heartbeat_ok(&b)?;
            Ok(Command::CrosswalksHeartbeat(b))
        },
    )
    .await?;
    forward(&bus, &keys.ego(), tx.clone(), |e: EgoPose| {
        match e.problem() {
            Some(p) => Err(p),
            None => Ok(Command::Ego(e)),
        }
    })
    .await?;
    let lanes: HashSet<String> = net.lanes.iter().map(|l| l.name.to_lowercase()).collect();
    let lanes = Arc::new(lanes);
    let known = lanes.clone();
    forward(
        &bus,
        &keys.spawn_config(),
        tx.clone(),
        move |c: TrafficSpawnConfig| {
            c.validate(|name| known.contains(&name.to_lowercase()))
                .map_err(|e| e.to_string())?;
            Ok(Command::SpawnConfig(c))
        },
    )
    .await?;

    serve(&bus, &keys.stepper("spawn"), tx.clone(), |b: SpawnBatch| {
        let (send, recv) = oneshot::channel();
        (
            Command::Spawn(b, send),
            answer(async move { recv.await.map(Ok) }),
        )
    })
    .await?;
    serve(
        &bus,
        &keys.stepper("remove"),
        tx.clone(),
        |t: RemoveTarget| {
            let (send, recv) = oneshot::channel();
            (Command::Remove(t, send), answer(recv))
        },
    )
    .await?;
    serve(
        &bus,
        &keys.stepper("restart"),
        tx.clone(),
        |r: RestartRequest| {
            let (send, recv) = oneshot::channel();
            (
                Command::Restart(r.max_vehicles, send),
                answer(async move { recv.await.map(Ok) }),
            )
        },
    )
    .await?;
    Ok(())
}

fn heartbeat_ok(b: &Heartbeat) -> Result<(), String> {
    if b.time.is_finite() && b.valid_until.is_finite() {
        Ok(())
    } else {
        Err("time and valid_until must be finite numbers".into())
    }
}

/// Subscribes to `key`, turns each good sample into a command.
async fn forward<T, F>(
    bus: &Arc<Bus>,
    key: &str,
    tx: CommandSender,
    to_command: F,
) -> Result<(), BusError>
where
    T: DeserializeOwned + Send + 'static,
    F: Fn(T) -> Result<Command, String> + Send + 'static,
{
    let subscriber = bus.subscribe(key).await?;
    let bus = bus.clone();
    tokio::spawn(async move {
        while let Ok(sample) = subscriber.recv_async().await {
            let Some(value) = bus.decode::<T>(&sample) else {
                continue;
            };
            match to_command(value) {
                Ok(c) => {
                    if tx.send(c).is_err() {
                        break;
                    }
                }
                Err(reason) => bus.reject(sample.key_expr().as_str(), &reason),
            }
        }
    });
    Ok(())
}

/// The tick thread's answer to a query, as JSON or an error message.
type Pending =
    std::pin::Pin<Box<dyn std::future::Future<Output = Result<serde_json::Value, String>> + Send>>;

fn answer<A, F>(reply: F) -> Pending
where
    A: serde::Serialize,
    F: std::future::Future<Output = Result<Result<A, String>, oneshot::error::RecvError>>
        + Send
        + 'static,
{
    Box::pin(async move {
        match reply.await {
            Ok(Ok(a)) => Ok(serde_json::to_value(a).expect("wire types serialise")),
            Ok(Err(e)) => Err(e),
            Err(_) => Err("stepper stopped".to_string()),
        }
    })
}

/// A queryable whose requests the tick thread answers.
async fn serve<T, F>(bus: &Arc<Bus>, key: &str, tx: CommandSender, make: F) -> Result<(), BusError>
where
    T: DeserializeOwned + Send + 'static,
    F: Fn(T) -> (Command, Pending) + Send + 'static,
{
    let queryable = bus.queryable(key).await?;
    let bus = bus.clone();
    tokio::spawn(async move {
        while let Ok(query) = queryable.recv_async().await {
            let Some(request) = bus.query_payload::<T>(&query).await else {
                continue;
            };
            let (command, pending) = make(request);
            if tx.send(command).is_err() {
                bus.reply_error(&query, "stepper stopped").await;
                break;
            }
            let bus = bus.clone();
            tokio::spawn(async move {
                match tokio::time::timeout(Duration::from_secs(5), pending).await {
                    Ok(Ok(value)) => bus.reply(&query, &value).await,
                    Ok(Err(reason)) => {
                        bus.reject(query.key_expr().as_str(), &reason);
                        bus.reply_error(&query, &reason).await;
                    }
                    Err(_) => {
                        bus.reply_error(&query, "stepper did not answer in time")
                            .await
                    }
                }
            });
        }
    });
    Ok(())
}

/// Late join: asks the lights and crosswalks services for their current states
/// and the spawner for its config, so a restarted stepper need not wait for changes.
pub async fn fetch_late_states(bus: &Bus, tx: &CommandSender) {
    let keys = bus.keys();
    let wait = Duration::from_millis(500);
    if let Ok(states) = bus.get_each::<LightState>(&keys.light_states(), wait).await {
        for s in states {
            let _ = tx.send(Command::Light(s));
        }
    }
    if let Ok(states) = bus
        .get_each::<CrosswalkOccupancy>(&keys.occupancies(), wait)
        .await
    {
        for o in states {
            let _ = tx.send(Command::Occupancy(o));
        }
    }
    if let Ok(mut configs) = bus
        .get_each::<TrafficSpawnConfig>(&keys.spawn_config(), wait)
        .await
        && let Some(c) = configs.pop()
    {
        let _ = tx.send(Command::SpawnConfig(c));
    }
}
