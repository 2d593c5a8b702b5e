//! trafficmesh-crosswalks: the ZebraCrossingArea role. Agent footprints from
//! any source become enter/exit events per area (detected types, whitelists,
//! one count per root); occupancy goes out on change with a heartbeat that
//! keeps it valid; the blocked-stop query is answered here.

use std::collections::{BTreeMap, BTreeSet};
use std::process::ExitCode;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use glam::DVec2;
use trafficmesh_bus::{Bus, Vouch, runtime};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{
    AgentBatch, BlockedStopAnswer, BlockedStopQuery, Clock, CrosswalkOccupancy, LockstepTick,
    TickReport,
};
use trafficmesh_service::settings::CrosswalksSettings;
use trafficmesh_service::{Service, ServiceArgs};
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
    service: ServiceArgs,
    #[command(flatten)]
    settings: CrosswalksSettings,
    /// With --lockstep: agent sources no tick is answered without,
    /// comma-separated (e.g. pedestrians); each tick asks every source in
    /// step (<cluster>/lockstep/agents/*) for its agents.
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
    vouch: Vouch,
}

impl Areas {
    fn state(&self, area: usize) -> CrosswalkOccupancy {
        let occupants: Vec<String> = self.occupancy.occupants(area).iter().cloned().collect();
        CrosswalkOccupancy {
            area: self.net.crosswalks[area].name.clone(),
            occupied: !occupants.is_empty(),
            occupants,
            valid_until: self.vouch.valid_until(self.time),
        }
    }
}

struct Crosswalks {
    areas: Mutex<Areas>,
    /// After this long (wall time) a silent source's agents are forgotten.
    source_timeout: Duration,
    /// Sources no lockstep tick is answered without.
    required_sources: Vec<String>,
}

impl Crosswalks {
    fn areas(&self) -> MutexGuard<'_, Areas> {
        self.areas.lock().expect("areas lock")
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| {
        let args = Args::parse();
        trafficmesh_service::check_flags(&args.settings)?;
        let net = args.service.map.load()?;
        runtime::check_key_names("crosswalk", net.crosswalks.iter().map(|c| c.name.as_str()))?;
        let map = net.fingerprint();
        let areas = Areas {
            occupancy: Occupancy::new(net.crosswalks.len()),
            agents: AgentOccupancy::new(&net.crosswalks),
            last_heard: BTreeMap::new(),
            in_step: BTreeSet::new(),
            time: 0.0,
            vouch: Vouch::new(args.settings.validity),
            net,
        };
        let service = Crosswalks {
            areas: Mutex::new(areas),
            source_timeout: Duration::from_secs_f64(args.settings.source_timeout),
            required_sources: args.lockstep_sources,
        };
        trafficmesh_service::run(&args.service, map, service)
    })
}

impl Service for Crosswalks {
    const NAME: &'static str = "crosswalks";
    type Answer = TickReport;

    fn status(&self) -> (f64, serde_json::Value) {
        let a = self.areas();
        (
            a.time,
            serde_json::json!({
                "areas": a.net.crosswalks.len(),
                "occupied": a.occupancy.occupied_areas().len(),
                "sources": a.last_heard.len(),
            }),
        )
    }

    async fn start(self: &Arc<Self>, bus: &Arc<Bus>) -> Result<()> {
        tokio::spawn(take_agents(bus.clone(), self.clone()));
        tokio::spawn(answer_states(bus.clone(), self.clone()));
        tokio::spawn(answer_blocked_stops(bus.clone(), self.clone()));
        Ok(())
    }

    /// Heartbeats on the stepper's clock, and forgetting silent sources.
    async fn on_clock(&self, bus: &Arc<Bus>, c: Clock) -> Result<()> {
        let (changed, beat) = {
            let mut guard = self.areas();
            let a = &mut *guard;
            a.time = c.time;
            let changed: Vec<_> = drop_silent(a, self.source_timeout)
                .into_iter()
                .map(|i| a.state(i))
                .collect();
            (changed, a.vouch.due(c.time))
        };
        publish(bus, changed).await;
        if let Some(beat) = beat {
            bus.publish(&topics::CROSSWALKS_HEARTBEAT, &beat).await?;
        }
        Ok(())
    }

    /// For each tick, the agents of every source in step (asked again until
    /// the required ones answered), then the areas that changed go to the
    /// stepper with the answer, and on the occupancy keys for everyone else.
    async fn on_tick(&self, bus: &Arc<Bus>, mut tick: LockstepTick) -> TickReport {
        let heartbeat = self.areas().vouch.due(tick.time);
        tick.spawn_verdicts.clear();
        let batches = bus
            .lockstep_round_of::<AgentBatch>(
                &bus.keys().key_all(&topics::LOCKSTEP_AGENTS),
                &tick,
                &self.required_sources,
                || true,
            )
            .await
            .unwrap_or_default();
        let changed = {
            let mut guard = self.areas();
            let a = &mut *guard;
            a.time = tick.time;
            // Sources that are not in step publish as they please.
            let mut changed = drop_silent(a, self.source_timeout);
            for (source, batch) in &batches {
                if let Some(problem) = batch.agents.iter().find_map(|a| a.problem()) {
                    bus.reject(
                        &bus.keys().key_at(&topics::LOCKSTEP_AGENTS, source),
                        &problem,
                    );
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
            changed.into_iter().map(|i| a.state(i)).collect::<Vec<_>>()
        };
        publish(bus, changed.clone()).await;
        TickReport::Crosswalks { changed, heartbeat }
    }
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

/// `agents/*`: each source's full set of agents.
async fn take_agents(bus: Arc<Bus>, crosswalks: Arc<Crosswalks>) {
    let Ok(agents) = bus.subscribe_to(&topics::AGENTS).await else {
        tracing::error!("cannot subscribe to the agent sources");
        return;
    };
    while let Some((source, batch)) = agents.next(&bus).await {
        if let Some(problem) = batch.agents.iter().find_map(|a| a.problem()) {
            bus.reject(&bus.keys().key_at(&topics::AGENTS, &source), &problem);
            continue;
        }
        let poses = poses(&batch);
        let changed = {
            let mut guard = crosswalks.areas();
            let a = &mut *guard;
            if a.in_step.contains(&source) {
                continue;
            }
            a.last_heard.insert(source.clone(), Instant::now());
            let changed =
                a.agents
                    .update_source(&a.net.crosswalks, &mut a.occupancy, &source, &poses);
            changed.into_iter().map(|i| a.state(i)).collect()
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

/// `crosswalks/occupancy/*` as a query: every area's current state (late joiners).
async fn answer_states(bus: Arc<Bus>, crosswalks: Arc<Crosswalks>) {
    let keys = bus.keys().clone();
    let Ok(states) = bus.queryable(&keys.key_all(&topics::OCCUPANCY)).await else {
        tracing::error!("cannot declare the occupancy queryable");
        return;
    };
    while let Ok(query) = states.recv_async().await {
        let all: Vec<CrosswalkOccupancy> = {
            let a = crosswalks.areas();
            (0..a.net.crosswalks.len()).map(|i| a.state(i)).collect()
        };
        for s in all {
            bus.reply_at(&query, &keys.key_at(&topics::OCCUPANCY, &s.area), &s)
                .await;
        }
    }
}

/// `crosswalks/blocked_stop`: where a vehicle at a pose must stop for an
/// occupied crosswalk ahead, if anywhere.
async fn answer_blocked_stops(bus: Arc<Bus>, crosswalks: Arc<Crosswalks>) {
    let served = bus
        .serve(&topics::BLOCKED_STOP, |q: BlockedStopQuery| {
            let answer = blocked_stop(&crosswalks.areas(), &q);
            async move { answer }
        })
        .await;
    if let Err(e) = served {
        tracing::error!("cannot serve the blocked-stop query: {e}");
    }
}

fn blocked_stop(a: &Areas, q: &BlockedStopQuery) -> Result<BlockedStopAnswer, String> {
    if let Some(bad) =
        trafficmesh_protocol::wire::first_non_finite(&[("x", q.x), ("y", q.y), ("yaw", q.yaw)])
    {
        return Err(format!("{bad} is not a finite number"));
    }
    let hit = try_get_blocked_stop(
        &a.net.crosswalks,
        &a.occupancy,
        DVec2::new(q.x, q.y),
        DVec2::from_angle(q.yaw),
    );
    Ok(BlockedStopAnswer {
        blocked: hit.is_some(),
        distance: hit.map(|(d, _)| d),
        area: hit.map(|(_, i)| a.net.crosswalks[i].name.clone()),
    })
}
