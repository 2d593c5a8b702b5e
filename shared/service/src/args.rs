//! `--map` (or `--sumocfg`) as every service and the CLI take it: one flag
//! pair, one help text, one loader for every supported format.

use std::path::PathBuf;

use trafficmesh_model::{NpcVehicleConfig, SpeedLimitSource};
use trafficmesh_sim::LaneNetwork;

use trafficmesh_maps::FileError;

#[derive(clap::Args, Clone, Debug)]
pub struct MapArgs {
    /// Map file: native `.map.json`, SUMO `.net.xml` or Lanelet2 `.osm`.
    #[arg(long, required_unless_present = "sumocfg", conflicts_with = "sumocfg")]
    pub map: Option<PathBuf>,
    /// A SUMO scenario (`.sumocfg`) instead of --map: its network with the
    /// signal programs of its additional files, and its demand.
    #[arg(long)]
    pub sumocfg: Option<PathBuf>,
}

impl MapArgs {
    /// The network (of the scenario, with its demand, when --sumocfg).
    pub fn load(&self) -> Result<LaneNetwork, FileError> {
        self.load_with_routes(None, 0).map(|(net, _)| net)
    }

    /// The network with a demand: the scenario's with --sumocfg (its vTypes
    /// drawn with `seed`), else a route file's in place of the map's
    /// simulators when one is given; with the import's warnings.
    pub fn load_with_routes(
        &self,
        routes: Option<&std::path::Path>,
        seed: u64,
    ) -> Result<(LaneNetwork, Vec<String>), FileError> {
        if let Some(cfg) = &self.sumocfg {
            let (net, warnings, _) = crate::load_scenario_network(cfg, seed)?;
            return Ok((net, warnings));
        }
        let map = self
            .map
            .as_deref()
            .expect("clap requires --map without --sumocfg");
        crate::load_network_with_routes(map, routes)
    }

    /// The file named: the scenario or the map.
    pub fn path(&self) -> &std::path::Path {
        self.sumocfg
            .as_deref()
            .or(self.map.as_deref())
            .expect("clap requires one")
    }
}

/// AWSIM's NPCVehicleConfig, as `sim` and the stepper take it (the
/// inspector's fields). Defaults are the reference's, from
/// [`NpcVehicleConfig::default`].
#[derive(clap::Args, Clone, Debug)]
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

/// The AWSIM reference's SpeedLimitSource, as the flags and cluster.toml name it.
#[derive(Clone, Copy, Debug, clap::ValueEnum, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpeedSource {
    Fixed,
    Lanelet,
}

impl VehicleArgs {
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

/// AWSIM's spawnDistanceToEgo, as `sim` and the spawner take it.
#[derive(clap::Args, Clone, Debug)]
pub struct SpawnDistanceArgs {
    /// spawnDistanceToEgo: no vehicle spawns closer than this to the ego, metres.
    #[arg(long, default_value_t = trafficmesh_sim::WorldConfig::default().spawn_distance_to_ego, allow_negative_numbers = true)]
    pub spawn_distance_to_ego: f64,
}

impl SpawnDistanceArgs {
    /// The distance, or what is wrong with it.
    pub fn checked(&self) -> Result<f64, String> {
        let d = self.spawn_distance_to_ego;
        if d.is_finite() && d >= 0.0 {
            Ok(d)
        } else {
            Err(format!(
                "--spawn-distance-to-ego must be a number of metres >= 0, got {d}"
            ))
        }
    }
}
