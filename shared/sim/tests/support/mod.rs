//! Scenes for the behaviour tests: small maps written as JSON, a world around
//! them, and checks shared by several tests.
#![allow(dead_code)]

use serde_json::{Value, json};
use trafficmesh_model::MapFile;
use trafficmesh_sim::{LaneNetwork, Vehicle, World, WorldConfig};

/// Two eastbound lanes side by side, 3.2 m apart, each going on through its own
/// junction lane to its own exit.
pub fn two_lane_road() -> MapFile {
    road_of_lanes(2)
}

/// `n` eastbound lanes side by side, 3.2 m apart (`a0` the rightmost), each
/// going on through its own junction lane `jk` to its own exit `xk`.
pub fn road_of_lanes(n: usize) -> MapFile {
    let y = |k: usize| 3.2 * k as f64;
    let approaches = (0..n).map(|k| {
        let (name, next) = (format!("a{k}"), format!("j{k}"));
        lane(&name, &[[0.0, y(k)], [200.0, y(k)]], &[&next])
    });
    let junctions = (0..n).map(|k| {
        let (name, next) = (format!("j{k}"), format!("x{k}"));
        let mut j = lane(&name, &[[200.0, y(k)], [220.0, y(k)]], &[&next]);
        j["intersection"] = json!(true);
        j
    });
    let exits = (0..n).map(|k| lane(&format!("x{k}"), &[[220.0, y(k)], [400.0, y(k)]], &[]));
    map(
        approaches.chain(junctions).chain(exits).collect(),
        json!({}),
    )
}

/// A lane as JSON: name, waypoints, next lanes.
pub fn lane(name: &str, points: &[[f64; 2]], next: &[&str]) -> Value {
    json!({ "name": name, "waypoints": points, "next": next })
}

/// A map from lanes (and optional extra top-level fields). A disabled random
/// simulator satisfies the start-up checklist unless `extra` sets simulators.
pub fn map(lanes: Vec<Value>, extra: Value) -> MapFile {
    let mut m = json!({
        "lanes": lanes,
        "traffic_simulators": [{ "kind": "random", "lanes": [lanes_first_name(&lanes)], "prefabs": ["Taxi"], "enabled": false }],
    });
    if let Value::Object(fields) = extra {
        for (k, v) in fields {
            m[k] = v;
        }
    }
    serde_json::from_value(m).expect("test map deserialises")
}

fn lanes_first_name(lanes: &[Value]) -> String {
    lanes[0]["name"].as_str().unwrap().to_string()
}

pub fn world(map: &MapFile, config: WorldConfig) -> World {
    let net = LaneNetwork::build(map).unwrap_or_else(|p| panic!("invalid test map: {p:?}"));
    World::new(net, config)
}

/// A world on a generated `size` x `size` signalised grid.
pub fn grid_world(size: usize, config: WorldConfig) -> World {
    let map = trafficmesh_maps::grid_map(&trafficmesh_maps::GridOptions {
        size,
        ..Default::default()
    });
    world(&map, config)
}

/// An eastbound road along y = 0: `approach` (0..200 m, stop line at 190 m, light
/// group "L"), a junction lane (200..220) and an exit (220..600).
pub fn signalised_road() -> MapFile {
    let mut approach = lane("approach", &[[0.0, 0.0], [200.0, 0.0]], &["junction"]);
    approach["stop_line"] = json!([[190.0, -1.75], [190.0, 1.75]]);
    approach["traffic_light"] = json!("L");
    let mut junction = lane("junction", &[[200.0, 0.0], [220.0, 0.0]], &["exit"]);
    junction["intersection"] = json!(true);
    map(
        vec![
            approach,
            junction,
            lane("exit", &[[220.0, 0.0], [600.0, 0.0]], &[]),
        ],
        json!({ "light_groups": [{ "name": "L", "program": { "green": 30, "yellow": 3, "red": 30 } }] }),
    )
}

/// A walker steps onto crosswalk `name` (and stays until `crosswalk_exit`):
/// the zebra holds the traffic that reaches its stop point.
pub fn walker_on(world: &mut World, name: &str) {
    world
        .crosswalk_enter(
            name,
            "Human_01",
            trafficmesh_sim::crosswalk::OccupantType::NpcPedestrian,
        )
        .expect("the crosswalk exists");
}

pub fn vehicle(world: &World, id: u64) -> &Vehicle {
    world.vehicle(id).expect("vehicle exists")
}

/// Steps until `done` holds or `seconds` pass; returns whether it held.
pub fn run_until(world: &mut World, seconds: f64, mut done: impl FnMut(&World) -> bool) -> bool {
    let end = world.time() + seconds;
    while world.time() < end {
        world.step();
        if done(world) {
            return true;
        }
    }
    false
}

pub fn run_for(world: &mut World, seconds: f64) {
    run_until(world, seconds, |_| false);
}

/// No two bodies overlap now, as the overlap check of `sim --check` reads them.
pub fn assert_no_overlap(w: &World) {
    let pairs = overlapping_pairs(
        w.network(),
        w.vehicles(),
        trafficmesh_sim::motion_check::OVERLAP_MARGIN,
    );
    assert!(pairs.is_empty(), "{pairs:?} overlap at t={:.2}", w.time());
}

/// Pairs of vehicles (by id) whose footprints overlap: the check `sim --check` makes.
pub fn overlapping_pairs(
    net: &trafficmesh_sim::network::LaneNetwork,
    vehicles: &[Vehicle],
    margin: f64,
) -> Vec<(u64, u64)> {
    trafficmesh_sim::motion_check::overlapping_pairs(net, vehicles, margin)
        .into_iter()
        .map(|(i, j)| (vehicles[i].id, vehicles[j].id))
        .collect()
}

/// Ten ticks a second, as SUMO scenarios run (a body changing lanes moves
/// across by 10 to 20 cm a tick), each vehicle at its lane's limit.
pub fn at_sumo_ticks_and_lane_limits() -> WorldConfig {
    WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            speed_limit_source: trafficmesh_model::SpeedLimitSource::LaneletSpeedLimit,
            ..Default::default()
        },
        dt: 0.1,
        ..WorldConfig::default()
    }
}
