//! Bus inputs: each key's samples are decoded and handed to the tick thread,
//! which checks them against the world (unknown group, area, lane, bad
//! numbers) and counts the ones it refuses as bad payloads of their key.

use std::sync::{Arc, Mutex};
use std::time::Duration;
use trafficmesh_protocol::topics;

use serde::de::DeserializeOwned;
use tokio::sync::oneshot;
use trafficmesh_bus::{Bus, BusError};
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_protocol::wire::{CrosswalkOccupancy, LightState};

use crate::commands::{Command, Input, InputSender, Request};

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
    /// Vehicles that entered the road (`spawned`, in SUMO's word).
    pub inserted: u64,
    /// Vehicles that reached the end of their route or of the road.
    pub arrived: u64,
    /// The longest standstill of any vehicle so far, seconds.
    pub max_wait_s: f64,
    /// Vehicles standing for 60 s or more, not at a red light (once a second).
    pub stuck_vehicles: usize,
    /// The same, counted at the start of each simulated minute and averaged.
    pub stuck_vehicles_mean: f64,
    /// Jammed vehicles moved on or taken off by the jam timeout or to
    /// break a gridlock.
    pub jam_resolutions: u64,
    /// Of those, the ones taken off the road.
    pub jam_removals: u64,
    /// Of those, the ones moved to break a gridlock before the timeout.
    pub gridlocks_broken: u64,
    /// Gridlocks let squeeze past bodies beside their way first.
    pub gridlocks_squeezed: u64,
    /// Front bumpers that went 0.5 m past a stop line more than 0.5 s into red.
    pub red_light_crossings: u64,
    pub batches_dropped: u64,
    pub lights_stale: bool,
    pub crosswalks_stale: bool,
    /// The intersection service did not answer the last round: no way
    /// through a reservation intersection is granted.
    pub intersections_unanswered: bool,
    /// The run's trajectory hash so far (`sim` prints the same for the same run).
    #[serde(serialize_with = "hex")]
    pub trajectory_hash: u64,
    /// Whether each tick waits for the lockstep members, and who answered last.
    pub lockstep: bool,
    pub lockstep_members: Vec<String>,
    /// The NPCVehicleConfig in force (accelerations, speed limit, driver model).
    pub vehicle_config: trafficmesh_model::NpcVehicleConfig,
    /// The snapshot tick this stepper resumed from, and the ticks the
    /// cluster had seen past it (lost with the previous stepper), if it did.
    pub resumed_from_tick: Option<u64>,
    pub ticks_lost: Option<u64>,
}

/// A trajectory hash as `sim --json` prints it (16 hex digits).
fn hex<S: serde::Serializer>(hash: &u64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{hash:016x}"))
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

pub async fn start(bus: Arc<Bus>, tx: InputSender) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    forward(
        &bus,
        &keys.key_all(&topics::LIGHT_STATE),
        &tx,
        Command::Light,
    )
    .await?;
    forward(
        &bus,
        &keys.key(&topics::LIGHTS_HEARTBEAT),
        &tx,
        Command::LightsHeartbeat,
    )
    .await?;
    forward(
        &bus,
        &keys.key_all(&topics::OCCUPANCY),
        &tx,
        Command::Occupancy,
    )
    .await?;
    forward(
        &bus,
        &keys.key(&topics::CROSSWALKS_HEARTBEAT),
        &tx,
        Command::CrosswalksHeartbeat,
    )
    .await?;
    forward(&bus, &keys.key(&topics::EGO), &tx, Command::Ego).await?;
    forward(
        &bus,
        &keys.key(&topics::SPAWN_CONFIG),
        &tx,
        Command::SpawnConfig,
    )
    .await?;
    serve(
        &bus,
        &keys.key(&trafficmesh_protocol::topics::STEPPER_SPAWN),
        &tx,
        Request::Spawn,
    )
    .await?;
    serve(
        &bus,
        &keys.key(&trafficmesh_protocol::topics::STEPPER_REMOVE),
        &tx,
        Request::Remove,
    )
    .await?;
    serve(
        &bus,
        &keys.key(&trafficmesh_protocol::topics::STEPPER_RESTART),
        &tx,
        Request::Restart,
    )
    .await?;
    Ok(())
}

/// Subscribes to `key` and hands each decodable sample to the tick thread.
async fn forward<T: DeserializeOwned + Send + 'static>(
    bus: &Arc<Bus>,
    key: &str,
    tx: &InputSender,
    command: fn(T) -> Command,
) -> Result<(), BusError> {
    let subscriber = bus.subscribe(key).await?;
    let (bus, tx) = (bus.clone(), tx.clone());
    tokio::spawn(async move {
        while let Ok(sample) = subscriber.recv_async().await {
            let Some(value) = bus.decode::<T>(&sample) else {
                continue;
            };
            let input = Input {
                key: sample.key_expr().as_str().to_string(),
                command: command(value),
            };
            if tx.send(input).is_err() {
                break;
            }
        }
    });
    Ok(())
}

/// A queryable the tick thread answers between ticks.
async fn serve<T: DeserializeOwned + Send + 'static>(
    bus: &Arc<Bus>,
    key: &str,
    tx: &InputSender,
    request: fn(T) -> Request,
) -> Result<(), BusError> {
    let queryable = bus.queryable(key).await?;
    let (bus, tx) = (bus.clone(), tx.clone());
    tokio::spawn(async move {
        while let Ok(query) = queryable.recv_async().await {
            let Some(payload) = bus.query_payload::<T>(&query).await else {
                continue;
            };
            let (answer, answered) = oneshot::channel();
            let input = Input {
                key: query.key_expr().as_str().to_string(),
                command: Command::Query(request(payload), answer),
            };
            if tx.send(input).is_err() {
                bus.reply_error(&query, "stepper stopped").await;
                break;
            }
            let bus = bus.clone();
            tokio::spawn(async move {
                match tokio::time::timeout(Duration::from_secs(5), answered).await {
                    Ok(Ok(Ok(value))) => bus.reply(&query, &value).await,
                    Ok(Ok(Err(reason))) => bus.reply_error(&query, &reason).await,
                    Ok(Err(_)) => bus.reply_error(&query, "stepper stopped").await,
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
/// While light or crosswalk states are stale (their service cut off, or its
/// changes lost in a partition), asks for them again once a second: what a
/// partition lost comes back as soon as the link does, not at the next change.
pub fn catch_up_while_stale(bus: Arc<Bus>, tx: InputSender, shared: Arc<Shared>) {
    tokio::spawn(async move {
        let mut every = tokio::time::interval(Duration::from_secs(1));
        loop {
            every.tick().await;
            let stale = {
                let s = shared.status.lock().expect("status lock");
                s.lights_stale || s.crosswalks_stale
            };
            if stale {
                fetch_late_states(&bus, &tx).await;
            }
        }
    });
}

pub async fn fetch_late_states(bus: &Bus, tx: &InputSender) {
    let keys = bus.keys();
    let wait = trafficmesh_service::LATE_STATES_WAIT;
    let send = |key: String, command| {
        let _ = tx.send(Input { key, command });
    };
    if let Ok(states) = bus
        .get_each::<LightState>(&keys.key_all(&topics::LIGHT_STATE), wait)
        .await
    {
        for s in states {
            send(
                keys.key_at(&topics::LIGHT_STATE, &s.group),
                Command::Light(s),
            );
        }
    }
    if let Ok(states) = bus
        .get_each::<CrosswalkOccupancy>(&keys.key_all(&topics::OCCUPANCY), wait)
        .await
    {
        for o in states {
            send(
                keys.key_at(&topics::OCCUPANCY, &o.area),
                Command::Occupancy(o),
            );
        }
    }
    if let Ok(mut configs) = bus
        .get_each::<TrafficSpawnConfig>(&keys.key(&topics::SPAWN_CONFIG), wait)
        .await
        && let Some(c) = configs.pop()
    {
        send(keys.key(&topics::SPAWN_CONFIG), Command::SpawnConfig(c));
    }
}
