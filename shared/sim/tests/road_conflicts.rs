//! Maps that do not mark every junction (`road_conflicts: everywhere`, as
//! Lanelet2 imports are): lanes that cross or run too close for two bodies
//! outside any junction still keep their vehicles apart.

mod support;

use serde_json::{Value, json};
use support::*;
use trafficmesh_sim::{Ego, WorldConfig};

/// `lanes` plus a junction lane far away (the start-up checklist wants one),
/// with conflicts outside junctions on.
fn unmarked_map(lanes: Vec<Value>) -> trafficmesh_model::MapFile {
    map_with_road_conflicts(lanes, "everywhere")
}

/// `lanes` plus a junction lane far away, with road conflicts `where`.
fn map_with_road_conflicts(mut lanes: Vec<Value>, r#where: &str) -> trafficmesh_model::MapFile {
    let mut far = lane("far_junction", &[[5000.0, 5000.0], [5020.0, 5000.0]], &[]);
    far["intersection"] = json!(true);
    lanes.push(far);
    map(lanes, json!({ "road_conflicts": r#where }))
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
        let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.05);
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
                let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.05);
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
            let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.05);
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

/// Runs up to two minutes, no two bodies overlapping on any tick, until each
/// vehicle is `past` metres along its exit lane (or gone), and no jam
/// resolution helped.
fn both_get_through(
    w: &mut trafficmesh_sim::World,
    what: &str,
    exits: [(u64, &str); 2],
    past: f64,
) {
    let beyond = |w: &trafficmesh_sim::World, (id, out): (u64, &str)| {
        let out = w.network().lane_id(out).unwrap();
        w.vehicle(id).is_none_or(|v| v.path[0] == out && v.s > past)
    };
    let done = run_until(w, 120.0, |w| {
        let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.05);
        assert!(pairs.is_empty(), "{what}: overlap at t={:.2}", w.time());
        exits.iter().all(|&e| beyond(w, e))
    });
    assert!(done, "{what}: both are through within two minutes");
    assert_eq!(w.wait_stats().jam_resolutions, 0, "{what}");
}

/// A road that leaves a junction lane and cuts back across that lane's end
/// at a shallow angle: the crossing begins on the junction lane, before the
/// lane the road conflict is found on.
fn cut_back_map() -> trafficmesh_model::MapFile {
    let mut a_junction = lane("a_junction", &[[60.0, 0.0], [80.0, 0.0]], &["a_out"]);
    a_junction["intersection"] = json!(true);
    let mut b_junction = lane("b_junction", &[[100.0, -12.0], [84.0, -4.0]], &["b_out"]);
    b_junction["intersection"] = json!(true);
    unmarked_map(vec![
        lane("a_in", &[[0.0, 0.0], [60.0, 0.0]], &["a_junction"]),
        a_junction,
        lane("a_out", &[[80.0, 0.0], [200.0, 0.0]], &[]),
        lane("b_in", &[[140.0, -40.0], [100.0, -12.0]], &["b_junction"]),
        b_junction,
        lane("b_out", &[[84.0, -4.0], [40.0, 18.0]], &[]),
    ])
}

/// The road after one junction lane crosses the other junction lane's end
/// and then runs close by the road after it: a road conflict gives way on the
/// second road, but the crossing begins on the junction lane before it. One
/// giving way at the road's conflict would stand inside the crossing, in
/// the way of the very vehicle it waits for.
#[test]
fn a_vehicle_giving_way_where_a_crossing_begins_on_its_junction_lane_waits_before_it() {
    let starts_a = [
        ("a_in", 40.0),
        ("a_in", 50.0),
        ("a_in", 55.0),
        ("a_junction", 0.0),
        ("a_junction", 2.0),
    ];
    let starts_b = [
        ("b_in", 40.0),
        ("b_in", 45.0),
        ("b_junction", 5.0),
        ("b_junction", 10.0),
    ];
    for (a_lane, a_at) in starts_a {
        for (b_lane, b_at) in starts_b {
            for speed in [0.0, 5.0] {
                let mut w = world(&cut_back_map(), WorldConfig::default());
                let a = w.place_vehicle("Taxi", a_lane, a_at, speed).unwrap();
                let b = w.place_vehicle("Taxi", b_lane, b_at, speed).unwrap();
                let what =
                    format!("a on {a_lane} at {a_at} m, b on {b_lane} at {b_at} m, {speed} m/s");
                both_get_through(&mut w, &what, [(a, "a_out"), (b, "b_out")], 20.0);
            }
        }
    }
}

/// A straight junction lane and a turn that end 2.9 m apart, each onto
/// its own exit, the two exits side by side: too close for two trucks.
/// Each junction lane's end comes close to the other's exit, so the two
/// trucks meet at two zones, each one nearer to one of them.
fn side_by_side_exits_map() -> trafficmesh_model::MapFile {
    let mut straight = lane("s_j", &[[30.0, -1.45], [50.0, -1.45]], &["s_out"]);
    straight["intersection"] = json!(true);
    // A quarter circle from southbound to eastbound.
    let arc: Vec<[f64; 2]> = (0..=12)
        .map(|i| {
            let t = std::f64::consts::PI * (1.0 + 0.5 * i as f64 / 12.0);
            [50.0 + 15.0 * t.cos(), 16.45 + 15.0 * t.sin()]
        })
        .collect();
    let mut turn = lane("n_j", &arc, &["n_out"]);
    turn["intersection"] = json!(true);
    unmarked_map(vec![
        lane("s_in", &[[-30.0, -1.45], [30.0, -1.45]], &["s_j"]),
        straight,
        lane("s_out", &[[50.0, -1.45], [200.0, -1.45]], &[]),
        lane("n_in", &[[35.0, 76.45], [35.0, 16.45]], &["n_j"]),
        turn,
        lane("n_out", &[[50.0, 1.45], [200.0, 1.45]], &[]),
    ])
}

/// Of two trucks each standing before the zone it is nearer to, waiting for
/// the other, the lower id goes: neither waits for the jam timeout.
#[test]
fn two_trucks_each_nearer_to_one_of_two_zones_do_not_wait_for_each_other() {
    for a_at in [40.0, 45.0, 50.0] {
        for b_at in [45.0, 50.0, 55.0] {
            for (va, vb) in [(0.0, 0.0), (5.0, 5.0), (5.0, 10.0), (10.0, 5.0)] {
                let mut w = world(&side_by_side_exits_map(), WorldConfig::default());
                let a = w.place_vehicle("Truck_2t", "s_in", a_at, va).unwrap();
                let b = w.place_vehicle("Truck_2t", "n_in", b_at, vb).unwrap();
                let what = format!("straight at {a_at} m, {va} m/s; turn at {b_at} m, {vb} m/s");
                both_get_through(&mut w, &what, [(a, "s_out"), (b, "n_out")], 30.0);
            }
        }
    }
}

/// A bend of a narrow two-way street, each way on its half (a two-way
/// lanelet of Lanelet2's example map, `mapping_example.osm`, lanelets 45484
/// and 45542, and their halves the other way): too narrow, by the road
/// conflicts' reckoning, for a car on the bend beside a car on the straight.
fn narrow_two_way_bend() -> trafficmesh_model::MapFile {
    let with_width = |mut lane: Value, width: f64| {
        lane["width"] = json!(width);
        lane
    };
    unmarked_map(vec![
        with_width(
            lane(
                "east_in",
                &[[5.3, 332.2], [-2.4, 324.4], [-10.9, 317.3]],
                &["east_bend"],
            ),
            3.45,
        ),
        with_width(
            lane(
                "east_bend",
                &[[-10.9, 317.3], [-11.2, 312.2], [-8.0, 308.2], [-3.4, 305.8]],
                &["east_narrow"],
            ),
            3.57,
        ),
        with_width(
            lane("east_narrow", &[[-3.4, 305.8], [3.5, 303.9]], &["east_out"]),
            2.85,
        ),
        with_width(
            lane(
                "east_out",
                &[[3.5, 303.9], [8.5, 302.4], [60.0, 287.0]],
                &[],
            ),
            2.92,
        ),
        with_width(
            lane(
                "west_in",
                &[[60.0, 290.6], [9.8, 305.1], [4.5, 306.6]],
                &["west_narrow"],
            ),
            2.92,
        ),
        with_width(
            lane(
                "west_narrow",
                &[[4.5, 306.6], [-2.7, 308.6]],
                &["west_bend"],
            ),
            2.85,
        ),
        with_width(
            lane(
                "west_bend",
                &[[-2.7, 308.6], [-5.6, 311.0], [-7.8, 314.1], [-7.1, 317.9]],
                &["west_out"],
            ),
            3.57,
        ),
        with_width(
            lane(
                "west_out",
                &[[-7.1, 317.9], [0.8, 324.6], [8.6, 331.6]],
                &[],
            ),
            3.45,
        ),
    ])
}

#[test]
fn two_cars_meeting_on_a_narrow_two_way_bend_squeeze_past_each_other() {
    // As met in random traffic on the Lanelet2 example map: one car standing
    // on the bend, the other on the straight just after it the other way.
    // Each judges the other's body too near to pass and waits for it: a
    // gridlock of two. Their bodies do pass (0.9 m apart on the straight),
    // and as drivers inch past each other they go by, kept apart by their
    // bodies alone, with no jam resolution.
    let mut w = world(&narrow_two_way_bend(), WorldConfig::default());
    let east = w.place_vehicle("Taxi", "east_bend", 12.3, 0.0).unwrap();
    let west = w
        .place_vehicle("Hatchback", "west_narrow", 3.0, 0.0)
        .unwrap();
    both_get_through(
        &mut w,
        "face-off",
        [(east, "east_out"), (west, "west_out")],
        5.0,
    );
    assert_eq!(w.wait_stats().gridlocks_squeezed, 1, "they squeezed past");
}

/// A two-way street of a SUMO network, each way one lane 3.2 m wide, their
/// centrelines 3.2 m apart, kinked by 8° and 17° (Bologna's edges 9 and 10,
/// between junctions 6 and 8): two trucks (3.08 m wide) pass each other on
/// the straight, not where the kinks swing their bodies out. SUMO imports
/// mark such stretches (`road_conflicts: opposing`).
fn two_way_kinked_street(road_conflicts: &str) -> trafficmesh_model::MapFile {
    map_with_road_conflicts(kinked_street_lanes(), road_conflicts)
}

/// The street above with a junction lane 10 m long at its west end, into
/// the eastbound way, as SUMO models every junction.
fn kinked_street_after_a_junction() -> trafficmesh_model::MapFile {
    let mut lanes = kinked_street_lanes();
    lanes[0] = lane(
        "east_in",
        &[[246.97, 127.07], [286.55, 132.83]],
        &["east_junction"],
    );
    let mut junction = lane(
        "east_junction",
        &[[286.55, 132.83], [296.47, 134.27]],
        &["east"],
    );
    junction["intersection"] = json!(true);
    lanes.push(junction);
    for lane in &mut lanes {
        lane["width"] = json!(3.2);
    }
    map_with_road_conflicts(lanes, "opposing")
}

/// The lanes of [`two_way_kinked_street`], each 3.2 m wide.
fn kinked_street_lanes() -> Vec<Value> {
    let with_width = |mut lane: Value| {
        lane["width"] = json!(3.2);
        lane
    };
    let lanes = vec![
        lane("east_in", &[[246.97, 127.07], [296.47, 134.27]], &["east"]),
        lane(
            "east",
            &[
                [296.47, 134.27],
                [308.15, 135.97],
                [326.41, 135.29],
                [380.95, 117.92],
                [386.52, 116.14],
            ],
            &["east_out"],
        ),
        lane("east_out", &[[386.52, 116.14], [434.1, 100.94]], &[]),
        lane("west_in", &[[435.09, 103.98], [387.49, 119.18]], &["west"]),
        lane(
            "west",
            &[
                [387.49, 119.18],
                [381.93, 120.96],
                [326.97, 138.47],
                [307.97, 139.17],
                [296.0, 137.43],
            ],
            &["west_out"],
        ),
        lane("west_out", &[[296.0, 137.43], [246.5, 130.23]], &[]),
    ];
    lanes.into_iter().map(with_width).collect()
}

/// Two trucks meeting head-on where the street kinks take turns, as on a
/// narrow bridge: the one that gets there first goes through, the other
/// waits before the stretch until it has passed. Without the marked stretch
/// each drove in, their bodies met, and the gridlock valve had to part them.
#[test]
fn two_trucks_meeting_where_a_two_way_street_kinks_take_turns() {
    for config in [WorldConfig::default(), at_sumo_ticks_and_lane_limits()] {
        for east_at in [0.0, 20.0, 40.0] {
            for west_at in [0.0, 20.0, 40.0] {
                for (v_east, v_west) in [(13.9, 13.9), (0.0, 13.9), (13.9, 5.0)] {
                    let mut w = world(&two_way_kinked_street("opposing"), config);
                    let east = w.place_vehicle("Truck_2t", "east_in", east_at, v_east);
                    let west = w.place_vehicle("Truck_2t", "west_in", west_at, v_west);
                    let what = format!(
                        "dt {}: east at {east_at} m, {v_east} m/s; west at {west_at} m, {v_west} m/s",
                        config.dt
                    );
                    both_get_through(
                        &mut w,
                        &what,
                        [(east.unwrap(), "east_out"), (west.unwrap(), "west_out")],
                        20.0,
                    );
                    assert_eq!(w.wait_stats().gridlocks_squeezed, 0, "{what}: no squeezing");
                }
            }
        }
    }
}

/// Where the map models its junctions, a truck about to come out of one
/// into a narrow stretch that a truck coming the other way goes through
/// first waits before the junction, not inside it, where it would stand in
/// the way of the junction's own traffic.
#[test]
fn a_truck_waits_for_a_narrow_stretch_before_the_junction_not_inside_it() {
    let mut waited_before = 0;
    for config in [WorldConfig::default(), at_sumo_ticks_and_lane_limits()] {
        for east_at in [0.0, 10.0, 20.0] {
            for west_at in [20.0, 30.0, 40.0] {
                let mut w = world(&kinked_street_after_a_junction(), config);
                let east = w.place_vehicle("Truck_2t", "east_in", east_at, 13.9);
                let west = w.place_vehicle("Truck_2t", "west", west_at, 13.9);
                let (east, west) = (east.unwrap(), west.unwrap());
                let before = w.network().lane_id("east_in").unwrap();
                let what = format!("dt {}: east at {east_at} m, west at {west_at} m", config.dt);
                let mut stood_before = false;
                let done = run_until(&mut w, 120.0, |w| {
                    let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.05);
                    assert!(pairs.is_empty(), "{what}: overlap at t={:.2}", w.time());
                    // Standing anywhere past the junction's entry, part of
                    // its body would be in the junction (10 m long; the
                    // stretch begins 7.5 m after it).
                    if let Some(v) = w.vehicle(east).filter(|v| v.speed < 0.1) {
                        assert_eq!(v.path[0], before, "{what}: stands in the junction");
                        stood_before = true;
                    }
                    w.vehicle(east).is_none() && w.vehicle(west).is_none()
                });
                assert!(done, "{what}: both are through within two minutes");
                assert_eq!(w.wait_stats().jam_resolutions, 0, "{what}");
                waited_before += usize::from(stood_before);
            }
        }
    }
    assert!(
        waited_before > 0,
        "in some of the runs the truck had to wait"
    );
}

/// A two-way stub at a map's edge, each way 2.24 m wide (as
/// `mapping_example.osm`'s lanelet 45576): a truck and a car cannot pass on
/// it, two cars can. A car is not put at one end while a truck is on the
/// stub: it would be committed head on against the truck, each waiting for
/// the other. Once the truck is through, or where the other is a car, it is.
#[test]
fn no_vehicle_is_put_into_a_narrow_stretch_an_oncoming_body_it_cannot_pass_is_in() {
    let stub = || {
        // Each way a long lanelet and a short one at the far end, where
        // the car is put.
        let mut lanes = vec![
            lane("in", &[[0.0, 0.0], [25.0, 0.0]], &["in_end"]),
            lane("in_end", &[[25.0, 0.0], [30.0, 0.0]], &[]),
            lane("out", &[[30.0, 2.24], [25.0, 2.24]], &["out_on"]),
            lane("out_on", &[[25.0, 2.24], [0.0, 2.24]], &[]),
        ];
        for l in &mut lanes {
            l["width"] = json!(2.24);
        }
        unmarked_map(lanes)
    };
    for (oncoming, put) in [("Truck_2t", false), ("SmallCar", true)] {
        let mut w = world(&stub(), WorldConfig::default());
        let car = w.kind_index("SmallCar").unwrap();
        let out = w.network().lane_id("out").unwrap();
        // Driving in slowly, far enough from the car's lanelet to stop
        // before it.
        let other = w.place_vehicle(oncoming, "in", 10.0, 2.0).unwrap();
        w.step();
        let admitted = w.admit_spawn(car, out, None, 10, &mut Vec::new());
        assert_eq!(
            admitted.is_ok(),
            put,
            "a car put facing a {oncoming} on the stub: {admitted:?}"
        );
        if !put {
            run_until(&mut w, 30.0, |w| w.vehicle(other).is_none());
            assert!(
                w.vehicle(other).is_none(),
                "the {oncoming} drove off the stub"
            );
            // The lane index is taken at the start of a tick.
            w.step();
            assert!(
                w.admit_spawn(car, out, None, 10, &mut Vec::new()).is_ok(),
                "the car is put once the stub is clear"
            );
        }
    }
}
