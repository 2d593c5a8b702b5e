//! A whole cluster on a generated grid for the cluster benchmarks, started
//! the one way tests and benchmarks start clusters (`trafficmesh_testkit`).

use anyhow::{Context, Result};
use trafficmesh_maps::GridOptions;
use trafficmesh_testkit::{ClusterSpec, LocalCluster};

/// `size` x `size` grid with `vehicles` placed and kept up by the spawner;
/// `stepper`: more of cluster.toml's `[stepper]` (e.g. `speed = 0`); the
/// admin with a token of its own when `with_admin`.
pub fn start(
    size: usize,
    vehicles: usize,
    stepper: &str,
    with_admin: bool,
) -> Result<LocalCluster> {
    let dir = LocalCluster::folder().context("cannot create a folder for the cluster")?;
    let map = dir.path().join("grid.map.json");
    let grid = trafficmesh_maps::grid_map(&GridOptions {
        size,
        ..GridOptions::default()
    });
    trafficmesh_maps::write_atomic(&map, serde_json::to_string(&grid)?.as_bytes())?;
    let pid = std::process::id();
    let spec = ClusterSpec {
        stepper: format!("populate = {vehicles}\n{stepper}"),
        spawner: format!("max_vehicles = {vehicles}"),
        admin_token: with_admin.then(|| format!("bench-token-{pid}")),
        ..ClusterSpec::new(format!("bench{pid}"), map)
    };
    LocalCluster::launch(&std::env::current_exe()?, dir, &spec)
        .context("cannot start `trafficmesh up`")
}
