//! Per-tick publication: the tick thread hands over plain data; this task
//! encodes and publishes it, so neither encoding nor a slow subscriber
//! holds up the next tick (the hand-over queue is short and drops when full).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use trafficmesh_protocol::topics;

use tokio::sync::mpsc;
use trafficmesh_bus::{Bus, BusError, Lane};
use trafficmesh_model::catalog::builtin_names;
use trafficmesh_protocol::wire::vehicle_codec;
use trafficmesh_protocol::wire::{Clock, Event, EventBatch, VehicleBatch, VehicleState};
use trafficmesh_sim::{SimEvent, World};

pub struct TickOutput {
    pub clock: Clock,
    pub vehicles: Vec<VehicleState>,
    pub events: Vec<Event>,
}

pub struct Outputs {
    queue: mpsc::Sender<TickOutput>,
    pub dropped: Arc<AtomicU64>,
    /// Catalogue index of each of the world's vehicle kinds.
    kind_codes: Vec<u16>,
}

impl Outputs {
    /// Hands a tick's output to the publisher; drops it if two are still waiting.
    pub fn offer(&self, output: TickOutput) {
        if self.queue.try_send(output).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The vehicles as they go on the wire.
    pub fn vehicle_states(&mut self, world: &World) -> Vec<VehicleState> {
        let net = world.network();
        while self.kind_codes.len() < net.kinds.len() {
            let name = &net.kinds[self.kind_codes.len()].name;
            let code = builtin_names()
                .position(|n| n == name)
                .unwrap_or(u16::MAX as usize);
            self.kind_codes.push(code as u16);
        }
        world
            .vehicles()
            .iter()
            .map(|v| VehicleState {
                id: v.id,
                kind: self.kind_codes[v.kind],
                lane: v.path[0],
                s: v.s as f32,
                x: v.pose.x as f32,
                y: v.pose.y as f32,
                z: v.pose.z as f32,
                yaw: v.pose.yaw as f32,
                speed: v.speed as f32,
                accel: v.acceleration as f32,
                length: v.length as f32,
                width: v.width as f32,
                mode: v.speed_mode,
                yield_phase: v.yield_phase,
                signal: v.turn_signal,
                zebra_blocked: v.zebra.is_blocked,
                check_distance: (v.path_length - v.s).max(0.0) as f32,
                front_offset: v.front_offset as f32,
            })
            .collect()
    }
}

/// The wire form of the world's events.
pub fn wire_events(world: &World, events: Vec<SimEvent>) -> Vec<Event> {
    let net = world.network();
    let lane = |id: u32| net.lane(id).name.clone();
    // The AWSIM reference's vehicle names in its log lines: `<prefab>(Clone)_<id>`.
    let vehicle = |id: u64| match world.vehicle(id) {
        Some(v) => format!("{}(Clone)_{id}", net.kinds[v.kind].name),
        None => format!("vehicle_{id}"),
    };
    events
        .into_iter()
        .map(|e| match e {
            SimEvent::Spawned {
                id, kind, lane: l, ..
            } => Event::Spawned {
                id,
                kind,
                lane: lane(l),
            },
            SimEvent::Despawned(t) => Event::Despawned {
                id: t.id,
                kind: t.kind,
                reason: t.reason.as_str().into(),
                spawn_time: t.spawn_time,
                distance: t.distance,
                stops: t.stops,
                time_stopped: t.time_stopped,
            },
            SimEvent::ZebraStop { id, area, distance } => Event::ZebraStop {
                id,
                vehicle: vehicle(id),
                area: net.crosswalks[area].name.clone(),
                distance,
            },
            SimEvent::ZebraClear { id, area } => Event::ZebraClear {
                id,
                vehicle: vehicle(id),
                area: net.crosswalks[area].name.clone(),
            },
            SimEvent::BranchDecision { id, choice } => Event::BranchDecision {
                id,
                from: lane(choice.from),
                to: lane(choice.to),
                from_lane: choice.from,
                to_lane: choice.to,
                mode: choice.mode.as_str().into(),
                configured_weight: choice.configured_weight,
                probability: choice.probability,
            },
        })
        .collect()
}

pub async fn start(bus: Arc<Bus>) -> Result<Outputs, BusError> {
    let keys = bus.keys();
    let clock = bus
        .publisher(keys.key(&topics::CLOCK), Lane::Telemetry)
        .await?;
    let vehicles = bus
        .binary_publisher(
            keys.key(&topics::VEHICLES),
            Lane::Telemetry,
            vehicle_codec::SCHEMA,
        )
        .await?;
    // Events too are dropped for a subscriber that cannot keep up: a stalled
    // subscriber must never stall the stepper's publications (the clock
    // included, which the lights and crosswalks heartbeats follow).
    let events = bus
        .publisher(keys.key(&topics::EVENTS), Lane::Telemetry)
        .await?;
    let (queue, mut rx) = mpsc::channel::<TickOutput>(2);
    tokio::spawn(async move {
        while let Some(out) = rx.recv().await {
            if let Err(e) = clock.put(&out.clock).await {
                tracing::warn!("cannot publish the clock: {e}");
            }
            let batch = VehicleBatch {
                tick: out.clock.tick,
                time: out.clock.time,
                sent_unix_us: trafficmesh_bus::runtime::unix_micros(),
                vehicles: out.vehicles,
            };
            if let Err(e) = vehicles.put_bytes(batch.encode()).await {
                tracing::warn!("cannot publish vehicles: {e}");
            }
            if !out.events.is_empty() {
                let batch = EventBatch {
                    tick: out.clock.tick,
                    time: out.clock.time,
                    events: out.events,
                };
                if let Err(e) = events.put(&batch).await {
                    tracing::warn!("cannot publish events: {e}");
                }
            }
        }
    });
    Ok(Outputs {
        queue,
        dropped: Arc::new(AtomicU64::new(0)),
        kind_codes: Vec::new(),
    })
}
