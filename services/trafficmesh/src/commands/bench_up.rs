//! A whole cluster on a generated grid for the cluster benchmarks: `up` in a
//! child process with its own cluster name, port and files; stopped on drop.

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

use anyhow::{Context, Result};
use trafficmesh_bus::{BusArgs, free_loopback_port};
use trafficmesh_maps::GridOptions;

pub struct BenchCluster {
    pub cluster: String,
    pub endpoint: String,
    /// `http://127.0.0.1:<port>` when started with the admin.
    pub admin: Option<String>,
    pub dir: PathBuf,
    pub log: PathBuf,
    up: Child,
}

impl BenchCluster {
    /// `size` x `size` grid with `vehicles` placed and kept up by the spawner;
    /// `stepper`: more of cluster.toml's `[stepper]` (e.g. `speed = 0`).
    pub fn start(
        size: usize,
        vehicles: usize,
        stepper: &str,
        with_admin: bool,
    ) -> Result<BenchCluster> {
        let dir = std::env::temp_dir().join(format!("trafficmesh-bench-{}", std::process::id()));
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let map = dir.join("grid.map.json");
        let grid = trafficmesh_maps::grid_map(&GridOptions {
            size,
            ..GridOptions::default()
        });
        trafficmesh_maps::write_atomic(&map, serde_json::to_string(&grid)?.as_bytes())?;
        let cluster = format!("bench{}", std::process::id());
        let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
        let admin_port = free_loopback_port()?;
        let token = format!("bench-token-{}-{admin_port}", std::process::id());
        let config = dir.join("cluster.toml");
        std::fs::write(
            &config,
            format!(
                "cluster = \"{cluster}\"\nmap = \"{map}\"\nendpoint = \"{endpoint}\"\n\
                 [stepper]\npopulate = {vehicles}\n{stepper}\n\
                 [spawner]\nmax_vehicles = {vehicles}\nspawn_config = \"{spawn}\"\nbranch_csv = \"{csv}\"\n\
                 [pedestrians]\nenabled = false\n\
                 [admin]\nenabled = {with_admin}\nlisten = \"127.0.0.1:{admin_port}\"\ntoken = \"{token}\"\n",
                map = map.display(),
                spawn = dir.join("spawn.json").display(),
                csv = dir.join("branch.csv").display(),
            ),
        )?;
        let log = dir.join("up.log");
        let up = Command::new(std::env::current_exe()?)
            .args(["up", "--config"])
            .arg(&config)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log)?)
            .spawn()
            .context("cannot start `trafficmesh up`")?;
        Ok(BenchCluster {
            cluster,
            endpoint,
            admin: with_admin.then(|| format!("http://127.0.0.1:{admin_port}")),
            dir,
            log,
            up,
        })
    }

    /// Bus flags for a measuring client of this cluster.
    pub fn bus_args(&self) -> BusArgs {
        BusArgs {
            cluster: self.cluster.clone(),
            zenoh_config: None,
            mode: None,
            connect: vec![self.endpoint.clone()],
            listen: vec!["tcp/127.0.0.1:0".into()],
        }
    }
}

impl Drop for BenchCluster {
    fn drop(&mut self) {
        unsafe { libc::kill(self.up.id() as i32, libc::SIGTERM) };
        let _ = self.up.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
