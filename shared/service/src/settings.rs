//! Each service's own settings, once: the flags its binary takes and the
//! section of `cluster.toml` that `trafficmesh up` reads are the same struct,
//! so a default, a help text and a validity rule live in one place. `up`
//! turns a section back into flags with [`Settings::flags`].

use std::net::SocketAddr;
use std::path::PathBuf;

use serde::Deserialize;
use trafficmesh_model::{NpcVehicleConfig, SpeedLimitSource};

use crate::args::SpeedSource;

/// What every settings struct offers.
pub trait Settings {
    /// Each bad value: its field and what is wrong with it ("must be ...").
    fn problems(&self) -> Vec<(&'static str, String)>;
    /// The command-line flags that give a service these settings.
    fn flags(&self) -> Vec<String>;
}

/// The first problem named as a flag (`--source-timeout must be ...`).
pub fn check_flags(settings: &impl Settings) -> anyhow::Result<()> {
    match settings.problems().into_iter().next() {
        Some((field, problem)) => anyhow::bail!("--{} {problem}", field.replace('_', "-")),
        None => Ok(()),
    }
}

/// Every problem named as in `cluster.toml` (`crosswalks.validity must be ...`).
pub fn problems_in(section: &str, settings: &impl Settings) -> Vec<String> {
    settings
        .problems()
        .into_iter()
        .map(|(field, problem)| format!("{section}.{field} {problem}"))
        .collect()
}

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

fn positive_seconds(x: f64) -> Option<String> {
    (!positive(x)).then(|| format!("must be a positive number of seconds, got {x}"))
}

/// `(field, problem)` for each check that found one.
fn collect(
    checks: impl IntoIterator<Item = (&'static str, Option<String>)>,
) -> Vec<(&'static str, String)> {
    checks
        .into_iter()
        .filter_map(|(field, problem)| problem.map(|p| (field, p)))
        .collect()
}

fn flag(name: &str, value: impl ToString) -> [String; 2] {
    [format!("--{}", name.replace('_', "-")), value.to_string()]
}

/// The lights service: `[lights]`.
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LightsSettings {
    /// Simulation seconds a published state stays valid without a heartbeat;
    /// after that the stepper counts the group red.
    #[arg(long, default_value_t = LightsSettings::default().validity, allow_negative_numbers = true)]
    pub validity: f64,
    /// Keep the overrides in force in this file (atomically, on every
    /// change) and take them up again at start: a restarted lights service
    /// keeps a forced colour or an admin's program. Unset: overrides last
    /// until the service stops.
    #[arg(long)]
    pub overrides: Option<PathBuf>,
}

impl Default for LightsSettings {
    fn default() -> Self {
        LightsSettings {
            validity: 2.0,
            overrides: None,
        }
    }
}

impl Settings for LightsSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect([("validity", positive_seconds(self.validity))])
    }
    fn flags(&self) -> Vec<String> {
        let mut flags: Vec<String> = flag("validity", self.validity).into();
        if let Some(path) = &self.overrides {
            flags.extend(flag("overrides", path.display()));
        }
        flags
    }
}

/// The crosswalks service: `[crosswalks]`.
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CrosswalksSettings {
    /// Simulation seconds published occupancy stays valid without a heartbeat;
    /// after that the stepper counts every crosswalk blocked.
    #[arg(long, default_value_t = CrosswalksSettings::default().validity, allow_negative_numbers = true)]
    pub validity: f64,
    /// Wall-clock seconds after which a silent agent source is forgotten.
    #[arg(long, default_value_t = CrosswalksSettings::default().source_timeout, allow_negative_numbers = true)]
    pub source_timeout: f64,
}

impl Default for CrosswalksSettings {
    fn default() -> Self {
        CrosswalksSettings {
            validity: 2.0,
            source_timeout: 3.0,
        }
    }
}

impl Settings for CrosswalksSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect([
            ("validity", positive_seconds(self.validity)),
            ("source_timeout", positive_seconds(self.source_timeout)),
        ])
    }
    fn flags(&self) -> Vec<String> {
        [
            flag("validity", self.validity),
            flag("source_timeout", self.source_timeout),
        ]
        .concat()
    }
}

/// The pedestrians service: `[pedestrians]`.
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PedestriansSettings {
    /// Whether `trafficmesh up` starts the service (cluster.toml only).
    #[arg(skip = true)]
    pub enabled: bool,
    /// Crossings started per minute on each crosswalk (0 = nobody crosses).
    #[arg(long, default_value_t = PedestriansSettings::default().per_minute, allow_negative_numbers = true)]
    pub per_minute: f64,
    /// Share of crossings made by cyclists, 0 to 1.
    #[arg(long, default_value_t = PedestriansSettings::default().cyclist_share, allow_negative_numbers = true)]
    pub cyclist_share: f64,
}

impl Default for PedestriansSettings {
    fn default() -> Self {
        PedestriansSettings {
            enabled: true,
            per_minute: 2.0,
            cyclist_share: 0.2,
        }
    }
}

impl Settings for PedestriansSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        let (p, c) = (self.per_minute, self.cyclist_share);
        collect([
            (
                "per_minute",
                (!(p.is_finite() && p >= 0.0)).then(|| format!("must be a number >= 0, got {p}")),
            ),
            (
                "cyclist_share",
                (!(0.0..=1.0).contains(&c)).then(|| format!("must be between 0 and 1, got {c}")),
            ),
        ])
    }
    fn flags(&self) -> Vec<String> {
        [
            flag("per_minute", self.per_minute),
            flag("cyclist_share", self.cyclist_share),
        ]
        .concat()
    }
}

/// The stepper: `[stepper]` (the lockstep flags are `up`'s to set).
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StepperSettings {
    /// Tick length, seconds of simulation time.
    #[arg(long, default_value_t = StepperSettings::default().dt, allow_negative_numbers = true)]
    pub dt: f64,
    /// Simulation seconds per wall-clock second; 0 runs as fast as possible.
    #[arg(long, default_value_t = StepperSettings::default().speed, allow_negative_numbers = true)]
    pub speed: f64,
    /// Vehicles placed on the map at start (benchmarks); 0 = none.
    #[arg(long, default_value_t = 0)]
    pub populate: usize,
    /// Stop after this many simulated seconds (default: run until stopped).
    #[arg(long, allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// Driver model of vehicle types that do not choose their own: `awsim`
    /// or `realistic` (IDM). Default: realistic on SUMO maps, awsim elsewhere.
    #[arg(long)]
    pub driver_model: Option<String>,
    /// Seconds a queue head may stand (not at a red light) before it is moved
    /// to the next lane of its way with room, or taken off (0: never).
    #[arg(long, default_value_t = StepperSettings::default().jam_timeout, allow_negative_numbers = true)]
    pub jam_timeout: f64,
    /// Start each tick only when the lockstep members have answered for it;
    /// unset: on when `speed` is 0 (cluster.toml only; see the stepper's
    /// --lockstep).
    #[arg(skip)]
    pub lockstep: Option<bool>,
    /// Save the road to this file every `snapshot_every` simulated seconds
    /// (atomically), and resume from it at start when it exists: a restarted
    /// stepper carries on with the vehicles it had, not an empty road.
    #[arg(long)]
    pub snapshot: Option<PathBuf>,
    /// Simulated seconds between two snapshots.
    #[arg(long, default_value_t = StepperSettings::default().snapshot_every, allow_negative_numbers = true)]
    pub snapshot_every: f64,
}

impl Default for StepperSettings {
    fn default() -> Self {
        StepperSettings {
            dt: 0.02,
            speed: 1.0,
            populate: 0,
            duration: None,
            driver_model: None,
            jam_timeout: trafficmesh_sim::world::DEFAULT_JAM_TIMEOUT,
            lockstep: None,
            snapshot: None,
            snapshot_every: 5.0,
        }
    }
}

impl StepperSettings {
    /// Lockstep unless told otherwise when running as fast as possible: the
    /// other services could not keep up with a free-running stepper.
    pub fn lockstep(&self) -> bool {
        self.lockstep.unwrap_or(self.speed == 0.0)
    }

    /// The driver model named, once `problems` found none.
    pub fn driver_model(&self) -> Option<trafficmesh_model::DriverModel> {
        self.driver_model
            .as_deref()
            .and_then(trafficmesh_model::DriverModel::by_name)
    }
}

impl Settings for StepperSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        let (dt, speed, j) = (self.dt, self.speed, self.jam_timeout);
        collect([
            (
                "dt",
                (!(positive(dt) && dt <= 1.0))
                    .then(|| format!("must be in (0, 1] seconds, got {dt}")),
            ),
            (
                "speed",
                (!(speed.is_finite() && speed >= 0.0)).then(|| {
                    format!("must be 0 (as fast as possible) or a positive factor, got {speed}")
                }),
            ),
            ("duration", self.duration.and_then(positive_seconds)),
            (
                "driver_model",
                self.driver_model
                    .as_ref()
                    .filter(|m| trafficmesh_model::DriverModel::by_name(m).is_none())
                    .map(|m| format!("'{m}' is not awsim or realistic")),
            ),
            (
                "jam_timeout",
                (!(j.is_finite() && j >= 0.0))
                    .then(|| format!("must be 0 (never) or a positive number of seconds, got {j}")),
            ),
            ("snapshot_every", positive_seconds(self.snapshot_every)),
        ])
    }
    fn flags(&self) -> Vec<String> {
        let mut flags = [
            flag("dt", self.dt),
            flag("speed", self.speed),
            flag("populate", self.populate),
            flag("jam_timeout", self.jam_timeout),
        ]
        .concat();
        if let Some(model) = &self.driver_model {
            flags.extend(flag("driver_model", model));
        }
        if let Some(d) = self.duration {
            flags.extend(flag("duration", d));
        }
        if let Some(path) = &self.snapshot {
            flags.extend(flag("snapshot", path.display()));
            flags.extend(flag("snapshot_every", self.snapshot_every));
        }
        flags
    }
}

/// The spawner: `[spawner]` (its seed is the cluster's).
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpawnerSettings {
    /// maxVehicleCount: NPC vehicles alive at once. Default: the AWSIM
    /// reference's 40, and no cap (a million) with --routes or --sumocfg, so
    /// that a timetable's vehicles all depart, as in SUMO.
    #[arg(long)]
    pub max_vehicles: Option<usize>,
    /// spawnDistanceToEgo: no vehicle spawns closer than this to the ego, metres.
    #[arg(long, default_value_t = SpawnerSettings::default().spawn_distance_to_ego, allow_negative_numbers = true)]
    pub spawn_distance_to_ego: f64,
    /// SUMO route file (`.rou.xml`): its vehicles and flows replace the map's simulators.
    #[arg(long, conflicts_with = "sumocfg")]
    pub routes: Option<PathBuf>,
    /// Spawn config (the AWSIM reference's traffic_spawn.json): loaded at start if it
    /// exists, and the file that save and load use.
    #[arg(long, default_value_os_t = SpawnerSettings::default().spawn_config)]
    pub spawn_config: PathBuf,
    /// Where the branch-decision CSV is written on shutdown.
    #[arg(long, default_value_os_t = SpawnerSettings::default().branch_csv)]
    pub branch_csv: PathBuf,
}

impl Default for SpawnerSettings {
    fn default() -> Self {
        SpawnerSettings {
            max_vehicles: None,
            spawn_distance_to_ego: trafficmesh_sim::WorldConfig::default().spawn_distance_to_ego,
            routes: None,
            spawn_config: "traffic_spawn.json".into(),
            branch_csv: "traffic_branch_decisions.csv".into(),
        }
    }
}

impl Settings for SpawnerSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect([spawn_distance_problem(self.spawn_distance_to_ego)])
    }
    fn flags(&self) -> Vec<String> {
        let mut flags = Vec::new();
        if let Some(max) = self.max_vehicles {
            flags.extend(flag("max_vehicles", max));
        }
        flags.extend(flag("spawn_distance_to_ego", self.spawn_distance_to_ego));
        if let Some(r) = &self.routes {
            flags.extend(flag("routes", r.display()));
        }
        flags.extend(flag("spawn_config", self.spawn_config.display()));
        flags.extend(flag("branch_csv", self.branch_csv.display()));
        flags
    }
}

/// The REST admin: `[admin]` (the token travels in the environment, never
/// on a command line).
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AdminSettings {
    /// Whether `trafficmesh up` starts the admin (cluster.toml only).
    #[arg(skip = true)]
    pub enabled: bool,
    /// HTTP address to listen on (`--listen` is the Zenoh one).
    #[arg(id = "bind", long = "bind", value_name = "ADDR", default_value_t = AdminSettings::default().listen)]
    pub listen: SocketAddr,
    /// Bearer token for mutating endpoints (`up` hands it over in the
    /// environment, never on a command line).
    #[arg(long, env = "TRAFFICMESH_ADMIN_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Where the token is kept when not given (default ~/.config/trafficmesh/admin.token).
    #[arg(long, env = "TRAFFICMESH_ADMIN_TOKEN_FILE")]
    pub token_file: Option<PathBuf>,
    /// Largest request body accepted, bytes.
    #[arg(long, default_value_t = AdminSettings::default().max_body_bytes)]
    pub max_body_bytes: usize,
    /// Seconds before a request is answered 408.
    #[arg(long, default_value_t = AdminSettings::default().request_timeout, allow_negative_numbers = true)]
    pub request_timeout: f64,
    /// Seconds a request waits for a service's answer on the bus before 503.
    #[arg(long, default_value_t = AdminSettings::default().bus_timeout, allow_negative_numbers = true)]
    pub bus_timeout: f64,
    /// Origin allowed to call the API from a browser page elsewhere (repeatable). None: CORS off.
    #[arg(long = "cors-origin")]
    pub cors_origins: Vec<String>,
    /// Serve HTTPS with this certificate chain (PEM; with --tls-key). None: plain HTTP.
    #[arg(long, env = "TRAFFICMESH_ADMIN_TLS_CERT", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// The HTTPS certificate's private key (PEM, PKCS#8, PKCS#1 or SEC1).
    #[arg(long, env = "TRAFFICMESH_ADMIN_TLS_KEY", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
}

impl Default for AdminSettings {
    fn default() -> Self {
        AdminSettings {
            enabled: true,
            listen: SocketAddr::from(([127, 0, 0, 1], 8080)),
            token: None,
            token_file: None,
            max_body_bytes: 1 << 20,
            request_timeout: 10.0,
            bus_timeout: 3.0,
            cors_origins: Vec::new(),
            tls_cert: None,
            tls_key: None,
        }
    }
}

impl Settings for AdminSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect([
            ("request_timeout", positive_seconds(self.request_timeout)),
            ("bus_timeout", positive_seconds(self.bus_timeout)),
            (
                "max_body_bytes",
                (self.max_body_bytes == 0).then(|| "must be positive".to_string()),
            ),
            (
                "tls_cert",
                (self.tls_cert.is_some() != self.tls_key.is_some())
                    .then(|| "tls_cert and tls_key go together".to_string()),
            ),
        ])
    }
    fn flags(&self) -> Vec<String> {
        let mut flags = [
            flag("bind", self.listen),
            flag("max_body_bytes", self.max_body_bytes),
            flag("request_timeout", self.request_timeout),
            flag("bus_timeout", self.bus_timeout),
        ]
        .concat();
        if let Some(f) = &self.token_file {
            flags.extend(flag("token_file", f.display()));
        }
        for origin in &self.cors_origins {
            flags.extend(flag("cors_origin", origin));
        }
        if let (Some(cert), Some(key)) = (&self.tls_cert, &self.tls_key) {
            flags.extend(flag("tls_cert", cert.display()));
            flags.extend(flag("tls_key", key.display()));
        }
        flags
    }
}

/// The traffic service (gRPC gateway): `[traffic_service]`.
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrafficServiceSettings {
    /// Whether `trafficmesh up` starts the traffic service (cluster.toml only).
    #[arg(skip = true)]
    pub enabled: bool,
    /// gRPC address to listen on (`--listen` is the Zenoh one).
    #[arg(id = "bind", long = "bind", value_name = "ADDR", default_value_t = TrafficServiceSettings::default().listen)]
    pub listen: SocketAddr,
    /// More scenes for map_id besides the run's map: a directory of maps
    /// (each named by its file name up to its first dot) or a TOML list (`[[scene]] id, map, offset`).
    #[arg(long)]
    pub scenes: Option<PathBuf>,
    /// History an actor needs before the model takes it over, microseconds.
    #[arg(long, default_value_t = TrafficServiceSettings::default().min_history_us)]
    pub min_history_us: u64,
    /// How far past time_query_us each answer forecasts, microseconds (0:
    /// only the pose at time_query_us).
    #[arg(long, default_value_t = TrafficServiceSettings::default().forecast_horizon_us)]
    pub forecast_horizon_us: u64,
    /// Time between forecast poses, microseconds.
    #[arg(long, default_value_t = TrafficServiceSettings::default().forecast_step_us)]
    pub forecast_step_us: u64,
    /// TLS: the service's certificate chain (PEM); with `tls_key`, gRPC
    /// runs over TLS only.
    #[arg(long, requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// TLS: the service's private key (PEM).
    #[arg(long, requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// TLS: the CA (PEM) a client's certificate must chain to; clients
    /// without one are refused (mutual TLS).
    #[arg(long, requires = "tls_cert")]
    pub tls_client_ca: Option<PathBuf>,
}

impl Default for TrafficServiceSettings {
    fn default() -> Self {
        TrafficServiceSettings {
            enabled: true,
            listen: SocketAddr::from(([127, 0, 0, 1], 50054)),
            scenes: None,
            min_history_us: 1_000_000,
            forecast_horizon_us: 2_000_000,
            forecast_step_us: 100_000,
            tls_cert: None,
            tls_key: None,
            tls_client_ca: None,
        }
    }
}

impl Settings for TrafficServiceSettings {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect([
            (
                "forecast_step_us",
                (self.forecast_step_us == 0).then(|| "must be positive".to_string()),
            ),
            (
                "tls_key",
                (self.tls_cert.is_some() != self.tls_key.is_some())
                    .then(|| "and tls_cert go together".to_string()),
            ),
            (
                "tls_client_ca",
                (self.tls_client_ca.is_some() && self.tls_cert.is_none())
                    .then(|| "needs tls_cert and tls_key".to_string()),
            ),
        ])
    }
    fn flags(&self) -> Vec<String> {
        let mut flags = [
            flag("bind", self.listen),
            flag("min_history_us", self.min_history_us),
            flag("forecast_horizon_us", self.forecast_horizon_us),
            flag("forecast_step_us", self.forecast_step_us),
        ]
        .concat();
        for (name, path) in [
            ("scenes", &self.scenes),
            ("tls_cert", &self.tls_cert),
            ("tls_key", &self.tls_key),
            ("tls_client_ca", &self.tls_client_ca),
        ] {
            if let Some(p) = path {
                flags.extend(flag(name, p.display()));
            }
        }
        flags
    }
}

/// AWSIM's NPCVehicleConfig as `sim` and the stepper take it (the
/// inspector's fields), and as `[vehicle]` in cluster.toml. Defaults are the
/// reference's, from [`NpcVehicleConfig::default`].
#[derive(clap::Args, Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VehicleArgs {
    /// Normal forward acceleration, m/s² (`acceleration`).
    #[arg(long, default_value_t = NpcVehicleConfig::default().acceleration, allow_negative_numbers = true)]
    pub acceleration: f64,
    /// Gentle braking of STOP and SLOW, m/s² (`deceleration`).
    #[arg(long, default_value_t = NpcVehicleConfig::default().deceleration, allow_negative_numbers = true)]
    pub deceleration: f64,
    /// Braking for a vehicle ahead, m/s² (`suddenDeceleration`).
    #[arg(long, default_value_t = NpcVehicleConfig::default().sudden_deceleration, allow_negative_numbers = true)]
    pub sudden_deceleration: f64,
    /// Emergency braking, m/s² (`absoluteDeceleration`).
    #[arg(long, default_value_t = NpcVehicleConfig::default().absolute_deceleration, allow_negative_numbers = true)]
    pub absolute_deceleration: f64,
    /// Where NORMAL-mode target speeds come from: one fixed speed, or each
    /// lane's limit (`speedLimitSource`). Default: the lanes' limits on
    /// imported maps (SUMO, Lanelet2), fixed on native ones.
    #[arg(long, value_enum)]
    pub speed_limit_source: Option<SpeedSource>,
    /// Target speed with `--speed-limit-source fixed`, m/s (50 km/h).
    #[arg(long, default_value_t = NpcVehicleConfig::default().fixed_speed_limit, allow_negative_numbers = true)]
    pub fixed_speed_limit: f64,
}

impl Default for VehicleArgs {
    fn default() -> Self {
        let c = NpcVehicleConfig::default();
        VehicleArgs {
            acceleration: c.acceleration,
            deceleration: c.deceleration,
            sudden_deceleration: c.sudden_deceleration,
            absolute_deceleration: c.absolute_deceleration,
            speed_limit_source: None,
            fixed_speed_limit: c.fixed_speed_limit,
        }
    }
}

impl VehicleArgs {
    /// The accelerations and the fixed limit, by field name.
    fn numbers(&self) -> [(&'static str, f64); 5] {
        [
            ("acceleration", self.acceleration),
            ("deceleration", self.deceleration),
            ("sudden_deceleration", self.sudden_deceleration),
            ("absolute_deceleration", self.absolute_deceleration),
            ("fixed_speed_limit", self.fixed_speed_limit),
        ]
    }
    /// `base` with these settings, for a run on `map`.
    pub fn apply(&self, base: NpcVehicleConfig, map: &std::path::Path) -> NpcVehicleConfig {
        NpcVehicleConfig {
            acceleration: self.acceleration,
            deceleration: self.deceleration,
            sudden_deceleration: self.sudden_deceleration,
            absolute_deceleration: self.absolute_deceleration,
            speed_limit_source: match self.speed_limit_source {
                Some(SpeedSource::Fixed) => SpeedLimitSource::FixedSpeedLimit,
                Some(SpeedSource::Lanelet) => SpeedLimitSource::LaneletSpeedLimit,
                None => trafficmesh_maps::default_speed_limit_source(map),
            },
            fixed_speed_limit: self.fixed_speed_limit,
            ..base
        }
    }
}

impl Settings for VehicleArgs {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect(self.numbers().map(|(name, v)| {
            (
                name,
                (!positive(v)).then(|| format!("must be a positive number, got {v}")),
            )
        }))
    }
    fn flags(&self) -> Vec<String> {
        let mut flags: Vec<String> = self
            .numbers()
            .into_iter()
            .flat_map(|(name, v)| flag(name, v))
            .collect();
        if let Some(source) = self.speed_limit_source {
            let value = clap::ValueEnum::to_possible_value(&source).expect("no variant is skipped");
            flags.extend(flag("speed_limit_source", value.get_name()));
        }
        flags
    }
}

/// AWSIM's spawnDistanceToEgo, as `sim` takes it (the spawner's is in
/// [`SpawnerSettings`]).
#[derive(clap::Args, Clone, Debug)]
pub struct SpawnDistanceArgs {
    /// spawnDistanceToEgo: no vehicle spawns closer than this to the ego, metres.
    #[arg(long, default_value_t = trafficmesh_sim::WorldConfig::default().spawn_distance_to_ego, allow_negative_numbers = true)]
    pub spawn_distance_to_ego: f64,
}

impl Settings for SpawnDistanceArgs {
    fn problems(&self) -> Vec<(&'static str, String)> {
        collect([spawn_distance_problem(self.spawn_distance_to_ego)])
    }
    fn flags(&self) -> Vec<String> {
        flag("spawn_distance_to_ego", self.spawn_distance_to_ego).into()
    }
}

/// The one rule for spawnDistanceToEgo.
fn spawn_distance_problem(d: f64) -> (&'static str, Option<String>) {
    (
        "spawn_distance_to_ego",
        (!(d.is_finite() && d >= 0.0)).then(|| format!("must be a number of metres >= 0, got {d}")),
    )
}
