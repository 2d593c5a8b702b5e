pub mod bench;
pub mod gen_grid;
pub mod sim;

use std::path::Path;

use anyhow::{Context, Result};
use trafficmesh_maps::FileError;
use trafficmesh_sim::LaneNetwork;

/// Loads and compiles a native map, with every problem named.
pub fn load_network(path: &Path) -> Result<LaneNetwork> {
    let map = trafficmesh_maps::load_map(path)?;
    let network = LaneNetwork::build(&map).map_err(|problems| FileError::Invalid {
        path: path.to_owned(),
        problems,
    })?;
    Ok(network)
}

/// A rayon pool of `threads` workers (0 = one per core).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start worker threads")
}
