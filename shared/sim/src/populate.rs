//! Fills a world with parked-then-starting traffic for benchmarks: vehicles
//! placed bumper to bumper with a gap on every non-junction lane, round-robin,
//! so a large run starts full instead of waiting minutes for spawns.

use trafficmesh_model::map::{MapFile, MapProblem};

use crate::network::LaneNetwork;
use crate::world::{World, WorldConfig};

const SPACING: f64 = 12.0;
const END_MARGIN: f64 = 2.0;

/// An empty world on `map` (the benchmarks' generated grid) with room for
/// `max_vehicles` and the default config otherwise.
pub fn empty_world(map: &MapFile, max_vehicles: usize) -> Result<World, Vec<MapProblem>> {
    let config = WorldConfig {
        max_vehicles,
        ..WorldConfig::default()
    };
    Ok(World::new(LaneNetwork::build(map)?, config))
}

/// Places up to `count` vehicles; returns how many fit.
pub fn populate(world: &mut World, count: usize) -> usize {
    let kinds = ["Taxi", "Hatchback", "SmallCar", "Van", "Truck_2t"];
    let lanes: Vec<(String, f64)> = world
        .network()
        .lanes
        .iter()
        .filter(|l| !l.intersection && l.length() > SPACING + END_MARGIN)
        .map(|l| (l.name.clone(), l.length()))
        .collect();
    let mut placed = 0;
    let mut row = 0;
    while placed < count {
        let mut any = false;
        for (name, length) in &lanes {
            let s = length - END_MARGIN - row as f64 * SPACING;
            if s < SPACING || placed == count {
                continue;
            }
            let kind = kinds[placed % kinds.len()];
            world
                .place_vehicle(kind, name, s, 0.0)
                .expect("lane and position are valid");
            placed += 1;
            any = true;
        }
        if !any {
            break;
        }
        row += 1;
    }
    placed
}
