//! File I/O for maps and spawn configs.

use crate::import::Imported;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use thiserror::Error;
use trafficmesh_model::{MapFile, MapProblem, TrafficSpawnConfig};

#[derive(Debug, Error)]
pub enum FileError {
    #[error("{path}: cannot read: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not valid JSON: {message}")]
    Syntax { path: PathBuf, message: String },
    #[error("{path}: {location}: {message}")]
    Field {
        path: PathBuf,
        location: String,
        message: String,
    },
    #[error("{path}: {source}")]
    Import {
        path: PathBuf,
        source: crate::import::ImportError,
    },
    #[error("{path}: {} problem(s):\n  {}", .problems.len(), .problems.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("\n  "))]
    Invalid {
        path: PathBuf,
        problems: Vec<MapProblem>,
    },
}

pub(crate) fn read(path: &Path) -> Result<String, FileError> {
    fs::read_to_string(path).map_err(|source| FileError::Read {
        path: path.to_owned(),
        source,
    })
}

/// Deserialises with the JSON path of a type error, and names the element the
/// path points into (`lanes[3]` becomes `lane 'N_in_1' (lanes[3])`).
fn parse<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, FileError> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| FileError::Syntax {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    serde_path_to_error::deserialize(&value).map_err(|e| {
        let json_path = e.path().to_string();
        FileError::Field {
            path: path.to_owned(),
            location: describe_location(&value, &json_path),
            message: e.into_inner().to_string(),
        }
    })
}

/// `lanes[3].width` -> `lane 'X' (lanes[3]), field 'width'`.
fn describe_location(value: &serde_json::Value, json_path: &str) -> String {
    let Some((head, rest)) = json_path.split_once(']') else {
        return format!("field '{json_path}'");
    };
    let Some((list, index)) = head.split_once('[') else {
        return format!("field '{json_path}'");
    };
    let element = index
        .parse::<usize>()
        .ok()
        .and_then(|i| value.get(list)?.get(i))
        .and_then(|el| {
            ["name", "lane", "fromLane"].iter().find_map(|k| {
                el.get(*k)
                    .and_then(|n| n.as_str())
                    .map(|n| (*k, n.to_string()))
            })
        });
    let field = rest.trim_start_matches('.');
    let field = if field.is_empty() {
        String::new()
    } else {
        format!(", field '{field}'")
    };
    match element {
        Some((_, name)) => format!("{} '{name}' ({head}]){field}", singular(list)),
        None => format!("{head}]{field}"),
    }
}

fn singular(list: &str) -> &str {
    match list {
        "lanes" => "lane",
        "light_groups" => "light group",
        "crosswalks" => "crosswalk",
        "zebra_configs" => "zebra config",
        "spawnRates" | "branchWeights" => "lane",
        other => other,
    }
}

/// Parses and validates a native map.
pub fn parse_map(path: &Path, text: &str) -> Result<MapFile, FileError> {
    let map: MapFile = parse(path, text)?;
    map.validate().map_err(|problems| FileError::Invalid {
        path: path.to_owned(),
        problems,
    })?;
    Ok(map)
}

/// Reads and validates a map in any supported format: a native `.map.json`, a
/// SUMO `.net.xml`, a Lanelet2 `.osm`.
pub fn load_map(path: &Path) -> Result<MapFile, FileError> {
    Ok(import_map(path)?.map)
}

/// A SUMO route file as a demand on `map` (lane routes through its connections).
pub fn load_routes(path: &Path, map: &MapFile) -> Result<crate::sumo_routes::Demand, FileError> {
    crate::sumo_routes::import(&read(path)?, map).map_err(|source| FileError::Import {
        path: path.to_owned(),
        source,
    })
}

/// As `load_map`, with the warnings of a foreign format's import.
pub fn import_map(path: &Path) -> Result<Imported, FileError> {
    import_text(path, &read(path)?)
}

/// As `import_map`, on the text of the file at `path` (its format from the
/// name, errors named against it).
pub fn import_text(path: &Path, text: &str) -> Result<Imported, FileError> {
    let stem = crate::map_stem(path);
    let import_error = |source| FileError::Import {
        path: path.to_owned(),
        source,
    };
    let imported = match crate::MapFormat::of(path) {
        crate::MapFormat::Sumo => crate::sumo::import(&stem, text).map_err(import_error)?,
        crate::MapFormat::Lanelet2 => crate::lanelet2::import(&stem, text).map_err(import_error)?,
        crate::MapFormat::Native | crate::MapFormat::SumoScenario => {
            return Ok(Imported {
                map: parse_map(path, text)?,
                warnings: Vec::new(),
            });
        }
    };
    imported
        .map
        .validate()
        .map_err(|problems| FileError::Invalid {
            path: path.to_owned(),
            problems,
        })?;
    Ok(imported)
}

/// Parses a spawn config; lane names are checked when it is applied to a map.
pub fn parse_spawn_config(path: &Path, text: &str) -> Result<TrafficSpawnConfig, FileError> {
    parse(path, text)
}

pub fn load_spawn_config(path: &Path) -> Result<TrafficSpawnConfig, FileError> {
    parse_spawn_config(path, &read(path)?)
}

/// Writes the spawn config atomically, keeping the previous file as `<name>.bak`.
pub fn save_spawn_config(path: &Path, config: &TrafficSpawnConfig) -> Result<(), FileError> {
    let mut text = serde_json::to_string_pretty(config).expect("a spawn config always serialises");
    text.push('\n');
    if path.exists() {
        let mut backup = path.as_os_str().to_owned();
        backup.push(".bak");
        fs::copy(path, PathBuf::from(backup)).map_err(|source| FileError::Write {
            path: path.to_owned(),
            source,
        })?;
    }
    write_atomic(path, text.as_bytes())
}

/// Writes to a temporary file beside `path`, syncs it, then renames it over
/// `path`: a reader sees the old file or the new one, never half of one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    let err = |source| FileError::Write {
        path: path.to_owned(),
        source,
    };
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut file = fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_error_names_lane_and_field() {
        let text = r#"{"lanes": [{"name": "A", "waypoints": [[0,0],[10,0]]},
                                 {"name": "B", "waypoints": [[10,0],[20,0]], "width": "wide"}]}"#;
        let err = parse_map(Path::new("m.json"), text)
            .unwrap_err()
            .to_string();
        assert!(err.contains("lane 'B'") && err.contains("width"), "{err}");
    }

    /// A crosswalk written with document 002's inspector names loads as the
    /// same crosswalk as one written with ours, and is written back with ours.
    #[test]
    fn crosswalks_in_the_documents_spelling_are_accepted() {
        // The directory at run time: a binary built from another checkout
        // that shares the build directory reads this checkout's files.
        let dir: std::path::PathBuf = std::env::var_os("CARGO_MANIFEST_DIR")
            .map(std::path::PathBuf::from)
            .unwrap_or_else(|| env!("CARGO_MANIFEST_DIR").into());
        let ours = load_map(&dir.join("../../configs/maps/four_way.map.json")).unwrap();
        let mut doc: serde_json::Value = serde_json::to_value(&ours).unwrap();
        let crosswalk = &mut doc["crosswalks"][0];
        let c = crosswalk.as_object_mut().unwrap();
        for (ours, theirs) in [
            ("max_detection_distance", "maxDetectionDistance"),
            ("forward_angle_tolerance_deg", "forwardAngleTolerance"),
            ("stop_buffer", "stopBuffer"),
            ("enable_debug_logs", "enableDebugLogs"),
        ] {
            let v = c.remove(ours).unwrap();
            c.insert(theirs.into(), v);
        }
        // One stop point as the document has it, given by its position.
        let stops = c.remove("stop_points").unwrap();
        c.insert("stopPoint".into(), stops[0]["position"].clone());
        let text = serde_json::to_string(&doc).unwrap();
        let theirs = parse_map(Path::new("doc.map.json"), &text).unwrap();
        let (a, b) = (&ours.crosswalks[0], &theirs.crosswalks[0]);
        assert_eq!(
            (
                a.max_detection_distance,
                a.forward_angle_tolerance_deg,
                a.stop_buffer,
                a.enable_debug_logs
            ),
            (
                b.max_detection_distance,
                b.forward_angle_tolerance_deg,
                b.stop_buffer,
                b.enable_debug_logs
            )
        );
        assert_eq!(b.stop_points.len(), 1);
        assert_eq!(b.stop_points[0].position, a.stop_points[0].position);
        let written = serde_json::to_string(&theirs).unwrap();
        assert!(
            written.contains("max_detection_distance") && !written.contains("maxDetectionDistance"),
            "one spelling in output: {written}"
        );
    }

    #[test]
    fn atomic_write_keeps_backup() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("traffic_spawn.json");
        let mut cfg = TrafficSpawnConfig::default();
        save_spawn_config(&path, &cfg).unwrap();
        cfg.spawn_rates.push(trafficmesh_model::SpawnRate {
            lane: "A".into(),
            spawns_per_minute: 6.0,
        });
        save_spawn_config(&path, &cfg).unwrap();
        assert_eq!(load_spawn_config(&path).unwrap(), cfg);
        let backup = load_spawn_config(&dir.path().join("traffic_spawn.json.bak")).unwrap();
        assert!(backup.spawn_rates.is_empty());
        let leftovers: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
            .collect();
        assert!(leftovers.is_empty());
    }
}
