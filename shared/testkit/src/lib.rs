//! A whole cluster on this machine, as a user starts it (`trafficmesh up`
//! with a cluster.toml), for the tests and the cluster benchmarks: its own
//! cluster name, endpoint, admin port and files in a temporary folder, so
//! that runs side by side never meet; stopped (SIGTERM, then kill) on drop.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use trafficmesh_bus::{BusArgs, free_loopback_port};

/// What to start: the parts of cluster.toml a test or benchmark chooses.
#[derive(Clone, Debug)]
pub struct ClusterSpec {
    /// The cluster name (the first chunk of every key).
    pub name: String,
    /// The map; a `.sumocfg` goes in as `sumocfg`, anything else as `map`.
    pub map: PathBuf,
    pub seed: u64,
    /// The body of `[stepper]`, e.g. `speed = 0`.
    pub stepper: String,
    /// More of `[spawner]` (the spawn config and branch CSV live in the folder).
    pub spawner: String,
    pub pedestrians: bool,
    /// The REST admin on a free port with this bearer token; None: no admin.
    pub admin_token: Option<String>,
    /// `up`'s first and largest restart delay for a service that died.
    pub restart_backoff_ms: u64,
    /// The traffic service (gRPC) on this port; None: not started.
    pub traffic_service_port: Option<u16>,
}

impl ClusterSpec {
    /// A cluster named `name` on `map`: seed 0, real time, no pedestrians,
    /// no admin, `up`'s restart delays.
    pub fn new(name: impl Into<String>, map: impl Into<PathBuf>) -> Self {
        ClusterSpec {
            name: name.into(),
            map: map.into(),
            seed: 0,
            stepper: String::new(),
            spawner: String::new(),
            pedestrians: false,
            admin_token: None,
            restart_backoff_ms: 250,
            traffic_service_port: None,
        }
    }
}

/// A running `trafficmesh up`.
pub struct LocalCluster {
    pub name: String,
    /// The stepper's endpoint, where clients connect.
    pub endpoint: String,
    /// `http://127.0.0.1:<port>` when the admin runs.
    pub admin: Option<String>,
    /// The folder of its files (cluster.toml, spawn config, CSV, log).
    pub dir: tempfile::TempDir,
    log: PathBuf,
    child: Child,
}

impl LocalCluster {
    /// A fresh folder for a cluster's files (maps a caller writes go there too).
    pub fn folder() -> std::io::Result<tempfile::TempDir> {
        tempfile::Builder::new().prefix("trafficmesh-").tempdir()
    }

    /// Writes cluster.toml into `dir` and starts `trafficmesh` (the binary
    /// at that path) `up` on it, its log in `dir/up.log`.
    pub fn launch(
        trafficmesh: &Path,
        dir: tempfile::TempDir,
        spec: &ClusterSpec,
    ) -> std::io::Result<LocalCluster> {
        let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
        let admin_port = free_loopback_port()?;
        let path = dir.path().join("cluster.toml");
        std::fs::write(&path, cluster_toml(spec, dir.path(), &endpoint, admin_port))?;
        let log = dir.path().join("up.log");
        let child = Command::new(trafficmesh)
            .args(["up", "--config"])
            .arg(&path)
            .env("RUST_LOG", "info,zenoh=warn")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log)?)
            .spawn()?;
        Ok(LocalCluster {
            name: spec.name.clone(),
            endpoint,
            admin: spec
                .admin_token
                .as_ref()
                .map(|_| format!("http://127.0.0.1:{admin_port}")),
            dir,
            log,
            child,
        })
    }

    /// Bus flags for a client of this cluster.
    pub fn bus_args(&self) -> BusArgs {
        BusArgs {
            cluster: self.name.clone(),
            zenoh_config: None,
            mode: None,
            connect: vec![self.endpoint.clone()],
            listen: vec!["tcp/127.0.0.1:0".into()],
        }
    }

    /// The combined log of `up` and its services so far.
    pub fn log(&self) -> String {
        let mut s = String::new();
        if let Ok(mut f) = std::fs::File::open(&self.log) {
            let _ = f.read_to_string(&mut s);
        }
        s
    }

    /// Waits for `up` to exit by itself: its exit status, or None on timeout.
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    }

    /// SIGTERM, as a user's Ctrl-C; killed if it has not stopped in 15 s.
    pub fn stop(&mut self) {
        // SAFETY: kill(2) on the pid of a child this value owns and has not reaped.
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
        if self.wait_exit(Duration::from_secs(15)).is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

impl Drop for LocalCluster {
    fn drop(&mut self) {
        self.stop();
        if std::thread::panicking() {
            eprintln!("---- cluster log ----\n{}", self.log());
        }
    }
}

fn cluster_toml(spec: &ClusterSpec, dir: &Path, endpoint: &str, admin_port: u16) -> String {
    let map_key = if spec.map.to_string_lossy().ends_with(".sumocfg") {
        "sumocfg"
    } else {
        "map"
    };
    let admin = match &spec.admin_token {
        Some(token) => format!(
            "enabled = true\nlisten = \"127.0.0.1:{admin_port}\"\ntoken = \"{token}\"\n\
             token_file = \"{}\"",
            dir.join("admin.token").display()
        ),
        None => "enabled = false".into(),
    };
    format!(
        r#"cluster = "{name}"
{map_key} = "{map}"
endpoint = "{endpoint}"
seed = {seed}
[stepper]
{stepper}
[spawner]
spawn_config = "{dir}/traffic_spawn.json"
branch_csv = "{dir}/traffic_branch_decisions.csv"
{spawner}
[lights]
overrides = "{dir}/light_overrides.json"
[pedestrians]
enabled = {pedestrians}
[restart]
initial_backoff_ms = {backoff}
max_backoff_ms = {backoff}
[admin]
{admin}
[traffic_service]
{traffic}
"#,
        name = spec.name,
        map = spec.map.display(),
        seed = spec.seed,
        stepper = spec.stepper,
        spawner = spec.spawner,
        pedestrians = spec.pedestrians,
        backoff = spec.restart_backoff_ms,
        dir = dir.display(),
        traffic = match spec.traffic_service_port {
            Some(port) => format!("enabled = true\nlisten = \"127.0.0.1:{port}\""),
            None => "enabled = false".into(),
        },
    )
}

/// The repository's root, found at run time from the directory cargo and
/// nextest give the test process (CARGO_MANIFEST_DIR): a test binary built
/// from another checkout that shares the build directory reads this
/// checkout's files. The root is the nearest directory with a Cargo.lock.
pub fn repo_root() -> PathBuf {
    let package = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| env!("CARGO_MANIFEST_DIR").into());
    package
        .ancestors()
        .find(|d| d.join("Cargo.lock").exists())
        .unwrap_or(&package)
        .to_path_buf()
}

/// A deployment's certificates, keys and passwords in `dir`, made by its own
/// script (deploy/secure/make-certs.sh; needs openssl), for localhost and
/// 127.0.0.1 among the router's names.
pub fn make_certs(dir: &Path) {
    let out = std::process::Command::new("bash")
        .arg(repo_root().join("deploy/secure/make-certs.sh"))
        .arg(dir)
        .output()
        .expect("bash runs");
    assert!(
        out.status.success(),
        "make-certs.sh (needs openssl): {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A Python (TRAFFICMESH_PYTHON, else python3) that can `import <module>`.
/// None, with a notice, when there is none, unless TRAFFICMESH_REQUIRE_PYTHON=1
/// (CI), which turns the absence into a failure.
pub fn python_with(module: &str, pip_hint: &str) -> Option<String> {
    let candidates = std::env::var("TRAFFICMESH_PYTHON")
        .into_iter()
        .chain(["python3".to_string()]);
    for p in candidates {
        let ok = std::process::Command::new(&p)
            .args(["-c", &format!("import {module}")])
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            return Some(p);
        }
    }
    if std::env::var("TRAFFICMESH_REQUIRE_PYTHON").is_ok_and(|v| v == "1") {
        panic!(
            "TRAFFICMESH_REQUIRE_PYTHON=1 but no python can import {module} (set TRAFFICMESH_PYTHON)"
        );
    }
    eprintln!("NOTICE: skipped: no python with {module} (pip install {pip_hint})");
    None
}
