//! `trafficmesh bench cluster`: the whole cluster on this machine (via `up`)
//! with N vehicles on a generated grid (real time, or as fast as possible in
//! lockstep), measured from another process over
//! Zenoh: tick rate, tick duration, and latency from the stepper's
//! publication of a batch to its arrival here; plus what encoding a batch costs.

use std::time::{Duration, Instant};
use trafficmesh_protocol::topics;

use anyhow::{Context, Result, bail};

use super::bench_up;
use clap::Args;
use serde::Serialize;
use trafficmesh_bus::{Bus, BusArgs, Role};
use trafficmesh_protocol::wire::{Clock, VehicleBatch};
use trafficmesh_service::stats::quantile;

#[derive(Args)]
pub struct ClusterArgs {
    /// Vehicles placed at start (the spawner keeps the count up).
    #[arg(long, default_value_t = 10_000)]
    vehicles: usize,
    /// Wall seconds measured, after the warm-up.
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// Grid size (junctions per side).
    #[arg(long, default_value_t = 40)]
    size: usize,
    /// The stepper's speed: simulation seconds per wall second, 0 = as fast
    /// as possible (in lockstep with the other services, as `up` runs it).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// Lockstep at any speed (each tick waits for lights, crosswalks, spawner).
    #[arg(long)]
    lockstep: bool,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Report {
    vehicles: usize,
    speed: f64,
    lockstep: bool,
    seconds: f64,
    ticks_per_sec: f64,
    /// At least 50 ticks a wall second (dt 0.02 s).
    real_time: bool,
    tick_p50_ms: f64,
    tick_p99_ms: f64,
    batches_received: usize,
    batches_per_sec: f64,
    batch_latency_p50_ms: f64,
    batch_latency_p99_ms: f64,
    /// The batch as published (binary, see `vehicle_codec`).
    batch_bytes: usize,
    binary_encode_ms: f64,
    binary_decode_ms: f64,
    /// The same batch as JSON, for the comparison that chose the encoding.
    json_bytes: usize,
    json_encode_ms: f64,
    json_decode_ms: f64,
}

pub fn run(a: ClusterArgs) -> Result<()> {
    if a.size == 0 || a.vehicles == 0 || !(a.duration.is_finite() && a.duration > 0.0) {
        bail!("--size, --vehicles and --duration must be positive");
    }
    if !(a.speed.is_finite() && a.speed >= 0.0) {
        bail!("--speed must be 0 (as fast as possible) or a positive factor");
    }
    let lockstep = a.lockstep || a.speed == 0.0;
    let stepper = format!("speed = {}\nlockstep = {lockstep}", a.speed);
    let cluster = bench_up::start(a.size, a.vehicles, &stepper, false)?;
    let report = measure(&a, &cluster.bus_args())
        .with_context(|| format!("cluster log:\n{}", cluster.log()))?;
    drop(cluster);
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{} vehicles, speed {}{}, {:.1} s: {:.1} ticks/s ({}), tick p50 {:.2} ms p99 {:.2} ms; {} batches ({:.1}/s), latency p50 {:.2} ms p99 {:.2} ms; batch {} bytes binary (encode {:.2} ms, decode {:.2} ms), {} bytes as JSON (encode {:.2} ms, decode {:.2} ms)",
            report.vehicles,
            report.speed,
            if report.lockstep { " in lockstep" } else { "" },
            report.seconds,
            report.ticks_per_sec,
            if report.real_time {
                "real time"
            } else {
                "NOT real time"
            },
            report.tick_p50_ms,
            report.tick_p99_ms,
            report.batches_received,
            report.batches_per_sec,
            report.batch_latency_p50_ms,
            report.batch_latency_p99_ms,
            report.batch_bytes,
            report.binary_encode_ms,
            report.binary_decode_ms,
            report.json_bytes,
            report.json_encode_ms,
            report.json_decode_ms
        );
    }
    Ok(())
}

fn measure(a: &ClusterArgs, args: &BusArgs) -> Result<Report> {
    trafficmesh_bus::runtime::tokio_runtime(1)?.block_on(async {
        let bus = Bus::open(args, Role::Member, "bench").await?;
        let keys = bus.keys().clone();
        let vehicles = bus.subscribe(&keys.key(&topics::VEHICLES)).await?;
        let clock = bus.subscribe(&keys.key(&topics::CLOCK)).await?;
        // Warm-up: the map loaded and the vehicles placed.
        let warm = Instant::now() + Duration::from_secs(120);
        loop {
            if Instant::now() > warm {
                bail!("no vehicle batches within 120 s");
            }
            if let Ok(Ok(s)) =
                tokio::time::timeout(Duration::from_secs(1), vehicles.recv_async()).await
            {
                let b = VehicleBatch::decode(&s.payload().to_bytes())?;
                if b.vehicles.len() * 10 >= a.vehicles * 9 {
                    break;
                }
            }
        }
        while let Ok(Some(_)) = clock.try_recv() {}
        while let Ok(Some(_)) = vehicles.try_recv() {}
        let start = Instant::now();
        let end = start + Duration::from_secs_f64(a.duration);
        let (mut latencies, mut ticks_ms) = (Vec::new(), Vec::new());
        let (mut first_tick, mut last_tick) = (None, 0u64);
        let mut sample_batch: Option<Vec<u8>> = None;
        while Instant::now() < end {
            tokio::select! {
                Ok(s) = vehicles.recv_async() => {
                    let now = trafficmesh_bus::runtime::unix_micros();
                    let bytes = s.payload().to_bytes();
                    let b = VehicleBatch::decode(&bytes)?;
                    latencies.push(now.saturating_sub(b.sent_unix_us) as f64 / 1e3);
                    if sample_batch.is_none() { sample_batch = Some(bytes.into_owned()); }
                }
                Ok(s) = clock.recv_async() => {
                    if let Ok(c) = serde_json::from_slice::<Clock>(&s.payload().to_bytes()) {
                        ticks_ms.push(c.tick_ms);
                        first_tick.get_or_insert(c.tick);
                        last_tick = c.tick;
                    }
                }
                _ = tokio::time::sleep_until(end.into()) => {}
            }
        }
        let seconds = start.elapsed().as_secs_f64();
        let ticks = last_tick.saturating_sub(first_tick.unwrap_or(last_tick)) as f64;
        let cost = encoding_cost(sample_batch.as_deref())?;
        let ticks_per_sec = ticks / seconds;
        Ok(Report {
            vehicles: a.vehicles,
            speed: a.speed,
            lockstep: a.lockstep || a.speed == 0.0,
            seconds,
            ticks_per_sec,
            real_time: ticks_per_sec >= 49.0,
            tick_p50_ms: quantile(&mut ticks_ms, 0.5),
            tick_p99_ms: quantile(&mut ticks_ms, 0.99),
            batches_received: latencies.len(),
            batches_per_sec: latencies.len() as f64 / seconds,
            batch_latency_p50_ms: quantile(&mut latencies, 0.5),
            batch_latency_p99_ms: quantile(&mut latencies, 0.99),
            batch_bytes: cost.binary.bytes,
            binary_encode_ms: cost.binary.encode_ms,
            binary_decode_ms: cost.binary.decode_ms,
            json_bytes: cost.json.bytes,
            json_encode_ms: cost.json.encode_ms,
            json_decode_ms: cost.json.decode_ms,
        })
    })
}

struct Cost {
    bytes: usize,
    encode_ms: f64,
    decode_ms: f64,
}

struct Costs {
    binary: Cost,
    json: Cost,
}

/// Median time to encode and decode one received batch, binary and JSON, in
/// this process.
fn encoding_cost(sample: Option<&[u8]>) -> Result<Costs> {
    let Some(bytes) = sample else {
        let nan = || Cost {
            bytes: 0,
            encode_ms: f64::NAN,
            decode_ms: f64::NAN,
        };
        return Ok(Costs {
            binary: nan(),
            json: nan(),
        });
    };
    let batch = VehicleBatch::decode(bytes)?;
    let binary = time_codec(|| batch.encode(), |b| Ok(VehicleBatch::decode(b)?))?;
    let json = time_codec(
        || serde_json::to_vec(&batch).expect("wire types serialise"),
        |b| Ok(serde_json::from_slice(b)?),
    )?;
    Ok(Costs { binary, json })
}

fn time_codec(
    encode: impl Fn() -> Vec<u8>,
    decode: impl Fn(&[u8]) -> Result<VehicleBatch>,
) -> Result<Cost> {
    let (mut enc, mut dec, mut bytes) = (Vec::new(), Vec::new(), 0);
    for _ in 0..20 {
        let t = Instant::now();
        let out = encode();
        enc.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        decode(&out)?;
        dec.push(t.elapsed().as_secs_f64() * 1e3);
        bytes = out.len();
    }
    Ok(Cost {
        bytes,
        encode_ms: quantile(&mut enc, 0.5),
        decode_ms: quantile(&mut dec, 0.5),
    })
}
