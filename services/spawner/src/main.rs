//! trafficmesh-spawner: the TrafficManager role. Runs the map's random and
//! route simulators and any external ones, makes the spawn decisions on the
//! stepper's clock and asks the stepper to spawn the winners; keeps the spawn
//! config and the branch statistics, and writes the branch CSV on shutdown.

mod queries;
mod spawn_loop;
mod state;
mod subscriptions;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use anyhow::{Context, Result};
use clap::Parser;
use trafficmesh_bus::{Bus, runtime};
use trafficmesh_protocol::wire::{Clock, LockstepTick, TickReport};
use trafficmesh_service::settings::SpawnerSettings;
use trafficmesh_service::{Service, ServiceArgs};
use trafficmesh_sim::branching::BranchStats;
use trafficmesh_sim::spawn::SpawnRequest;

use crate::state::SpawnerState;

#[derive(Parser)]
#[command(
    name = "trafficmesh-spawner",
    version,
    about = "Spawn decisions, spawn config and branch statistics (the TrafficManager role)",
    after_help = "Usually started by `trafficmesh up`. Keys: see docs/cluster.md."
)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
    /// Random seed of the simulators.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    settings: SpawnerSettings,
}

pub struct Spawner {
    pub state: Mutex<SpawnerState>,
    pub spawn_config_path: PathBuf,
    branch_csv_path: PathBuf,
    /// In lockstep: the last orders and the time they were planned at,
    /// booked when the next question brings their verdicts.
    pending: Mutex<(Vec<SpawnRequest>, f64)>,
    /// A failed spawn query was logged; quiet until one succeeds.
    warned: AtomicBool,
    /// The decisions counted when the CSV was last written, and when.
    stats_saved: Mutex<(u64, std::time::Instant)>,
}

/// Seconds between two writes of the branch-decision CSV while running: a
/// spawner killed without warning loses at most this much of them.
const STATS_SAVE_INTERVAL: std::time::Duration = std::time::Duration::from_secs(5);

impl Spawner {
    /// Writes the branch-decision CSV every few seconds while decisions come
    /// in, off the async workers (atomically: a kill mid-write leaves the
    /// last one whole).
    async fn save_stats_when_due(&self) {
        let csv = {
            let mut saved = self.stats_saved.lock().expect("stats lock");
            if saved.1.elapsed() < STATS_SAVE_INTERVAL {
                return;
            }
            let state = self.state();
            let total = state.stats.total();
            if total == saved.0 {
                return;
            }
            *saved = (total, std::time::Instant::now());
            state.branch_csv()
        };
        let path = self.branch_csv_path.clone();
        let written = tokio::task::spawn_blocking(move || {
            trafficmesh_maps::write_atomic(&path, csv.as_bytes())
        })
        .await;
        if let Ok(Err(e)) = written {
            tracing::warn!("cannot save the branch statistics: {e}");
        }
    }

    pub fn state(&self) -> std::sync::MutexGuard<'_, SpawnerState> {
        self.state.lock().expect("spawner state lock")
    }

    /// Publishes the config in force, for the stepper's branch choices.
    pub async fn publish_config(&self, bus: &Bus) {
        let config = self.state().config.clone();
        if let Err(e) = bus
            .publish(&trafficmesh_protocol::topics::SPAWN_CONFIG, &config)
            .await
        {
            tracing::warn!("cannot publish the spawn config: {e}");
        }
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| {
        let args = Args::parse();
        let (map, service) = build(&args)?;
        trafficmesh_service::run(&args.service, map, service)
    })
}

/// The spawner on its map (and demand), and the map's fingerprint.
fn build(args: &Args) -> Result<(u64, Spawner)> {
    trafficmesh_service::check_flags(&args.settings)?;
    let (map_args, settings) = (&args.service.map, &args.settings);
    let (net, warnings) = map_args.load_with_routes(settings.routes.as_deref(), args.seed)?;
    for w in warnings {
        tracing::warn!("map and demand: {w}");
    }
    let timetable = settings.routes.is_some() || map_args.sumocfg.is_some();
    let max_vehicles = settings
        .max_vehicles
        .unwrap_or(trafficmesh_sim::world::default_max_vehicles(timetable));
    let map = net.fingerprint();
    let mut state = SpawnerState::new(net, args.seed, max_vehicles, settings.spawn_distance_to_ego);
    let path = &settings.spawn_config;
    if path.exists() {
        let config = trafficmesh_maps::load_spawn_config(path)?;
        state
            .set_config(config)
            .map_err(|problems| anyhow::anyhow!("{}: {}", path.display(), problems.join("; ")))?;
        tracing::info!("loaded spawn config {}", path.display());
    }
    // The statistics of the run so far, when a spawner of it wrote them.
    let csv = &settings.branch_csv;
    if csv.exists() {
        let text = std::fs::read_to_string(csv)
            .with_context(|| format!("cannot read {}", csv.display()))?;
        state.stats = BranchStats::from_csv(&state.net, &text).map_err(|e| {
            anyhow::anyhow!(
                "{}: {e}; move it away to start the branch statistics afresh",
                csv.display()
            )
        })?;
        tracing::info!(
            "resumed {} branch decisions from {} (move it away to start afresh)",
            state.stats.total(),
            csv.display()
        );
    }
    let saved = state.stats.total();
    let spawner = Spawner {
        state: Mutex::new(state),
        spawn_config_path: settings.spawn_config.clone(),
        branch_csv_path: settings.branch_csv.clone(),
        pending: Mutex::new((Vec::new(), 0.0)),
        warned: AtomicBool::new(false),
        stats_saved: Mutex::new((saved, std::time::Instant::now())),
    };
    Ok((map, spawner))
}

impl Service for Spawner {
    const NAME: &'static str = "spawner";
    const WORKERS: usize = 2;
    type Answer = TickReport;

    fn status(&self) -> (f64, serde_json::Value) {
        let s = self.state();
        let st = s.manager.stats();
        (
            s.time,
            serde_json::json!({
                "max_vehicles": s.max_vehicles,
                "spawn_distance_to_ego": s.spawn_distance_to_ego,
                "spawned": st.spawned,
                // A timetable's vehicles due and still waiting for room.
                "insertion_backlog": s.manager.backlog(),
                "rejected": {
                    "too_close_to_ego": st.too_close_to_ego,
                    "rate_limited": st.rate_limited,
                    "lost_priority": st.lost_priority,
                    "not_spawnable": st.not_spawnable,
                    "max_vehicles": st.max_vehicles,
                },
                "branch_decisions": s.stats.total(),
            }),
        )
    }

    async fn start(self: &Arc<Self>, bus: &Arc<Bus>) -> Result<()> {
        subscriptions::start(self.clone(), bus).await?;
        queries::start(self.clone(), bus).await?;
        self.publish_config(bus).await;
        Ok(())
    }

    async fn on_clock(&self, bus: &Arc<Bus>, clock: Clock) -> Result<()> {
        spawn_loop::on_clock(self, bus, clock).await;
        self.save_stats_when_due().await;
        Ok(())
    }

    async fn on_tick(&self, bus: &Arc<Bus>, tick: LockstepTick) -> TickReport {
        let report = spawn_loop::on_tick(self, bus, tick).await;
        self.save_stats_when_due().await;
        report
    }

    /// The branch-decision CSV, written whole or not at all.
    fn stop(&self) -> Result<()> {
        let csv = self.state().branch_csv();
        let rows = csv.lines().count().saturating_sub(1);
        trafficmesh_maps::write_atomic(&self.branch_csv_path, csv.as_bytes())?;
        tracing::info!(
            "wrote {rows} branch-decision rows to {}",
            self.branch_csv_path.display()
        );
        Ok(())
    }
}
