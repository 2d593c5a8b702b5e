//! What the bus asks of the world, applied by the tick thread between ticks.

use std::collections::BTreeSet;
use std::sync::mpsc::Sender;

use tokio::sync::oneshot;
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_protocol::wire::{
    CrosswalkOccupancy, EgoPose, Heartbeat, LightState, RemoveAnswer, RemoveTarget, RestartAnswer,
    RestartRequest, SpawnAnswer, SpawnBatch, SpawnOrder, SpawnVerdict,
};
use trafficmesh_sim::World;
use trafficmesh_sim::world::{QueuedSpawn, SpawnRejection};

pub enum Command {
    /// A query; the answer (JSON) or the reason it was refused goes back.
    Query(Request, oneshot::Sender<Result<serde_json::Value, String>>),
    Ego(EgoPose),
    Light(LightState),
    LightsHeartbeat(Heartbeat),
    Occupancy(CrosswalkOccupancy),
    CrosswalksHeartbeat(Heartbeat),
    SpawnConfig(TrafficSpawnConfig),
    Stop,
}

pub enum Request {
    Spawn(SpawnBatch),
    Remove(RemoveTarget),
    Restart(RestartRequest),
}

/// A command and the key it came from (for the bad-payload count).
pub struct Input {
    pub key: String,
    pub command: Command,
}

pub type InputSender = Sender<Input>;

/// State the tick thread keeps about its inputs between ticks.
#[derive(Debug)]
pub struct InputState {
    /// Simulation time until which the crosswalk states are vouched for.
    pub crosswalks_valid_until: f64,
    /// Spawn batches whose orders wait in the world's queue for the next tick.
    pending_spawns: Vec<PendingSpawn>,
    /// Members whose states come with their lockstep answers: their ordinary
    /// publications are ignored, which could arrive late and out of turn.
    pub in_step: InStep,
}

/// Which of the stepper's sources keep in step (have answered a lockstep round).
#[derive(Debug, Default, Clone, Copy)]
pub struct InStep {
    pub lights: bool,
    pub crosswalks: bool,
    pub spawner: bool,
}

impl Default for InputState {
    fn default() -> Self {
        // Nothing heard yet: fail-safe, every crosswalk counts as blocked.
        InputState {
            crosswalks_valid_until: f64::NEG_INFINITY,
            pending_spawns: Vec::new(),
            in_step: InStep::default(),
        }
    }
}

/// A spawn batch in the world's queue: each order's verdict, `None` while it
/// waits for the tick's spawn phase, and who gets the verdicts.
#[derive(Debug)]
struct PendingSpawn {
    verdicts: Vec<Option<SpawnVerdict>>,
    reply: SpawnReply,
}

#[derive(Debug)]
enum SpawnReply {
    Query(oneshot::Sender<Result<serde_json::Value, String>>),
    /// The spawner's lockstep orders: the verdicts go with the next round.
    Lockstep,
}

impl InputState {
    /// After a tick: fills in the verdicts of the queued orders, answers the
    /// spawn queries and returns the verdicts on the lockstep orders.
    pub fn finish_spawns(&mut self, world: &mut World) -> Vec<SpawnVerdict> {
        let mut results = world.take_spawn_results().into_iter();
        let mut for_lockstep = Vec::new();
        for pending in self.pending_spawns.drain(..) {
            let verdicts: Vec<SpawnVerdict> = pending
                .verdicts
                .into_iter()
                .map(|v| {
                    v.unwrap_or_else(|| match results.next() {
                        Some(result) => verdict(result),
                        None => SpawnVerdict::Invalid {
                            reason: "not admitted".into(),
                        },
                    })
                })
                .collect();
            match pending.reply {
                SpawnReply::Query(answer) => {
                    let _ = answer.send(Ok(json(SpawnAnswer { verdicts })));
                }
                SpawnReply::Lockstep => for_lockstep.extend(verdicts),
            }
        }
        for_lockstep
    }

    /// Queues the spawner's lockstep orders for this tick.
    pub fn queue_lockstep_spawns(&mut self, world: &mut World, batch: SpawnBatch) {
        let verdicts = queue_spawns(world, batch);
        self.pending_spawns.push(PendingSpawn {
            verdicts,
            reply: SpawnReply::Lockstep,
        });
    }
}

/// Applies one command; returns false for Stop. An error names what is wrong
/// with the input (unknown group, area or lane, bad numbers); the world is
/// unchanged then.
pub fn apply(world: &mut World, inputs: &mut InputState, command: Command) -> Result<bool, String> {
    match command {
        Command::Stop => return Ok(false),
        Command::Query(request, answer) => {
            let result = match request {
                Request::Spawn(batch) => {
                    // Answered after the tick that admits the orders.
                    let verdicts = queue_spawns(world, batch);
                    inputs.pending_spawns.push(PendingSpawn {
                        verdicts,
                        reply: SpawnReply::Query(answer),
                    });
                    return Ok(true);
                }
                Request::Remove(target) => remove(world, target).map(json),
                Request::Restart(r) => {
                    let disposed = world.vehicles().len();
                    world.restart(r.max_vehicles, r.seed);
                    Ok(json(RestartAnswer {
                        disposed,
                        max_vehicles: r.max_vehicles,
                        after_tick: world.ticks(),
                    }))
                }
            };
            let refused = result.as_ref().err().cloned();
            let _ = answer.send(result);
            if let Some(reason) = refused {
                return Err(reason);
            }
        }
        Command::Ego(pose) => {
            if let Some(problem) = pose.problem() {
                return Err(problem);
            }
            world.set_ego(Some(trafficmesh_service::ego_of(&pose)));
        }
        // A member in step sends its states with its lockstep answers.
        Command::Light(_) | Command::LightsHeartbeat(_) if inputs.in_step.lights => {}
        Command::Occupancy(_) | Command::CrosswalksHeartbeat(_) if inputs.in_step.crosswalks => {}
        Command::SpawnConfig(_) if inputs.in_step.spawner => {}
        Command::Light(state) => {
            world
                .set_remote_light(
                    &state.group,
                    state.color,
                    state.valid_until,
                    state.next_change,
                )
                .map_err(|e| e.to_string())?;
        }
        Command::LightsHeartbeat(beat) => world.extend_remote_lights(beat.valid_until),
        Command::Occupancy(o) => {
            let roots: BTreeSet<String> = o.occupants.into_iter().collect();
            world
                .set_crosswalk_occupants(&o.area, roots)
                .map_err(|e| e.to_string())?;
            inputs.crosswalks_valid_until = inputs.crosswalks_valid_until.max(o.valid_until);
        }
        Command::CrosswalksHeartbeat(beat) => {
            inputs.crosswalks_valid_until = beat.valid_until;
        }
        Command::SpawnConfig(config) => {
            world.set_spawn_config(config).map_err(|e| e.to_string())?;
        }
    }
    Ok(true)
}

fn json<T: serde::Serialize>(value: T) -> serde_json::Value {
    serde_json::to_value(value).expect("wire types serialise")
}

/// Checks each order and queues the valid ones for the next tick's spawn
/// phase (the final IsSpawnable and max-count check, in order); an order
/// with an unknown lane or kind gets its verdict at once.
fn queue_spawns(world: &mut World, batch: SpawnBatch) -> Vec<Option<SpawnVerdict>> {
    batch
        .orders
        .into_iter()
        .map(
            |order| match resolve_order(world, order, batch.max_vehicles) {
                Ok(queued) => {
                    world.queue_spawn(queued);
                    None
                }
                Err(reason) => Some(SpawnVerdict::Invalid { reason }),
            },
        )
        .collect()
}

fn resolve_order(
    world: &mut World,
    order: SpawnOrder,
    max_vehicles: usize,
) -> Result<QueuedSpawn, String> {
    let lanes = world.network().lanes.len();
    let known_lane = |l: u32| {
        ((l as usize) < lanes)
            .then_some(l)
            .ok_or_else(|| format!("unknown lane {l} (the map has {lanes})"))
    };
    let lane = known_lane(order.lane)?;
    let known = match order.kind_def {
        Some(def) if def.name == order.kind => Some(world.add_vehicle_kind(def)),
        _ => world.kind_index(&order.kind),
    };
    let kind = known.ok_or_else(|| format!("unknown vehicle kind '{}'", order.kind))?;
    let route = match order.route {
        None => None,
        Some(route) => {
            let route = route
                .into_iter()
                .map(known_lane)
                .collect::<Result<Vec<_>, _>>()?;
            Some(trafficmesh_sim::spawn::Route {
                lanes: route.into(),
                leave_at_end: order.leave_at_route_end,
                depart: order.depart,
            })
        }
    };
    Ok(QueuedSpawn {
        kind,
        lane,
        route,
        max_vehicles,
    })
}

fn verdict(result: Result<u64, SpawnRejection>) -> SpawnVerdict {
    match result {
        Ok(id) => SpawnVerdict::Spawned { id },
        Err(SpawnRejection::MaxVehicles) => SpawnVerdict::MaxVehicles,
        // An order the restart voided: tried again as any other.
        Err(SpawnRejection::NotSpawnable | SpawnRejection::Restarted) => SpawnVerdict::NotSpawnable,
        Err(e) => SpawnVerdict::Invalid {
            reason: e.to_string(),
        },
    }
}

fn remove(world: &mut World, target: RemoveTarget) -> Result<RemoveAnswer, String> {
    if let Some(problem) = target.problem() {
        return Err(problem);
    }
    let removed = match target {
        RemoveTarget::Point { x, y, z, radius } => {
            world.remove_vehicles_in_radius(glam::DVec3::new(x, y, z), radius)
        }
        RemoveTarget::Ego { radius } => world
            .remove_vehicles_around_ego(radius)
            .ok_or("no ego pose has been published")?,
        RemoveTarget::Vehicle { id } => world.remove_vehicle(id),
    };
    Ok(RemoveAnswer { removed })
}
