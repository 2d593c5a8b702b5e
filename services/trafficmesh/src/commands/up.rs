//! `trafficmesh up`: checks every service's configuration, starts every
//! service as a child process with its own log prefix, restarts one that dies
//! (with backoff; one that exits with the configuration-error code stops the
//! cluster instead), and on Ctrl-C or SIGTERM
//! stops them all with SIGTERM so each finishes cleanly (the spawner writes
//! its CSV).

use std::path::PathBuf;
use std::process::Stdio;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use tokio::io::{AsyncBufReadExt, AsyncRead, BufReader};
use tokio::process::{Child, Command};
use tokio::sync::mpsc;

use super::cluster_config::ClusterConfig;

#[derive(Args)]
pub struct UpArgs {
    /// Cluster config (TOML).
    #[arg(long, default_value = "configs/cluster.toml")]
    config: PathBuf,
    /// Overrides the config's cluster name.
    #[arg(long)]
    cluster: Option<String>,
    /// Overrides the config's endpoint (the stepper listens, the others connect).
    #[arg(long)]
    endpoint: Option<String>,
    /// Overrides the config's map.
    #[arg(long)]
    map: Option<PathBuf>,
}

/// Where the service binaries are: next to this one (cargo builds them all
/// into one directory), else on PATH.
fn service_binary(service: &str) -> PathBuf {
    let name = format!("trafficmesh-{service}");
    std::env::current_exe()
        .ok()
        .and_then(|exe| exe.parent().map(|d| d.join(&name)))
        .filter(|p| p.exists())
        .unwrap_or_else(|| PathBuf::from(name))
}

struct Running {
    name: &'static str,
    flags: Vec<String>,
    env: Vec<(String, String)>,
    child: Option<Child>,
    started: Instant,
    backoff: Duration,
    restart_at: Option<Instant>,
    /// Exited with the configuration-error code: never restarted.
    failed: bool,
    /// Its clean exit ends the run (the stepper with a `duration`).
    ends_run: bool,
    /// It exited cleanly and `ends_run`: the run is over.
    finished: bool,
}

/// The exit code of a service that cannot run with its configuration (bad
/// flags, files or settings): restarting it would fail again.
const CONFIG_ERROR: i32 = 2;

pub fn run(a: UpArgs) -> Result<()> {
    let mut config = ClusterConfig::load(&a.config)?;
    if let Some(c) = a.cluster {
        config.cluster = c;
    }
    if let Some(e) = a.endpoint {
        config.endpoint = e;
    }
    let map_given = a.map.is_some();
    if let Some(m) = a.map {
        config.map = Some(m);
        config.sumocfg = None;
    }
    // Every service's configuration is checked here, before anything starts:
    // one message naming the file, rather than five children failing at once
    // or one restarted for ever.
    let net = match (&config.sumocfg, &config.map) {
        (Some(cfg), _) => trafficmesh_service::load_scenario_network(cfg, config.seed)?.0,
        (None, Some(map)) => trafficmesh_service::load_network(map)?,
        (None, None) => unreachable!("ClusterConfig::load checks that one is given"),
    };
    check_spawn_config(&mut config, &net, &a.config, map_given)?;
    config.reservation_intersections = !net.reservation_junctions.is_empty();
    trafficmesh_protocol::Keys::new(&config.cluster)?;
    // The folders of the files the services keep their state in.
    let state_files = [
        Some(&config.spawner.branch_csv),
        config.lights.overrides.as_ref(),
        config.stepper.snapshot.as_ref(),
    ];
    for dir in state_files.into_iter().flatten().filter_map(|f| f.parent()) {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
        }
    }
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?
        .block_on(supervise(config))
}

/// The spawn config the spawner starts from must name lanes of the map. With
/// a map given on the command line, one written for another map is set
/// aside: the spawner starts from the map's own spawn config
/// (`traffic_spawn.<map>.json` beside it, where the admin's saves then go),
/// empty until one is saved.
fn check_spawn_config(
    config: &mut ClusterConfig,
    net: &trafficmesh_sim::LaneNetwork,
    cluster_toml: &std::path::Path,
    map_given: bool,
) -> Result<()> {
    let lanes_ok = |path: &std::path::Path| -> Result<std::result::Result<(), String>> {
        if !path.exists() {
            return Ok(Ok(()));
        }
        let spawn = trafficmesh_maps::load_spawn_config(path)?;
        Ok(spawn
            .validate(|lane| net.lane_id(lane).is_some())
            .map_err(|e| e.problems.join("; ")))
    };
    let path = config.spawner.spawn_config.clone();
    let Err(problem) = lanes_ok(&path)? else {
        return Ok(());
    };
    let map = config
        .map
        .clone()
        .or(config.sumocfg.clone())
        .expect("one is given");
    if !map_given {
        bail!(
            "{}: {problem}\n  fix: correct or remove those entries, or set spawner.spawn_config in {} to a spawn config for {}",
            path.display(),
            cluster_toml.display(),
            map.display()
        );
    }
    let own = path.with_file_name(format!(
        "traffic_spawn.{}.json",
        trafficmesh_maps::map_stem(&map)
    ));
    if let Err(problem) = lanes_ok(&own)? {
        bail!(
            "{}: {problem}\n  fix: correct or remove that file (the spawn config kept for {})",
            own.display(),
            map.display()
        );
    }
    tracing::warn!(
        "{} is written for another map ({}); starting with {}'s own spawn config {} ({})",
        path.display(),
        problem.split("; ").next().unwrap_or_default(),
        map.display(),
        own.display(),
        if own.exists() {
            "saved earlier"
        } else {
            "empty until the admin saves one"
        }
    );
    config.spawner.spawn_config = own;
    Ok(())
}

async fn supervise(config: ClusterConfig) -> Result<()> {
    let initial = Duration::from_millis(config.restart.initial_backoff_ms);
    let max = Duration::from_millis(config.restart.max_backoff_ms);
    let (lines, mut line_rx) = mpsc::unbounded_channel::<String>();
    let timed = config.stepper.duration.is_some();
    let mut services: Vec<Running> = config
        .services()
        .into_iter()
        .map(|l| Running {
            ends_run: timed && l.name == "stepper",
            name: l.name,
            flags: l.flags,
            env: l.env,
            child: None,
            started: Instant::now(),
            backoff: initial,
            restart_at: Some(Instant::now()),
            failed: false,
            finished: false,
        })
        .collect();
    tracing::info!(
        "starting cluster '{}' on {} with {}",
        config.cluster,
        config.endpoint,
        services
            .iter()
            .map(|s| s.name)
            .collect::<Vec<_>>()
            .join(", ")
    );
    let stop = trafficmesh_bus::runtime::shutdown_signal();
    tokio::pin!(stop);
    let mut every = tokio::time::interval(Duration::from_millis(50));
    loop {
        tokio::select! {
            _ = &mut stop => break,
            Some(line) = line_rx.recv() => eprintln!("{line}"),
            _ = every.tick() => {
                for s in &mut services {
                    check(s, &lines, initial, max);
                }
                // A part that cannot run stops the whole: a cluster without
                // it would run on, silently incomplete.
                if services.iter().any(|s| s.failed) {
                    break;
                }
                if services.iter().any(|s| s.finished) {
                    tracing::info!("the stepper ran its duration; the run is over");
                    break;
                }
            }
        }
    }
    tracing::info!("stopping every service");
    for s in &mut services {
        if let Some(child) = &s.child
            && let Some(pid) = child.id()
        {
            // SIGTERM, so each service shuts down cleanly.
            unsafe { libc::kill(pid as i32, libc::SIGTERM) };
        }
    }
    let deadline = Instant::now() + Duration::from_secs(10);
    for s in &mut services {
        if let Some(child) = &mut s.child {
            let left = deadline.saturating_duration_since(Instant::now());
            match tokio::time::timeout(left, child.wait()).await {
                Ok(_) => {}
                Err(_) => {
                    tracing::warn!("{} did not stop in time; killing it", s.name);
                    let _ = child.kill().await;
                }
            }
        }
    }
    while let Ok(line) = line_rx.try_recv() {
        eprintln!("{line}");
    }
    tracing::info!("cluster stopped");
    let failed: Vec<&str> = services
        .iter()
        .filter(|s| s.failed)
        .map(|s| s.name)
        .collect();
    if !failed.is_empty() {
        bail!(
            "{}: cannot run with the configuration given (see the log above); the cluster is stopped",
            failed.join(", ")
        );
    }
    Ok(())
}

/// Starts a service that is due, notices one that died and schedules its restart.
fn check(s: &mut Running, lines: &mpsc::UnboundedSender<String>, initial: Duration, max: Duration) {
    if let Some(child) = &mut s.child
        && let Ok(Some(status)) = child.try_wait()
    {
        s.child = None;
        if s.ends_run && status.success() {
            s.finished = true;
            return;
        }
        if status.code() == Some(CONFIG_ERROR) {
            tracing::error!(
                "{} exited with the configuration-error code {CONFIG_ERROR} (its log above names the problem); not restarted: fix its configuration and run `trafficmesh up` again",
                s.name
            );
            s.failed = true;
            return;
        }
        // A service that ran a while gets the short delay again.
        if s.started.elapsed() > Duration::from_secs(10) {
            s.backoff = initial;
        }
        tracing::warn!(
            "{} exited ({status}); restarting in {} ms",
            s.name,
            s.backoff.as_millis()
        );
        s.restart_at = Some(Instant::now() + s.backoff);
        s.backoff = (s.backoff * 2).min(max);
    }
    if s.child.is_none() && s.restart_at.is_some_and(|t| Instant::now() >= t) {
        s.restart_at = None;
        match start(s, lines) {
            Ok(child) => {
                tracing::info!("{} started (pid {})", s.name, child.id().unwrap_or(0));
                s.child = Some(child);
                s.started = Instant::now();
            }
            Err(e) => {
                tracing::error!("cannot start {}: {e:#}", s.name);
                s.restart_at = Some(Instant::now() + s.backoff);
                s.backoff = (s.backoff * 2).min(max);
            }
        }
    }
}

fn start(s: &Running, lines: &mpsc::UnboundedSender<String>) -> Result<Child> {
    let name = s.name;
    let binary = service_binary(name);
    let mut child = Command::new(&binary)
        .args(&s.flags)
        .envs(s.env.iter().cloned())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .with_context(|| {
            format!(
                "cannot run {} (build every service with `cargo build --release --workspace --bins`)",
                binary.display()
            )
        })?;
    forward(name, child.stdout.take().expect("piped"), lines.clone());
    forward(name, child.stderr.take().expect("piped"), lines.clone());
    Ok(child)
}

/// Copies a child's output line by line with the service's name in front.
fn forward(
    name: &'static str,
    out: impl AsyncRead + Unpin + Send + 'static,
    lines: mpsc::UnboundedSender<String>,
) {
    tokio::spawn(async move {
        let mut reader = BufReader::new(out).lines();
        while let Ok(Some(line)) = reader.next_line().await {
            if lines.send(format!("[{name:<11}] {line}")).is_err() {
                break;
            }
        }
    });
}
