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
