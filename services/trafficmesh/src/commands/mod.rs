pub mod bench;
pub mod bench_cluster;
pub mod cluster_config;
pub mod ego;
pub mod gen_grid;
pub mod sim;
pub mod up;
pub mod watch;

use std::path::Path;

use anyhow::{Context, Result};
use trafficmesh_sim::LaneNetwork;

/// Loads and compiles a native map, with every problem named.
pub fn load_network(path: &Path) -> Result<LaneNetwork> {
    Ok(trafficmesh_maps::load_network(path)?)
}

/// A rayon pool of `threads` workers (0 = one per core).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start worker threads")
}

/// Resolves on SIGINT or SIGTERM.
pub async fn shutdown_signal() {
    trafficmesh_bus::runtime::shutdown_signal().await
}
