//! Turns across the oncoming way at a signal of an imported Lanelet2 map.

use crate::support::shared_map;
use crate::{assert_no_overlaps, world_of};

const STRAIGHT: [&str; 3] = ["ll_3011", "ll_3101", "ll_1501"];
const TURN: [&str; 3] = ["ll_1013", "ll_1301", "ll_4501"];
const TURN_FROM_AFAR: [&str; 4] = ["ll_1003", "ll_1013", "ll_1301", "ll_4501"];

/// Autoware's intersection drives on the left. Its program, synthesised per
/// approach axis, gives the northbound right turn (`ll_1013` to `ll_1301`)
/// green with the southbound straight way it crosses (`ll_3011` to
/// `ll_3101`), and the map says nothing of who yields there. As at a
/// permitted turn, the turners yield: a car going straight, at its stop line
/// when the light turns green, crosses before a queue of turners, not after
/// the last of them; then the turners go, every one in that green.
#[test]
fn turners_across_the_oncoming_way_let_a_straight_car_go_first_at_green() {
    let Some(osm) = shared_map("autoware_intersection_lanelet2_map.osm") else {
        return;
    };
    let net = trafficmesh_service::load_network(&osm).unwrap();
    // No random traffic: only the vehicles placed here.
    let mut world = world_of(net, 1, 0);
    let lane = |world: &trafficmesh_sim::World, id: u64| {
        let v = world.vehicle(id)?;
        Some(world.network().lane(v.path[0]).name.clone())
    };
    let straight = world
        .place_vehicle_on_route("Taxi", &STRAIGHT, 26.0, 0.0)
        .unwrap();
    let mut turners = Vec::new();
    for s in [26.0, 17.0, 8.0] {
        turners.push(world.place_vehicle_on_route("Taxi", &TURN, s, 0.0).unwrap());
    }
    for s in [211.0, 202.0, 193.0, 184.0] {
        turners.push(
            world
                .place_vehicle_on_route("Hatchback", &TURN_FROM_AFAR, s, 0.0)
                .unwrap(),
        );
    }
    // The light of both ways turns green at 0 s, red at 33 s.
    let mut straight_in = None;
    let mut turners_in = vec![None; turners.len()];
    while world.time() < 33.0 {
        world.step();
        assert_no_overlaps(&world, "Autoware's intersection");
        let t = world.time();
        if straight_in.is_none() && lane(&world, straight).as_deref() != Some(STRAIGHT[0]) {
            straight_in = Some(t);
        }
        for (k, &id) in turners.iter().enumerate() {
            let on = lane(&world, id);
            if turners_in[k].is_none()
                && on.as_deref() != Some(TURN[0])
                && on.as_deref() != Some(TURN_FROM_AFAR[0])
            {
                turners_in[k] = Some(t);
            }
        }
    }
    let straight_in = straight_in.expect("the straight car crossed at green");
    assert!(
        turners_in.iter().all(|t| t.is_some()),
        "every turner went in the green: {turners_in:?}"
    );
    let first_turner = turners_in
        .iter()
        .flatten()
        .copied()
        .fold(f64::INFINITY, f64::min);
    assert!(
        straight_in < first_turner,
        "the straight car went in at {straight_in:.1} s, the first turner at {first_turner:.1} s"
    );
}
