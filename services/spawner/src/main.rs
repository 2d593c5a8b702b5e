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
use std::sync::{Arc, Mutex};

use anyhow::Result;
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Role, runtime};
use trafficmesh_service::MapArgs;

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
    bus: BusArgs,
    #[command(flatten)]
    map: MapArgs,
    /// SUMO route file (`.rou.xml`): its vehicles and flows replace the map's simulators.
    #[arg(long, conflicts_with = "sumocfg")]
    routes: Option<PathBuf>,
    /// Random seed of the simulators.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// maxVehicleCount: NPC vehicles alive at once. Default: the AWSIM
    /// reference's 40, and no cap (a million) with --routes or --sumocfg, so
    /// that a timetable's vehicles all depart, as in SUMO.
    #[arg(long)]
    max_vehicles: Option<usize>,
    #[command(flatten)]
    spawn_distance: trafficmesh_service::SpawnDistanceArgs,
    /// Spawn config (the AWSIM reference's traffic_spawn.json): loaded at start if it
    /// exists, and the file that save and load use.
    #[arg(long, default_value = "traffic_spawn.json")]
    spawn_config: PathBuf,
    /// Where the branch-decision CSV is written on shutdown.
    #[arg(long, default_value = "traffic_branch_decisions.csv")]
    branch_csv: PathBuf,
    /// Plan on the stepper's lockstep questions (answers on
    /// <cluster>/lockstep/step/spawner) instead of its clock.
    #[arg(long)]
    lockstep: bool,
}

pub struct Spawner {
    pub bus: Arc<Bus>,
    pub state: Mutex<SpawnerState>,
    pub spawn_config_path: PathBuf,
}

impl Spawner {
    pub fn state(&self) -> std::sync::MutexGuard<'_, SpawnerState> {
        self.state.lock().expect("spawner state lock")
    }

    /// Publishes the config in force, for the stepper's branch choices.
    pub async fn publish_config(&self) {
        let config = self.state().config.clone();
        if let Err(e) = self
            .bus
            .publish(&trafficmesh_protocol::topics::SPAWN_CONFIG, &config)
            .await
        {
            tracing::warn!("cannot publish the spawn config: {e}");
        }
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| run(Args::parse()))
}

fn run(args: Args) -> Result<()> {
    args.bus.keys()?;
    let (net, warnings) = args
        .map
        .load_with_routes(args.routes.as_deref(), args.seed)?;
    for w in warnings {
        tracing::warn!("map and demand: {w}");
    }
    let timetable = args.routes.is_some() || args.map.sumocfg.is_some();
    let max_vehicles = args
        .max_vehicles
        .unwrap_or(trafficmesh_sim::world::default_max_vehicles(timetable));
    let spawn_distance_to_ego = args.spawn_distance.checked().map_err(anyhow::Error::msg)?;
    let mut state = SpawnerState::new(net, args.seed, max_vehicles);
    state.spawn_distance_to_ego = spawn_distance_to_ego;
    if args.spawn_config.exists() {
        let config = trafficmesh_maps::load_spawn_config(&args.spawn_config)?;
        state.set_config(config).map_err(|problems| {
            anyhow::anyhow!("{}: {}", args.spawn_config.display(), problems.join("; "))
        })?;
        tracing::info!("loaded spawn config {}", args.spawn_config.display());
    }
    let rt = runtime::tokio_runtime(2)?;
    rt.block_on(async move {
        let bus = Bus::open_service(&args.bus, Role::Member, "spawner").await?;
        let spawner = Arc::new(Spawner {
            bus: Arc::new(bus),
            state: Mutex::new(state),
            spawn_config_path: args.spawn_config.clone(),
        });
        let map = spawner.state().net.fingerprint();
        trafficmesh_bus::check_map(&spawner.bus, map).await?;
        subscriptions::start(spawner.clone()).await?;
        queries::start(spawner.clone()).await?;
        let status = spawner.clone();
        trafficmesh_bus::serve_status(
            spawner.bus.clone(),
            Some(map),
            Arc::new(move || {
                let s = status.state();
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
            }),
        );
        spawner.publish_config().await;
        if args.lockstep {
            tokio::spawn(spawn_loop::run_in_step(spawner.clone()));
        } else {
            tokio::spawn(spawn_loop::run(spawner.clone()));
        }
        tokio::select! {
            _ = runtime::shutdown_signal() => {}
            e = trafficmesh_bus::another_map(&spawner.bus, map) => return Err(e.into()),
        }
        let csv = spawner.state().branch_csv();
        let rows = csv.lines().count().saturating_sub(1);
        trafficmesh_maps::write_atomic(&args.branch_csv, csv.as_bytes())?;
        tracing::info!(
            "wrote {rows} branch-decision rows to {}",
            args.branch_csv.display()
        );
        Ok(())
    })
}
