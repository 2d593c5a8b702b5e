//! Foreign map formats: what an importer returns, its errors (with the line
//! and element), and the XML attribute helpers the importers share.

use roxmltree::{Document, Node};
use trafficmesh_model::map::{
    CrosswalkDef, LaneDef, LightGroupDef, MapFile, RoadConflicts, SimulatorDef,
};

/// A map read from a foreign file, and what could not be carried over.
#[derive(Debug)]
pub struct Imported {
    pub map: MapFile,
    /// One line each, naming the element (id) it concerns.
    pub warnings: Vec<String>,
}

/// Why a foreign file cannot be read: the line (when known) and the element.
#[derive(Debug, thiserror::Error)]
#[error("{}{message}", line.map(|l| format!("line {l}: ")).unwrap_or_default())]
pub struct ImportError {
    pub line: Option<u32>,
    pub message: String,
}

impl ImportError {
    pub fn xml(e: roxmltree::Error) -> ImportError {
        ImportError {
            line: Some(e.pos().row),
            message: format!("not well-formed XML: {e}"),
        }
    }

    /// A problem with one element, located by its start.
    pub fn at(doc: &Document, node: Node, message: &str) -> ImportError {
        let id = node
            .attribute("id")
            .map(|id| format!(" id='{id}'"))
            .unwrap_or_default();
        ImportError {
            line: Some(doc.text_pos_at(node.range().start).row),
            message: format!("<{}{id}>: {message}", node.tag_name().name()),
        }
    }

    pub fn plain(message: String) -> ImportError {
        ImportError {
            line: None,
            message,
        }
    }
}

/// The network an importer read, in the native format. `is_entry` tells the
/// lanes nothing leads into, where the map's random simulator spawns;
/// `road_conflicts` where lanes outside the junctions it marks may touch.
pub fn assemble(
    name: String,
    lanes: Vec<LaneDef>,
    light_groups: Vec<LightGroupDef>,
    crosswalks: Vec<CrosswalkDef>,
    is_entry: impl Fn(usize) -> bool,
    road_conflicts: RoadConflicts,
    warnings: Vec<String>,
) -> Imported {
    let entries: Vec<String> = lanes
        .iter()
        .enumerate()
        .filter(|(i, l)| is_entry(*i) && !l.intersection)
        .map(|(_, l)| l.name.clone())
        .collect();
    let traffic_simulators = random_simulator(&lanes, entries).into_iter().collect();
    Imported {
        map: MapFile {
            format: trafficmesh_model::map::MAP_FORMAT.to_string(),
            name,
            lanes,
            light_groups,
            crosswalks,
            zebra_configs: Vec::new(),
            traffic_simulators,
            road_conflicts,
            vehicle_kinds: Vec::new(),
            intersections: Vec::new(),
        },
        warnings,
    }
}

/// The map's random simulator for an imported network: every catalogue kind,
/// spawning at `entries` (lanes nothing leads into), or at every non-junction
/// lane when there are none (a closed network). None when the map has no lane.
pub fn random_simulator(lanes: &[LaneDef], entries: Vec<String>) -> Option<SimulatorDef> {
    let sources = if entries.is_empty() {
        lanes
            .iter()
            .filter(|l| !l.intersection)
            .map(|l| l.name.clone())
            .collect()
    } else {
        entries
    };
    (!sources.is_empty()).then(|| SimulatorDef::Random {
        lanes: sources,
        prefabs: trafficmesh_model::catalog::builtin_names()
            .map(String::from)
            .collect(),
        maximum_spawns: 0,
        enabled: true,
        spawn_attempts_per_tick: 1,
    })
}

/// Parses the XML and checks the root element's name (`what` says which format it is not).
pub fn parse_xml<'a>(text: &'a str, root: &str, what: &str) -> Result<Document<'a>, ImportError> {
    let doc = Document::parse(text).map_err(ImportError::xml)?;
    let found = doc.root_element();
    if found.tag_name().name() != root {
        return Err(ImportError::at(
            &doc,
            found,
            &format!("the root element is not <{root}> (not a {what})"),
        ));
    }
    Ok(doc)
}

pub fn attr<'a>(doc: &Document, node: Node<'a, '_>, name: &str) -> Result<&'a str, ImportError> {
    node.attribute(name)
        .ok_or_else(|| ImportError::at(doc, node, &format!("missing attribute '{name}'")))
}

pub fn attr_f64(doc: &Document, node: Node, name: &str) -> Result<f64, ImportError> {
    let text = attr(doc, node, name)?;
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            ImportError::at(
                doc,
                node,
                &format!("attribute '{name}': '{text}' is not a finite number"),
            )
        })
}
