//! `--map` (or `--sumocfg`) as every service and the CLI take it: one flag
//! pair, one help text, one loader for every supported format.

use std::path::PathBuf;

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

/// The AWSIM reference's SpeedLimitSource, as the flags and cluster.toml name it.
#[derive(Clone, Copy, Debug, clap::ValueEnum, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpeedSource {
    Fixed,
    Lanelet,
}
