//! A real cluster per test: `trafficmesh up` with its own cluster name, port
//! and files, and a Zenoh client session that talks to it like any user's.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde::Serialize;
use serde::de::DeserializeOwned;
use trafficmesh_bus::{Bus, BusArgs, Role};
use trafficmesh_protocol::wire::{ServiceStatus, VehicleBatch};

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn four_way() -> PathBuf {
    repo().join("configs/maps/four_way.map.json")
}

/// `../shared/maps/<name>`; a notice and None when the folder is absent,
/// unless TRAFFICMESH_REQUIRE_SHARED=1 (CI) makes that a failure.
pub fn shared_map(name: &str) -> Option<PathBuf> {
    let path = repo().join("../shared/maps").join(name);
    if path.exists() {
        return Some(path);
    }
    if std::env::var("TRAFFICMESH_REQUIRE_SHARED").is_ok_and(|v| v == "1") {
        panic!(
            "TRAFFICMESH_REQUIRE_SHARED=1 but {} is missing",
            path.display()
        );
    }
    eprintln!("NOTICE: skipped: {} is absent", path.display());
    None
}

pub fn free_port() -> u16 {
    trafficmesh_bus::free_loopback_port().expect("a free loopback port")
}

pub struct Cluster {
    pub name: String,
    pub endpoint: String,
    pub dir: tempfile::TempDir,
    /// `http://127.0.0.1:<port>` when the admin runs.
    pub admin: Option<String>,
    child: Child,
    log: PathBuf,
}

/// The admin token the test clusters use.
pub const TOKEN: &str = "test-token-0123456789abcdef";

impl Cluster {
    /// Starts `trafficmesh up` with the four-way map; `extra` is appended to
    /// the generated cluster.toml (sections override the defaults below).
    pub fn start(test: &str, spawner: &str, pedestrians: bool, stepper_speed: f64) -> Cluster {
        Self::start_with_backoff(test, spawner, pedestrians, stepper_speed, 200)
    }

    /// As `start`, with `up`'s first restart delay for a dead service.
    pub fn start_with_backoff(
        test: &str,
        spawner: &str,
        pedestrians: bool,
        stepper_speed: f64,
        backoff_ms: u64,
    ) -> Cluster {
        Self::launch(
            test,
            &four_way(),
            spawner,
            pedestrians,
            &format!("speed = {stepper_speed}"),
            backoff_ms,
            false,
        )
    }

    /// As `start`, with `stepper` as the body of cluster.toml's `[stepper]`.
    pub fn start_stepper(test: &str, stepper: &str, pedestrians: bool) -> Cluster {
        Self::launch(test, &four_way(), "", pedestrians, stepper, 200, false)
    }

    /// Waits for `up` to exit by itself; its exit status, or None on timeout.
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<std::process::ExitStatus> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    }

    /// As `start`, with the REST admin on a free port (token [`TOKEN`]).
    pub fn start_with_admin(test: &str, spawner: &str, pedestrians: bool) -> Cluster {
        Self::start_on_with_admin(test, &four_way(), spawner, pedestrians)
    }

    /// As `start_with_admin`, on another map (any format `up` reads).
    pub fn start_on_with_admin(
        test: &str,
        map: &Path,
        spawner: &str,
        pedestrians: bool,
    ) -> Cluster {
        let cluster = Self::launch(test, map, spawner, pedestrians, "speed = 1", 200, true);
        cluster.wait_for_admin();
        cluster
    }

    fn launch(
        test: &str,
        map: &Path,
        spawner: &str,
        pedestrians: bool,
        stepper: &str,
        backoff_ms: u64,
        with_admin: bool,
    ) -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let admin_port = free_port();
        let name = format!("t{}_{test}", std::process::id());
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        // A SUMO scenario goes in as `sumocfg`, any other map as `map`.
        let map_key = if map.to_string_lossy().ends_with(".sumocfg") {
            "sumocfg"
        } else {
            "map"
        };
        let config = format!(
            r#"cluster = "{name}"
{map_key} = "{map}"
endpoint = "{endpoint}"
seed = 7
[stepper]
{stepper}
[spawner]
spawn_config = "{dir}/traffic_spawn.json"
branch_csv = "{dir}/traffic_branch_decisions.csv"
{spawner}
[pedestrians]
enabled = {pedestrians}
[restart]
initial_backoff_ms = {backoff_ms}
max_backoff_ms = {backoff_ms}
[admin]
enabled = {with_admin}
listen = "127.0.0.1:{admin_port}"
token = "{TOKEN}"
token_file = "{dir}/admin.token"
"#,
            map = map.display(),
            dir = dir.path().display(),
        );
        let path = dir.path().join("cluster.toml");
        std::fs::write(&path, config).unwrap();
        let log = dir.path().join("up.log");
        let child = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
            .args(["up", "--config"])
            .arg(&path)
            .env("RUST_LOG", "info,zenoh=warn")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        Cluster {
            name,
            endpoint,
            dir,
            admin: with_admin.then(|| format!("http://127.0.0.1:{admin_port}")),
            child,
            log,
        }
    }

    /// Waits (up to a minute) until the admin answers and sees the core services alive.
    fn wait_for_admin(&self) {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            if let Ok(mut r) =
                ureq::get(format!("{}/api/v1/status", self.admin.as_ref().unwrap())).call()
            {
                let status: serde_json::Value = r.body_mut().read_json().unwrap();
                if status["degraded"] == false && status["vehicles"].is_u64() {
                    return;
                }
            }
            assert!(
                Instant::now() < deadline,
                "admin not ready within 60 s; log:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    pub fn bus_args(&self) -> BusArgs {
        BusArgs {
            cluster: self.name.clone(),
            zenoh_config: None,
            mode: None,
            connect: vec![self.endpoint.clone()],
            listen: vec!["tcp/127.0.0.1:0".into()],
        }
    }

    pub async fn client(&self) -> Bus {
        let bus = Bus::open(&self.bus_args(), Role::Member, "test")
            .await
            .unwrap();
        assert!(
            bus.wait_for_peer(Duration::from_secs(10)).await,
            "no peer: is the cluster up?"
        );
        bus
    }

    /// The cluster's combined log so far.
    pub fn log(&self) -> String {
        let mut s = String::new();
        std::fs::File::open(&self.log)
            .unwrap()
            .read_to_string(&mut s)
            .unwrap();
        s
    }

    /// Waits until the log contains `needle`.
    pub async fn wait_log(&self, needle: &str, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if self.log().contains(needle) {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        false
    }

    pub fn stop(&mut self) {
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
        let deadline = Instant::now() + Duration::from_secs(15);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        self.stop();
        if std::thread::panicking() {
            eprintln!("---- cluster log ----\n{}", self.log());
        }
    }
}

/// A service's status, once it answers.
pub async fn status(bus: &Bus, service: &str) -> ServiceStatus {
    let key = bus.keys().status(service);
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        match bus
            .get::<(), ServiceStatus>(&key, None, Duration::from_secs(1))
            .await
        {
            Ok(s) => return s,
            Err(e) if Instant::now() > deadline => panic!("{service} status: {e}"),
            Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
        }
    }
}

/// Waits until a subscriber on `key` is known to this session, so that a put
/// is not lost to a declaration still on its way.
pub async fn subscriber_on(bus: &Bus, key: &str) {
    let publisher = bus
        .publisher(key.to_string(), trafficmesh_bus::Lane::Reliable)
        .await
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    while !publisher.has_subscribers().await {
        assert!(Instant::now() < deadline, "no subscriber on {key}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// A query that retries while the service is still starting.
pub async fn ask<Q: Serialize, R: DeserializeOwned>(bus: &Bus, key: &str, q: &Q) -> R {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        match bus.get::<Q, R>(key, Some(q), Duration::from_secs(2)).await {
            Ok(r) => return r,
            Err(e) if Instant::now() > deadline => panic!("{key}: {e}"),
            Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
        }
    }
}

/// Vehicle batches as they arrive.
pub struct Batches {
    sub: zenoh::pubsub::Subscriber<zenoh::handlers::RingChannelHandler<zenoh::sample::Sample>>,
}

impl Batches {
    pub async fn new(bus: &Bus) -> Batches {
        Batches {
            sub: bus.subscribe_ring(&bus.keys().vehicles(), 1).await.unwrap(),
        }
    }

    /// Subscribes and waits until at least `vehicles` are on the map.
    pub async fn with_traffic(bus: &Bus, vehicles: usize) -> Batches {
        let batches = Batches::new(bus).await;
        batches.traffic(vehicles).await;
        batches
    }

    /// Waits (up to a minute) for a batch with at least `vehicles`.
    pub async fn traffic(&self, vehicles: usize) -> VehicleBatch {
        self.until(Duration::from_secs(60), "traffic", |b| {
            b.vehicles.len() >= vehicles
        })
        .await
    }

    /// The newest batch (waits for one).
    pub async fn latest(&self) -> VehicleBatch {
        let mut sample = tokio::time::timeout(Duration::from_secs(10), self.sub.recv_async())
            .await
            .expect("no vehicle batch within 10 s")
            .unwrap();
        while let Ok(Some(s)) = self.sub.try_recv() {
            sample = s;
        }
        VehicleBatch::decode(&sample.payload().to_bytes()).expect("batch decodes")
    }

    /// Waits until `pred` holds for a batch; returns it.
    pub async fn until(
        &self,
        timeout: Duration,
        what: &str,
        pred: impl Fn(&VehicleBatch) -> bool,
    ) -> VehicleBatch {
        let deadline = Instant::now() + timeout;
        loop {
            let b = self.latest().await;
            if pred(&b) {
                return b;
            }
            assert!(Instant::now() < deadline, "timed out waiting for: {what}");
        }
    }
}

pub fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
}

/// A Python (TRAFFICMESH_PYTHON, else python3) that can `import <module>`.
/// None, with a notice, when there is none, unless TRAFFICMESH_REQUIRE_PYTHON=1
/// (CI), which turns the absence into a failure.
pub fn python_with(module: &str, pip_hint: &str) -> Option<String> {
    let candidates = std::env::var("TRAFFICMESH_PYTHON")
        .into_iter()
        .chain(["python3".to_string()]);
    for p in candidates {
        let ok = Command::new(&p)
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
