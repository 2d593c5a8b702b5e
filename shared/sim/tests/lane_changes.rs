//! Lane changes that routes need: at a gap, never into another body, and two
//! vehicles that each want the other's lane swap.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::LightColor;
use trafficmesh_sim::lights::LightControl;
use trafficmesh_sim::{World, WorldConfig};

fn lane_of(world: &World, id: u64) -> &str {
    let v = vehicle(world, id);
    &world.network().lane(v.path[0]).name
}

/// Runs until every vehicle has left the map; no two may overlap on the way.
/// Returns the lanes each vehicle was seen on, in order.
fn run_out(world: &mut World, ids: &[u64]) -> Vec<Vec<String>> {
    let mut seen: Vec<Vec<String>> = ids
        .iter()
        .map(|&id| vec![lane_of(world, id).to_string()])
        .collect();
    let done = run_until(world, 120.0, |w| {
        assert!(
            overlapping_pairs(w.network(), w.vehicles(), 0.05).is_empty(),
            "overlap at t={:.2}",
            w.time()
        );
        for (k, &id) in ids.iter().enumerate() {
            if w.vehicle(id).is_some() {
                let lane = lane_of(w, id).to_string();
                if seen[k].last() != Some(&lane) {
                    seen[k].push(lane);
                }
            }
        }
        w.vehicles().is_empty()
    });
    assert!(done, "everyone leaves the road");
    seen
}

#[test]
fn a_route_from_the_lane_beside_changes_lanes_behind_the_vehicle_there() {
    let mut w = world(&two_lane_road(), WorldConfig::default());
    // Beside each other at the same speed: the routed one must let the other pass.
    let routed = w
        .place_vehicle_on_route("Taxi", &["a0", "j1", "x1"], 40.0, 10.0)
        .unwrap();
    let beside = w.place_vehicle("Taxi", "a1", 40.0, 10.0).unwrap();
    let seen = run_out(&mut w, &[routed, beside]);
    assert_eq!(
        seen[0],
        ["a0", "a1", "j1", "x1"],
        "the routed vehicle changes lanes"
    );
    assert_eq!(seen[1], ["a1", "j1", "x1"]);
}

#[test]
fn a_route_two_lanes_across_changes_one_lane_at_a_time_behind_the_vehicle_between() {
    let mut w = world(&road_of_lanes(3), WorldConfig::default());
    // The body drawn across two lanes would sweep over the middle one: it
    // moves onto it first, behind the vehicle there, then on.
    let routed = w
        .place_vehicle_on_route("Taxi", &["a0", "j2", "x2"], 40.0, 10.0)
        .unwrap();
    let between = w.place_vehicle("Taxi", "a1", 40.0, 10.0).unwrap();
    let seen = run_out(&mut w, &[routed, between]);
    assert_eq!(
        seen[0],
        ["a0", "a1", "a2", "j2", "x2"],
        "the routed vehicle crosses the middle lane"
    );
    assert_eq!(seen[1], ["a1", "j1", "x1"]);
}

#[test]
fn a_route_two_lanes_across_from_a_standstill_at_the_lanes_end_still_crosses_both() {
    let mut w = world(&road_of_lanes(3), WorldConfig::default());
    // Standing at the end of a0: the first change leaves the body drawn
    // where it stands, still a body on a0; it moves on across in place, or
    // the second change would wait for it for ever.
    let routed = w
        .place_vehicle_on_route("Taxi", &["a0", "j2", "x2"], 199.5, 0.0)
        .unwrap();
    let seen = run_out(&mut w, &[routed]);
    assert_eq!(seen[0], ["a0", "a1", "a2", "j2", "x2"]);
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

#[test]
fn a_long_body_changing_lanes_keeps_its_ends_out_of_the_lane_on_the_far_side() {
    let mut w = world(&road_of_lanes(3), WorldConfig::default());
    // A 9.2 m truck pulling out slowly toward the right lane, turning as
    // tightly as it may, swings its rear toward the left one about its
    // middle; the car beside its rear there must not be touched (nor, once across,
    // the truck's nose past the right lane).
    let truck = w
        .place_vehicle_on_route("Truck_2t", &["a1", "j0", "x0"], 40.0, 2.0)
        .unwrap();
    let beside = w.place_vehicle("Taxi", "a2", 35.0, 2.0).unwrap();
    let seen = run_out(&mut w, &[truck, beside]);
    assert_eq!(seen[0], ["a1", "a0", "j0", "x0"], "the truck changes lanes");
    assert_eq!(seen[1], ["a2", "j2", "x2"]);
}

#[test]
fn a_vehicle_that_finds_no_gap_waits_before_its_lane_ends() {
    let mut w = world(&two_lane_road(), WorldConfig::default());
    let routed = w
        .place_vehicle_on_route("Taxi", &["a0", "j1", "x1"], 150.0, 0.0)
        .unwrap();
    // A stream on the target lane, close together, going past.
    let stream: Vec<u64> = (0..4)
        .map(|k| {
            w.place_vehicle("Taxi", "a1", 150.0 - 12.0 * k as f64, 12.0)
                .unwrap()
        })
        .collect();
    let mut ids = vec![routed];
    ids.extend(&stream);
    let seen = run_out(&mut w, &ids);
    assert_eq!(seen[0], ["a0", "a1", "j1", "x1"]);
    for lanes in &seen[1..] {
        assert_eq!(lanes, &["a1", "j1", "x1"], "the stream keeps its lane");
    }
}

#[test]
fn two_vehicles_that_each_want_the_others_lane_swap() {
    let mut w = world(&two_lane_road(), WorldConfig::default());
    // Stopped side by side in a queue-like standstill: no gap will open.
    let left = w
        .place_vehicle_on_route("Taxi", &["a0", "j1", "x1"], 180.0, 0.0)
        .unwrap();
    let right = w
        .place_vehicle_on_route("Taxi", &["a1", "j0", "x0"], 180.0, 0.0)
        .unwrap();
    let seen = run_out(&mut w, &[left, right]);
    assert_eq!(seen[0], ["a0", "a1", "j1", "x1"]);
    assert_eq!(seen[1], ["a1", "a0", "j0", "x0"]);
}

#[test]
fn a_vehicle_that_changes_lanes_standing_still_is_on_its_new_lane_but_drawn_where_it_stands() {
    let mut w = world(&two_lane_road(), WorldConfig::default());
    let id = w.place_vehicle("Taxi", "a0", 100.0, 0.0).unwrap();
    let net = w.network();
    let mut v = vehicle(&w, id).clone();
    assert_eq!(v.speed, 0.0);
    assert!(v.front.y.abs() < 1e-9, "placed on a0 (y = 0)");
    // The move across, then a tick's pose update with the position unchanged.
    trafficmesh_sim::lane_change::apply(net, &mut v, net.lane_id("a1").unwrap());
    trafficmesh_sim::control::update_pose(net, &mut v, trafficmesh_sim::Moved::NOT);
    // a1 runs along y = 3.2: both bumpers follow it, for those who look for
    // it there; a car standing still does not move sideways, so its pose stays.
    for (what, y) in [("front", v.front.y), ("back", v.back.y)] {
        assert!((y - 3.2).abs() < 1e-9, "{what} at y = {y}, not on a1");
    }
    assert!(
        v.pose.y.abs() < 1e-9,
        "drawn at y = {}, not where it stood",
        v.pose.y
    );
    assert_eq!(v.shadow_lane(net), net.lane_id("a0"), "still a body on a0");
}

#[test]
fn a_queue_starting_up_lets_in_a_car_waiting_at_its_lane_end() {
    let config = WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: trafficmesh_model::DriverModel::by_name("realistic").unwrap(),
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    let mut w = world(&two_lane_road(), config);
    // Standing at the end of a0, its route going on from a1.
    let waiting = w
        .place_vehicle_on_route("Taxi", &["a0", "j1", "x1"], 190.0, 0.0)
        .unwrap();
    // A queue standing on a1, bumper to bumper beside and behind it: at the
    // pace it starts up, no gap of its own is ever wide enough.
    let queue: Vec<u64> = (0..8)
        .map(|k| {
            w.place_vehicle("Taxi", "a1", 196.0 - 7.0 * k as f64, 0.0)
                .unwrap()
        })
        .collect();
    let mut ids = vec![waiting];
    ids.extend(&queue);
    let mut entered: Vec<Option<f64>> = vec![None; ids.len()];
    let done = run_until(&mut w, 120.0, |w| {
        assert!(
            overlapping_pairs(w.network(), w.vehicles(), 0.05).is_empty(),
            "overlap at t={:.2}",
            w.time()
        );
        for (k, &id) in ids.iter().enumerate() {
            if entered[k].is_none()
                && w.vehicle(id)
                    .is_none_or(|_| lane_of(w, id) != "a0" && lane_of(w, id) != "a1")
            {
                entered[k] = Some(w.time());
            }
        }
        entered.iter().all(Option::is_some)
    });
    assert!(done, "everyone reaches the junction");
    let waiting_at = entered[0].unwrap();
    let ahead = entered[1..]
        .iter()
        .filter(|t| t.unwrap() < waiting_at)
        .count();
    // The one beside it and the next go first; the queue behind lets it in.
    assert!(
        ahead <= 3,
        "{ahead} of the queue went before the waiting car (it entered at {waiting_at:.1} s)"
    );
}

/// The road of `two_lane_road`, where the outer lane also turns right.
fn road_with_a_right_turn_from_the_outer_lane() -> trafficmesh_model::MapFile {
    let mut m = serde_json::to_value(two_lane_road()).unwrap();
    let lanes = m["lanes"].as_array_mut().unwrap();
    let mut turn = lane("r0", &[[200.0, 0.0], [210.0, -4.0], [215.0, -15.0]], &["r"]);
    turn["intersection"] = json!(true);
    turn["turn_direction"] = json!("right");
    lanes.push(turn);
    lanes.push(lane("r", &[[215.0, -15.0], [215.0, -200.0]], &[]));
    for l in lanes.iter_mut() {
        if l["name"] == "a0" {
            l["next"] = json!(["j0", "r0"]);
        }
    }
    serde_json::from_value(m).unwrap()
}

/// Of 20 vehicles without a route, each alone on the inner lane (seeds 0 to
/// 19), how many turn right at the end of the road.
fn right_turns_from_the_inner_lane(driver_model: trafficmesh_model::DriverModel) -> usize {
    (0..20)
        .filter(|&seed| {
            let config = WorldConfig {
                seed,
                vehicle: trafficmesh_model::NpcVehicleConfig {
                    driver_model,
                    ..Default::default()
                },
                ..WorldConfig::default()
            };
            let mut w = world(&road_with_a_right_turn_from_the_outer_lane(), config);
            let id = w.place_vehicle("Taxi", "a1", 10.0, 8.0).unwrap();
            run_out(&mut w, &[id])[0].contains(&"r".to_string())
        })
        .count()
}

#[test]
fn a_realistic_driver_without_a_route_may_change_lanes_for_a_turn_its_own_lane_does_not_make() {
    let turned = right_turns_from_the_inner_lane(trafficmesh_model::DriverModel::Realistic(
        Default::default(),
    ));
    assert!(
        (3..=17).contains(&turned),
        "about half of them turn right, across to the outer lane first: {turned} of 20"
    );
    assert_eq!(
        right_turns_from_the_inner_lane(trafficmesh_model::DriverModel::Awsim),
        0,
        "the reference's NPCs keep their lanes"
    );
}

/// Two eastbound lanes into a junction: "a0" goes straight on only, "a1"
/// straight on or left through "left" (its own signal, "ARROW"). Straight on,
/// "x0" and "x1" run side by side and merge into "y"; "n" goes north after
/// the left turn.
fn shared_left_lane() -> trafficmesh_model::MapFile {
    let mut j0 = lane("j0", &[[200.0, 0.0], [220.0, 0.0]], &["x0"]);
    let mut j1 = lane("j1", &[[200.0, 3.2], [220.0, 3.2]], &["x1"]);
    let mut left = lane("left", &[[200.0, 3.2], [210.0, 6.0], [215.0, 20.0]], &["n"]);
    let mut k0 = lane("k0", &[[400.0, 0.0], [420.0, 1.6]], &["y"]);
    let mut k1 = lane("k1", &[[400.0, 3.2], [420.0, 1.6]], &["y"]);
    for l in [&mut j0, &mut j1, &mut left, &mut k0, &mut k1] {
        l["intersection"] = json!(true);
    }
    left["stop_line"] = json!([[200.0, 1.6], [200.0, 4.8]]);
    left["traffic_light"] = json!("ARROW");
    map(
        vec![
            lane("a0", &[[0.0, 0.0], [200.0, 0.0]], &["j0"]),
            lane("a1", &[[0.0, 3.2], [200.0, 3.2]], &["j1", "left"]),
            j0,
            j1,
            left,
            lane("x0", &[[220.0, 0.0], [400.0, 0.0]], &["k0"]),
            lane("x1", &[[220.0, 3.2], [400.0, 3.2]], &["k1"]),
            k0,
            k1,
            lane("y", &[[420.0, 1.6], [700.0, 1.6]], &[]),
            lane("n", &[[215.0, 20.0], [215.0, 300.0]], &[]),
        ],
        json!({ "light_groups": [{ "name": "ARROW", "program": { "green": 30, "yellow": 3, "red": 30 } }] }),
    )
}

/// Four left turners wait at a red arrow; behind them in the shared lane,
/// four drivers going straight on by `route`. Returns the world and their ids.
fn queue_behind_a_red_arrow(
    model: trafficmesh_model::DriverModel,
    route: &[&str],
) -> (World, Vec<u64>) {
    let config = WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: model,
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    let mut w = world(&shared_left_lane(), config);
    w.set_light("ARROW", LightControl::Forced(LightColor::Red))
        .unwrap();
    for s in [199.0, 191.0, 183.0, 175.0] {
        w.place_vehicle_on_route("Taxi", &["a1", "left", "n"], s, 0.0)
            .unwrap();
    }
    let straight = [167.0, 159.0, 151.0, 143.0]
        .iter()
        .map(|&s| w.place_vehicle_on_route("Taxi", route, s, 0.0).unwrap())
        .collect();
    (w, straight)
}

/// Runs `seconds` (the arrow stays red throughout), failing on any overlap;
/// returns the road lanes each of `ids` was seen on, in order.
fn road_lanes_seen(w: &mut World, ids: &[u64], seconds: f64) -> Vec<Vec<String>> {
    let mut seen: Vec<Vec<String>> = vec![Vec::new(); ids.len()];
    run_until(w, seconds, |w| {
        assert!(
            overlapping_pairs(w.network(), w.vehicles(), 0.05).is_empty(),
            "overlap at t={:.2}",
            w.time()
        );
        for (k, &id) in ids.iter().enumerate() {
            if let Some(v) = w.vehicle(id) {
                let lane = w.network().lane(v.path[0]);
                if !lane.intersection && seen[k].last() != Some(&lane.name) {
                    seen[k].push(lane.name.clone());
                }
            }
        }
        false
    });
    seen
}

#[test]
fn drivers_going_straight_leave_a_lane_held_by_a_red_arrow_for_the_free_lane_beside() {
    let realistic = trafficmesh_model::DriverModel::Realistic(Default::default());
    let (mut w, straight) = queue_behind_a_red_arrow(realistic, &["a1", "j1", "x1"]);
    let seen = road_lanes_seen(&mut w, &straight, 60.0);
    for (id, lanes) in straight.iter().zip(&seen) {
        // Their route ends on x1: beside it is as good.
        assert_eq!(lanes[..3], ["a1", "a0", "x0"], "vehicle {id}: {lanes:?}");
    }
}

#[test]
fn a_driver_who_leaves_its_planned_lane_rejoins_its_route_further_on() {
    let realistic = trafficmesh_model::DriverModel::Realistic(Default::default());
    let route = ["a1", "j1", "x1", "k1", "y"];
    let (mut w, straight) = queue_behind_a_red_arrow(realistic, &route);
    let starts: Vec<f64> = straight.iter().map(|&id| vehicle(&w, id).s).collect();
    let seen = road_lanes_seen(&mut w, &straight, 90.0);
    let trips: Vec<trafficmesh_sim::TripRecord> = w
        .drain_events()
        .filter_map(|e| match e {
            trafficmesh_sim::SimEvent::Despawned(trip) => Some(trip),
            _ => None,
        })
        .collect();
    for ((id, lanes), start) in straight.iter().zip(&seen).zip(starts) {
        assert_eq!(lanes, &["a1", "a0", "x0", "y"], "vehicle {id}");
        let trip = trips
            .iter()
            .find(|t| t.id == *id)
            .unwrap_or_else(|| panic!("vehicle {id} did not reach y's end"));
        // To the end of y and no further: the rest of the route is not
        // driven again after the rejoin.
        let route_left = (200.0 - start) + 20.0 + 180.0 + 20.06 + 280.0;
        assert!(
            (trip.distance - route_left).abs() < 2.0,
            "vehicle {id} drove {:.1} m, its route's rest is {route_left:.1} m",
            trip.distance
        );
    }
}

#[test]
fn the_references_drivers_keep_their_lane_behind_a_red_arrow() {
    let (mut w, straight) =
        queue_behind_a_red_arrow(trafficmesh_model::DriverModel::Awsim, &["a1", "j1", "x1"]);
    run_for(&mut w, 60.0);
    for id in straight {
        assert_eq!(lane_of(&w, id), "a1", "vehicle {id} left its lane");
    }
}

/// `shared_left_lane` with its arrow red for good and a1 full of left
/// turners standing at it, bumper to bumper back to s = 119: no gap there.
/// Returns the world and the turners' ids.
fn left_lane_held_by_a_red_arrow(seed: u64) -> (World, Vec<u64>) {
    let config = WorldConfig {
        seed,
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: trafficmesh_model::DriverModel::Realistic(Default::default()),
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    // A left turn, which a0's own way (straight on) is not.
    let mut map = serde_json::to_value(shared_left_lane()).unwrap();
    for l in map["lanes"].as_array_mut().unwrap() {
        if l["name"] == "left" {
            l["turn_direction"] = json!("left");
        }
    }
    let mut w = world(&serde_json::from_value(map).unwrap(), config);
    w.set_light("ARROW", LightControl::Forced(LightColor::Red))
        .unwrap();
    let turners = (0..11)
        .map(|k| {
            let s = 199.0 - 8.0 * k as f64;
            w.place_vehicle_on_route("Taxi", &["a1", "left", "n"], s, 0.0)
                .unwrap()
        })
        .collect();
    (w, turners)
}

#[test]
fn a_driver_without_a_route_gives_up_a_turn_it_finds_no_gap_for_and_goes_on_its_own_way() {
    let mut gave_up = 0;
    for seed in 0..12 {
        let (mut w, turners) = left_lane_held_by_a_red_arrow(seed);
        let id = w.place_vehicle("Taxi", "a0", 150.0, 0.0).unwrap();
        w.step();
        if vehicle(&w, id).lane_change.is_none() {
            continue; // It chose straight on: nothing to give up.
        }
        // It waits at a0's end for a gap on a1 that never opens, then goes
        // straight on, the way a0 itself leads, and leaves the map.
        let mut waited_from = None;
        let gone = run_until(&mut w, 120.0, |w| {
            assert!(
                overlapping_pairs(w.network(), w.vehicles(), 0.05).is_empty(),
                "seed {seed}: overlap at t={:.2}",
                w.time()
            );
            let Some(v) = w.vehicle(id) else {
                return true;
            };
            let lane = &w.network().lane(v.path[0]).name;
            assert!(lane != "a1" && lane != "left", "seed {seed}: on {lane}");
            if v.speed == 0.0 && lane == "a0" {
                waited_from.get_or_insert(w.time());
            }
            false
        });
        assert!(gone, "seed {seed}: still on the map after 120 s");
        let waited = w.time() - waited_from.expect("it stood at a0's end");
        assert!(
            waited > 45.0,
            "seed {seed}: gave up after {waited:.1} s, before 45 s of waiting"
        );
        for t in turners {
            assert_eq!(lane_of(&w, t), "a1", "seed {seed}: the arrow stays red");
        }
        gave_up += 1;
    }
    assert!(gave_up > 0, "no seed chose the left turn from a0");
}

#[test]
fn a_routed_vehicle_keeps_waiting_for_its_gap() {
    let (mut w, _) = left_lane_held_by_a_red_arrow(0);
    let id = w
        .place_vehicle_on_route("Taxi", &["a0", "left", "n"], 150.0, 0.0)
        .unwrap();
    run_for(&mut w, 120.0);
    let v = vehicle(&w, id);
    assert_eq!(lane_of(&w, id), "a0", "SUMO's routes are kept");
    assert!(v.lane_change.is_some(), "still waiting to move across");
}

/// A two-lane ring road, anticlockwise round a 200 m square: four sides
/// ("s0" to "s3", each with lanes `_0` outside and `_1` inside) joined by
/// quarter circles ("c0" to "c3"). `with_exit`: one way off leaves from the
/// outer lane at the end of the south side ("exit", then "out"), and the
/// inner lane only ever goes round.
fn ring_road(with_exit: bool) -> trafficmesh_model::MapFile {
    let origin = [[0.0, 0.0], [200.0, 0.0], [200.0, 200.0], [0.0, 200.0]];
    let along = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
    let point = |side: usize, t: f64, inward: f64| {
        let (o, d) = (origin[side], along[side]);
        // Inward is the direction of travel turned left.
        [
            o[0] + d[0] * t - d[1] * inward,
            o[1] + d[1] * t + d[0] * inward,
        ]
    };
    let mut lanes = Vec::new();
    for (side, d) in along.iter().enumerate() {
        let next_side = (side + 1) % 4;
        for i in 0..2 {
            let inward = 3.2 * i as f64;
            let corner = format!("c{side}_{i}");
            let mut next = vec![corner.as_str()];
            if with_exit && side == 0 && i == 0 {
                next.push("exit");
            }
            lanes.push(lane(
                &format!("s{side}_{i}"),
                &[point(side, 20.0, inward), point(side, 180.0, inward)],
                &next,
            ));
            // A quarter circle about the corner's centre, 20 m in.
            let centre = point(side, 180.0, 20.0);
            let radius = 20.0 - inward;
            let n = [-d[1], d[0]];
            let arc: Vec<[f64; 2]> = (0..=6)
                .map(|k| {
                    let a = std::f64::consts::FRAC_PI_2 * k as f64 / 6.0;
                    [
                        centre[0] + radius * (-n[0] * a.cos() + d[0] * a.sin()),
                        centre[1] + radius * (-n[1] * a.cos() + d[1] * a.sin()),
                    ]
                })
                .collect();
            let mut c = lane(&corner, &arc, &[&format!("s{next_side}_{i}")]);
            c["intersection"] = json!(true);
            c["turn_direction"] = json!("left");
            lanes.push(c);
        }
    }
    if with_exit {
        let mut exit = lane("exit", &[[180.0, 0.0], [200.0, 0.0]], &["out"]);
        exit["intersection"] = json!(true);
        lanes.push(exit);
        lanes.push(lane("out", &[[200.0, 0.0], [400.0, 0.0]], &[]));
    }
    map(lanes, json!({}))
}

/// Drivers without a route on the inner lane of a ring that never leads off
/// it change to the outer lane for the way off the first time they come to
/// it: each would otherwise take it at one pass in two, and a ring filled
/// with drivers going round and round stands still.
#[test]
fn a_driver_without_a_route_leaves_a_ring_whose_inner_lane_never_leads_off_it() {
    let m = ring_road(true);
    let config = WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: trafficmesh_model::DriverModel::Realistic(Default::default()),
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    let mut w = world(&m, config);
    let net = w.network();
    let looped = |name: &str| net.lane(net.lane_id(name).unwrap()).in_closed_loop;
    assert!(
        looped("s2_1") && looped("c3_1"),
        "the inner lane is a closed loop"
    );
    assert!(
        !looped("s2_0") && !looped("c3_0") && !looped("out"),
        "the outer lane leads off the ring"
    );
    // Without the way off, both lanes go round for ever.
    let closed = world(&ring_road(false), WorldConfig::default());
    let net = closed.network();
    let looped = |name: &str| net.lane(net.lane_id(name).unwrap()).in_closed_loop;
    assert!(
        looped("s2_1") && looped("s2_0"),
        "a closed ring is a closed loop"
    );
    let ids: Vec<u64> = ["s1_1", "s2_1", "s3_1"]
        .iter()
        .flat_map(|&lane| [30.0, 110.0].map(|s| (lane, s)))
        .map(|(lane, s)| w.place_vehicle("Taxi", lane, s, 8.0).unwrap())
        .collect();
    let mut seen: Vec<Vec<String>> = vec![Vec::new(); ids.len()];
    let done = run_until(&mut w, 400.0, |w| {
        assert_no_overlap(w);
        for (k, &id) in ids.iter().enumerate() {
            if let Some(v) = w.vehicle(id) {
                let lane = &w.network().lane(v.path[0]).name;
                if seen[k].last() != Some(lane) {
                    seen[k].push(lane.clone());
                }
            }
        }
        w.vehicles().is_empty()
    });
    assert!(done, "every driver leaves the ring: {seen:?}");
    for (id, lanes) in ids.iter().zip(&seen) {
        let south = lanes.iter().filter(|l| l.starts_with("s0_")).count();
        assert!(
            lanes.ends_with(&["s0_1".into(), "s0_0".into(), "exit".into(), "out".into()]),
            "vehicle {id} changes to the outer lane on the south side and leaves: {lanes:?}"
        );
        assert_eq!(
            south, 2,
            "vehicle {id} drove the south side once: {lanes:?}"
        );
    }
}
