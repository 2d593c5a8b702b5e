//! A traffic session as a simulation runtime drives one: its logged actors
//! follow their logs until handover, then trafficmesh's NPC model drives
//! them (on a lane: lanes, lights, right of way and the vehicle in front;
//! off the lanes: on at their heading and speed, braking for what is in
//! front), reacting to the bodies the client moves (the ego). Deterministic
//! from the seed and the inputs.

mod free;
mod log;
mod placement;

use std::collections::HashMap;

use glam::{DQuat, DVec2, DVec3};

pub use log::{PoseAt, PoseLog, yaw_of};

use crate::ego::Ego;
use crate::network::LaneNetwork;
use crate::vehicle::VehicleId;
use crate::world::{World, WorldConfig};
use free::FreeBody;

/// How a session runs.
#[derive(Clone, Copy, Debug)]
pub struct SessionConfig {
    /// History an actor needs before the model takes it over.
    pub min_history_us: u64,
    /// Forecast poses after the queried time: how far and how often.
    pub forecast_horizon_us: u64,
    pub forecast_step_us: u64,
    /// The simulation's tick, microseconds.
    pub tick_us: u64,
}

impl Default for SessionConfig {
    fn default() -> Self {
        SessionConfig {
            min_history_us: 1_000_000,
            forecast_horizon_us: 2_000_000,
            forecast_step_us: 100_000,
            tick_us: 20_000,
        }
    }
}

/// A logged actor as the session starts.
#[derive(Clone, Debug)]
pub struct Actor {
    pub id: String,
    /// Box size: length, width, height.
    pub size: DVec3,
    pub is_static: bool,
    pub log: Vec<PoseAt>,
}

/// What a request got wrong; the session is left as it was.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SessionError {
    #[error("time_query_us {asked} is before the session's time {now}: time never goes backwards")]
    TimeBackwards { now: u64, asked: u64 },
    #[error("object '{0}' has an empty trajectory")]
    EmptyTrajectory(String),
    #[error("object '{object}' has poses only up to {last_us} us, short of time_query_us {asked}")]
    MissingPoses {
        object: String,
        last_us: u64,
        asked: u64,
    },
    #[error("object '{0}' has a pose that is not a finite number (NaN or infinite)")]
    NotFinite(String),
    #[error("object '{0}' appears twice in the session request")]
    DuplicateObject(String),
}

/// Who moves an actor now.
#[derive(Clone, Debug)]
enum Control {
    /// Its log, until handover.
    Log,
    /// The NPC model, as this vehicle of the world.
    Npc { vehicle: VehicleId, lift: f64 },
    /// On at its heading, braking for what is in front (off the lanes, or
    /// with no map).
    Free(FreeBody),
    /// The client's updates.
    Client,
    /// Where it stands: static actors, and NPCs that left the map.
    Parked(PoseAt),
}

struct Tracked {
    actor: Actor,
    log: PoseLog,
    control: Control,
    /// Its pose at the session's time.
    pose: Option<PoseAt>,
}

/// One actor's answer: its pose at the queried time, then its forecast.
#[derive(Clone, Debug, PartialEq)]
pub struct ActorAnswer {
    pub id: String,
    pub poses: Vec<PoseAt>,
    /// Who moves it: `log`, `model`, `client` or `static`.
    pub driver: &'static str,
    /// Its box: length, width, height.
    pub size: DVec3,
}

pub struct TrafficSession {
    world: Option<World>,
    lane_boxes: Option<placement::LaneBoxes>,
    actors: Vec<Tracked>,
    /// Bodies only the client moves (the ego), by id, in first-seen order.
    clients: Vec<(String, PoseLog, DVec3)>,
    handover_us: u64,
    /// The session's time; None before the first request.
    now_us: Option<u64>,
    config: SessionConfig,
}

impl TrafficSession {
    /// A session on `network` (None: no map; every actor handed over drives
    /// free). `seed` draws the NPCs' choices.
    pub fn new(
        network: Option<LaneNetwork>,
        actors: Vec<Actor>,
        seed: u64,
        handover_us: u64,
        config: SessionConfig,
    ) -> Result<Self, SessionError> {
        let mut seen = std::collections::HashSet::new();
        for a in &actors {
            if !seen.insert(a.id.as_str()) {
                return Err(SessionError::DuplicateObject(a.id.clone()));
            }
            if a.log.iter().any(|p| !p.is_finite()) || !a.size.is_finite() {
                return Err(SessionError::NotFinite(a.id.clone()));
            }
        }
        let world = network.map(|net| {
            World::new(
                net,
                WorldConfig {
                    seed,
                    dt: config.tick_us as f64 * 1e-6,
                    max_vehicles: actors.len().max(1),
                    ..WorldConfig::default()
                },
            )
            .without_simulators()
        });
        let lane_boxes = world
            .as_ref()
            .map(|w| placement::LaneBoxes::new(w.network()));
        let actors = actors
            .into_iter()
            .map(|actor| {
                let log = PoseLog::new(actor.log.clone());
                let control = match (actor.is_static, log.first()) {
                    (true, Some(first)) => Control::Parked(*first),
                    _ => Control::Log,
                };
                Tracked {
                    actor,
                    log,
                    control,
                    pose: None,
                }
            })
            .collect();
        Ok(TrafficSession {
            world,
            lane_boxes,
            actors,
            clients: Vec::new(),
            handover_us,
            now_us: None,
            config,
        })
    }

    /// Advances to `t_us` with the client's `updates` (object id, poses up to
    /// at least `t_us`) and answers every actor in the order given at start.
    pub fn simulate(
        &mut self,
        t_us: u64,
        updates: Vec<(String, Vec<PoseAt>)>,
    ) -> Result<Vec<ActorAnswer>, SessionError> {
        if let Some(now) = self.now_us
            && t_us < now
        {
            return Err(SessionError::TimeBackwards { now, asked: t_us });
        }
        for (id, poses) in &updates {
            let last = poses
                .iter()
                .map(|p| p.t_us)
                .max()
                .ok_or_else(|| SessionError::EmptyTrajectory(id.clone()))?;
            if poses.iter().any(|p| !p.is_finite()) {
                return Err(SessionError::NotFinite(id.clone()));
            }
            if last < t_us {
                return Err(SessionError::MissingPoses {
                    object: id.clone(),
                    last_us: last,
                    asked: t_us,
                });
            }
        }
        for (id, poses) in updates {
            self.take_update(id, poses);
        }
        let start = *self.now_us.get_or_insert(t_us);
        let mut tick = start;
        while tick + self.config.tick_us <= t_us {
            self.tick(tick);
            tick += self.config.tick_us;
        }
        // The world's clock runs in whole ticks; the rest is extrapolated.
        self.now_us = Some(t_us);
        let lag = (t_us - tick) as f64 * 1e-6;
        // Where each of the world's vehicles is in its list: looking each
        // NPC up by id would read the whole list once per actor.
        let slots: HashMap<VehicleId, usize> = self
            .world
            .iter()
            .flat_map(|w| w.vehicles().iter().enumerate().map(|(i, v)| (v.id, i)))
            .collect();
        // The queried time, then the forecast's.
        let step = self.config.forecast_step_us.max(1);
        let times: Vec<u64> = (0..=self.config.forecast_horizon_us / step)
            .map(|i| t_us + i * step)
            .collect();
        Ok((0..self.actors.len())
            .map(|k| self.answer(k, &times, lag, &slots))
            .collect())
    }

    /// Client-moved bodies: a logged actor's updates put the client in
    /// charge of it; others are bodies of the client's own (the ego).
    fn take_update(&mut self, id: String, poses: Vec<PoseAt>) {
        if let Some(a) = self.actors.iter_mut().find(|a| a.actor.id == id) {
            if let Control::Npc { vehicle, .. } = a.control
                && let Some(w) = &mut self.world
            {
                w.remove_vehicle(vehicle);
            }
            a.control = Control::Client;
            a.log.extend(poses);
            return;
        }
        match self.clients.iter_mut().find(|c| c.0 == id) {
            Some(c) => c.1.extend(poses),
            None => self
                .clients
                .push((id, PoseLog::new(poses), DVec3::new(4.9, 1.9, 1.5))),
        }
    }

    /// One tick from `t_us`: hand over who is due, show the world the bodies
    /// it does not drive, step it, move the free ones.
    fn tick(&mut self, t_us: u64) {
        for k in 0..self.actors.len() {
            self.hand_over_if_due(k, t_us);
        }
        let bodies = self.foreign_bodies(t_us);
        let dt = self.config.tick_us as f64 * 1e-6;
        let mut obstacles: Vec<free::Obstacle> = bodies.iter().map(free::Obstacle::from).collect();
        if let Some(w) = &mut self.world {
            w.set_foreign_bodies(bodies);
            w.step();
            obstacles.extend(w.vehicles().iter().map(|v| free::Obstacle {
                center: v.front - v.heading * (v.length * 0.5),
                length: v.length,
                width: v.width,
            }));
        }
        for a in &mut self.actors {
            if let Control::Free(body) = &mut a.control {
                body.advance(dt, &obstacles);
            }
        }
    }

    /// Hands actor `k` over to the model once it is due: not before the
    /// handover time, and with enough history.
    fn hand_over_if_due(&mut self, k: usize, t_us: u64) {
        let a = &self.actors[k];
        if !matches!(a.control, Control::Log) || t_us < self.handover_us {
            return;
        }
        let Some(first) = a.log.first() else {
            return;
        };
        if t_us.saturating_sub(first.t_us) < self.config.min_history_us || t_us < first.t_us {
            return;
        }
        let pose = a.log.at_or_held(t_us).expect("a log with poses");
        let velocity = a
            .log
            .velocity(t_us.min(a.log.last().map_or(t_us, |l| l.t_us)));
        let speed = velocity.length();
        let (length, width) = (a.actor.size.x, a.actor.size.y);
        let yaw = pose.yaw();
        let front = pose.position.truncate() + DVec2::from_angle(yaw) * (length * 0.5);
        let boxes = &self.lane_boxes;
        let placed = self
            .world
            .as_mut()
            .zip(boxes.as_ref())
            .and_then(|(w, boxes)| {
                let (lane, s) = placement::match_lane(w.network(), boxes, front, yaw)?;
                // A kind of its own size, its origin at the box centre.
                let kind = format!("actor {}", a.actor.id);
                w.add_vehicle_kind(trafficmesh_model::VehicleKind {
                    name: kind.clone(),
                    front: length * 0.5,
                    length,
                    width,
                    driver: None,
                    idm: None,
                    class: None,
                });
                let lane = w.network().lane(lane);
                let (name, s) = (lane.name.clone(), s.clamp(0.0, lane.length()));
                w.place_vehicle(&kind, &name, s, speed).ok()
            });
        let lift = self
            .world
            .as_ref()
            .zip(placed)
            .and_then(|(w, id)| w.vehicle(id))
            .map_or(0.0, |v| pose.position.z - v.pose.z);
        self.actors[k].control = match placed {
            Some(vehicle) => Control::Npc { vehicle, lift },
            None => Control::Free(FreeBody::new(pose, speed, length, width)),
        };
    }

    /// The bodies the world does not drive, at `t_us`: the client's, the
    /// actors still on their logs, parked and free ones.
    fn foreign_bodies(&self, t_us: u64) -> Vec<Ego> {
        // As the ego: its pose at the box centre, half its length to the front.
        let body = |pose: PoseAt, size: DVec3| Ego {
            pose: crate::vehicle::Pose {
                x: pose.position.x,
                y: pose.position.y,
                z: pose.position.z,
                yaw: pose.yaw(),
            },
            length: size.x,
            width: size.y,
            front_offset: size.x * 0.5,
        };
        let clients = self
            .clients
            .iter()
            .filter_map(|(_, log, size)| Some(body(log.at_or_held(t_us)?, *size)));
        let actors = self.actors.iter().filter_map(|a| {
            let pose = match &a.control {
                Control::Log | Control::Client => a.log.at(t_us),
                Control::Parked(p) => Some(*p),
                Control::Free(body) => Some(body.pose(t_us)),
                Control::Npc { .. } => None,
            }?;
            Some(body(pose, a.actor.size))
        });
        clients.chain(actors).collect()
    }

    /// Actor `k`'s poses at `times` (the queried time first, then its
    /// forecast). `lag` is how far the queried time lies past the world's
    /// last tick, seconds; `slots` where each vehicle is in the world's list.
    fn answer(
        &mut self,
        k: usize,
        times: &[u64],
        lag: f64,
        slots: &HashMap<VehicleId, usize>,
    ) -> ActorAnswer {
        let t_us = times[0];
        // Seconds from the queried time to `t`.
        let after = |t: u64| (t - t_us) as f64 * 1e-6;
        let held = |p: PoseAt| times.iter().map(move |&t| PoseAt { t_us: t, ..p });
        let a = &self.actors[k];
        let poses: Vec<PoseAt> = match &a.control {
            Control::Log | Control::Client => {
                let now = a.log.at_or_held(t_us).or(a.pose);
                let v = a.log.velocity(t_us);
                times
                    .iter()
                    .filter_map(|&t| {
                        a.log.at(t).or_else(|| {
                            now.map(|p| PoseAt {
                                t_us: t,
                                position: p.position + (v * after(t)).extend(0.0),
                                rotation: p.rotation,
                            })
                        })
                    })
                    .collect()
            }
            Control::Parked(p) => held(*p).collect(),
            Control::Free(body) => times
                .iter()
                .map(|&t| body.pose_after(t, lag + after(t)))
                .collect(),
            Control::Npc { vehicle, lift } => {
                let world = self.world.as_ref().expect("NPCs live in a world");
                match slots.get(vehicle).map(|&i| &world.vehicles()[i]) {
                    Some(v) => {
                        let aheads = times.iter().map(|&t| v.speed * (lag + after(t)));
                        placement::along_path(world.network(), &v.path, v.s, v.length, aheads)
                            .zip(times)
                            .map(|((c, heading), &t)| PoseAt {
                                t_us: t,
                                position: c + DVec3::Z * *lift,
                                rotation: DQuat::from_rotation_arc_2d(DVec2::X, heading),
                            })
                            .collect()
                    }
                    None => {
                        // It drove off the map: it stays where it was last seen.
                        let last = a.pose.unwrap_or(PoseAt {
                            t_us,
                            position: DVec3::ZERO,
                            rotation: DQuat::IDENTITY,
                        });
                        self.actors[k].control = Control::Parked(last);
                        held(last).collect()
                    }
                }
            }
        };
        let a = &mut self.actors[k];
        a.pose = poses.first().copied();
        let driver = match a.control {
            Control::Log => "log",
            Control::Npc { .. } | Control::Free(_) => "model",
            Control::Client => "client",
            Control::Parked(_) => "static",
        };
        ActorAnswer {
            id: a.actor.id.clone(),
            poses,
            driver,
            size: a.actor.size,
        }
    }
}
