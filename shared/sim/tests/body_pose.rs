//! Where a body lies along its way: the back follows the lanes it came by.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_sim::WorldConfig;

#[test]
fn a_body_just_past_a_short_tight_turn_lies_back_along_the_lane_before_the_turn() {
    // North up x = 0, a 1 m junction lane turning right, then east: a car
    // whose front is just onto `east` has most of its body on `north`.
    let mut turn = lane("turn", &[[0.0, 0.0], [0.3, 0.6], [1.0, 0.8]], &["east"]);
    turn["intersection"] = json!(true);
    let m = map(
        vec![
            lane("north", &[[0.0, -100.0], [0.0, 0.0]], &["turn"]),
            turn,
            lane("east", &[[1.0, 0.8], [100.0, 0.8]], &[]),
        ],
        json!({}),
    );
    let mut w = world(&m, WorldConfig::default());
    let id = w
        .place_vehicle_on_route("Taxi", &["north", "turn", "east"], 80.0, 5.0)
        .unwrap();
    let mut checked = 0;
    run_until(&mut w, 30.0, |w| {
        let v = vehicle(w, id);
        let net = w.network();
        let behind_the_turn = v.length - v.s - net.lane(net.lane_id("turn").unwrap()).length();
        if net.lane(v.path[0]).name == "east" && behind_the_turn > 0.5 {
            assert!(
                v.back.x.abs() < 1e-6 && v.back.y < 0.0,
                "the back at {:?}, not on `north`, with the front {:.2} m onto `east`",
                v.back,
                v.s
            );
            checked += 1;
        }
        net.lane(v.path[0]).name == "east" && v.s > v.length
    });
    assert!(checked > 0, "the car passed the turn");
}

#[test]
fn a_body_across_a_merge_lies_back_along_the_approach_it_came_by() {
    // Two junction lanes, from the west and from the south, join a 1 m
    // lane that leads east: a car from the south whose front is just onto
    // `east` reaches back past both short lanes into `south`, not into the
    // other approach.
    let junction = |name, from: [f64; 2]| {
        let mut l = lane(name, &[from, [0.0, 0.0]], &["short"]);
        l["intersection"] = json!(true);
        l
    };
    let m = map(
        vec![
            lane("west", &[[-100.0, 0.0], [-1.0, 0.0]], &["from_west"]),
            lane("south", &[[0.0, -100.0], [0.0, -1.0]], &["from_south"]),
            junction("from_west", [-1.0, 0.0]),
            junction("from_south", [0.0, -1.0]),
            lane("short", &[[0.0, 0.0], [1.0, 0.0]], &["east"]),
            lane("east", &[[1.0, 0.0], [100.0, 0.0]], &[]),
        ],
        json!({}),
    );
    let mut w = world(&m, WorldConfig::default());
    let id = w
        .place_vehicle_on_route("Taxi", &["south", "from_south", "short", "east"], 80.0, 5.0)
        .unwrap();
    let mut checked = 0;
    run_until(&mut w, 30.0, |w| {
        let v = vehicle(w, id);
        let on_east = w.network().lane(v.path[0]).name == "east";
        if on_east && v.length - v.s > 2.5 {
            assert!(
                v.back.x.abs() < 1e-6 && v.back.y < -1.0,
                "the back at {:?}, not on `south`, with the front {:.2} m onto `east`",
                v.back,
                v.s
            );
            checked += 1;
        }
        on_east && v.s > v.length
    });
    assert!(checked > 0, "the car passed the merge");
}
