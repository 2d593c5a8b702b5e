//! `trafficmesh bench vs-sumo`: SUMO and trafficmesh on the same network and
//! demand, alternating, each in its own process: wall time, vehicle-steps per
//! second, instructions per vehicle-step (where `perf` counts them), peak
//! memory, and trip statistics.
//!
//! The two count steps differently: SUMO steps every vehicle once per
//! simulated second by default, trafficmesh 50 times (dt 0.02 s). The figures
//! are per vehicle-step as each simulator defines it; `speedup` divides
//! trafficmesh's vehicle-steps per second by SUMO's, as the issue asks.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;

#[derive(Args)]
pub struct VsSumoArgs {
    /// SUMO network (.net.xml).
    #[arg(long)]
    net: PathBuf,
    /// SUMO routes (.rou.xml) with routed vehicles and flows.
    #[arg(long)]
    routes: PathBuf,
    /// Simulated seconds.
    #[arg(long, default_value_t = 900.0)]
    duration: f64,
    /// Rounds, alternating SUMO and trafficmesh; the median round is reported.
    #[arg(long, default_value_t = 1)]
    rounds: usize,
    /// The `sumo` binary (default: TRAFFICMESH_SUMO, `sumo` on PATH, then the
    /// virtualenv `.ci/run` makes).
    #[arg(long, env = "TRAFFICMESH_SUMO")]
    sumo: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize, Clone)]
struct Figures {
    wall_seconds: f64,
    vehicle_steps_per_sec: f64,
    instructions_per_vehicle_step: Option<f64>,
    peak_memory_bytes: u64,
    trips_completed: u64,
    mean_travel_time_s: f64,
    mean_waiting_time_s: f64,
}

#[derive(Serialize)]
struct Report {
    net: String,
    routes: String,
    duration: f64,
    sumo: Figures,
    trafficmesh: Figures,
    speedup: f64,
}

/// Runs a child to its end (stdout kept in `scratch/stdout`): wall seconds,
/// peak resident bytes, instructions (under perf).
fn run_measured(cmd: Command, perf: bool, scratch: &Path) -> Result<(f64, u64, Option<u64>)> {
    let perf_out = scratch.join("perf.csv");
    let mut command = if perf {
        let mut c = Command::new("perf");
        c.args(["stat", "-x,", "-e", "instructions", "-o"])
            .arg(&perf_out)
            .arg("--")
            .arg(cmd.get_program())
            .args(cmd.get_args());
        c
    } else {
        cmd
    };
    let started = Instant::now();
    let child = command
        .stdout(std::fs::File::create(scratch.join("stdout"))?)
        .stderr(std::process::Stdio::null())
        .spawn()
        .with_context(|| format!("cannot run {:?}", command.get_program()))?;
    let mut status = 0;
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    let wall = started.elapsed().as_secs_f64();
    if pid < 0 || !libc::WIFEXITED(status) || libc::WEXITSTATUS(status) != 0 {
        bail!("{:?} failed (status {status})", command.get_program());
    }
    let instructions = perf
        .then(|| std::fs::read_to_string(&perf_out).ok())
        .flatten()
        .and_then(|t| {
            t.lines()
                .find(|l| l.contains("instructions"))?
                .split(',')
                .next()?
                .parse()
                .ok()
        });
    Ok((wall, usage.ru_maxrss as u64 * 1024, instructions))
}

fn perf_counts_instructions() -> bool {
    Command::new("perf")
        .args(["stat", "-x,", "-e", "instructions", "true"])
        .output()
        .is_ok_and(|o| {
            let text = String::from_utf8_lossy(&o.stderr);
            text.lines().any(|l| {
                l.contains("instructions")
                    && l.split(',')
                        .next()
                        .is_some_and(|n| n.parse::<u64>().is_ok())
            })
        })
}

fn sumo_binary(given: Option<PathBuf>) -> PathBuf {
    if let Some(p) = given {
        return p;
    }
    let on_path = Command::new("sumo")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if on_path {
        return "sumo".into();
    }
    let home = std::env::var_os("HOME")
        .map(PathBuf::from)
        .unwrap_or_default();
    home.join(".cache/trafficmesh-venv/bin/sumo")
}

fn run_sumo(a: &VsSumoArgs, sumo: &Path, perf: bool, scratch: &Path) -> Result<Figures> {
    let stats = scratch.join("sumo-stats.xml");
    let mut cmd = Command::new(sumo);
    cmd.arg("-n").arg(&a.net).arg("-r").arg(&a.routes);
    // Trip statistics are written only with duration-log.statistics.
    cmd.args([
        "--end",
        &a.duration.to_string(),
        "--no-step-log",
        "--duration-log.statistics",
        "--statistic-output",
    ])
    .arg(&stats);
    let (wall, memory, instructions) = run_measured(cmd, perf, scratch)?;
    let text = std::fs::read_to_string(&stats)
        .with_context(|| format!("SUMO wrote no {}", stats.display()))?;
    let doc = roxmltree::Document::parse(&text)?;
    let find = |tag: &str| doc.descendants().find(|n| n.has_tag_name(tag));
    let num = |tag: &str, attr: &str| -> Result<f64> {
        find(tag)
            .and_then(|n| n.attribute(attr))
            .and_then(|v| v.parse().ok())
            .with_context(|| format!("SUMO statistics lack {tag}@{attr}"))
    };
    let ups = num("performance", "vehicleUpdatesPerSecond")?;
    let sim_wall = num("performance", "clockDuration")?;
    Ok(Figures {
        wall_seconds: wall,
        vehicle_steps_per_sec: ups,
        instructions_per_vehicle_step: instructions.map(|i| i as f64 / (ups * sim_wall).max(1.0)),
        peak_memory_bytes: memory,
        trips_completed: num("vehicleTripStatistics", "count")? as u64,
        mean_travel_time_s: num("vehicleTripStatistics", "duration")?,
        mean_waiting_time_s: num("vehicleTripStatistics", "waitingTime")?,
    })
}

fn run_trafficmesh(a: &VsSumoArgs, perf: bool, scratch: &Path) -> Result<Figures> {
    let out = scratch.join("trafficmesh");
    let mut cmd = Command::new(std::env::current_exe()?);
    cmd.args(["sim", "--map"])
        .arg(&a.net)
        .arg("--routes")
        .arg(&a.routes);
    cmd.args([
        "--duration",
        &a.duration.to_string(),
        "--max-vehicles",
        "1000000",
        "--json",
        "--out",
    ])
    .arg(&out);
    let (wall, memory, instructions) = run_measured(cmd, perf, scratch)?;
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(scratch.join("stdout"))?)?;
    let steps = s["vehicle_steps"].as_f64().unwrap_or(0.0);
    let mut trips = csv::Reader::from_path(out.join("trips.csv"))?;
    let (mut n, mut travel, mut waiting) = (0u64, 0.0, 0.0);
    for row in trips.records() {
        let row = row?;
        if row.get(7) == Some("route_end") {
            n += 1;
            travel += row[3].parse::<f64>()? - row[2].parse::<f64>()?;
            waiting += row[6].parse::<f64>()?;
        }
    }
    Ok(Figures {
        wall_seconds: wall,
        vehicle_steps_per_sec: s["vehicle_steps_per_sec"].as_f64().unwrap_or(0.0),
        instructions_per_vehicle_step: instructions.map(|i| i as f64 / steps.max(1.0)),
        peak_memory_bytes: memory,
        trips_completed: n,
        mean_travel_time_s: travel / n.max(1) as f64,
        mean_waiting_time_s: waiting / n.max(1) as f64,
    })
}

fn median(mut runs: Vec<Figures>) -> Figures {
    runs.sort_by(|a, b| a.vehicle_steps_per_sec.total_cmp(&b.vehicle_steps_per_sec));
    runs[runs.len() / 2].clone()
}

pub fn run(a: VsSumoArgs) -> Result<()> {
    if a.rounds == 0 || !(a.duration.is_finite() && a.duration > 0.0) {
        bail!("--rounds and --duration must be positive");
    }
    for f in [&a.net, &a.routes] {
        if !f.exists() {
            bail!("{} does not exist", f.display());
        }
    }
    let sumo = sumo_binary(a.sumo.clone());
    let perf = perf_counts_instructions();
    let scratch = std::env::temp_dir().join(format!("trafficmesh-vs-sumo-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let (mut s_runs, mut t_runs) = (Vec::new(), Vec::new());
    for _ in 0..a.rounds {
        s_runs.push(
            run_sumo(&a, &sumo, perf, &scratch)
                .with_context(|| format!("SUMO ({})", sumo.display()))?,
        );
        t_runs.push(run_trafficmesh(&a, perf, &scratch)?);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let (sumo_f, tm) = (median(s_runs), median(t_runs));
    let report = Report {
        net: a.net.display().to_string(),
        routes: a.routes.display().to_string(),
        duration: a.duration,
        speedup: tm.vehicle_steps_per_sec / sumo_f.vehicle_steps_per_sec.max(1e-9),
        sumo: sumo_f,
        trafficmesh: tm,
    };
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    println!(
        "{} + {}, {} simulated s:",
        report.net, report.routes, report.duration
    );
    for (name, f) in [("SUMO", &report.sumo), ("trafficmesh", &report.trafficmesh)] {
        println!(
            "  {name:<12} wall {:.2} s, {:.0} vehicle-steps/s, {} instructions/vehicle-step, peak {:.0} MiB; {} trips, mean travel {:.1} s, waiting {:.1} s",
            f.wall_seconds,
            f.vehicle_steps_per_sec,
            f.instructions_per_vehicle_step
                .map_or("n/a (perf cannot count here)".to_string(), |i| format!(
                    "{i:.0}"
                )),
            f.peak_memory_bytes as f64 / 1048576.0,
            f.trips_completed,
            f.mean_travel_time_s,
            f.mean_waiting_time_s
        );
    }
    println!("  speedup (vehicle-steps/s): {:.1}x", report.speedup);
    Ok(())
}
