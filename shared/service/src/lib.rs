//! What every trafficmesh binary shares at its edge: the map and vehicle
//! flags (one flag set, one help text), the loading of a map file, any
//! format, into the simulation's lane network, and the skeleton of a cluster
//! service ([`Service`], [`run`]).

pub mod args;
mod kit;
pub mod settings;
pub mod stats;

pub use args::{MapArgs, SpeedSource};
pub use kit::{Service, ServiceArgs, run};
pub use settings::{Settings, SpawnDistanceArgs, VehicleArgs, check_flags};

use trafficmesh_maps::FileError;
use trafficmesh_protocol::wire::EgoPose;
use trafficmesh_sim::{Ego, LaneNetwork, Pose};

/// How long a service joining a running cluster waits for the answers to
/// its query of the states in force (lights, crosswalk occupancy).
pub const LATE_STATES_WAIT: std::time::Duration = std::time::Duration::from_millis(500);

/// The ego as the simulation takes it, from its pose on the bus.
pub fn ego_of(p: &EgoPose) -> Ego {
    Ego {
        pose: Pose {
            x: p.x,
            y: p.y,
            z: p.z,
            yaw: p.yaw,
        },
        length: p.length,
        width: p.width,
        front_offset: p.front_offset,
    }
}

/// Loads a map (any format), with a SUMO route file's demand in place of the
/// map's own simulators when one is given, and compiles it; the map
/// import's warnings (what a foreign format had that is not simulated, or
/// was made up) and the route import's come back with it.
pub fn load_network_with_routes(
    map: &std::path::Path,
    routes: Option<&std::path::Path>,
) -> Result<(LaneNetwork, Vec<String>), FileError> {
    let trafficmesh_maps::Imported {
        map: mut file,
        mut warnings,
    } = trafficmesh_maps::import_map(map)?;
    let Some(routes) = routes else {
        return Ok((build_network(&file, map)?, warnings));
    };
    let demand = trafficmesh_maps::load_routes(routes, &file)?;
    file.traffic_simulators = vec![demand.simulator];
    file.vehicle_kinds.extend(demand.kinds);
    warnings.extend(demand.warnings);
    Ok((build_network(&file, routes)?, warnings))
}

/// Compiles a map read from `path` into the simulation's lane network, with
/// every problem of the start-up checklist named against that file.
pub fn build_network(
    map: &trafficmesh_model::MapFile,
    path: &std::path::Path,
) -> Result<LaneNetwork, FileError> {
    LaneNetwork::build(map).map_err(|problems| FileError::Invalid {
        path: path.to_owned(),
        problems,
    })
}

/// A SUMO scenario's network with its demand (vTypes drawn with `seed`),
/// the import's warnings, and the configuration.
pub fn load_scenario_network(
    path: &std::path::Path,
    seed: u64,
) -> Result<(LaneNetwork, Vec<String>, trafficmesh_maps::SumoConfig), FileError> {
    let scenario = trafficmesh_maps::load_scenario(path, seed)?;
    Ok((
        build_network(&scenario.map, path)?,
        scenario.warnings,
        scenario.config,
    ))
}

/// Loads a map file and compiles it into the simulation's lane network, with
/// every problem of the start-up checklist named.
pub fn load_network(path: &std::path::Path) -> Result<LaneNetwork, FileError> {
    build_network(&trafficmesh_maps::load_map(path)?, path)
}
