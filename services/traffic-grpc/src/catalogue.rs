//! The scenes the service knows: scene id -> map file (native, SUMO net,
//! Lanelet2 or a SUMO scenario) and the offset that puts a log's frame onto
//! the map's. Read from a directory (every map file in it, named by its map
//! name: the file name up to its first dot) or a TOML list:
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
use trafficmesh_maps::MapFormat;
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

/// Loads the map at `path` (any format `--map` takes, or a SUMO scenario's
/// network) as the scene named by its map name, the file name up to its
/// first dot; refuses a name already taken.
pub fn add(scenes: &mut BTreeMap<String, Scene>, path: &Path, offset: DVec3) -> Result<()> {
    add_as(scenes, trafficmesh_maps::map_stem(path), path, offset)
}

fn add_as(
    scenes: &mut BTreeMap<String, Scene>,
    id: String,
    path: &Path,
    offset: DVec3,
) -> Result<()> {
    if scenes.contains_key(&id) {
        bail!("scene '{id}' is given twice ({})", path.display());
    }
    let network = if MapFormat::of(path) == MapFormat::SumoScenario {
        trafficmesh_service::load_scenario_network(path, 0).map(|(net, _, _)| net)
    } else {
        trafficmesh_service::load_network(path)
    }
    .with_context(|| format!("scene '{id}': {}", path.display()))?;
    scenes.insert(id, Scene { network, offset });
    Ok(())
}

/// Every scene of `path`: a directory of maps (`.map.json`, `.net.xml`,
/// `.osm`, `.sumocfg`), or a TOML list.
pub fn load(path: &Path) -> Result<BTreeMap<String, Scene>> {
    let mut scenes = BTreeMap::new();
    if path.is_dir() {
        let mut files = Vec::new();
        for file in
            std::fs::read_dir(path).with_context(|| format!("reading {}", path.display()))?
        {
            let file = file?.path();
            let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if [".map.json", ".net.xml", ".osm", ".sumocfg"]
                .iter()
                .any(|ext| name.ends_with(ext))
            {
                files.push(file);
            }
        }
        files.sort();
        for file in files {
            add(&mut scenes, &file, DVec3::ZERO)?;
        }
        return Ok(scenes);
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading the scene catalogue {}", path.display()))?;
    let file: CatalogueFile =
        toml::from_str(&text).with_context(|| format!("the scene catalogue {}", path.display()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    for e in file.scene {
        add_as(
            &mut scenes,
            e.id,
            &base.join(&e.map),
            DVec3::from_array(e.offset),
        )?;
    }
    Ok(scenes)
}
