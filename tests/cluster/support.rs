//! A real cluster per test: `trafficmesh up` with its own cluster name, port
//! and files, and a Zenoh client session that talks to it like any user's.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use trafficmesh_protocol::topics;

use serde::Serialize;
use serde::de::DeserializeOwned;
use trafficmesh_bus::{Bus, Role};
use trafficmesh_protocol::wire::{ServiceStatus, VehicleBatch};
use trafficmesh_testkit::{ClusterSpec, LocalCluster};

pub fn repo() -> PathBuf {
    trafficmesh_testkit::repo_root()
}

pub fn four_way() -> PathBuf {
    repo().join("configs/maps/four_way.map.json")
}

/// The four-way map with its junction run by reservations; its folder and
/// the lanes inside the junction and leading into it (by map index).
pub fn reservation_four_way() -> (
    tempfile::TempDir,
    std::path::PathBuf,
    HashSet<u32>,
    HashSet<u32>,
) {
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(four_way()).unwrap()).unwrap();
    m["intersections"] = serde_json::json!([{ "lane": "J0_0_E0_S", "controller": "reservation" }]);
    let lanes = m["lanes"].as_array().unwrap();
    let indices = |pred: &dyn Fn(&serde_json::Value) -> bool| -> HashSet<u32> {
        lanes
            .iter()
            .enumerate()
            .filter(|(_, l)| pred(l))
            .map(|(i, _)| i as u32)
            .collect()
    };
    let inside = indices(&|l| l["intersection"].as_bool().unwrap_or(false));
    let approaches = indices(&|l| l["name"].as_str().unwrap_or("").contains("_in_"));
    let dir = LocalCluster::folder().unwrap();
    let path = dir.path().join("reservation_four_way.map.json");
    std::fs::write(&path, m.to_string()).unwrap();
    (dir, path, inside, approaches)
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

/// A cluster of the tests: `trafficmesh up` on a map, seed 7, started the
/// one way tests and benchmarks start clusters.
pub struct Cluster(LocalCluster);

impl std::ops::Deref for Cluster {
    type Target = LocalCluster;
    fn deref(&self) -> &LocalCluster {
        &self.0
    }
}

impl std::ops::DerefMut for Cluster {
    fn deref_mut(&mut self) -> &mut LocalCluster {
        &mut self.0
    }
}

/// The admin token the test clusters use.
pub const TOKEN: &str = "test-token-0123456789abcdef";

impl Cluster {
    /// Starts `trafficmesh up` with the four-way map; `spawner` is appended
    /// to cluster.toml's `[spawner]`.
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
        Self::launch_spec(ClusterSpec {
            seed: 7,
            stepper: stepper.into(),
            spawner: spawner.into(),
            pedestrians,
            admin_token: with_admin.then(|| TOKEN.to_string()),
            restart_backoff_ms: backoff_ms,
            ..Self::spec(test, map)
        })
    }

    /// The tests' cluster spec: `t<pid>_<test>` on `map`.
    pub fn spec(test: &str, map: &Path) -> ClusterSpec {
        ClusterSpec::new(format!("t{}_{test}", std::process::id()), map)
    }

    pub fn launch_spec(spec: ClusterSpec) -> Cluster {
        let dir = LocalCluster::folder().unwrap();
        Cluster(
            LocalCluster::launch(Path::new(env!("CARGO_BIN_EXE_trafficmesh")), dir, &spec).unwrap(),
        )
    }

    /// Waits (up to a minute) until the admin answers and sees the core services alive.
    pub fn wait_for_admin(&self) {
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

    /// `trafficmesh status --json` of this cluster, as a user would ask it,
    /// waiting up to `timeout` seconds for the services to answer.
    pub fn health(&self, timeout: &str) -> serde_json::Value {
        let args = [
            "status",
            "--json",
            "--timeout",
            timeout,
            "--cluster",
            &self.name,
            "--connect",
            &self.endpoint,
        ];
        serde_json::from_str(&trafficmesh_cli(&args)).unwrap()
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
}

/// A service's status, once it answers.
pub async fn status(bus: &Bus, service: &str) -> ServiceStatus {
    let key = bus.keys().key_at(&topics::STATUS, service);
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
            sub: bus
                .subscribe_ring(&bus.keys().key(&topics::VEHICLES), 1)
                .await
                .unwrap(),
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

/// Runs the `trafficmesh` command line with `args`, as a user would; its
/// standard output, once it exits successfully.
pub fn trafficmesh_cli<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> String {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_trafficmesh"));
    command.args(args);
    stdout_of(command, "trafficmesh")
}

/// Runs the Python client `tests/cluster/<script>` with `args`, as a user's
/// client would run against the cluster; its standard output, once it exits
/// successfully.
pub fn python_client<S: AsRef<std::ffi::OsStr>>(python: &str, script: &str, args: &[S]) -> String {
    let mut command = std::process::Command::new(python);
    command
        .arg(repo().join("tests/cluster").join(script))
        .args(args);
    stdout_of(command, script)
}

/// The standard output of `command`, which must exit successfully.
fn stdout_of(mut command: std::process::Command, what: &str) -> String {
    let out = command.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{what} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The number after `name=` in a client's `name=value ...` output.
pub fn figure(out: &str, name: &str) -> f64 {
    out.split(&format!("{name}="))
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no {name} in: {out}"))
}
