//! `trafficmesh bench traffic-service`: simulate() latency of the traffic
//! service (gRPC) per concurrent session count, measured by real gRPC clients
//! over loopback TCP calling at the runtime's 10 Hz. A call lasts from the
//! request sent to the whole answer received; the client's decoding of the
//! answer afterwards is reported apart.

use anyhow::{Result, bail};
use clap::Args;
use trafficmesh_traffic_grpc::bench::{BenchOptions, run as run_bench};

#[derive(Args)]
pub struct TrafficServiceArgs {
    /// Logged actors per session, handed over to the NPC model after 1 s.
    #[arg(long, default_value_t = 200)]
    objects: usize,
    /// Concurrent session counts, one run each (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1,50")]
    sessions: Vec<usize>,
    /// Simulated seconds per session (10 calls a second, paced in real time).
    #[arg(long, default_value_t = 10)]
    seconds: u64,
    /// The forecast each answer carries, microseconds (the service's
    /// default: 2 s at 10 Hz, 21 poses per actor).
    #[arg(long, default_value_t = 2_000_000)]
    forecast_horizon_us: u64,
    /// Print one JSON object `{"rows": [...]}` instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(a: TrafficServiceArgs) -> Result<()> {
    if a.sessions.contains(&0) || a.objects == 0 || a.seconds == 0 {
        bail!("--objects, --sessions and --seconds must be positive");
    }
    let rows = tokio::runtime::Runtime::new()?.block_on(run_bench(&BenchOptions {
        objects: a.objects,
        sessions: a.sessions,
        seconds: a.seconds,
        forecast_horizon_us: a.forecast_horizon_us,
    }))?;
    if a.json {
        println!("{}", serde_json::json!({ "rows": rows }));
        return Ok(());
    }
    println!(
        "sessions  objects  poses  calls   p50 ms   p99 ms   max ms   step p50   step p99   decode p50"
    );
    for r in rows {
        println!(
            "{:>8} {:>8} {:>6} {:>6} {:>8.2} {:>8.2} {:>8.2} {:>10.2} {:>10.2} {:>12.2}",
            r.sessions,
            r.objects,
            r.poses_per_object,
            r.calls,
            r.p50_ms,
            r.p99_ms,
            r.max_ms,
            r.step_p50_ms,
            r.step_p99_ms,
            r.client_decode_p50_ms
        );
    }
    Ok(())
}
