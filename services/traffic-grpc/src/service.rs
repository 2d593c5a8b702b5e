//! The six methods of `traffic.TrafficService` over trafficmesh's traffic
//! sessions: wire messages in, session calls, wire messages out.

use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex};

use glam::{DQuat, DVec3};
use tonic::{Request, Response, Status};
use trafficmesh_sim::session::{Actor, PoseAt, SessionConfig, SessionError, TrafficSession};

use trafficmesh_bus::Bus;
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{SessionObject, SessionObjects};
use trafficmesh_sim::session::{ActorAnswer, yaw_of};

use crate::catalogue::Scene;
use crate::proto::common::{
    self, AvailableScenesReturn, Empty, PoseAtTime, SessionRequestStatus, Trajectory,
};
use crate::proto::traffic::traffic_service_server::TrafficService;
use crate::proto::traffic::{
    ObjectTrajectoryUpdate, TrafficModuleMetadata, TrafficRequest, TrafficReturn,
    TrafficSessionCloseRequest, TrafficSessionRequest,
};

/// The API version the wire contract describes.
const API_VERSION: (u32, u32, u32) = (0, 1, 0);

struct Session {
    core: TrafficSession,
    /// Log frame + offset = map frame.
    offset: DVec3,
    map_id: String,
}

pub struct Gateway {
    scenes: BTreeMap<String, Scene>,
    config: SessionConfig,
    sessions: Mutex<HashMap<String, Arc<Mutex<Session>>>>,
    shutdown: tokio::sync::watch::Sender<bool>,
    /// Where each answer's actors are published for viewers.
    bus: Option<Arc<Bus>>,
    /// Each simulate call's own time (the session's step and the answer
    /// built), when measured.
    step_times: Option<Arc<Mutex<Vec<std::time::Duration>>>>,
}

impl Gateway {
    pub fn new(
        scenes: BTreeMap<String, Scene>,
        config: SessionConfig,
        shutdown: tokio::sync::watch::Sender<bool>,
    ) -> Self {
        Gateway {
            scenes,
            config,
            sessions: Mutex::new(HashMap::new()),
            shutdown,
            bus: None,
            step_times: None,
        }
    }

    /// Records each simulate call's own time in `times` (benchmarks).
    pub fn with_step_times(mut self, times: Arc<Mutex<Vec<std::time::Duration>>>) -> Self {
        self.step_times = Some(times);
        self
    }

    /// Publishes every answer on `bus` under its session id.
    pub fn with_bus(mut self, bus: Arc<Bus>) -> Self {
        self.bus = Some(bus);
        self
    }

    fn session(&self, id: &str) -> Result<Arc<Mutex<Session>>, Status> {
        self.sessions
            .lock()
            .expect("the session table is never poisoned")
            .get(id)
            .cloned()
            .ok_or_else(|| Status::not_found(format!("no session '{id}'")))
    }
}

/// A wire pose (float32) in the log's frame as the session's pose in the map frame.
fn from_wire(p: &PoseAtTime, offset: DVec3) -> PoseAt {
    let pose = p.pose.unwrap_or_default();
    let v = pose.vec.unwrap_or_default();
    let q = pose.quat.unwrap_or(common::Quat {
        w: 1.0,
        x: 0.0,
        y: 0.0,
        z: 0.0,
    });
    PoseAt {
        t_us: p.timestamp_us,
        position: DVec3::new(v.x as f64, v.y as f64, v.z as f64) + offset,
        rotation: DQuat::from_xyzw(q.x as f64, q.y as f64, q.z as f64, q.w as f64),
    }
}

fn to_wire(p: &PoseAt, offset: DVec3) -> PoseAtTime {
    let v = p.position - offset;
    let q = p.rotation;
    PoseAtTime {
        pose: Some(common::Pose {
            vec: Some(common::Vec3 {
                x: v.x as f32,
                y: v.y as f32,
                z: v.z as f32,
            }),
            quat: Some(common::Quat {
                w: q.w as f32,
                x: q.x as f32,
                y: q.y as f32,
                z: q.z as f32,
            }),
        }),
        timestamp_us: p.t_us,
    }
}

fn poses_of(t: &Option<Trajectory>, offset: DVec3) -> Vec<PoseAt> {
    t.as_ref()
        .map(|t| t.poses.iter().map(|p| from_wire(p, offset)).collect())
        .unwrap_or_default()
}

/// An answer as viewers on the bus see it: box centres in the map frame.
fn view_of(id: &str, s: &Session, time_us: u64, answers: &[ActorAnswer]) -> SessionObjects {
    SessionObjects {
        session: id.to_string(),
        map_id: s.map_id.clone(),
        time_us,
        objects: answers
            .iter()
            .filter_map(|a| {
                let p = a.poses.first()?;
                Some(SessionObject {
                    id: a.id.clone(),
                    x: p.position.x,
                    y: p.position.y,
                    z: p.position.z,
                    yaw: yaw_of(p.rotation),
                    length: a.size.x,
                    width: a.size.y,
                    height: a.size.z,
                    driver: a.driver.to_string(),
                })
            })
            .collect(),
    }
}

fn invalid(e: SessionError) -> Status {
    Status::invalid_argument(e.to_string())
}

#[tonic::async_trait]
impl TrafficService for Gateway {
    async fn start_session(
        &self,
        request: Request<TrafficSessionRequest>,
    ) -> Result<Response<SessionRequestStatus>, Status> {
        let r = request.into_inner();
        if r.session_uuid.is_empty() {
            return Err(Status::invalid_argument("session_uuid is empty"));
        }
        let scene = self.scenes.get(&r.map_id);
        if scene.is_none() {
            tracing::info!(
                session = %r.session_uuid,
                map_id = %r.map_id,
                "map_id is not a known scene: the session runs without a map"
            );
        }
        let offset = scene.map_or(DVec3::ZERO, |s| s.offset);
        let mut actors = Vec::with_capacity(r.logged_object_trajectories.len());
        for o in &r.logged_object_trajectories {
            let log = poses_of(&o.trajectory, offset);
            if log.is_empty() && !o.is_static {
                return Err(Status::invalid_argument(format!(
                    "object '{}' has an empty trajectory",
                    o.object_id
                )));
            }
            let size = o.aabb.unwrap_or_default();
            actors.push(Actor {
                id: o.object_id.clone(),
                size: DVec3::new(size.size_x as f64, size.size_y as f64, size.size_z as f64),
                is_static: o.is_static,
                log,
            });
        }
        let core = TrafficSession::new(
            scene.map(|s| s.network.clone()),
            actors,
            r.random_seed,
            r.handover_time_us,
            self.config,
        )
        .map_err(invalid)?;
        let mut sessions = self.sessions.lock().expect("never poisoned");
        if sessions.contains_key(&r.session_uuid) {
            return Err(Status::already_exists(format!(
                "session '{}' already exists",
                r.session_uuid
            )));
        }
        tracing::info!(session = %r.session_uuid, map_id = %r.map_id, objects = r.logged_object_trajectories.len(), "session started");
        sessions.insert(
            r.session_uuid,
            Arc::new(Mutex::new(Session {
                core,
                offset,
                map_id: r.map_id.clone(),
            })),
        );
        Ok(Response::new(SessionRequestStatus {}))
    }

    async fn close_session(
        &self,
        request: Request<TrafficSessionCloseRequest>,
    ) -> Result<Response<Empty>, Status> {
        let id = request.into_inner().session_uuid;
        self.sessions
            .lock()
            .expect("never poisoned")
            .remove(&id)
            .ok_or_else(|| Status::not_found(format!("no session '{id}'")))?;
        tracing::info!(session = %id, "session closed");
        Ok(Response::new(Empty {}))
    }

    async fn simulate(
        &self,
        request: Request<TrafficRequest>,
    ) -> Result<Response<TrafficReturn>, Status> {
        let r = request.into_inner();
        let session = self.session(&r.session_uuid)?;
        let bus = self.bus.clone();
        let watched = bus.is_some();
        let id = r.session_uuid.clone();
        // On the network's worker itself: a session of a few hundred actors
        // steps in well under a millisecond, less than handing the call to
        // another thread and back costs on a small machine.
        let started = std::time::Instant::now();
        let (answer, view) = {
            let mut s = session.lock().expect("a session lock is never poisoned");
            let offset = s.offset;
            let updates = r
                .object_trajectory_updates
                .iter()
                .map(|u| (u.object_id.clone(), poses_of(&u.trajectory, offset)))
                .collect();
            let answers = s.core.simulate(r.time_query_us, updates);
            let view = match (&answers, watched) {
                (Ok(answers), true) => Some(view_of(&id, &s, r.time_query_us, answers)),
                _ => None,
            };
            let answer = answers
                .map(|answers| TrafficReturn {
                    object_trajectory_updates: answers
                        .into_iter()
                        .map(|a| ObjectTrajectoryUpdate {
                            object_id: a.id,
                            trajectory: Some(Trajectory {
                                poses: a.poses.iter().map(|p| to_wire(p, offset)).collect(),
                            }),
                        })
                        .collect(),
                })
                .map_err(invalid);
            (answer, view)
        };
        if let Some(times) = &self.step_times {
            times
                .lock()
                .expect("the timings are never poisoned")
                .push(started.elapsed());
        }
        if let (Some(bus), Some(view)) = (bus, view) {
            // Viewers never hold up the runtime's answer.
            tokio::spawn(async move {
                if let Err(e) = bus
                    .publish_at(&topics::TRAFFIC_SESSION, &view.session, &view)
                    .await
                {
                    tracing::debug!(session = %view.session, "not published: {e}");
                }
            });
        }
        let answer = answer?;
        Ok(Response::new(answer))
    }

    async fn get_metadata(
        &self,
        _request: Request<Empty>,
    ) -> Result<Response<TrafficModuleMetadata>, Status> {
        Ok(Response::new(TrafficModuleMetadata {
            version_id: Some(common::VersionId {
                version_id: env!("CARGO_PKG_VERSION").to_string(),
                git_hash: env!("TRAFFICMESH_GIT_HASH").to_string(),
                grpc_api_version: Some(common::version_id::ApiVersion {
                    major: API_VERSION.0,
                    minor: API_VERSION.1,
                    patch: API_VERSION.2,
                }),
            }),
            minimum_history_length_us: self.config.min_history_us,
            supported_map_ids: self.scenes.keys().cloned().collect(),
        }))
    }

    async fn get_available_scenes(
        &self,
        _request: Request<Empty>,
    ) -> Result<Response<AvailableScenesReturn>, Status> {
        Ok(Response::new(AvailableScenesReturn {
            scene_ids: self.scenes.keys().cloned().collect(),
        }))
    }

    async fn shut_down(&self, _request: Request<Empty>) -> Result<Response<Empty>, Status> {
        tracing::info!("shut_down called: stopping");
        let _ = self.shutdown.send(true);
        Ok(Response::new(Empty {}))
    }
}
