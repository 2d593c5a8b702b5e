//! Bodies never drive into each other, even where no rule of the map keeps
//! their ways apart: a vehicle stops short of a body in its way.

mod support;

use serde_json::{Value, json};
use support::*;
use trafficmesh_sim::motion_check::OVERLAP_MARGIN;
use trafficmesh_sim::{World, WorldConfig};

/// Two roads crossing at (100, 0) with nothing marked: no conflict, no rule
/// for who goes first. Each road enters a junction 4 m past the crossing
/// (bodies are checked near junctions, where ways meet), with `extra` map
/// fields.
fn unmarked_crossing(extra: Value) -> trafficmesh_model::MapFile {
    let junction = |name: &str, points: &[[f64; 2]], next: &str| {
        let mut j = lane(name, points, &[next]);
        j["intersection"] = json!(true);
        j
    };
    map(
        vec![
            lane("east", &[[0.0, 0.0], [104.0, 0.0]], &["east_j"]),
            junction("east_j", &[[104.0, 0.0], [114.0, 0.0]], "east_x"),
            lane("east_x", &[[114.0, 0.0], [300.0, 0.0]], &[]),
            lane("north", &[[100.0, -100.0], [100.0, 4.0]], &["north_j"]),
            junction("north_j", &[[100.0, 4.0], [100.0, 14.0]], "north_x"),
            lane("north_x", &[[100.0, 14.0], [100.0, 200.0]], &[]),
        ],
        extra,
    )
}

/// The overlap check of `sim --check`.
fn assert_no_overlap(w: &World) {
    let pairs = overlapping_pairs(w.vehicles(), OVERLAP_MARGIN);
    assert!(pairs.is_empty(), "{pairs:?} overlap at t={:.2}", w.time());
}

/// Arriving together where nothing tells them who goes first, the two
/// bodies would meet: the later one (higher id) stops short of the ground
/// the earlier one covers, and both get through.
#[test]
fn where_no_rule_keeps_two_ways_apart_the_bodies_still_never_meet() {
    for dt in [0.02, 0.05, 0.1] {
        let mut w = world(
            &unmarked_crossing(json!({})),
            WorldConfig {
                dt,
                ..WorldConfig::default()
            },
        );
        // Fronts 40 m from the crossing, at the same speed: without a rule
        // they arrive together.
        let first = w.place_vehicle("Taxi", "east", 60.0, 10.0).unwrap();
        let second = w.place_vehicle("Taxi", "north", 60.0, 10.0).unwrap();
        let mut crossed = Vec::new();
        let done = run_until(&mut w, 120.0, |w| {
            assert_no_overlap(w);
            for id in [first, second] {
                // Its front 5 m past the crossing point (or gone).
                let past = w.vehicle(id).is_none_or(|v| {
                    (v.front.x - 100.0) * v.heading.x + v.front.y * v.heading.y > 5.0
                });
                if past && !crossed.contains(&id) {
                    crossed.push(id);
                }
            }
            w.vehicles().is_empty()
        });
        assert!(done, "both drive on (dt {dt})");
        assert_eq!(
            crossed,
            [first, second],
            "the earlier one goes first (dt {dt})"
        );
    }
}

/// A body standing across the way (held in the crossing by a walker on the
/// zebra just past it) stops the vehicle coming up to it, which goes on once
/// the crossing is clear.
#[test]
fn a_body_standing_across_the_way_stops_the_vehicle_short_of_it() {
    let mut w = world(
        &unmarked_crossing(json!({
            "crosswalks": [{
                "name": "Zebra",
                "area": { "shape": "box", "center": [100.0, 6.0], "half_extents": [6.0, 1.5] },
                "stop_points": [{ "position": [100.0, 3.0] }]
            }]
        })),
        WorldConfig::default(),
    );
    walker_on(&mut w, "Zebra");
    // Northbound, its front at the zebra's stop point: its body stands
    // across the eastbound road.
    let standing = w.place_vehicle("Taxi", "north", 102.5, 0.0).unwrap();
    let coming = w.place_vehicle("Taxi", "east", 50.0, 10.0).unwrap();
    run_until(&mut w, 20.0, |w| {
        assert_no_overlap(w);
        false
    });
    let (s, c) = (vehicle(&w, standing), vehicle(&w, coming));
    assert!(s.speed < 0.01, "the walker holds the northbound car");
    assert!(c.speed < 0.01, "the eastbound car waits");
    assert!(
        c.s > 90.0,
        "it drove up to the body, not further back (s {:.1})",
        c.s
    );
    w.crosswalk_exit("Zebra", "Human_01").unwrap();
    let crossed = run_until(&mut w, 30.0, |w| {
        assert_no_overlap(w);
        w.vehicle(coming).is_none_or(|v| v.front.x > 110.0)
    });
    assert!(crossed, "it never went on once the crossing was clear");
}
