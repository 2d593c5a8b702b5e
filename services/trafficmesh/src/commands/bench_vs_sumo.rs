//! `trafficmesh bench vs-sumo`: SUMO and trafficmesh on the same network and
//! demand, alternating, each in its own process: wall time, vehicle-steps per
//! second, instructions per vehicle-step (where `perf` counts them), peak
//! memory, and trip statistics.
//!
//! The two count steps differently: SUMO steps every vehicle once per
//! simulated second by default, trafficmesh 20 times with `realistic` drivers and 50 with
//! `awsim` ones (`sim`'s default tick; `--dt`). The figures
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
    #[arg(long, requires = "routes", required_unless_present = "sumocfg")]
    net: Option<PathBuf>,
    /// SUMO routes (.rou.xml) with routed vehicles and flows.
    #[arg(long, requires = "net")]
    routes: Option<PathBuf>,
    /// A SUMO scenario as shipped (.sumocfg) instead of --net and --routes:
    /// both run it whole (`sumo -c`, `trafficmesh sim --sumocfg`).
    #[arg(long, conflicts_with_all = ["net", "routes"])]
    sumocfg: Option<PathBuf>,
    /// Simulated seconds (default: 900 with --net, until every vehicle has
    /// arrived with --sumocfg).
    #[arg(long)]
    duration: Option<f64>,
    /// Rounds, alternating SUMO and trafficmesh; the median round is reported.
    #[arg(long, default_value_t = 1)]
    rounds: usize,
    /// trafficmesh's tick length, seconds (`sim --dt`; default `sim`'s for the
    /// run's driver model).
    #[arg(long)]
    dt: Option<f64>,
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
    inserted: u64,
    /// Trips that reached their route's end.
    trips_completed: u64,
    last_arrival_s: f64,
    mean_travel_time_s: f64,
    mean_waiting_time_s: f64,
    mean_time_loss_s: f64,
    /// SUMO's teleports; trafficmesh's jam resolutions (the same last resort).
    jam_resolutions: u64,
}

#[derive(Serialize)]
struct Report {
    scenario: String,
    duration: Option<f64>,
    sumo: Figures,
    trafficmesh: Figures,
    /// trafficmesh's vehicle-steps per second over SUMO's.
    speedup: f64,
    /// SUMO's wall time over trafficmesh's, for the same simulated run.
    wall_time_ratio: f64,
}

impl VsSumoArgs {
    /// The simulated seconds to run: given, else 900 for a net and routes,
    /// else (a scenario) to its end.
    fn run_length(&self) -> Option<f64> {
        self.duration.or(if self.sumocfg.is_some() {
            None
        } else {
            Some(900.0)
        })
    }

    fn scenario(&self) -> String {
        match (&self.sumocfg, &self.net, &self.routes) {
            (Some(cfg), _, _) => cfg.display().to_string(),
            (None, Some(net), Some(routes)) => format!("{} + {}", net.display(), routes.display()),
            _ => unreachable!("clap requires --sumocfg or --net with --routes"),
        }
    }
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

/// The scenario's folder copied into the scratch folder, and a copy of the
/// configuration whose input files outside that folder are named by their
/// absolute paths: SUMO writes the outputs a scenario's own files name
/// (detectors, its tripinfo and log) beside those files, and a benchmark
/// must not write into a user's scenario.
fn scenario_copy(cfg: &Path, scratch: &Path) -> Result<PathBuf> {
    let folder = cfg
        .canonicalize()
        .with_context(|| format!("cannot read {}", cfg.display()))?
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let copy = scratch.join("scenario");
    std::fs::create_dir_all(&copy).with_context(|| format!("cannot create {}", copy.display()))?;
    for entry in
        std::fs::read_dir(&folder).with_context(|| format!("cannot read {}", folder.display()))?
    {
        let path = entry?.path();
        if path.is_file() {
            let to = copy.join(path.file_name().expect("a file has a name"));
            std::fs::copy(&path, &to)
                .with_context(|| format!("cannot copy {} to {}", path.display(), to.display()))?;
        }
    }
    let text =
        std::fs::read_to_string(cfg).with_context(|| format!("cannot read {}", cfg.display()))?;
    let doc = roxmltree::Document::parse(&text)
        .with_context(|| format!("{} is not XML", cfg.display()))?;
    // An input outside the folder, by its absolute path; the rest as written.
    let input = |value: &str| -> String {
        value
            .split(',')
            .map(|f| {
                let f = f.trim();
                let resolved = folder.join(f);
                match resolved.canonicalize() {
                    Ok(abs) if abs.parent() != Some(folder.as_path()) => abs.display().to_string(),
                    _ => f.to_string(),
                }
            })
            .collect::<Vec<_>>()
            .join(",")
    };
    let mut out = String::from("<configuration>\n");
    for section in doc.root_element().children().filter(|n| n.is_element()) {
        out += &format!("  <{}>\n", section.tag_name().name());
        for option in section.children().filter(|n| n.is_element()) {
            let tag = option.tag_name().name();
            let value = option.attribute("value").unwrap_or("");
            let value = if matches!(tag, "net-file" | "route-files" | "additional-files") {
                input(value)
            } else {
                value.to_string()
            };
            let escaped = value
                .replace('&', "&amp;")
                .replace('"', "&quot;")
                .replace('<', "&lt;");
            out += &format!("    <{tag} value=\"{escaped}\"/>\n");
        }
        out += &format!("  </{}>\n", section.tag_name().name());
    }
    out += "</configuration>\n";
    let copied = copy.join(cfg.file_name().expect("a configuration file has a name"));
    std::fs::write(&copied, out).with_context(|| format!("cannot write {}", copied.display()))?;
    Ok(copied)
}

fn run_sumo(a: &VsSumoArgs, sumo: &Path, perf: bool, scratch: &Path) -> Result<Figures> {
    let stats = scratch.join("sumo-stats.xml");
    let trips = scratch.join("sumo-trips.xml");
    let mut cmd = Command::new(sumo);
    match (&a.sumocfg, &a.net, &a.routes) {
        (Some(cfg), _, _) => {
            cmd.arg("-c").arg(scenario_copy(cfg, scratch)?);
        }
        (None, Some(net), Some(routes)) => {
            cmd.arg("-n").arg(net).arg("-r").arg(routes);
        }
        _ => unreachable!("clap requires --sumocfg or --net with --routes"),
    }
    if let Some(end) = a.run_length() {
        cmd.args(["--end", &end.to_string()]);
    }
    // Trip statistics are written only with duration-log.statistics; the
    // outputs go to the scratch folder, not where a configuration names them.
    cmd.args([
        "--no-step-log",
        "--no-warnings",
        "--duration-log.statistics",
        "--statistic-output",
    ])
    .arg(&stats)
    .arg("--tripinfo-output")
    .arg(&trips)
    .arg("--log")
    .arg(scratch.join("sumo-log.txt"));
    let (wall, memory, instructions) = run_measured(cmd, perf, scratch)?;
    let trip_text = std::fs::read_to_string(&trips)
        .with_context(|| format!("SUMO wrote no {}", trips.display()))?;
    let last_arrival = roxmltree::Document::parse(&trip_text)?
        .descendants()
        .filter(|n| n.has_tag_name("tripinfo"))
        .filter_map(|n| n.attribute("arrival")?.parse::<f64>().ok())
        .fold(0.0, f64::max);
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
        inserted: num("vehicles", "inserted")? as u64,
        trips_completed: num("vehicleTripStatistics", "count")? as u64,
        last_arrival_s: last_arrival,
        mean_travel_time_s: num("vehicleTripStatistics", "duration")?,
        mean_waiting_time_s: num("vehicleTripStatistics", "waitingTime")?,
        mean_time_loss_s: num("vehicleTripStatistics", "timeLoss")?,
        jam_resolutions: num("teleports", "total")? as u64,
    })
}

fn run_trafficmesh(a: &VsSumoArgs, perf: bool, scratch: &Path) -> Result<Figures> {
    let out = scratch.join("trafficmesh");
    let mut cmd = Command::new(std::env::current_exe()?);
    match (&a.sumocfg, &a.net, &a.routes) {
        (Some(cfg), _, _) => {
            cmd.arg("sim").arg("--sumocfg").arg(cfg);
        }
        (None, Some(net), Some(routes)) => {
            cmd.args(["sim", "--map"])
                .arg(net)
                .arg("--routes")
                .arg(routes);
        }
        _ => unreachable!("clap requires --sumocfg or --net with --routes"),
    }
    if let Some(end) = a.run_length() {
        cmd.args(["--duration", &end.to_string()]);
    }
    if let Some(dt) = a.dt {
        cmd.args(["--dt", &dt.to_string()]);
    }
    // SUMO's side has no built-in walkers: neither has ours.
    cmd.args(["--pedestrians", "0", "--json", "--out"])
        .arg(&out);
    let (wall, memory, instructions) = run_measured(cmd, perf, scratch)?;
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(scratch.join("stdout"))?)?;
    let steps = s["vehicle_steps"].as_f64().unwrap_or(0.0);
    let mut trips = csv::Reader::from_path(out.join("trips.csv"))?;
    let (mut n, mut travel, mut waiting, mut loss, mut last) = (0u64, 0.0, 0.0, 0.0, 0.0f64);
    for row in trips.records() {
        let row = row?;
        if row.get(7) == Some("route_end") {
            n += 1;
            let arrival = row[3].parse::<f64>()?;
            travel += arrival - row[2].parse::<f64>()?;
            waiting += row[6].parse::<f64>()?;
            loss += row[9].parse::<f64>()?;
            last = last.max(arrival);
        }
    }
    Ok(Figures {
        wall_seconds: wall,
        vehicle_steps_per_sec: s["vehicle_steps_per_sec"].as_f64().unwrap_or(0.0),
        instructions_per_vehicle_step: instructions.map(|i| i as f64 / steps.max(1.0)),
        peak_memory_bytes: memory,
        inserted: s["inserted"].as_u64().unwrap_or(0),
        trips_completed: n,
        last_arrival_s: last,
        mean_travel_time_s: travel / n.max(1) as f64,
        mean_waiting_time_s: waiting / n.max(1) as f64,
        mean_time_loss_s: loss / n.max(1) as f64,
        jam_resolutions: s["jam_resolutions"].as_u64().unwrap_or(0),
    })
}

fn median(mut runs: Vec<Figures>) -> Figures {
    runs.sort_by(|a, b| a.vehicle_steps_per_sec.total_cmp(&b.vehicle_steps_per_sec));
    runs[runs.len() / 2].clone()
}

pub fn run(a: VsSumoArgs) -> Result<()> {
    if a.rounds == 0 || a.duration.is_some_and(|d| !(d.is_finite() && d > 0.0)) {
        bail!("--rounds and --duration must be positive");
    }
    for f in [&a.net, &a.routes, &a.sumocfg].into_iter().flatten() {
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
        scenario: a.scenario(),
        duration: a.run_length(),
        speedup: tm.vehicle_steps_per_sec / sumo_f.vehicle_steps_per_sec.max(1e-9),
        wall_time_ratio: sumo_f.wall_seconds / tm.wall_seconds.max(1e-9),
        sumo: sumo_f,
        trafficmesh: tm,
    };
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    let length = report
        .duration
        .map_or("to the end".to_string(), |d| format!("{d} simulated s"));
    println!("{}, {length}:", report.scenario);
    for (name, f) in [("SUMO", &report.sumo), ("trafficmesh", &report.trafficmesh)] {
        println!(
            "  {name:<12} wall {:.2} s, {:.0} vehicle-steps/s, {} instructions/vehicle-step, peak {:.0} MiB",
            f.wall_seconds,
            f.vehicle_steps_per_sec,
            f.instructions_per_vehicle_step
                .map_or("n/a (perf cannot count here)".to_string(), |i| format!(
                    "{i:.0}"
                )),
            f.peak_memory_bytes as f64 / 1048576.0,
        );
        println!(
            "  {:<12} {} inserted, {} arrived (last at {:.0} s); mean duration {:.1} s, waiting {:.1} s, time loss {:.1} s; {} teleports / jam resolutions",
            "",
            f.inserted,
            f.trips_completed,
            f.last_arrival_s,
            f.mean_travel_time_s,
            f.mean_waiting_time_s,
            f.mean_time_loss_s,
            f.jam_resolutions
        );
    }
    println!(
        "  speedup: {:.1}x vehicle-steps/s, {:.1}x wall time",
        report.speedup, report.wall_time_ratio
    );
    Ok(())
}
