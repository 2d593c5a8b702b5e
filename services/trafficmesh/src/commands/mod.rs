#[cfg(feature = "bench")]
pub mod bench;
#[cfg(feature = "bench")]
pub mod bench_admin;
#[cfg(feature = "bench")]
pub mod bench_bus;
#[cfg(feature = "bench")]
pub mod bench_cluster;
#[cfg(feature = "bench")]
pub mod bench_intersection;
pub mod bench_saturation;
#[cfg(feature = "bench")]
pub mod bench_traffic_service;
#[cfg(feature = "bench")]
mod bench_up;
#[cfg(feature = "bench")]
pub mod bench_vs_sumo;
pub mod cluster_config;
#[cfg(feature = "bench")]
mod delay_plot;
pub mod ego;
pub mod gen_grid;
pub mod import;
#[cfg(feature = "bench")]
mod memory;
pub mod router;
pub mod sim;
pub mod status;
pub mod up;
pub mod watch;

use anyhow::{Context, Result};

/// A rayon pool of `threads` workers (0 = one per core).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start worker threads")
}
