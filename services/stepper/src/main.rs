//! trafficmesh-stepper: owns simulation time. Each tick it applies what arrived
//! from the bus (spawn requests, removals, light and crosswalk states, the ego),
//! steps the world of `shared/sim` and publishes the clock, the vehicle batch
//! and the events.

mod commands;
mod inputs;
mod intersections;
mod lockstep;
mod snapshots;
mod telemetry;
mod tick_loop;

use std::process::ExitCode;
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Role, runtime};
use trafficmesh_service::MapArgs;
use trafficmesh_service::settings::StepperSettings;
use trafficmesh_sim::{World, WorldConfig};

#[derive(Parser)]
#[command(
    name = "trafficmesh-stepper",
    version,
    about = "Steps every NPC vehicle each tick and publishes the clock, vehicle states and events",
    after_help = "Usually started by `trafficmesh up`. Keys: see docs/cluster.md."
)]
pub struct Args {
    #[command(flatten)]
    bus: BusArgs,
    #[command(flatten)]
    map: MapArgs,
    /// Random seed of the vehicles' branch choices.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    settings: StepperSettings,
    /// Worker threads for the vehicle pipeline (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    #[command(flatten)]
    vehicle: trafficmesh_service::VehicleArgs,
    /// Start each tick only when the lockstep members (every process answering
    /// on <cluster>/lockstep/step/*) have answered for it: deterministic at any
    /// speed, the same trajectories as `sim`. `trafficmesh up` turns it on with
    /// `--speed 0`.
    #[arg(long)]
    lockstep: bool,
    /// With --lockstep: members no tick starts without, comma-separated
    /// (e.g. lights,crosswalks,spawner); others are waited for while they answer.
    #[arg(long, value_delimiter = ',', requires = "lockstep")]
    lockstep_members: Vec<String>,
}

fn main() -> ExitCode {
    runtime::main_with(|| run(Args::parse()))
}

fn run(args: Args) -> Result<()> {
    let settings = &args.settings;
    trafficmesh_service::check_flags(settings)?;
    args.bus.keys()?;
    let net = args.map.load()?;
    let driver_model = settings
        .driver_model()
        .unwrap_or_else(|| trafficmesh_maps::default_driver_model(args.map.path()));
    let config = WorldConfig {
        seed: args.seed,
        dt: settings.dt,
        jam_timeout: settings.jam_timeout,
        vehicle: args.vehicle.apply(
            trafficmesh_model::NpcVehicleConfig {
                driver_model,
                ..Default::default()
            },
            args.map.path(),
        ),
        // The spawner's request carries the maximum; the world's own is unused.
        max_vehicles: usize::MAX,
        ..WorldConfig::default()
    };
    config.vehicle.validate().map_err(anyhow::Error::msg)?;
    // Lights come from the lights service: red until it vouches for them.
    let mut world = World::new(net, config).without_simulators();
    world.use_remote_lights();
    let resumed = match &settings.snapshot {
        Some(path) => snapshots::load(path)?
            .map(|snapshot| {
                world.restore(&snapshot).with_context(|| {
                    format!(
                        "cannot resume from {}; move it away to start from an empty road",
                        path.display()
                    )
                })?;
                anyhow::Ok(snapshot)
            })
            .transpose()?,
        None => None,
    };
    if settings.populate > 0 && resumed.is_none() {
        let placed = trafficmesh_sim::populate::populate(&mut world, settings.populate);
        tracing::info!("placed {placed} vehicles");
    }
    let saver = settings
        .snapshot
        .clone()
        .map(|path| snapshots::Saver::start(path, settings.snapshot_every, world.time()))
        .transpose()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .context("cannot start worker threads")?;
    let rt = runtime::tokio_runtime(2)?;
    rt.block_on(async move {
        let bus = Bus::open_service(&args.bus, Role::Hub, "stepper").await?;
        let bus = Arc::new(bus);
        let (tx, rx) = std::sync::mpsc::channel();
        let shared = Arc::new(inputs::Shared::default());
        {
            let mut s = shared.status.lock().expect("status lock");
            s.vehicle_config = world.config().vehicle;
            s.lockstep = args.lockstep;
        }
        if !world.network().reservation_junctions.is_empty() {
            world.use_intersection_manager(Box::new(intersections::RemoteIntersections::new(
                bus.clone(),
                tokio::runtime::Handle::current(),
                shared.clone(),
            )));
        }
        inputs::start(bus.clone(), tx.clone()).await?;
        let outputs = telemetry::start(bus.clone()).await?;
        let status = shared.clone();
        let map = Some(world.network().fingerprint());
        trafficmesh_bus::serve_status(bus.clone(), map, Arc::new(move || status.status()));
        if let Some(snapshot) = &resumed {
            let seen = cluster_time(&bus).await;
            let lost = seen.map(|t| ((t - snapshot.time) / world.config().dt).round().max(0.0) as u64);
            match (seen, lost) {
                (Some(seen), Some(lost)) => tracing::info!(
                    "resumed from the snapshot of tick {} (t={:.2} s, {} vehicles); the cluster had seen t={seen:.2} s: {lost} ticks lost",
                    snapshot.tick,
                    snapshot.time,
                    snapshot.vehicles.len()
                ),
                _ => tracing::info!(
                    "resumed from the snapshot of tick {} (t={:.2} s, {} vehicles); no other service says how far the cluster had come",
                    snapshot.tick,
                    snapshot.time,
                    snapshot.vehicles.len()
                ),
            }
            let mut s = shared.status.lock().expect("status lock");
            s.resumed_from_tick = Some(snapshot.tick);
            s.ticks_lost = lost;
        }
        inputs::fetch_late_states(&bus, &tx).await;
        inputs::catch_up_while_stale(bus.clone(), tx.clone(), shared.clone());
        let lockstep = args.lockstep.then(|| {
            tracing::info!(
                "lockstep: each tick waits for {}",
                if args.lockstep_members.is_empty() {
                    "whoever answers".to_string()
                } else {
                    args.lockstep_members.join(", ")
                }
            );
            lockstep::Lockstep::new(
                bus.clone(),
                tokio::runtime::Handle::current(),
                args.lockstep_members.clone(),
            )
        });
        let pacing = tick_loop::Pacing {
            speed: args.settings.speed,
            duration: args.settings.duration,
            lockstep,
            saver,
        };
        // In place before the tick thread announces anything.
        let signal = runtime::shutdown_signal();
        let tick_bus = bus.clone();
        let handle = std::thread::Builder::new()
            .name("tick".into())
            .spawn(move || {
                pool.install(|| tick_loop::run(world, rx, tick_bus, outputs, pacing, shared))
            })
            .context("cannot start the tick thread")?;
        tokio::select! {
            _ = signal => {
                let _ = tx.send(commands::Input {
                    key: String::new(),
                    command: commands::Command::Stop,
                });
            }
            _ = wait_thread(&handle) => {}
        }
        tokio::task::spawn_blocking(move || handle.join())
            .await
            .ok();
        Ok(())
    })
}

/// The latest simulation time any other service has seen, asked for up to
/// two seconds (they come back to a restarted stepper one by one).
async fn cluster_time(bus: &Bus) -> Option<f64> {
    let key = bus.keys().key_all(&trafficmesh_protocol::topics::STATUS);
    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(2);
    loop {
        let statuses = bus
            .get_each::<trafficmesh_protocol::wire::ServiceStatus>(
                &key,
                std::time::Duration::from_millis(300),
            )
            .await
            .unwrap_or_default();
        let seen = statuses
            .iter()
            .filter(|s| s.service != "stepper" && s.time > 0.0)
            .map(|s| s.time)
            .reduce(f64::max);
        if seen.is_some() || tokio::time::Instant::now() >= deadline {
            return seen;
        }
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }
}

async fn wait_thread(handle: &std::thread::JoinHandle<()>) {
    while !handle.is_finished() {
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
}
