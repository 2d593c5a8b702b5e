//! `trafficmesh sim`: the headless runner.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use trafficmesh_model::{DriverModel, NpcVehicleConfig};
use trafficmesh_sim::motion_check::MotionCheck;
use trafficmesh_sim::{DespawnReason, SimEvent, TripRecord, World, WorldConfig};

use super::thread_pool;
use crate::output;

#[derive(Args)]
pub struct SimArgs {
    /// SUMO route file (`.rou.xml`): its vehicles and flows replace the map's simulators.
    #[arg(long, conflicts_with = "sumocfg")]
    routes: Option<PathBuf>,
    /// Map file: native `.map.json` (make one with `trafficmesh gen-grid`), SUMO
    /// `.net.xml` or Lanelet2 `.osm`.
    #[arg(long, required_unless_present = "sumocfg", conflicts_with = "sumocfg")]
    map: Option<PathBuf>,
    /// A SUMO scenario as shipped (`.sumocfg`): its network, route files and
    /// additional files (signal programs, vehicle types), and its begin/end.
    #[arg(long)]
    sumocfg: Option<PathBuf>,
    /// Simulated seconds to run. With --sumocfg it defaults to the
    /// configuration's end; with --sumocfg or --routes, else to when every
    /// vehicle has arrived (at most a day).
    #[arg(
        long,
        allow_negative_numbers = true,
        required_unless_present_any = ["sumocfg", "routes"]
    )]
    duration: Option<f64>,
    /// Random seed: same map, config and seed give the same trajectories.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Spawn rates and branch weights (the AWSIM reference's traffic_spawn.json format).
    #[arg(long)]
    spawn_config: Option<PathBuf>,
    /// Maximum simultaneous NPC vehicles (the AWSIM reference's
    /// maxVehicleCount, 40). With --routes or --sumocfg there is no cap unless
    /// one is given: a timetable's vehicles all depart, as in SUMO.
    #[arg(long)]
    max_vehicles: Option<usize>,
    /// Worker threads (0 = one per core). Results do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Tick length, seconds [default: 0.02 with `awsim` drivers, the
    /// reference's 50 Hz; 0.1 with `realistic` ones, IDM's usual step].
    #[arg(long, allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Directory for trips.csv, traffic_branch_decisions.csv and traffic_spawn.json.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print one JSON object with the run's figures on stdout.
    #[arg(long)]
    json: bool,
    /// Seconds a queue head may stand still (not at a red light) before it is
    /// moved to the next lane of its way with room, or taken off the road, and
    /// counted (SUMO's time-to-teleport); 0 never does.
    #[arg(long, default_value_t = trafficmesh_sim::world::DEFAULT_JAM_TIMEOUT, allow_negative_numbers = true)]
    jam_timeout: f64,
    /// Driver model of vehicle types that do not choose their own: `awsim` (the
    /// AWSIM reference's speed modes) or `realistic` (IDM car following).
    /// Default: realistic for SUMO networks, awsim for other maps.
    #[arg(long)]
    driver_model: Option<DriverModel>,
    #[command(flatten)]
    vehicle: trafficmesh_service::VehicleArgs,
    #[command(flatten)]
    spawn_distance: trafficmesh_service::SpawnDistanceArgs,
    /// Built-in walkers and cyclists starting across each crosswalk per minute
    /// (the cluster's pedestrians service, run in this process; a fifth of
    /// them cyclists, deterministic by seed); 0 = none.
    #[arg(long, default_value_t = trafficmesh_sim::pedestrians::PedestrianConfig::default().per_minute, allow_negative_numbers = true)]
    pedestrians: f64,
    /// Check every tick's motion as a viewer of the vehicle batch would:
    /// poses that move further than speed x dt + 5 cm, headings that turn
    /// faster than a 4 m turning radius allows, overlapping bodies, speeds
    /// over the limit in force. Counts and first examples go in the summary
    /// (`check`); slower.
    #[arg(long)]
    check: bool,
    /// Also report the wall time per tick of each phase (spawn, lane index,
    /// cognition, ...) and the share spent on one thread only.
    #[cfg(feature = "bench")]
    #[arg(long)]
    phases: bool,
}

#[derive(Serialize)]
struct Summary {
    map: String,
    driver_model: &'static str,
    /// The NPCVehicleConfig in force.
    vehicle_config: NpcVehicleConfig,
    seed: u64,
    threads: usize,
    dt: f64,
    ticks: u64,
    simulated_seconds: f64,
    wall_seconds: f64,
    vehicle_steps: u64,
    vehicle_steps_per_sec: f64,
    mean_vehicles: f64,
    max_vehicles: usize,
    spawned: u64,
    despawned: u64,
    /// Vehicles that entered the road (the same as `spawned`, in SUMO's word).
    inserted: u64,
    /// Vehicles that reached the end of their route or of the road.
    arrived: u64,
    /// Vehicles due to depart still waiting for room at the end.
    insertion_backlog: usize,
    /// The longest standstill of any vehicle, seconds.
    max_wait_s: f64,
    /// Vehicles standing for 60 s or more at the end, not at a red light.
    stuck_vehicles: usize,
    /// The same, counted at the start of each simulated minute and averaged.
    stuck_vehicles_mean: f64,
    /// Jammed vehicles moved on (or, with no room ahead, taken off the road)
    /// by `--jam-timeout` or to break a gridlock.
    jam_resolutions: u64,
    /// Of those, the ones taken off the road.
    jam_removals: u64,
    /// Of those, the ones moved to break a gridlock before the timeout.
    gridlocks_broken: u64,
    /// Gridlocks let squeeze past bodies beside their way first.
    gridlocks_squeezed: u64,
    /// Front bumpers that went 0.5 m past a stop line more than 0.5 s into red.
    red_light_crossings: u64,
    branch_decisions: u64,
    trajectory_hash: String,
    /// With --check: what the motion checks found.
    #[serde(skip_serializing_if = "Option::is_none")]
    check: Option<serde_json::Value>,
    /// With --phases: where the tick's time went.
    #[cfg(feature = "bench")]
    #[serde(flatten)]
    phases: Option<super::bench::PhaseReport>,
}

/// The longest a run to the end of its demand goes on, simulated seconds.
const UNTIL_DONE_LIMIT: f64 = 86_400.0;

/// The network and its warnings, from --sumocfg or --map (and --routes), and
/// the run's length: given, the configuration's, or until the demand is done.
fn load(a: &SimArgs) -> Result<(trafficmesh_sim::LaneNetwork, Vec<String>, Option<f64>)> {
    if let Some(cfg) = &a.sumocfg {
        let (net, warnings, config) = trafficmesh_service::load_scenario_network(cfg, a.seed)?;
        let window = config.end.map(|end| end - config.begin);
        return Ok((net, warnings, a.duration.or(window)));
    }
    let map = a
        .map
        .as_deref()
        .expect("clap requires --map without --sumocfg");
    let (net, warnings) = trafficmesh_service::load_network_with_routes(map, a.routes.as_deref())?;
    Ok((net, warnings, a.duration))
}

pub fn run(a: SimArgs) -> Result<()> {
    if let Some(d) = a.duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration must be a positive number of seconds, got {d}");
    }
    if !(a.jam_timeout.is_finite() && a.jam_timeout >= 0.0) {
        bail!(
            "--jam-timeout must be 0 (never) or a positive number of seconds, got {}",
            a.jam_timeout
        );
    }
    if !(a.pedestrians.is_finite() && a.pedestrians >= 0.0) {
        bail!(
            "--pedestrians must be a number of crossings per minute >= 0, got {}",
            a.pedestrians
        );
    }
    trafficmesh_service::check_flags(&a.spawn_distance)?;
    let spawn_distance_to_ego = a.spawn_distance.spawn_distance_to_ego;
    if let Some(dt) = a.dt
        && !(dt.is_finite() && dt > 0.0 && dt <= 1.0)
    {
        bail!("--dt must be in (0, 1] seconds, got {dt}");
    }
    let map_path = a
        .sumocfg
        .as_deref()
        .or(a.map.as_deref())
        .expect("clap requires one");
    let vehicle = a.vehicle.apply(
        NpcVehicleConfig {
            driver_model: a
                .driver_model
                .unwrap_or_else(|| trafficmesh_maps::default_driver_model(map_path)),
            ..NpcVehicleConfig::default()
        },
        map_path,
    );
    vehicle.validate().map_err(anyhow::Error::msg)?;
    let dt = a.dt.unwrap_or(vehicle.driver_model.default_tick());
    let (net, warnings, duration) = load(&a)?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    let config = WorldConfig {
        seed: a.seed,
        max_vehicles: a
            .max_vehicles
            .unwrap_or(trafficmesh_sim::world::default_max_vehicles(
                a.routes.is_some() || a.sumocfg.is_some(),
            )),
        dt,
        vehicle,
        jam_timeout: a.jam_timeout,
        spawn_distance_to_ego,
        ..WorldConfig::default()
    };
    let mut world = World::new(net, config);
    if a.pedestrians > 0.0 {
        world.enable_pedestrians(trafficmesh_sim::pedestrians::PedestrianConfig {
            per_minute: a.pedestrians,
            ..Default::default()
        });
    }
    if let Some(path) = &a.spawn_config {
        let config = trafficmesh_maps::load_spawn_config(path)?;
        world
            .set_spawn_config(config)
            .with_context(|| format!("{}", path.display()))?;
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let pool = thread_pool(a.threads)?;
    // Without a length, run until every vehicle has arrived.
    let until_done = duration.is_none();
    let ticks = (duration.unwrap_or(UNTIL_DONE_LIMIT) / dt).round() as u64;
    let progress = ProgressBar::new(ticks).with_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}% sim {msg} eta {eta}")
            .expect("valid template"),
    );

    let mut trips: Vec<TripRecord> = Vec::new();
    let (mut vehicle_steps, mut peak, mut spawned, mut despawned) = (0u64, 0usize, 0u64, 0u64);
    let mut arrived = 0u64;
    let mut check = a.check.then(MotionCheck::default);
    #[cfg(feature = "bench")]
    if a.phases {
        world.phase_times_mut().enable();
    }
    let started = Instant::now();
    pool.install(|| {
        for tick in 0..ticks {
            if tick + 1 == ticks {
                world.log_stuck_vehicles_next_tick();
            }
            world.step();
            if let Some(check) = &mut check {
                check.observe(&world);
            }
            let n = world.vehicles().len();
            vehicle_steps += n as u64;
            peak = peak.max(n);
            for event in world.drain_events() {
                match event {
                    SimEvent::Spawned { .. } => spawned += 1,
                    SimEvent::Despawned(trip) => {
                        despawned += 1;
                        if matches!(
                            trip.reason,
                            DespawnReason::RouteEnd | DespawnReason::DeadEnd
                        ) {
                            arrived += 1;
                        }
                        trips.push(trip);
                    }
                    _ => {}
                }
            }
            if until_done && tick > 0 && world.demand_done() {
                break;
            }
            if tick.is_multiple_of(250) {
                progress.set_position(tick);
                progress.set_message(format!("{:.0}s, {n} vehicles", world.time()));
            }
        }
    });
    progress.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();

    if let Some(dir) = &a.out {
        output::write_trips(&dir.join("trips.csv"), &trips, &world)?;
        trafficmesh_maps::write_atomic(
            &dir.join("traffic_branch_decisions.csv"),
            world.branch_csv().as_bytes(),
        )?;
        trafficmesh_maps::save_spawn_config(
            &dir.join("traffic_spawn.json"),
            &world.spawn_config(),
        )?;
    }
    let waits = world.wait_stats();
    let summary = Summary {
        map: a
            .sumocfg
            .as_ref()
            .or(a.map.as_ref())
            .map(|p| p.display().to_string())
            .unwrap_or_default(),
        driver_model: world.config().vehicle.driver_model.name(),
        vehicle_config: world.config().vehicle,
        seed: a.seed,
        threads: pool.current_num_threads(),
        dt,
        ticks: world.ticks(),
        simulated_seconds: world.time(),
        wall_seconds: wall,
        vehicle_steps,
        vehicle_steps_per_sec: vehicle_steps as f64 / wall.max(1e-9),
        mean_vehicles: vehicle_steps as f64 / world.ticks().max(1) as f64,
        max_vehicles: peak,
        spawned,
        despawned,
        inserted: spawned,
        arrived,
        insertion_backlog: world.insertion_backlog(),
        max_wait_s: waits.max_wait,
        stuck_vehicles: world.stuck_vehicles(),
        stuck_vehicles_mean: waits.stuck_mean(),
        jam_resolutions: waits.jam_resolutions,
        jam_removals: waits.jam_removals,
        gridlocks_broken: waits.gridlocks_broken,
        gridlocks_squeezed: waits.gridlocks_squeezed,
        red_light_crossings: world.red_light_crossings(),
        branch_decisions: world.branch_stats().map_or(0, |s| s.total()),
        trajectory_hash: format!("{:016x}", world.trajectory_hash()),
        check: check.as_ref().map(output::check_report),
        #[cfg(feature = "bench")]
        phases: a.phases.then(|| super::bench::PhaseReport::of(&world)),
    };
    if a.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        output::print_summary(&summary)?;
    }
    Ok(())
}
