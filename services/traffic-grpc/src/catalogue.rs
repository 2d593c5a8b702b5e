//! The scenes the service knows: scene id -> map file (native, SUMO net or
//! Lanelet2) and the offset that puts a log's frame onto the map's. Read
//! from a directory (every map file in it, named by its file stem) or a
//! TOML list:
//!
//! ```toml
//! [[scene]]
//! id = "four_way"
//! map = "configs/maps/four_way.map.json"   # relative to the TOML file
//! offset = [0.0, 0.0, 0.0]                   # log frame + offset = map frame
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use glam::DVec3;
use serde::Deserialize;
use trafficmesh_sim::LaneNetwork;

/// One scene: its compiled network and its frame offset.
pub struct Scene {
    pub network: LaneNetwork,
    pub offset: DVec3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogueFile {
    #[serde(default)]
    scene: Vec<SceneEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneEntry {
    id: String,
    map: PathBuf,
    #[serde(default)]
    offset: [f64; 3],
}

/// Adds one map file (native, SUMO net or Lanelet2, or a SUMO scenario's
/// network) as the scene named by its file stem.
pub fn add_file(scenes: &mut BTreeMap<String, Scene>, path: &Path) -> Result<()> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let id = [".map.json", ".net.xml", ".sumocfg", ".osm"]
        .iter()
        .find_map(|ext| name.strip_suffix(ext))
        .unwrap_or(name)
        .to_string();
    let network = if name.ends_with(".sumocfg") {
        trafficmesh_service::load_scenario_network(path, 0)
            .map(|(net, _, _)| net)
            .with_context(|| format!("scene '{id}': {}", path.display()))?
    } else {
        trafficmesh_service::load_network(path)
            .with_context(|| format!("scene '{id}': {}", path.display()))?
    };
    scenes.insert(
        id,
        Scene {
            network,
            offset: DVec3::ZERO,
        },
    );
    Ok(())
}

/// Loads every scene of `path` (a directory or a TOML list), naming the
/// entry and file of any that fails.
pub fn load(path: &Path) -> Result<BTreeMap<String, Scene>> {
    let entries = if path.is_dir() {
        let mut entries = Vec::new();
        for file in
            std::fs::read_dir(path).with_context(|| format!("reading {}", path.display()))?
        {
            let file = file?.path();
            let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
            let id = [".map.json", ".net.xml", ".osm"]
                .iter()
                .find_map(|ext| name.strip_suffix(ext));
            if let Some(id) = id {
                entries.push(SceneEntry {
                    id: id.to_string(),
                    map: file.clone(),
                    offset: [0.0; 3],
                });
            }
        }
        entries
    } else {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading the scene catalogue {}", path.display()))?;
        let file: CatalogueFile = toml::from_str(&text)
            .with_context(|| format!("the scene catalogue {}", path.display()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        file.scene
            .into_iter()
            .map(|e| SceneEntry {
                map: base.join(&e.map),
                ..e
            })
            .collect()
    };
    let mut scenes = BTreeMap::new();
    for e in entries {
        if scenes.contains_key(&e.id) {
            bail!("scene '{}' is listed twice in {}", e.id, path.display());
        }
        let network = trafficmesh_service::load_network(&e.map)
            .with_context(|| format!("scene '{}': {}", e.id, e.map.display()))?;
        scenes.insert(
            e.id,
            Scene {
                network,
                offset: DVec3::from_array(e.offset),
            },
        );
    }
    Ok(scenes)
}
