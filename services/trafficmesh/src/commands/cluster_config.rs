//! `configs/cluster.toml`: what `trafficmesh up` starts and with which flags.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClusterConfig {
    #[serde(default = "default_cluster")]
    pub cluster: String,
    /// The map every service loads; or `sumocfg`.
    #[serde(default)]
    pub map: Option<PathBuf>,
    /// A SUMO scenario instead of `map`: every service loads its network
    /// (with the signal programs of its additional files) and the spawner
    /// runs its demand.
    #[serde(default)]
    pub sumocfg: Option<PathBuf>,
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "default_endpoint")]
    pub endpoint: String,
    #[serde(default)]
    pub zenoh_config: Option<PathBuf>,
    #[serde(default)]
    pub stepper: StepperSection,
    #[serde(default)]
    pub vehicle: VehicleSection,
    #[serde(default)]
    pub spawner: SpawnerSection,
    #[serde(default)]
    pub lights: ValiditySection,
    #[serde(default)]
    pub crosswalks: ValiditySection,
    #[serde(default)]
    pub pedestrians: PedestriansSection,
    #[serde(default)]
    pub admin: AdminSection,
    #[serde(default)]
    pub restart: RestartSection,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AdminSection {
    pub enabled: bool,
    pub listen: String,
    /// The bearer token; TRAFFICMESH_ADMIN_TOKEN in the environment also works.
    /// Handed to the admin in its environment, never on its command line.
    pub token: Option<String>,
    /// Where a generated token is kept (default ~/.config/trafficmesh/admin.token).
    pub token_file: Option<PathBuf>,
    pub max_body_bytes: usize,
    pub request_timeout: f64,
    /// Origins allowed by CORS; empty = CORS off.
    pub cors_origins: Vec<String>,
}
impl Default for AdminSection {
    fn default() -> Self {
        AdminSection {
            enabled: true,
            listen: "127.0.0.1:8080".into(),
            token: None,
            token_file: None,
            max_body_bytes: 1 << 20,
            request_timeout: 10.0,
            cors_origins: Vec::new(),
        }
    }
}

/// One service as `up` starts it.
pub struct Launch {
    pub name: &'static str,
    pub flags: Vec<String>,
    /// Extra environment (secrets stay off the command line).
    pub env: Vec<(String, String)>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StepperSection {
    pub dt: f64,
    pub speed: f64,
    /// Vehicles placed at start (benchmarks); 0 = the spawner fills the map.
    pub populate: usize,
    /// `awsim` or `realistic`; None takes the map's default.
    pub driver_model: Option<String>,
    pub jam_timeout: f64,
    /// Each tick waits for the lights, crosswalks and spawner; None: on
    /// when `speed` is 0.
    pub lockstep: Option<bool>,
    /// Simulated seconds after which the run ends (the cluster stops); None: no end.
    pub duration: Option<f64>,
}
impl Default for StepperSection {
    fn default() -> Self {
        StepperSection {
            dt: 0.02,
            speed: 1.0,
            populate: 0,
            driver_model: None,
            jam_timeout: trafficmesh_sim::world::DEFAULT_JAM_TIMEOUT,
            lockstep: None,
            duration: None,
        }
    }
}

impl StepperSection {
    /// Lockstep unless told otherwise when running as fast as possible: the
    /// other services could not keep up with a free-running stepper.
    pub fn lockstep(&self) -> bool {
        self.lockstep.unwrap_or(self.speed == 0.0)
    }
}

/// AWSIM's NPCVehicleConfig: accelerations in m/s² and the speed limit;
/// unset: the reference's (the stepper's defaults).
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct VehicleSection {
    pub acceleration: Option<f64>,
    pub deceleration: Option<f64>,
    pub sudden_deceleration: Option<f64>,
    pub absolute_deceleration: Option<f64>,
    /// `fixed` or `lanelet` (each lane's limit); unset: the map's default.
    pub speed_limit_source: Option<trafficmesh_service::SpeedSource>,
    pub fixed_speed_limit: Option<f64>,
}

impl VehicleSection {
    /// (name in the file, stepper flag, value) of each one set.
    fn set(&self) -> Vec<(&'static str, &'static str, f64)> {
        [
            ("acceleration", "--acceleration", self.acceleration),
            ("deceleration", "--deceleration", self.deceleration),
            (
                "sudden_deceleration",
                "--sudden-deceleration",
                self.sudden_deceleration,
            ),
            (
                "absolute_deceleration",
                "--absolute-deceleration",
                self.absolute_deceleration,
            ),
            (
                "fixed_speed_limit",
                "--fixed-speed-limit",
                self.fixed_speed_limit,
            ),
        ]
        .into_iter()
        .filter_map(|(name, flag, v)| v.map(|v| (name, flag, v)))
        .collect()
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpawnerSection {
    /// Default: 40, or no cap with `routes` or `sumocfg` (the spawner's).
    pub max_vehicles: Option<usize>,
    /// spawnDistanceToEgo, metres; unset: the reference's 50.
    pub spawn_distance_to_ego: Option<f64>,
    /// A SUMO route file whose demand replaces the map's simulators.
    pub routes: Option<PathBuf>,
    pub spawn_config: PathBuf,
    pub branch_csv: PathBuf,
}
impl Default for SpawnerSection {
    fn default() -> Self {
        SpawnerSection {
            max_vehicles: None,
            spawn_distance_to_ego: None,
            routes: None,
            spawn_config: "traffic_spawn.json".into(),
            branch_csv: "traffic_branch_decisions.csv".into(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ValiditySection {
    pub validity: f64,
}
impl Default for ValiditySection {
    fn default() -> Self {
        ValiditySection { validity: 2.0 }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PedestriansSection {
    pub enabled: bool,
    pub per_minute: f64,
    pub cyclist_share: f64,
}
impl Default for PedestriansSection {
    fn default() -> Self {
        PedestriansSection {
            enabled: true,
            per_minute: 2.0,
            cyclist_share: 0.2,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RestartSection {
    pub initial_backoff_ms: u64,
    pub max_backoff_ms: u64,
}
impl Default for RestartSection {
    fn default() -> Self {
        RestartSection {
            initial_backoff_ms: 250,
            max_backoff_ms: 8000,
        }
    }
}

fn default_cluster() -> String {
    "trafficmesh".into()
}
fn default_endpoint() -> String {
    trafficmesh_bus::DEFAULT_ENDPOINT.into()
}

impl ClusterConfig {
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let config: ClusterConfig =
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        if config.map.is_some() == config.sumocfg.is_some() {
            bail!(
                "{}: give exactly one of `map` and `sumocfg`",
                path.display()
            );
        }
        if config.sumocfg.is_some() && config.spawner.routes.is_some() {
            bail!(
                "{}: spawner.routes and sumocfg both name a demand; keep one",
                path.display()
            );
        }
        if let Some(model) = &config.stepper.driver_model
            && trafficmesh_model::DriverModel::by_name(model).is_none()
        {
            bail!(
                "{}: stepper.driver_model '{model}' is not awsim or realistic",
                path.display()
            );
        }
        if !(config.stepper.jam_timeout.is_finite() && config.stepper.jam_timeout >= 0.0) {
            bail!(
                "{}: stepper.jam_timeout must be 0 (never) or a positive number of seconds",
                path.display()
            );
        }
        let problems = config.value_problems();
        if !problems.is_empty() {
            bail!("{}: {}", path.display(), problems.join("; "));
        }
        if config.restart.initial_backoff_ms == 0
            || config.restart.max_backoff_ms < config.restart.initial_backoff_ms
        {
            bail!(
                "{}: restart.initial_backoff_ms must be > 0 and <= max_backoff_ms",
                path.display()
            );
        }
        Ok(config)
    }

    /// The settings each service would refuse at start, named as in the file
    /// (the same rules the services apply to their flags).
    fn value_problems(&self) -> Vec<String> {
        let mut problems = Vec::new();
        let mut check = |ok: bool, what: &str| {
            if !ok {
                problems.push(what.to_string());
            }
        };
        let positive = |x: f64| x.is_finite() && x > 0.0;
        let (st, p, a) = (&self.stepper, &self.pedestrians, &self.admin);
        check(
            positive(st.dt) && st.dt <= 1.0,
            &format!("stepper.dt must be in (0, 1] seconds, got {}", st.dt),
        );
        check(
            st.speed.is_finite() && st.speed >= 0.0,
            &format!(
                "stepper.speed must be 0 (as fast as possible) or a positive factor, got {}",
                st.speed
            ),
        );
        if let Some(d) = st.duration {
            check(
                positive(d),
                &format!("stepper.duration must be a positive number of seconds, got {d}"),
            );
        }
        for (name, v) in [
            ("lights.validity", self.lights.validity),
            ("crosswalks.validity", self.crosswalks.validity),
            ("admin.request_timeout", a.request_timeout),
        ] {
            check(
                positive(v),
                &format!("{name} must be a positive number of seconds, got {v}"),
            );
        }
        check(
            p.per_minute.is_finite() && p.per_minute >= 0.0,
            &format!(
                "pedestrians.per_minute must be a number >= 0, got {}",
                p.per_minute
            ),
        );
        check(
            (0.0..=1.0).contains(&p.cyclist_share),
            &format!(
                "pedestrians.cyclist_share must be between 0 and 1, got {}",
                p.cyclist_share
            ),
        );
        for (name, _, v) in self.vehicle.set() {
            check(
                positive(v),
                &format!("vehicle.{name} must be a positive number, got {v}"),
            );
        }
        if let Some(d) = self.spawner.spawn_distance_to_ego {
            check(
                d.is_finite() && d >= 0.0,
                &format!("spawner.spawn_distance_to_ego must be a number of metres >= 0, got {d}"),
            );
        }
        check(
            a.max_body_bytes > 0,
            "admin.max_body_bytes must be positive",
        );
        check(
            !a.enabled || a.listen.parse::<std::net::SocketAddr>().is_ok(),
            &format!(
                "admin.listen must be an address and port like 127.0.0.1:8080, got '{}'",
                a.listen
            ),
        );
        problems
    }

    /// Every service to start.
    /// `--map M` or `--sumocfg S`, as every service takes it.
    pub fn map_flags(&self) -> [String; 2] {
        match (&self.sumocfg, &self.map) {
            (Some(cfg), _) => ["--sumocfg".into(), cfg.display().to_string()],
            (None, Some(map)) => ["--map".into(), map.display().to_string()],
            (None, None) => unreachable!("load checks that one is given"),
        }
    }

    pub fn services(&self) -> Vec<Launch> {
        let map = self.map_flags();
        let mut common = vec!["--cluster".to_string(), self.cluster.clone()];
        if let Some(z) = &self.zenoh_config {
            common.extend(["--zenoh-config".into(), z.display().to_string()]);
        }
        let member = |extra: Vec<String>| {
            let mut flags = common.clone();
            if self.zenoh_config.is_none() {
                flags.extend([
                    "--connect".into(),
                    self.endpoint.clone(),
                    "--listen".into(),
                    "tcp/127.0.0.1:0".into(),
                ]);
            }
            flags.extend(map.clone());
            flags.extend(extra);
            flags
        };
        let mut stepper = common.clone();
        if self.zenoh_config.is_none() {
            stepper.extend(["--listen".into(), self.endpoint.clone()]);
        }
        stepper.extend(map.clone());
        stepper.extend([
            "--seed".into(),
            self.seed.to_string(),
            "--dt".into(),
            self.stepper.dt.to_string(),
            "--speed".into(),
            self.stepper.speed.to_string(),
            "--populate".into(),
            self.stepper.populate.to_string(),
            "--jam-timeout".into(),
            self.stepper.jam_timeout.to_string(),
        ]);
        if let Some(model) = &self.stepper.driver_model {
            stepper.extend(["--driver-model".into(), model.clone()]);
        }
        if let Some(d) = self.stepper.duration {
            stepper.extend(["--duration".into(), d.to_string()]);
        }
        let lockstep = self.stepper.lockstep();
        // Each member's flag to keep in step, when the run is in lockstep.
        let in_step = |mut flags: Vec<String>| {
            if lockstep {
                flags.push("--lockstep".into());
            }
            flags
        };
        if lockstep {
            stepper.extend([
                "--lockstep".into(),
                "--lockstep-members".into(),
                "lights,crosswalks,spawner".into(),
            ]);
        }
        for (_, flag, v) in self.vehicle.set() {
            stepper.extend([flag.into(), v.to_string()]);
        }
        if let Some(source) = self.vehicle.speed_limit_source {
            let flag = clap::ValueEnum::to_possible_value(&source).expect("no variant is skipped");
            stepper.extend(["--speed-limit-source".into(), flag.get_name().to_string()]);
        }
        let mut list: Vec<(&'static str, Vec<String>)> = vec![
            ("stepper", stepper),
            (
                "spawner",
                member({
                    let mut flags = vec!["--seed".into(), self.seed.to_string()];
                    if let Some(max) = self.spawner.max_vehicles {
                        flags.extend(["--max-vehicles".into(), max.to_string()]);
                    }
                    if let Some(d) = self.spawner.spawn_distance_to_ego {
                        flags.extend(["--spawn-distance-to-ego".into(), d.to_string()]);
                    }
                    if let Some(r) = &self.spawner.routes {
                        flags.extend(["--routes".into(), r.display().to_string()]);
                    }
                    flags.extend([
                        "--spawn-config".into(),
                        self.spawner.spawn_config.display().to_string(),
                        "--branch-csv".into(),
                        self.spawner.branch_csv.display().to_string(),
                    ]);
                    in_step(flags)
                }),
            ),
            (
                "lights",
                member(in_step(vec![
                    "--validity".into(),
                    self.lights.validity.to_string(),
                ])),
            ),
            (
                "crosswalks",
                member({
                    let mut flags = in_step(vec![
                        "--validity".into(),
                        self.crosswalks.validity.to_string(),
                    ]);
                    if lockstep && self.pedestrians.enabled {
                        flags.extend(["--lockstep-sources".into(), "pedestrians".into()]);
                    }
                    flags
                }),
            ),
        ];
        if self.pedestrians.enabled {
            list.push((
                "pedestrians",
                member(in_step(vec![
                    "--seed".into(),
                    self.seed.to_string(),
                    "--per-minute".into(),
                    self.pedestrians.per_minute.to_string(),
                    "--cyclist-share".into(),
                    self.pedestrians.cyclist_share.to_string(),
                ])),
            ));
        }
        let mut launches: Vec<Launch> = list
            .into_iter()
            .map(|(name, flags)| Launch {
                name,
                flags,
                env: Vec::new(),
            })
            .collect();
        if self.admin.enabled {
            let a = &self.admin;
            let mut extra = vec![
                "--bind".into(),
                a.listen.clone(),
                "--max-body-bytes".into(),
                a.max_body_bytes.to_string(),
                "--request-timeout".into(),
                a.request_timeout.to_string(),
            ];
            if let Some(f) = &a.token_file {
                extra.extend(["--token-file".into(), f.display().to_string()]);
            }
            for origin in &a.cors_origins {
                extra.extend(["--cors-origin".into(), origin.clone()]);
            }
            let expected: Vec<&str> = launches.iter().map(|l| l.name).collect();
            extra.extend(["--expect".into(), expected.join(",")]);
            launches.push(Launch {
                name: "admin",
                flags: member(extra),
                env: a
                    .token
                    .iter()
                    .map(|t| ("TRAFFICMESH_ADMIN_TOKEN".to_string(), t.clone()))
                    .collect(),
            });
        }
        launches
    }
}
