//! `trafficmesh bench tick`: tick cost on a full grid, for `perf stat` and reports.

use std::collections::BTreeMap;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::{Args, Subcommand};
use serde::Serialize;
use trafficmesh_maps::{GridOptions, grid_map};
use trafficmesh_sim::populate::populate;

use super::memory::{heap_bytes, resident_bytes};
use super::thread_pool;
use crate::output::print_summary;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Step a generated grid filled with N vehicles and report the tick cost.
    Tick(TickArgs),
    /// Run the whole cluster with N vehicles; tick rate, tick time, batch latency.
    Cluster(super::bench_cluster::ClusterArgs),
    /// The cluster with N vehicles and the admin under a fixed rate of REST requests.
    Admin(super::bench_admin::AdminArgs),
    /// SUMO and trafficmesh on the same SUMO network and routes, side by side.
    VsSumo(super::bench_vs_sumo::VsSumoArgs),
    /// A queue of 20 cars released by a green light: discharge headway and
    /// saturation flow per lane of a driver model.
    Saturation(super::bench_saturation::SaturationArgs),
    /// One four-way intersection (three lanes per approach) under fixed-time
    /// lights and under reservations at the same demands: served vehicles,
    /// delays, collisions.
    Intersection(super::bench_intersection::IntersectionArgs),
    /// The traffic service (gRPC): simulate() latency with N concurrent
    /// sessions of 200 actors each, called at 10 Hz as a runtime calls it.
    TrafficService(super::bench_traffic_service::TrafficServiceArgs),
    /// The bus through a router on loopback: throughput and round trip over
    /// plain TCP, and over the secure profile's TLS with `--tls-dir`.
    Bus(super::bench_bus::BusArgs),
}

#[derive(Args)]
pub struct TickArgs {
    /// Grid size (junctions per side).
    #[arg(long, default_value_t = 40)]
    size: usize,
    /// Vehicles placed before measuring.
    #[arg(long, default_value_t = 10_000)]
    vehicles: usize,
    /// Ticks to measure.
    #[arg(long, default_value_t = 500)]
    ticks: u64,
    /// Simulated seconds to run before measuring, so that queues and junction
    /// interactions reach a steady state (the first seconds are cheaper).
    #[arg(long, default_value_t = 60.0)]
    warmup: f64,
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Also report the time per tick of each phase (spawn, lane index,
    /// cognition, ...) and the share spent on one thread only.
    #[arg(long)]
    phases: bool,
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct TickReport {
    grid: usize,
    vehicles: usize,
    threads: usize,
    warmup_seconds: f64,
    ticks: u64,
    vehicle_steps: u64,
    vehicle_steps_per_sec: f64,
    tick_mean_ms: f64,
    tick_p50_ms: f64,
    tick_p99_ms: f64,
    realtime_factor_at_dt_0_02: f64,
    /// Resident memory added by the vehicles (after warm-up), per vehicle:
    /// an upper figure that also counts the allocator's reserve.
    bytes_per_vehicle: f64,
    /// Heap bytes in use added by the vehicles and the per-tick buffers they
    /// size (after warm-up), per vehicle: the data itself (glibc only).
    #[serde(skip_serializing_if = "Option::is_none")]
    heap_bytes_per_vehicle: Option<f64>,
    /// With --phases: where the tick's time went.
    #[serde(flatten)]
    phases: Option<PhaseReport>,
}

/// Where a tick's time went, per phase (`--phases`).
#[derive(Serialize)]
pub struct PhaseReport {
    /// Milliseconds per tick spent in each phase.
    phase_ms_per_tick: BTreeMap<&'static str, f64>,
    /// The share of the tick spent in phases that run on one thread.
    serial_share: f64,
}

impl PhaseReport {
    /// The world's phase times since timing was enabled.
    pub fn of(world: &trafficmesh_sim::World) -> Self {
        let times = world.phase_times();
        PhaseReport {
            phase_ms_per_tick: times.ms_per_tick().map(|(p, ms)| (p.name(), ms)).collect(),
            serial_share: times.serial_share(),
        }
    }
}

pub fn run(cmd: BenchCommand) -> Result<()> {
    let a = match cmd {
        BenchCommand::Tick(a) => a,
        BenchCommand::Cluster(a) => return super::bench_cluster::run(a),
        BenchCommand::Admin(a) => return super::bench_admin::run(a),
        BenchCommand::VsSumo(a) => return super::bench_vs_sumo::run(a),
        BenchCommand::Saturation(a) => return super::bench_saturation::run(a),
        BenchCommand::Intersection(a) => return super::bench_intersection::run_bench(a),
        BenchCommand::TrafficService(a) => return super::bench_traffic_service::run(a),
        BenchCommand::Bus(a) => return super::bench_bus::run(a),
    };
    if a.size == 0 || a.ticks == 0 {
        bail!("--size and --ticks must be positive");
    }
    if !(a.warmup.is_finite() && a.warmup >= 0.0) {
        bail!(
            "--warmup must be a non-negative number of seconds, got {}",
            a.warmup
        );
    }
    let grid = grid_map(&GridOptions {
        size: a.size,
        ..GridOptions::default()
    });
    let mut world = trafficmesh_sim::populate::empty_world(&grid, a.vehicles)
        .map_err(|p| anyhow::anyhow!("generated grid is invalid: {p:?}"))?;
    // Everything allocated from here on (vehicles, per-tick buffers) counts per vehicle.
    let (rss_map, heap_map) = (resident_bytes(), heap_bytes());
    let placed = populate(&mut world, a.vehicles);
    let pool = thread_pool(a.threads)?;
    let mut durations = Vec::with_capacity(a.ticks as usize);
    let mut vehicle_steps = 0u64;
    pool.install(|| {
        let warmup_ticks = (a.warmup / world.config().dt).round() as u64;
        for _ in 0..warmup_ticks {
            world.step();
            world.drain_events().for_each(drop);
        }
        if a.phases {
            world.phase_times_mut().enable();
        }
        for _ in 0..a.ticks {
            let t = Instant::now();
            world.step();
            durations.push(t.elapsed().as_secs_f64());
            vehicle_steps += world.vehicles().len() as u64;
            world.drain_events().for_each(drop);
        }
    });
    let (rss_traffic, heap_traffic) = (resident_bytes(), heap_bytes());
    let per_vehicle =
        |before: u64, after: u64| after.saturating_sub(before) as f64 / placed.max(1) as f64;
    let total: f64 = durations.iter().sum();
    durations.sort_by(f64::total_cmp);
    let pct = |q: f64| durations[((durations.len() - 1) as f64 * q).round() as usize] * 1e3;
    let report = TickReport {
        grid: a.size,
        vehicles: placed,
        threads: pool.current_num_threads(),
        warmup_seconds: a.warmup,
        ticks: a.ticks,
        vehicle_steps,
        vehicle_steps_per_sec: vehicle_steps as f64 / total,
        tick_mean_ms: total / a.ticks as f64 * 1e3,
        tick_p50_ms: pct(0.5),
        tick_p99_ms: pct(0.99),
        realtime_factor_at_dt_0_02: 0.02 / (total / a.ticks as f64),
        bytes_per_vehicle: per_vehicle(rss_map, rss_traffic),
        heap_bytes_per_vehicle: heap_map.zip(heap_traffic).map(|(a, b)| per_vehicle(a, b)),
        phases: a.phases.then(|| PhaseReport::of(&world)),
    };
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print_summary(&report)?;
    }
    Ok(())
}
