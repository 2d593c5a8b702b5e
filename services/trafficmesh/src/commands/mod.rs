pub mod bench;
pub mod gen_grid;
pub mod sim;

use std::path::Path;

use anyhow::{Context, Result, anyhow};
use trafficmesh_sim::LaneNetwork;

/// Loads and compiles a native map, with every problem named.
pub fn load_network(path: &Path) -> Result<LaneNetwork> {
    let map = trafficmesh_maps::load_map(path)?;
    LaneNetwork::build(&map).map_err(|problems| {
        anyhow!(
            "{}: {} problem(s):\n  {}",
            path.display(),
            problems.len(),
            problems
                .iter()
                .map(|p| p.to_string())
                .collect::<Vec<_>>()
                .join("\n  ")
        )
    })
}

/// A rayon pool of `threads` workers (0 = one per core).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start worker threads")
}
