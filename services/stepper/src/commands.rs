//! What the bus asks of the world, applied by the tick thread between ticks.

use std::collections::BTreeSet;
use std::sync::mpsc::Sender;

use tokio::sync::oneshot;
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_model::wire::{
    CrosswalkOccupancy, EgoPose, Heartbeat, LightState, RemoveAnswer, RemoveTarget, RestartAnswer,
    RestartRequest, SpawnAnswer, SpawnBatch, SpawnVerdict,
};
use trafficmesh_sim::world::SpawnRejection;
use trafficmesh_sim::{Ego, World};

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
}

impl Default for InputState {
    fn default() -> Self {
        // Nothing heard yet: fail-safe, every crosswalk counts as blocked.
        InputState {
            crosswalks_valid_until: f64::NEG_INFINITY,
        }
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
                Request::Spawn(batch) => Ok(json(spawn(world, batch))),
                Request::Remove(target) => remove(world, target).map(json),
                Request::Restart(r) => {
                    let disposed = world.vehicles().len();
                    world.restart(r.max_vehicles, r.seed);
                    Ok(json(RestartAnswer {
                        disposed,
                        max_vehicles: r.max_vehicles,
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
            world.set_ego(Some(Ego::from(&pose)));
        }
        Command::Light(state) => {
            world
                .set_remote_light(&state.group, state.color, state.valid_until)
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

/// The final IsSpawnable and max-count check of each order, in order.
fn spawn(world: &mut World, batch: SpawnBatch) -> SpawnAnswer {
    let mut spawned_here = Vec::new();
    let verdicts = batch
        .orders
        .into_iter()
        .map(|order| {
            let Some(lane) = world.network().lane_id(&order.lane) else {
                return SpawnVerdict::Invalid {
                    reason: format!("unknown lane '{}'", order.lane),
                };
            };
            let known = match order.kind_def {
                Some(def) if def.name == order.kind => Some(world.add_vehicle_kind(def)),
                _ => world.kind_index(&order.kind),
            };
            let Some(kind) = known else {
                return SpawnVerdict::Invalid {
                    reason: format!("unknown vehicle kind '{}'", order.kind),
                };
            };
            let route = match order.route {
                None => None,
                Some(names) => {
                    let mut lanes = Vec::with_capacity(names.len());
                    for n in &names {
                        match world.network().lane_id(n) {
                            Some(l) => lanes.push(l),
                            None => {
                                return SpawnVerdict::Invalid {
                                    reason: format!("unknown route lane '{n}'"),
                                };
                            }
                        }
                    }
                    Some(trafficmesh_sim::spawn::Route {
                        lanes: lanes.into(),
                        leave_at_end: order.leave_at_route_end,
                        depart: order.depart,
                    })
                }
            };
            match world.admit_spawn(kind, lane, route, batch.max_vehicles, &mut spawned_here) {
                Ok(id) => SpawnVerdict::Spawned { id },
                Err(SpawnRejection::MaxVehicles) => SpawnVerdict::MaxVehicles,
                Err(SpawnRejection::NotSpawnable) => SpawnVerdict::NotSpawnable,
                Err(e) => SpawnVerdict::Invalid {
                    reason: e.to_string(),
                },
            }
        })
        .collect();
    SpawnAnswer { verdicts }
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
