//! `configs/cluster.toml`: what `trafficmesh up` starts and with which flags.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use trafficmesh_service::VehicleArgs;
use trafficmesh_service::settings::{
    AdminSettings, CrosswalksSettings, LightsSettings, PedestriansSettings, Settings,
    SpawnerSettings, StepperSettings, TrafficServiceSettings, problems_in,
};

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
    pub stepper: StepperSettings,
    #[serde(default)]
    pub vehicle: VehicleArgs,
    #[serde(default)]
    pub spawner: SpawnerSettings,
    #[serde(default)]
    pub lights: LightsSettings,
    #[serde(default)]
    pub crosswalks: CrosswalksSettings,
    #[serde(default)]
    pub pedestrians: PedestriansSettings,
    #[serde(default)]
    pub admin: AdminSettings,
    #[serde(default)]
    pub traffic_service: TrafficServiceSettings,
    #[serde(default)]
    pub restart: RestartSection,
    /// The map has reservation intersections: `up` starts the intersection
    /// service (set from the map, not the file).
    #[serde(skip)]
    pub reservation_intersections: bool,
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
        [
            problems_in("stepper", &self.stepper),
            problems_in("spawner", &self.spawner),
            problems_in("lights", &self.lights),
            problems_in("crosswalks", &self.crosswalks),
            problems_in("pedestrians", &self.pedestrians),
            problems_in("admin", &self.admin),
            problems_in("traffic_service", &self.traffic_service),
            problems_in("vehicle", &self.vehicle),
        ]
        .concat()
    }

    /// `--map M` or `--sumocfg S`, as every service takes it.
    pub fn map_flags(&self) -> [String; 2] {
        match (&self.sumocfg, &self.map) {
            (Some(cfg), _) => ["--sumocfg".into(), cfg.display().to_string()],
            (None, Some(map)) => ["--map".into(), map.display().to_string()],
            (None, None) => unreachable!("load checks that one is given"),
        }
    }

    /// Every service to start, with its flags.
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
        stepper.extend(["--seed".into(), self.seed.to_string()]);
        stepper.extend(self.stepper.flags());
        let lockstep = self.stepper.lockstep();
        // Each member's flag to keep in step, when the run is in lockstep.
        let in_step = |mut flags: Vec<String>| {
            if lockstep {
                flags.push("--lockstep".into());
            }
            flags
        };
        if lockstep {
            // The intersection service too, where it runs: the first round
            // then finds it up, as in `sim`.
            let mut members = "lights,crosswalks,spawner".to_string();
            if self.reservation_intersections {
                members.push_str(",intersection");
            }
            stepper.extend(["--lockstep".into(), "--lockstep-members".into(), members]);
        }
        stepper.extend(self.vehicle.flags());
        let mut list: Vec<(&'static str, Vec<String>)> = vec![
            ("stepper", stepper),
            (
                "spawner",
                member({
                    let mut flags = vec!["--seed".into(), self.seed.to_string()];
                    flags.extend(self.spawner.flags());
                    in_step(flags)
                }),
            ),
            ("lights", member(in_step(self.lights.flags()))),
            (
                "crosswalks",
                member({
                    let mut flags = in_step(self.crosswalks.flags());
                    if lockstep && self.pedestrians.enabled {
                        flags.extend(["--lockstep-sources".into(), "pedestrians".into()]);
                    }
                    flags
                }),
            ),
        ];
        if self.reservation_intersections {
            list.push(("intersection", member(in_step(Vec::new()))));
        }
        if self.pedestrians.enabled {
            list.push((
                "pedestrians",
                member(in_step(
                    [
                        vec!["--seed".into(), self.seed.to_string()],
                        self.pedestrians.flags(),
                    ]
                    .concat(),
                )),
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
            let mut extra = a.flags();
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
        if self.traffic_service.enabled {
            launches.push(Launch {
                name: "traffic-grpc",
                flags: member(self.traffic_service.flags()),
                env: Vec::new(),
            });
        }
        launches
    }
}
