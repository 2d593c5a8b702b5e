//! `--map` as every service and the CLI take it: one flag, one help text, one
//! loader for every supported format.

use std::path::PathBuf;

use trafficmesh_sim::LaneNetwork;

use crate::FileError;

#[derive(clap::Args, Clone, Debug)]
pub struct MapArgs {
    /// Map file: native `.map.json`, SUMO `.net.xml` or Lanelet2 `.osm`.
    #[arg(long)]
    pub map: PathBuf,
}

impl MapArgs {
    pub fn load(&self) -> Result<LaneNetwork, FileError> {
        crate::load_network(&self.map)
    }
}
