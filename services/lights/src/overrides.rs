//! The overrides in force, kept in a file (`--overrides`) so that a restarted
//! lights service takes them up again: a forced colour or an admin's
//! program outlives a crash. The file is the REST body's shape, one entry per
//! overridden group: `[{"group": "g1", "color": "red"}, ...]`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use trafficmesh_protocol::wire::LightOverride;
use trafficmesh_sim::LaneNetwork;
use trafficmesh_sim::lights::Lights;

/// The overrides saved in `path` (none when there is no file yet). Entries for
/// groups this map does not have are left out with a warning: the next save
/// drops them.
pub fn load(path: &Path, net: &LaneNetwork) -> Result<Vec<LightOverride>> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let saved: Vec<LightOverride> = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not a list of light overrides; move it away to start from the map's programs",
            path.display()
        )
    })?;
    let (known, unknown): (Vec<_>, Vec<_>) = saved
        .into_iter()
        .partition(|o| net.light_group(&o.group).is_some());
    if !unknown.is_empty() {
        let names: Vec<&str> = unknown.iter().map(|o| o.group.as_str()).collect();
        tracing::warn!(
            "{}: no light group {} on this map; those overrides are dropped",
            path.display(),
            names.join(", ")
        );
    }
    Ok(known)
}

/// Every group not on its map's program, as the overrides that put it there.
pub fn in_force(net: &LaneNetwork, lights: &Lights) -> Vec<LightOverride> {
    net.light_groups
        .iter()
        .enumerate()
        .filter_map(|(i, g)| {
            let (color, program) = lights.control(i).as_override(g.program);
            (color.is_some() || program.is_some()).then(|| LightOverride {
                group: g.name.clone(),
                color,
                program,
            })
        })
        .collect()
}

/// Writes `overrides` to `path` atomically (a kill mid-write leaves the last
/// file whole).
pub fn save(path: PathBuf, overrides: &[LightOverride]) -> Result<()> {
    let bytes = serde_json::to_vec_pretty(overrides)?;
    trafficmesh_maps::write_atomic(&path, &bytes)?;
    Ok(())
}
