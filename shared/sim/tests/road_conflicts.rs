//! Maps that do not mark every junction (`conflicts_outside_junctions`, as
//! Lanelet2 imports are): lanes that cross or run too close for two bodies
//! outside any junction still keep their vehicles apart.

mod support;

use serde_json::{Value, json};
use support::*;
use trafficmesh_sim::{Ego, WorldConfig};

/// `lanes` plus a junction lane far away (the start-up checklist wants one),
/// with conflicts outside junctions on.
fn unmarked_map(mut lanes: Vec<Value>) -> trafficmesh_model::MapFile {
    let mut far = lane("far_junction", &[[5000.0, 5000.0], [5020.0, 5000.0]], &[]);
    far["intersection"] = json!(true);
    lanes.push(far);
    map(lanes, json!({ "conflicts_outside_junctions": true }))
}

#[test]
fn at_an_unmarked_crossing_the_vehicle_nearer_to_it_goes_first() {
    // An eastbound and a northbound road crossing at (100, 0), no junction.
    let m = unmarked_map(vec![
        lane("east", &[[0.0, 0.0], [200.0, 0.0]], &[]),
        lane("north", &[[100.0, -100.0], [100.0, 100.0]], &[]),
    ]);
    let mut w = world(&m, WorldConfig::default());
    // Same speed, fronts 40 m and 38 m from the crossing: without a rule they
    // arrive together and collide.
    let far = w.place_vehicle("Taxi", "east", 60.0, 10.0).unwrap();
    let near = w.place_vehicle("Taxi", "north", 62.0, 10.0).unwrap();
    let mut crossed: Vec<(u64, f64)> = Vec::new();
    let done = run_until(&mut w, 120.0, |w| {
        let pairs = overlapping_pairs(w.vehicles(), 0.05);
        assert!(pairs.is_empty(), "overlap at t={:.2}", w.time());
        for id in [far, near] {
            if let Some(v) = w.vehicle(id)
                && v.s > 100.0
                && !crossed.iter().any(|c| c.0 == id)
            {
                crossed.push((id, w.time()));
            }
        }
        w.vehicles().is_empty()
    });
    assert!(done, "both drive on");
    let order: Vec<u64> = crossed.iter().map(|c| c.0).collect();
    assert_eq!(order, [near, far], "the nearer one crosses first");
}

/// Which of two vehicles crosses first where they arrive together: the
/// lower id, whichever was placed on which road and wherever the vehicles
/// lie in the world's list (regrouped by lane every tick, or never).
#[test]
fn at_an_unmarked_crossing_reached_together_the_lower_id_goes_first() {
    for regroup_interval in [0, 1] {
        for lower_on in ["east", "north"] {
            let m = unmarked_map(vec![
                lane("east", &[[0.0, 0.0], [200.0, 0.0]], &[]),
                lane("north", &[[100.0, -100.0], [100.0, 100.0]], &[]),
            ]);
            let config = WorldConfig {
                regroup_interval,
                ..WorldConfig::default()
            };
            let mut w = world(&m, config);
            let higher_on = if lower_on == "east" { "north" } else { "east" };
            // Fronts 40 m from the crossing, same speed: level all the way.
            let lower = w.place_vehicle("Taxi", lower_on, 60.0, 10.0).unwrap();
            let higher = w.place_vehicle("Taxi", higher_on, 60.0, 10.0).unwrap();
            let mut crossed: Vec<u64> = Vec::new();
            let done = run_until(&mut w, 120.0, |w| {
                let pairs = overlapping_pairs(w.vehicles(), 0.05);
                assert!(pairs.is_empty(), "overlap at t={:.2}", w.time());
                for id in [lower, higher] {
                    if w.vehicle(id).is_some_and(|v| v.s > 100.0) && !crossed.contains(&id) {
                        crossed.push(id);
                    }
                }
                w.vehicles().is_empty()
            });
            assert!(done, "both drive on");
            let what = format!("lower id on {lower_on}, regrouped every {regroup_interval}");
            assert_eq!(
                crossed,
                [lower, higher],
                "{what}: the lower id crosses first"
            );
        }
    }
}

#[test]
fn two_trucks_do_not_fit_side_by_side_on_narrow_lanes_but_two_cars_do() {
    // Two eastbound lanes 2.8 m apart: room for a car beside a car (1.94 m
    // each), not for a truck beside a truck (3.08 m each).
    let road = || {
        unmarked_map(vec![
            lane("right", &[[0.0, 0.0], [400.0, 0.0]], &[]),
            lane("left", &[[0.0, 2.8], [400.0, 2.8]], &[]),
        ])
    };
    for (kind, overtakes) in [("Truck_2t", false), ("Taxi", true)] {
        let mut w = world(&road(), WorldConfig::default());
        // The ego stands on the right lane; one vehicle queues behind it, the
        // other comes up on the left.
        w.set_ego(Some(Ego::car(150.0, 0.0, 0.0)));
        let queued = w.place_vehicle(kind, "right", 120.0, 0.0).unwrap();
        let coming = w.place_vehicle(kind, "left", 60.0, 10.0).unwrap();
        let mut passed = false;
        run_until(&mut w, 40.0, |w| {
            let pairs = overlapping_pairs(w.vehicles(), 0.05);
            assert!(pairs.is_empty(), "{kind}: overlap at t={:.2}", w.time());
            if let (Some(a), Some(b)) = (w.vehicle(queued), w.vehicle(coming)) {
                passed |= b.rear_s() > a.s;
            }
            false
        });
        assert_eq!(passed, overtakes, "{kind}: does the one coming up pass?");
        if !overtakes {
            let (a, b) = (vehicle(&w, queued), vehicle(&w, coming));
            assert!(
                b.speed < 0.1 && b.s < a.rear_s(),
                "{kind}: it waits behind (front {:.1}, the other's rear {:.1})",
                b.s,
                a.rear_s()
            );
        }
    }
}
