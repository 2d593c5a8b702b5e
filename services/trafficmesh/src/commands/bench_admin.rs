//! `trafficmesh bench admin`: the cluster with N vehicles and the admin, a
//! fixed rate of GET requests from several keep-alive connections, and the
//! stepper's tick rate measured over Zenoh meanwhile.
//!
//! The load is open-loop: each request has a scheduled send time, and its
//! latency runs from that time, so a stalled server is not hidden by the
//! client waiting for it (no coordinated omission).

use std::time::{Duration, Instant};
use trafficmesh_protocol::topics;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;
use trafficmesh_bus::{Bus, BusArgs, Role};
use trafficmesh_protocol::wire::Clock;
use trafficmesh_service::stats::quantile;

use super::bench_up;

#[derive(Args)]
pub struct AdminArgs {
    /// Vehicles placed at start (the spawner keeps the count up).
    #[arg(long, default_value_t = 10_000)]
    vehicles: usize,
    /// Grid size (junctions per side).
    #[arg(long, default_value_t = 40)]
    size: usize,
    /// Requests per second, all connections together.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Keep-alive connections sharing the rate.
    #[arg(long, default_value_t = 16)]
    connections: usize,
    /// Wall seconds of load, after the warm-up.
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// The endpoint requested.
    #[arg(long, default_value = "/api/v1/status")]
    path: String,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Report {
    vehicles: usize,
    path: String,
    rate_target: f64,
    requests: usize,
    errors: usize,
    achieved_rate: f64,
    latency_p50_ms: f64,
    latency_p90_ms: f64,
    latency_p99_ms: f64,
    latency_max_ms: f64,
    ticks_per_sec: f64,
    tick_p99_ms: f64,
    real_time: bool,
}

pub fn run(a: AdminArgs) -> Result<()> {
    if a.size == 0
        || a.vehicles == 0
        || a.connections == 0
        || !(a.rate.is_finite() && a.rate > 0.0)
        || !(a.duration.is_finite() && a.duration > 0.0)
    {
        bail!("--size, --vehicles, --connections, --rate and --duration must be positive");
    }
    let cluster = bench_up::start(a.size, a.vehicles, "", true)?;
    let base = cluster.admin.clone().expect("started with the admin");
    warm_up(&base, a.vehicles).with_context(|| format!("cluster log:\n{}", cluster.log()))?;

    let bus_args = cluster.bus_args();
    let seconds = a.duration;
    let ticks = std::thread::spawn(move || watch_ticks(&bus_args, seconds));
    let (mut latencies, errors, wall) = load(&base, &a);
    let (ticks_per_sec, mut tick_ms) = ticks
        .join()
        .map_err(|_| anyhow::anyhow!("tick watcher panicked"))??;
    drop(cluster);

    let report = Report {
        vehicles: a.vehicles,
        path: a.path.clone(),
        rate_target: a.rate,
        requests: latencies.len(),
        errors,
        achieved_rate: latencies.len() as f64 / wall,
        latency_p50_ms: quantile(&mut latencies, 0.5),
        latency_p90_ms: quantile(&mut latencies, 0.9),
        latency_p99_ms: quantile(&mut latencies, 0.99),
        latency_max_ms: quantile(&mut latencies, 1.0),
        ticks_per_sec,
        tick_p99_ms: quantile(&mut tick_ms, 0.99),
        real_time: ticks_per_sec >= 49.0,
    };
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{} vehicles; GET {} at {:.0}/s over {} connections: {} requests ({:.0}/s), {} errors, latency p50 {:.2} ms p90 {:.2} ms p99 {:.2} ms max {:.2} ms; stepper {:.1} ticks/s ({}), tick p99 {:.2} ms",
            report.vehicles,
            report.path,
            report.rate_target,
            a.connections,
            report.requests,
            report.achieved_rate,
            report.errors,
            report.latency_p50_ms,
            report.latency_p90_ms,
            report.latency_p99_ms,
            report.latency_max_ms,
            report.ticks_per_sec,
            if report.real_time {
                "real time"
            } else {
                "NOT real time"
            },
            report.tick_p99_ms
        );
    }
    Ok(())
}

/// Until the admin reports the cluster healthy with most vehicles placed.
fn warm_up(base: &str, vehicles: usize) -> Result<()> {
    let deadline = Instant::now() + Duration::from_secs(180);
    loop {
        if let Ok(mut r) = ureq::get(format!("{base}/api/v1/status")).call() {
            let s: serde_json::Value = r.body_mut().read_json()?;
            let placed = s["vehicles"].as_u64().unwrap_or(0) as usize;
            if s["degraded"] == false && placed * 10 >= vehicles * 9 {
                return Ok(());
            }
        }
        if Instant::now() > deadline {
            bail!("the admin did not report {vehicles} vehicles within 180 s");
        }
        std::thread::sleep(Duration::from_millis(250));
    }
}

/// Every latency (ms, from the scheduled send time), the error count, and the wall time.
fn load(base: &str, a: &AdminArgs) -> (Vec<f64>, usize, f64) {
    let start = Instant::now() + Duration::from_millis(100);
    let total = (a.rate * a.duration) as usize;
    let interval = Duration::from_secs_f64(1.0 / a.rate);
    let workers: Vec<_> = (0..a.connections)
        .map(|c| {
            let url = format!("{base}{}", a.path);
            let connections = a.connections;
            std::thread::spawn(move || {
                let agent: ureq::Agent = ureq::Agent::config_builder()
                    .timeout_global(Some(Duration::from_secs(10)))
                    .build()
                    .into();
                let (mut latencies, mut errors) = (Vec::new(), 0);
                for k in (c..total).step_by(connections) {
                    let scheduled = start + interval * k as u32;
                    if let Some(wait) = scheduled.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                    match agent.get(&url).call() {
                        Ok(mut r) if r.status() == 200 => {
                            let _ = r.body_mut().read_to_vec();
                            latencies.push(scheduled.elapsed().as_secs_f64() * 1e3);
                        }
                        _ => errors += 1,
                    }
                }
                (latencies, errors)
            })
        })
        .collect();
    let (mut all, mut errors) = (Vec::with_capacity(total), 0);
    for w in workers {
        if let Ok((l, e)) = w.join() {
            all.extend(l);
            errors += e;
        }
    }
    (all, errors, start.elapsed().as_secs_f64())
}

/// Ticks per second and tick durations seen on the bus for `seconds`.
fn watch_ticks(args: &BusArgs, seconds: f64) -> Result<(f64, Vec<f64>)> {
    trafficmesh_bus::runtime::tokio_runtime(1)?.block_on(async {
        let bus = Bus::open(args, Role::Member, "bench").await?;
        let clock = bus.subscribe(&bus.keys().key(&topics::CLOCK)).await?;
        let start = Instant::now();
        let end = start + Duration::from_secs_f64(seconds);
        let (mut first, mut last, mut tick_ms) = (None, 0u64, Vec::new());
        while Instant::now() < end {
            tokio::select! {
                Ok(s) = clock.recv_async() => {
                    if let Ok(c) = serde_json::from_slice::<Clock>(&s.payload().to_bytes()) {
                        first.get_or_insert(c.tick);
                        last = c.tick;
                        tick_ms.push(c.tick_ms);
                    }
                }
                _ = tokio::time::sleep_until(end.into()) => {}
            }
        }
        let ticks = last.saturating_sub(first.unwrap_or(last)) as f64;
        Ok((ticks / start.elapsed().as_secs_f64(), tick_ms))
    })
}
