//! Reading and writing trafficmesh's files: native JSON maps (with errors that
//! name the lane and field), spawn configs (written atomically, previous version
//! kept), the signalised-grid generator, and importers of foreign formats
//! (SUMO `.net.xml`, Lanelet2 `.osm`).

mod crossing;
pub mod files;
pub mod four_way;
pub mod grid;
pub mod import;
mod joints;
mod lanelet2;
mod permitted_turns;
mod sumo;
mod sumo_levels;
pub mod sumo_routes;
pub mod sumocfg;

pub use files::{
    FileError, import_map, import_text, load_map, load_routes, load_spawn_config, parse_map,
    parse_spawn_config, save_spawn_config, write_atomic,
};
pub use four_way::{FourWayOptions, four_way_map};
pub use grid::{GridOptions, grid_map};
pub use import::{ImportError, Imported};
pub use sumocfg::{Scenario, SumoConfig, load_scenario, read_sumocfg};

/// The driver model a map runs by unless told: `realistic` for SUMO
/// networks and scenarios (their demand was made for traffic that flows like
/// real traffic), `awsim` (the AWSIM reference's) for every other map.
pub fn default_driver_model(map: &std::path::Path) -> trafficmesh_model::DriverModel {
    let model = match MapFormat::of(map) {
        MapFormat::Sumo | MapFormat::SumoScenario => "realistic",
        MapFormat::Native | MapFormat::Lanelet2 => "awsim",
    };
    trafficmesh_model::DriverModel::by_name(model).expect("a known model")
}

/// What kind of file a map path names, by its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapFormat {
    /// `.map.json` (and any other name).
    Native,
    /// A SUMO network, `.net.xml`.
    Sumo,
    /// A SUMO scenario, `.sumocfg`.
    SumoScenario,
    /// A Lanelet2 map, `.osm`.
    Lanelet2,
}

impl MapFormat {
    pub fn of(path: &std::path::Path) -> MapFormat {
        let name = path.to_string_lossy().to_lowercase();
        if name.ends_with(".net.xml") {
            MapFormat::Sumo
        } else if name.ends_with(".sumocfg") {
            MapFormat::SumoScenario
        } else if name.ends_with(".osm") {
            MapFormat::Lanelet2
        } else {
            MapFormat::Native
        }
    }

    /// Imported from another tool's format.
    pub fn is_imported(self) -> bool {
        self != MapFormat::Native
    }
}

/// A map file's name up to its first dot (`town` for `town.net.xml`).
pub fn map_stem(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().to_lowercase())
        .and_then(|n| n.split('.').next().map(str::to_string))
        .unwrap_or_default()
}

/// Where target speeds come from unless told: the lanes' own limits on
/// imported maps (SUMO networks and scenarios, Lanelet2), which carry them,
/// the fixed 13.89 m/s of the AWSIM reference on native maps.
pub fn default_speed_limit_source(map: &std::path::Path) -> trafficmesh_model::SpeedLimitSource {
    if MapFormat::of(map).is_imported() {
        trafficmesh_model::SpeedLimitSource::LaneletSpeedLimit
    } else {
        trafficmesh_model::SpeedLimitSource::FixedSpeedLimit
    }
}
