//! trafficmesh-crosswalks: the ZebraCrossingArea role. Agent footprints from
//! any source become enter/exit events per area (detected types, whitelists,
//! one count per root); occupancy goes out on change with a heartbeat that
//! keeps it valid; the blocked-stop query is answered here.

use std::collections::{BTreeMap, BTreeSet};
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use clap::Parser;
use glam::DVec2;
use trafficmesh_bus::{Bus, BusArgs, Lane, Role, Vouch, runtime};
use trafficmesh_protocol::Keys;
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{
    AgentBatch, BlockedStopAnswer, BlockedStopQuery, Clock, CrosswalkOccupancy, TickReport,
};
use trafficmesh_service::MapArgs;
use trafficmesh_sim::LaneNetwork;
use trafficmesh_sim::crosswalk::{Occupancy, OccupantType, try_get_blocked_stop};
use trafficmesh_sim::crosswalk_agents::{AgentOccupancy, AgentPose};

#[derive(Parser)]
#[command(
    name = "trafficmesh-crosswalks",
    version,
    about = "Crosswalk occupancy from pedestrian and cyclist poses, and the blocked-stop query",
    after_help = "Usually started by `trafficmesh up`. Keys: see docs/cluster.md."
)]
struct Args {
    #[command(flatten)]
    bus: BusArgs,
    #[command(flatten)]
    map: MapArgs,
    /// Simulation seconds published occupancy stays valid without a heartbeat;
    /// after that the stepper counts every crosswalk blocked.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    validity: f64,
    /// Wall-clock seconds after which a silent agent source is forgotten.
    #[arg(long, default_value_t = 3.0, allow_negative_numbers = true)]
    source_timeout: f64,
    /// Advance on the stepper's lockstep questions instead of its clock
    /// (answers on <cluster>/lockstep/step/crosswalks), asking the agent
    /// sources in step (<cluster>/lockstep/agents/*) for each tick's agents.
    #[arg(long)]
    lockstep: bool,
    /// With --lockstep: agent sources no tick is answered without,
    /// comma-separated (e.g. pedestrians).
    #[arg(long, value_delimiter = ',', requires = "lockstep")]
    lockstep_sources: Vec<String>,
}

struct Areas {
    net: LaneNetwork,
    occupancy: Occupancy,
    agents: AgentOccupancy,
    last_heard: BTreeMap<String, Instant>,
    /// Sources whose agents come with their lockstep answers; their ordinary
    /// publications are ignored.
    in_step: BTreeSet<String>,
    time: f64,
}

impl Areas {
    fn state(&self, area: usize, validity: f64) -> CrosswalkOccupancy {
        let occupants: Vec<String> = self.occupancy.occupants(area).iter().cloned().collect();
        CrosswalkOccupancy {
            area: self.net.crosswalks[area].name.clone(),
            occupied: !occupants.is_empty(),
            occupants,
            valid_until: self.time + validity,
        }
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| run(Args::parse()))
}

fn run(args: Args) -> Result<()> {
    if !(args.validity.is_finite() && args.validity > 0.0) {
        bail!(
            "--validity must be a positive number of seconds, got {}",
            args.validity
        );
    }
    if !(args.source_timeout.is_finite() && args.source_timeout > 0.0) {
        bail!(
            "--source-timeout must be a positive number of seconds, got {}",
            args.source_timeout
        );
    }
    args.bus.keys()?;
    let net = args.map.load()?;
    runtime::check_key_names("crosswalk", net.crosswalks.iter().map(|c| c.name.as_str()))?;
    let occupancy = Occupancy::new(net.crosswalks.len());
    let agents = AgentOccupancy::new(&net.crosswalks);
    let areas = Arc::new(Mutex::new(Areas {
        net,
        occupancy,
        agents,
        last_heard: BTreeMap::new(),
        in_step: BTreeSet::new(),
        time: 0.0,
    }));
    let validity = args.validity;
    let timeout = Duration::from_secs_f64(args.source_timeout);
    runtime::tokio_runtime(1)?.block_on(async move {
        let bus = Bus::open_service(&args.bus, Role::Member, "crosswalks").await?;
        let bus = Arc::new(bus);
        let status = areas.clone();
        let map = areas.lock().expect("areas lock").net.fingerprint();
        trafficmesh_bus::check_map(&bus, map).await?;
        trafficmesh_bus::serve_status(
            bus.clone(),
            Some(map),
            Arc::new(move || {
                let a = status.lock().expect("areas lock");
                (
                    a.time,
                    serde_json::json!({
                        "areas": a.net.crosswalks.len(),
                        "occupied": a.occupancy.occupied_areas().len(),
                        "sources": a.last_heard.len(),
                    }),
                )
            }),
        );
        tokio::spawn(take_agents(bus.clone(), areas.clone(), validity));
        tokio::spawn(answer_queries(bus.clone(), areas.clone(), validity));
        let advance = async {
            if args.lockstep {
                let sources = (args.lockstep_sources, timeout);
                follow_lockstep(bus.clone(), areas.clone(), validity, sources).await
            } else {
                follow_clock(bus.clone(), areas.clone(), validity, timeout).await
            }
        };
        tokio::select! {
            r = advance => r?,
            _ = runtime::shutdown_signal() => {}
            e = trafficmesh_bus::another_map(&bus, map) => return Err(e.into()),
        }
        Ok(())
    })
}

async fn publish(bus: &Bus, states: Vec<CrosswalkOccupancy>) {
    for s in states {
        if let Err(e) = bus.publish_at(&topics::OCCUPANCY, &s.area, &s).await {
            tracing::warn!("cannot publish occupancy: {e}");
        }
    }
}

fn poses(batch: &AgentBatch) -> Vec<AgentPose> {
    batch
        .agents
        .iter()
        .map(|a| AgentPose {
            id: a.id.clone(),
            root: a.root.clone(),
            kind: OccupantType::parse(&a.kind),
            footprint: a.footprint.iter().map(|p| DVec2::new(p[0], p[1])).collect(),
        })
        .collect()
}

/// In lockstep: for each tick, the agents of every source in step (asked
/// again until the required ones answered), then the areas that changed go
/// to the stepper with the answer, and on the occupancy keys for everyone else.
async fn follow_lockstep(
    bus: Arc<Bus>,
    areas: Arc<Mutex<Areas>>,
    validity: f64,
    (required, timeout): (Vec<String>, Duration),
) -> Result<()> {
    let key = bus.keys().lockstep_member("crosswalks");
    let sources_key = bus.keys().lockstep_all_agents();
    let mut vouch = Vouch::new(validity);
    bus.answer_ticks(&key, |mut tick| {
        let heartbeat = vouch.due(tick.time);
        let (bus, areas, required, sources_key) = (
            bus.clone(),
            areas.clone(),
            required.clone(),
            sources_key.clone(),
        );
        async move {
            tick.spawn_verdicts.clear();
            let batches = bus
                .lockstep_round_of::<AgentBatch>(&sources_key, &tick, &required, || true)
                .await
                .unwrap_or_default();
            let changed = {
                let mut guard = areas.lock().expect("areas lock");
                let a = &mut *guard;
                a.time = tick.time;
                // Sources that are not in step publish as they please.
                let mut changed = drop_silent(a, timeout);
                for (source, batch) in &batches {
                    if let Some(problem) = batch.agents.iter().find_map(|a| a.problem()) {
                        bus.reject(&bus.keys().lockstep_agents(source), &problem);
                        continue;
                    }
                    a.in_step.insert(source.clone());
                    changed.extend(a.agents.update_source(
                        &a.net.crosswalks,
                        &mut a.occupancy,
                        source,
                        &poses(batch),
                    ));
                }
                changed
                    .into_iter()
                    .map(|i| a.state(i, validity))
                    .collect::<Vec<_>>()
            };
            publish(&bus, changed.clone()).await;
            TickReport::Crosswalks { changed, heartbeat }
        }
    })
    .await?;
    Ok(())
}

/// `agents/*`: each source's full set of agents.
async fn take_agents(bus: Arc<Bus>, areas: Arc<Mutex<Areas>>, validity: f64) {
    let keys = bus.keys().clone();
    let Ok(subscriber) = bus.subscribe(&keys.all_agents()).await else {
        tracing::error!("cannot subscribe to {}", keys.all_agents());
        return;
    };
    while let Ok(sample) = subscriber.recv_async().await {
        let key = sample.key_expr().as_str().to_string();
        let Some(batch) = bus.decode::<AgentBatch>(&sample) else {
            continue;
        };
        if let Some(problem) = batch.agents.iter().find_map(|a| a.problem()) {
            bus.reject(&key, &problem);
            continue;
        }
        let source = Keys::last_chunk(&key).to_string();
        let poses = poses(&batch);
        let changed = {
            let mut guard = areas.lock().expect("areas lock");
            let a = &mut *guard;
            if a.in_step.contains(&source) {
                continue;
            }
            a.last_heard.insert(source.clone(), Instant::now());
            let changed =
                a.agents
                    .update_source(&a.net.crosswalks, &mut a.occupancy, &source, &poses);
            changed.into_iter().map(|i| a.state(i, validity)).collect()
        };
        publish(&bus, changed).await;
    }
}

/// Forgets the sources silent for longer than `timeout` (wall time); returns
/// the areas that changed.
fn drop_silent(a: &mut Areas, timeout: Duration) -> BTreeSet<usize> {
    let silent: Vec<String> = a
        .last_heard
        .iter()
        .filter(|(_, at)| at.elapsed() > timeout)
        .map(|(s, _)| s.clone())
        .collect();
    let mut changed = BTreeSet::new();
    for s in silent {
        tracing::info!("agent source '{s}' went quiet; its agents are gone");
        a.last_heard.remove(&s);
        changed.extend(
            a.agents
                .drop_source(&a.net.crosswalks, &mut a.occupancy, &s),
        );
    }
    changed
}

/// Heartbeats on the stepper's clock, and forgetting silent sources.
async fn follow_clock(
    bus: Arc<Bus>,
    areas: Arc<Mutex<Areas>>,
    validity: f64,
    timeout: Duration,
) -> Result<()> {
    let keys = bus.keys().clone();
    let clock = bus.subscribe(&keys.clock()).await?;
    let heartbeat = bus
        .publisher(keys.crosswalks_heartbeat(), Lane::Reliable)
        .await?;
    let mut vouch = Vouch::new(validity);
    while let Some(c) = bus.next_latest::<Clock>(&clock).await {
        let changed = {
            let mut guard = areas.lock().expect("areas lock");
            let a = &mut *guard;
            a.time = c.time;
            drop_silent(a, timeout)
                .into_iter()
                .map(|i| a.state(i, validity))
                .collect::<Vec<_>>()
        };
        publish(&bus, changed).await;
        if let Some(beat) = vouch.due(c.time) {
            heartbeat.put(&beat).await?;
        }
    }
    Ok(())
}

/// `crosswalks/occupancy/*` (current states) and `crosswalks/blocked_stop`.
async fn answer_queries(bus: Arc<Bus>, areas: Arc<Mutex<Areas>>, validity: f64) {
    let keys = bus.keys().clone();
    let (Ok(states), Ok(blocked)) = (
        bus.queryable(&keys.occupancies()).await,
        bus.queryable(&keys.blocked_stop()).await,
    ) else {
        tracing::error!("cannot declare the crosswalk queryables");
        return;
    };
    loop {
        tokio::select! {
            Ok(query) = states.recv_async() => {
                let all: Vec<CrosswalkOccupancy> = {
                    let a = areas.lock().expect("areas lock");
                    (0..a.net.crosswalks.len()).map(|i| a.state(i, validity)).collect()
                };
                for s in all {
                    bus.reply_at(&query, &keys.occupancy(&s.area), &s).await;
                }
            }
            Ok(query) = blocked.recv_async() => {
                let Some(q) = bus.query_payload::<BlockedStopQuery>(&query).await else { continue };
                if let Some(bad) = trafficmesh_protocol::wire::first_non_finite(&[("x", q.x), ("y", q.y), ("yaw", q.yaw)]) {
                    let reason = format!("{bad} is not a finite number");
                    bus.reject(query.key_expr().as_str(), &reason);
                    bus.reply_error(&query, &reason).await;
                    continue;
                }
                let answer = {
                    let a = areas.lock().expect("areas lock");
                    let hit = try_get_blocked_stop(
                        &a.net.crosswalks,
                        &a.occupancy,
                        DVec2::new(q.x, q.y),
                        DVec2::from_angle(q.yaw),
                    );
                    BlockedStopAnswer {
                        blocked: hit.is_some(),
                        distance: hit.map(|(d, _)| d),
                        area: hit.map(|(_, i)| a.net.crosswalks[i].name.clone()),
                    }
                };
                bus.reply(&query, &answer).await;
            }
        }
    }
}
