//! `trafficmesh bench traffic-service`: simulate() latency as a runtime sees
//! it. The service runs in-process on a loopback port; each session is a
//! gRPC client over TCP with `objects` logged actors on a generated grid,
//! called every 100 ms (the runtime's control step) with the ego's poses,
//! the sessions' calls spread over the step. A call's latency runs from the
//! request sent to the whole answer received; the client's own decoding of
//! the answer is timed apart, since it depends on the client's language and
//! library, not on the service.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use glam::DVec2;
use prost::Message;
use prost::bytes::{Buf, Bytes};
use serde::Serialize;
use tonic::codec::{BufferSettings, Codec, DecodeBuf, Decoder};
use tonic::codegen::http::uri::PathAndQuery;
use trafficmesh_maps::{GridOptions, grid_map};
use trafficmesh_service::stats::quantile;
use trafficmesh_sim::LaneNetwork;
use trafficmesh_sim::session::SessionConfig;

use crate::catalogue::Scene;
use crate::codec::{WholeEncoder, whole_buffers};
use crate::proto::common::{Aabb, Pose, PoseAtTime, Quat, Trajectory, Vec3};
use crate::proto::traffic::traffic_service_client::TrafficServiceClient;
use crate::proto::traffic::{
    ObjectTrajectory, ObjectTrajectoryUpdate, TrafficRequest, TrafficReturn, TrafficSessionRequest,
};

/// The runtime's control step, microseconds.
const STEP_US: u64 = 100_000;
/// Logged actors' speed along their lanes, m/s.
const LOG_SPEED: f64 = 8.0;

pub struct BenchOptions {
    pub objects: usize,
    /// Concurrent session counts to measure, one run each.
    pub sessions: Vec<usize>,
    /// Simulated seconds per session.
    pub seconds: u64,
    /// The service's forecast per answer (its default: 2 s).
    pub forecast_horizon_us: u64,
}

#[derive(Serialize)]
pub struct BenchRow {
    pub sessions: usize,
    pub objects: usize,
    /// Poses per actor in each answer: the queried one and the forecast.
    pub poses_per_object: u64,
    pub calls: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    /// The client decoding an answer, after it arrived: p50.
    pub client_decode_p50_ms: f64,
    /// The service's own part of a call (the session's step and the answer
    /// built, before encoding): p50 and p99.
    pub step_p50_ms: f64,
    pub step_p99_ms: f64,
}

/// simulate() as a client that keeps the answer's bytes, so that a call's
/// latency ends when the answer has arrived; it is decoded afterwards.
struct ArrivalCodec;

impl Codec for ArrivalCodec {
    type Encode = TrafficRequest;
    type Decode = Bytes;
    type Encoder = WholeEncoder<TrafficRequest>;
    type Decoder = BytesDecoder;

    fn encoder(&mut self) -> Self::Encoder {
        WholeEncoder::default()
    }

    fn decoder(&mut self) -> Self::Decoder {
        BytesDecoder
    }
}

struct BytesDecoder;

impl Decoder for BytesDecoder {
    type Item = Bytes;
    type Error = tonic::Status;

    fn decode(&mut self, buf: &mut DecodeBuf<'_>) -> Result<Option<Bytes>, tonic::Status> {
        let len = buf.remaining();
        Ok(Some(buf.copy_to_bytes(len)))
    }

    fn buffer_settings(&self) -> BufferSettings {
        whole_buffers()
    }
}

/// The grid the sessions drive on: 6 x 6 junctions, 200 m blocks.
fn grid() -> Result<LaneNetwork> {
    let map = grid_map(&GridOptions {
        size: 6,
        ..GridOptions::default()
    });
    LaneNetwork::build(&map).map_err(|p| anyhow::anyhow!("the bench grid: {p:?}"))
}

fn pose_at(t_us: u64, p: DVec2, yaw: f64) -> PoseAtTime {
    PoseAtTime {
        pose: Some(Pose {
            vec: Some(Vec3 {
                x: p.x as f32,
                y: p.y as f32,
                z: 0.75,
            }),
            quat: Some(Quat {
                w: (yaw * 0.5).cos() as f32,
                x: 0.0,
                y: 0.0,
                z: (yaw * 0.5).sin() as f32,
            }),
        }),
        timestamp_us: t_us,
    }
}

/// `n` actors, each logged for 1.5 s along a road lane of `net` (up to four
/// per lane, 30 m apart), the first 1.5 s of a 10 Hz log.
fn actors(net: &LaneNetwork, n: usize) -> Vec<ObjectTrajectory> {
    let slots = net
        .lanes
        .iter()
        .filter(|l| !l.intersection && l.line.length() > 140.0)
        .flat_map(|l| (0..4).map(move |k| (l, 10.0 + 30.0 * k as f64)));
    slots
        .take(n)
        .enumerate()
        .map(|(i, (lane, s0))| {
            let poses = (0..=15)
                .map(|k| {
                    let s = s0 + LOG_SPEED * k as f64 * 0.1;
                    let (p, _) = lane.line.point_at(s);
                    let (q, _) = lane.line.point_at(s + 0.5);
                    let d = q - p;
                    pose_at(k * STEP_US, p, d.y.atan2(d.x))
                })
                .collect();
            ObjectTrajectory {
                aabb: Some(Aabb {
                    size_x: 4.5,
                    size_y: 1.9,
                    size_z: 1.5,
                }),
                trajectory: Some(Trajectory { poses }),
                object_id: format!("actor-{i}"),
                is_static: false,
                label_class: "car".into(),
            }
        })
        .collect()
}

/// One session's calls: start, then `seconds` at 10 Hz paced in real time
/// from `phase`; the latency of each simulate call.
async fn session(
    address: String,
    id: String,
    objects: Vec<ObjectTrajectory>,
    seconds: u64,
    phase: Duration,
    all_started: Arc<tokio::sync::Barrier>,
) -> Result<Vec<(Duration, Duration)>> {
    let actors = objects.len();
    let channel = tonic::transport::Endpoint::from_shared(format!("http://{address}"))?
        .tcp_nodelay(true)
        .initial_stream_window_size(crate::WINDOW)
        .initial_connection_window_size(4 * crate::WINDOW)
        // What a grpcio client (the runtime's) offers: 4 MB windows and frames.
        .max_frame_size(crate::WINDOW)
        .connect()
        .await?;
    let mut client = TrafficServiceClient::new(channel.clone());
    let mut raw = tonic::client::Grpc::new(channel);
    client
        .start_session(TrafficSessionRequest {
            session_uuid: id.clone(),
            map_id: "grid".into(),
            random_seed: 7,
            logged_object_trajectories: objects,
            handover_time_us: 600_000,
        })
        .await?;
    // Steady state: every session's calls begin once all have started.
    all_started.wait().await;
    tokio::time::sleep(phase).await;
    let mut tick = tokio::time::interval(Duration::from_micros(STEP_US));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut latencies = Vec::new();
    for t in (STEP_US..=seconds * 1_000_000).step_by(STEP_US as usize) {
        tick.tick().await;
        let ego = ObjectTrajectoryUpdate {
            object_id: "ego".into(),
            trajectory: Some(Trajectory {
                poses: vec![pose_at(t, DVec2::new(-500.0, -500.0), 0.0)],
            }),
        };
        let request = tonic::Request::new(TrafficRequest {
            session_uuid: id.clone(),
            time_query_us: t,
            object_trajectory_updates: vec![ego],
        });
        raw.ready().await?;
        let started = Instant::now();
        let bytes = raw
            .unary(
                request,
                PathAndQuery::from_static("/traffic.TrafficService/simulate"),
                ArrivalCodec,
            )
            .await?
            .into_inner();
        let arrived = started.elapsed();
        let answer = TrafficReturn::decode(bytes).context("decoding an answer")?;
        latencies.push((arrived, started.elapsed() - arrived));
        anyhow::ensure!(
            answer.object_trajectory_updates.len() == actors,
            "session {id} answered {} of its {actors} actors",
            answer.object_trajectory_updates.len()
        );
    }
    client
        .close_session(crate::proto::traffic::TrafficSessionCloseRequest { session_uuid: id })
        .await?;
    Ok(latencies)
}

/// Runs the bench: one row per session count.
pub async fn run(o: &BenchOptions) -> Result<Vec<BenchRow>> {
    let net = grid()?;
    let objects = actors(&net, o.objects);
    anyhow::ensure!(
        objects.len() == o.objects,
        "the bench grid holds {} actors, fewer than --objects {}",
        objects.len(),
        o.objects
    );
    let mut scenes = BTreeMap::new();
    scenes.insert(
        "grid".to_string(),
        Scene {
            network: net,
            offset: glam::DVec3::ZERO,
        },
    );
    let (stop, _) = tokio::sync::watch::channel(false);
    let step_times = Arc::new(std::sync::Mutex::new(Vec::new()));
    let gateway = crate::service::Gateway::new(
        scenes,
        SessionConfig {
            forecast_horizon_us: o.forecast_horizon_us,
            ..SessionConfig::default()
        },
        stop,
    )
    .with_step_times(step_times.clone());
    let incoming = tonic::transport::server::TcpIncoming::bind("127.0.0.1:0".parse()?)
        .context("binding a loopback port")?
        .with_nodelay(Some(true));
    let address = incoming.local_addr()?.to_string();
    let (halt, halted) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(crate::serve(gateway, incoming, None, async {
        let _ = halted.await;
    }));
    let mut rows = Vec::new();
    for (run, &n) in o.sessions.iter().enumerate() {
        let all_started = Arc::new(tokio::sync::Barrier::new(n));
        let runs: Vec<_> = (0..n)
            .map(|k| {
                tokio::spawn(session(
                    address.clone(),
                    format!("bench-{run}-{k}"),
                    objects.clone(),
                    o.seconds,
                    Duration::from_micros(STEP_US * k as u64 / n as u64),
                    all_started.clone(),
                ))
            })
            .collect();
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mut all = Vec::new();
        let mut decoding = Vec::new();
        for r in runs {
            for (arrived, decoded) in r.await?? {
                all.push(ms(arrived));
                decoding.push(ms(decoded));
            }
        }
        let steps = std::mem::take(&mut *step_times.lock().expect("never poisoned"));
        let mut steps: Vec<f64> = steps.into_iter().map(ms).collect();
        rows.push(BenchRow {
            sessions: n,
            objects: o.objects,
            poses_per_object: 1 + o.forecast_horizon_us / SessionConfig::default().forecast_step_us,
            calls: all.len(),
            p50_ms: quantile(&mut all, 0.5),
            p99_ms: quantile(&mut all, 0.99),
            max_ms: quantile(&mut all, 1.0),
            client_decode_p50_ms: quantile(&mut decoding, 0.5),
            step_p50_ms: quantile(&mut steps, 0.5),
            step_p99_ms: quantile(&mut steps, 0.99),
        });
    }
    let _ = halt.send(());
    server.await??;
    Ok(rows)
}
