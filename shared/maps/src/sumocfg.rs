//! SUMO's own configuration (`.sumocfg`): a scenario as its authors ship it.
//! The network, every route file and the additional files: their `tlLogic`
//! programs replace the network's of the same id, their vTypes and
//! vTypeDistributions feed the route files, and whatever else they hold
//! (detectors, bus stops, ...) is named and counted in one warning. The
//! `begin`/`end` window keeps the departures inside it.

use std::path::{Path, PathBuf};

use trafficmesh_model::MapFile;

use crate::files::{FileError, read};
use crate::import::{ImportError, attr, parse_xml};
use crate::sumo_routes::DemandBuilder;

/// What a `.sumocfg` names, paths resolved against its folder.
#[derive(Clone, Debug, PartialEq)]
pub struct SumoConfig {
    pub net: PathBuf,
    pub routes: Vec<PathBuf>,
    pub additionals: Vec<PathBuf>,
    pub begin: f64,
    pub end: Option<f64>,
}

/// A scenario loaded: the map with its demand and vehicle types, the
/// configuration's time window, and what could not be carried over.
pub struct Scenario {
    pub map: MapFile,
    pub config: SumoConfig,
    pub warnings: Vec<String>,
}

fn located(path: &Path) -> impl Fn(ImportError) -> FileError + '_ {
    move |source| FileError::Import {
        path: path.to_owned(),
        source,
    }
}

/// Reads a `.sumocfg` (root `configuration` or `sumoConfiguration`).
pub fn read_sumocfg(path: &Path) -> Result<SumoConfig, FileError> {
    let text = read(path)?;
    let doc = roxmltree::Document::parse(&text)
        .map_err(ImportError::xml)
        .map_err(located(path))?;
    let root = doc.root_element();
    if !matches!(
        root.tag_name().name(),
        "configuration" | "sumoConfiguration"
    ) {
        return Err(located(path)(ImportError::at(
            &doc,
            root,
            "the root element is not <configuration> (not a SUMO configuration)",
        )));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let option = |name: &str| {
        root.descendants()
            .find(|n| n.has_tag_name(name))
            .map(|n| attr(&doc, n, "value").map(|v| (n, v)))
            .transpose()
    };
    let files = |name: &str| -> Result<Vec<PathBuf>, FileError> {
        Ok(option(name)
            .map_err(located(path))?
            .map(|(_, v)| {
                v.split([',', ' '])
                    .filter(|f| !f.is_empty())
                    .map(|f| dir.join(f))
                    .collect()
            })
            .unwrap_or_default())
    };
    let time = |name: &str| -> Result<Option<f64>, FileError> {
        match option(name).map_err(located(path))? {
            None => Ok(None),
            Some((n, v)) => v
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite() && *t >= 0.0)
                .map(Some)
                .ok_or_else(|| {
                    located(path)(ImportError::at(
                        &doc,
                        n,
                        &format!("<{name}>: '{v}' is not a time in seconds"),
                    ))
                }),
        }
    };
    let net = files("net-file")?;
    let [net] = net.as_slice() else {
        return Err(located(path)(ImportError::plain(
            "the configuration names no <net-file> (or more than one)".into(),
        )));
    };
    let config = SumoConfig {
        net: net.clone(),
        routes: files("route-files")?,
        additionals: files("additional-files")?,
        begin: time("begin")?.unwrap_or(0.0),
        end: time("end")?,
    };
    if config.end.is_some_and(|end| end <= config.begin) {
        return Err(located(path)(ImportError::plain(format!(
            "<end> ({}) is not after <begin> ({})",
            config.end.unwrap_or_default(),
            config.begin
        ))));
    }
    if config.routes.is_empty() {
        return Err(located(path)(ImportError::plain(
            "the configuration names no <route-files>: there is no demand to run".into(),
        )));
    }
    Ok(config)
}

/// Loads the scenario of a `.sumocfg`; `seed` draws each vehicle's vType
/// from its distribution.
pub fn load_scenario(path: &Path, seed: u64) -> Result<Scenario, FileError> {
    let config = read_sumocfg(path)?;
    let additionals: Vec<(PathBuf, String)> = config
        .additionals
        .iter()
        .map(|p| read(p).map(|text| (p.clone(), text)))
        .collect::<Result<_, _>>()?;
    let mut additional_docs = Vec::with_capacity(additionals.len());
    for (p, text) in &additionals {
        let doc = roxmltree::Document::parse(text)
            .map_err(ImportError::xml)
            .map_err(located(p))?;
        additional_docs.push((p, doc));
    }
    // Signal programs first: they go into the network's import.
    let mut warnings = Vec::new();
    let mut programs = crate::sumo::Programs::new();
    for (p, doc) in &additional_docs {
        programs.extend(
            crate::sumo::tl_programs(doc, doc.root_element(), &mut warnings).map_err(located(p))?,
        );
    }
    let replaced = programs.len();
    let net_text = read(&config.net)?;
    let stem = config
        .net
        .file_name()
        .map(|n| {
            n.to_string_lossy()
                .split('.')
                .next()
                .unwrap_or("")
                .to_string()
        })
        .unwrap_or_default();
    let imported = crate::sumo::import_with_programs(&stem, &net_text, programs)
        .map_err(located(&config.net))?;
    warnings.extend(imported.warnings);
    if replaced > 0 {
        warnings.push(format!(
            "{replaced} tlLogic program(s) from the additional files replace the network's"
        ));
    }
    let mut map = imported.map;
    let routes: Vec<(PathBuf, String)> = config
        .routes
        .iter()
        .map(|p| read(p).map(|text| (p.clone(), text)))
        .collect::<Result<_, _>>()?;
    let demand = {
        let mut builder = DemandBuilder::new(
            &map,
            seed,
            config.begin,
            config.end.unwrap_or(f64::INFINITY),
        );
        for (p, doc) in &additional_docs {
            builder.add_types(doc).map_err(located(p))?;
            builder.note_additionals(doc);
        }
        for (p, text) in &routes {
            let doc = parse_xml(text, "routes", "SUMO route file").map_err(located(p))?;
            builder.add_routes(&doc).map_err(located(p))?;
        }
        builder.finish().map_err(located(path))?
    };
    warnings.extend(demand.warnings);
    map.traffic_simulators = vec![demand.simulator];
    map.vehicle_kinds.extend(demand.kinds);
    map.validate().map_err(|problems| FileError::Invalid {
        path: path.to_owned(),
        problems,
    })?;
    Ok(Scenario {
        map,
        config,
        warnings,
    })
}
