//! The jam timeout and the waiting figures: a queue head that stands for the
//! timeout (away from a red light) is moved to the next lane of its route
//! where it fits, or taken off the road, and counted; one held by a red light
//! is not; a vehicle standing a minute counts as stuck.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::{LightColor, MapFile};
use trafficmesh_sim::crosswalk::OccupantType;
use trafficmesh_sim::lights::LightControl;
use trafficmesh_sim::{DespawnReason, SimEvent, WorldConfig};

/// An eastbound road with a zebra crossing at x = 150 that a walker who never
/// leaves can block for good, ending in a junction lane, with or without an
/// exit lane after it.
fn road_with_crossing(with_exit: bool) -> MapFile {
    let next: &[&str] = if with_exit { &["exit"] } else { &[] };
    let mut junction = lane("junction", &[[400.0, 0.0], [420.0, 0.0]], next);
    junction["intersection"] = json!(true);
    let mut lanes = vec![
        lane("east", &[[0.0, 0.0], [400.0, 0.0]], &["junction"]),
        junction,
    ];
    if with_exit {
        lanes.push(lane("exit", &[[420.0, 0.0], [800.0, 0.0]], &[]));
    }
    map(
        lanes,
        json!({
            "crosswalks": [{
                "name": "Zebra",
                "area": { "shape": "box", "center": [150.0, 0.0], "half_extents": [2.0, 6.0] },
                "stop_points": [{ "position": [145.0, 0.0] }]
            }]
        }),
    )
}

fn blocked_for_good(jam_timeout: f64) -> (trafficmesh_sim::World, u64) {
    let config = WorldConfig {
        jam_timeout,
        ..WorldConfig::default()
    };
    let mut w = world(&road_with_crossing(false), config);
    let id = w.place_vehicle("Taxi", "east", 60.0, 10.0).unwrap();
    w.crosswalk_enter("Zebra", "Human_01", OccupantType::NpcPedestrian)
        .unwrap();
    (w, id)
}

/// The stuck vehicles are sampled at the start of each simulated minute:
/// one held for good from its first seconds is stuck at minutes 2, 3 and 4
/// (standing 60 s or more), not at 0 and 1.
#[test]
fn the_mean_stuck_count_samples_each_simulated_minute() {
    let (mut w, _) = blocked_for_good(0.0);
    run_for(&mut w, 290.0);
    let stats = w.wait_stats();
    assert_eq!((stats.stuck_sampled, stats.stuck_samples), (3, 5));
    assert!((stats.stuck_mean() - 0.6).abs() < 1e-12);
    assert_eq!(w.stuck_vehicles(), 1, "stuck at the end");
}

#[test]
fn a_vehicle_standing_for_the_jam_timeout_is_taken_off_the_road_and_counted() {
    let (mut w, id) = blocked_for_good(120.0);
    run_for(&mut w, 100.0);
    assert!(w.vehicle(id).is_some(), "gone before its timeout");
    assert_eq!(w.stuck_vehicles(), 1, "standing over a minute: stuck");
    run_until(&mut w, 60.0, |w| w.vehicle(id).is_none());
    assert!(w.vehicle(id).is_none(), "still on the road after 160 s");
    let events: Vec<SimEvent> = w.drain_events().collect();
    assert!(
        events.iter().any(|e| matches!(e, SimEvent::Despawned(t) if t.id == id && t.reason == DespawnReason::Jammed)),
        "no jammed despawn among {events:?}"
    );
    let stats = w.wait_stats();
    assert_eq!(stats.jam_resolutions, 1);
    assert_eq!(
        stats.jam_removals, 1,
        "no ordinary lane ahead without a route"
    );
    assert!(
        (120.0..125.0).contains(&stats.max_wait),
        "max wait {} s",
        stats.max_wait
    );
}

#[test]
fn a_jammed_vehicle_with_a_route_is_moved_to_the_next_lane_of_its_route_where_it_fits() {
    let config = WorldConfig {
        jam_timeout: 120.0,
        ..WorldConfig::default()
    };
    let mut w = world(&road_with_crossing(true), config);
    let id = w
        .place_vehicle_on_route("Taxi", &["east", "junction", "exit"], 60.0, 10.0)
        .unwrap();
    w.crosswalk_enter("Zebra", "Human_01", OccupantType::NpcPedestrian)
        .unwrap();
    let exit = w.network().lane_id("exit").unwrap();
    run_until(&mut w, 119.0, |w| vehicle(w, id).path[0] == exit);
    assert!(
        vehicle(&w, vehicle_lane_is(&w, id, "east")).speed < 0.1,
        "it waits at the zebra until its timeout"
    );
    run_until(&mut w, 20.0, |w| vehicle(w, id).path[0] == exit);
    let v = vehicle(&w, id);
    assert_eq!(
        v.path[0], exit,
        "moved to the start of the route's next lane"
    );
    assert!(v.pose.x >= 420.0, "its body is on the exit: x {}", v.pose.x);
    assert_eq!(w.wait_stats().jam_resolutions, 1);
    assert_eq!(w.wait_stats().jam_removals, 0);
    run_for(&mut w, 10.0);
    assert!(vehicle(&w, id).speed > 5.0, "it drives on from there");
}

/// `road_with_crossing` whose junction leads to a lane shorter than a car
/// (a stub), then the exit; a road beside the exit's start where a truck
/// can be held by a zebra of its own.
fn road_with_stub_and_side_road() -> MapFile {
    let mut m = serde_json::to_value(road_with_crossing(true)).unwrap();
    let lanes = m["lanes"].as_array_mut().unwrap();
    lanes[1]["next"] = json!(["stub"]);
    lanes[2] = lane("exit", &[[422.0, 0.0], [800.0, 0.0]], &[]);
    lanes.push(lane("stub", &[[420.0, 0.0], [422.0, 0.0]], &["exit"]));
    lanes.push(lane("side", &[[380.0, 2.0], [470.0, 2.0]], &[]));
    m["crosswalks"].as_array_mut().unwrap().push(json!({
        "name": "SideZebra",
        "area": { "shape": "box", "center": [440.0, 2.0], "half_extents": [2.0, 1.0] },
        "stop_points": [{ "position": [436.0, 2.0] }]
    }));
    serde_json::from_value(m).unwrap()
}

/// Where it fits: the next lane that holds the whole body (a shorter one
/// would leave it reaching back over lanes nobody knows it is on), with no
/// other body there now.
#[test]
fn a_jammed_vehicle_is_moved_only_where_its_whole_body_fits() {
    let route = ["east", "junction", "stub", "exit"];
    for side_truck in [false, true] {
        let config = WorldConfig {
            jam_timeout: 120.0,
            ..WorldConfig::default()
        };
        let mut w = world(&road_with_stub_and_side_road(), config);
        let id = w
            .place_vehicle_on_route("Taxi", &route, 60.0, 10.0)
            .unwrap();
        w.crosswalk_enter("Zebra", "Human_01", OccupantType::NpcPedestrian)
            .unwrap();
        run_for(&mut w, 100.0);
        if side_truck {
            // Held by its own zebra, its body over the exit's first metres.
            w.crosswalk_enter("SideZebra", "Human_02", OccupantType::NpcPedestrian)
                .unwrap();
            w.place_vehicle("Truck_2t", "side", 50.0, 0.0).unwrap();
        }
        assert!(
            run_until(&mut w, 60.0, |w| w.wait_stats().jam_resolutions == 1),
            "its timeout comes"
        );
        let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.0);
        assert!(pairs.is_empty(), "overlap after the move: {pairs:?}");
        if side_truck {
            assert!(w.vehicle(id).is_none(), "no room on the exit: taken off");
            assert_eq!(w.wait_stats().jam_removals, 1);
        } else {
            let v = vehicle(&w, id);
            assert_eq!(w.network().lane(v.path[0]).name, "exit", "past the stub");
            assert_eq!(w.wait_stats().jam_removals, 0);
        }
    }
}

/// The vehicle's id, after checking that it is on `lane`.
fn vehicle_lane_is(w: &trafficmesh_sim::World, id: u64, lane: &str) -> u64 {
    let on = vehicle(w, id).path[0];
    assert_eq!(w.network().lane(on).name, lane);
    id
}

#[test]
fn with_the_jam_timeout_at_zero_nobody_is_taken_off() {
    let (mut w, id) = blocked_for_good(0.0);
    run_for(&mut w, 400.0);
    assert!(w.vehicle(id).is_some());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
    assert!(w.wait_stats().max_wait > 300.0);
}

#[test]
fn a_vehicle_held_by_a_red_light_is_neither_stuck_nor_jammed() {
    let config = WorldConfig {
        jam_timeout: 120.0,
        ..WorldConfig::default()
    };
    let mut w = world(&signalised_road(), config);
    w.set_light("L", LightControl::Forced(LightColor::Red))
        .unwrap();
    let id = w.place_vehicle("Taxi", "approach", 100.0, 10.0).unwrap();
    run_for(&mut w, 300.0);
    assert!(vehicle(&w, id).speed < 0.1, "it waits at the red light");
    assert_eq!(w.stuck_vehicles(), 0);
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

/// An eastbound road into a junction of `junction` lanes (in a row, 20 m in
/// all, from x = 400) and out on an exit lane, whose first vehicle a walker
/// who never leaves a zebra crossing holds just past the box (stop line at
/// x = 428).
fn held_exit(junction: &[&str], config: WorldConfig) -> trafficmesh_sim::World {
    let step = 20.0 / junction.len() as f64;
    let mut lanes = vec![lane("east", &[[0.0, 0.0], [400.0, 0.0]], &[junction[0]])];
    for (k, name) in junction.iter().enumerate() {
        let next = junction.get(k + 1).copied().unwrap_or("exit");
        let x = 400.0 + step * k as f64;
        let mut l = lane(name, &[[x, 0.0], [x + step, 0.0]], &[next]);
        l["intersection"] = json!(true);
        lanes.push(l);
    }
    lanes.push(lane("exit", &[[420.0, 0.0], [800.0, 0.0]], &[]));
    let m = map(
        lanes,
        json!({
            "crosswalks": [{
                "name": "Zebra",
                "area": { "shape": "box", "center": [432.0, 0.0], "half_extents": [2.0, 6.0] },
                "stop_points": [{ "position": [428.0, 0.0] }]
            }]
        }),
    );
    let mut w = world(&m, config);
    w.crosswalk_enter("Zebra", "Human_01", OccupantType::NpcPedestrian)
        .unwrap();
    w
}

/// "Don't block the box" through a junction of two lanes (a left turn past
/// the junction's inner point): with the exit taken, a vehicle waits before
/// the first junction lane, not inside the box, where it would block the
/// crossing traffic and lock the junction.
#[test]
fn a_vehicle_whose_exit_is_taken_waits_before_a_two_lane_junction() {
    let mut w = held_exit(&["junction_a", "junction_b"], WorldConfig::default());
    let blocker = w
        .place_vehicle_on_route("Taxi", &["exit"], 6.0, 0.0)
        .unwrap();
    let id = w
        .place_vehicle_on_route(
            "Taxi",
            &["east", "junction_a", "junction_b", "exit"],
            300.0,
            10.0,
        )
        .unwrap();
    run_for(&mut w, 60.0);
    assert!(vehicle(&w, blocker).s < 10.0, "the exit stays taken");
    let v = vehicle(&w, id);
    assert_eq!(
        w.network().lane(v.path[0]).name,
        "east",
        "it entered the box: on {} at s {:.1}",
        w.network().lane(v.path[0]).name,
        v.s
    );
    assert!(v.speed < 0.1, "it waits");
}

/// Keep clear also behind a car still rolling onto the exit: if it will come
/// to rest too near the exit's start to leave room (here behind a zebra
/// crossing a walker holds), the vehicle waits before the box instead of
/// following it in and standing across the junction.
#[test]
fn a_vehicle_does_not_follow_a_car_into_the_box_that_will_stop_at_its_exit() {
    let realistic = WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: trafficmesh_model::DriverModel::by_name("realistic").unwrap(),
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    let mut w = held_exit(&["junction"], realistic);
    // Rolling at 5 m/s with its rear 0.5 m into the exit: it stops at the zebra.
    let rolling = w
        .place_vehicle_on_route("Taxi", &["exit"], 5.0, 5.0)
        .unwrap();
    let id = w
        .place_vehicle_on_route("Taxi", &["east", "junction", "exit"], 380.0, 12.0)
        .unwrap();
    run_for(&mut w, 30.0);
    assert!(vehicle(&w, rolling).speed < 0.1, "the rolling car stopped");
    let v = vehicle(&w, id);
    assert_eq!(
        w.network().lane(v.path[0]).name,
        "east",
        "it followed into the box: on {} at s {:.1}",
        w.network().lane(v.path[0]).name,
        v.s
    );
}

/// The jam timeout moves a vehicle ahead along the way it drives, also after
/// a lane change took it off its route's planned lanes: onto the road beyond
/// the block, never back to a lane of its route it has passed.
#[test]
fn a_jammed_vehicle_that_changed_lanes_is_moved_ahead_not_back() {
    let mut m = serde_json::to_value(two_lane_road()).unwrap();
    let lanes = m["lanes"].as_array_mut().unwrap();
    let mut jw = lane("jw", &[[-20.0, 0.0], [0.0, 0.0]], &["a0"]);
    jw["intersection"] = json!(true);
    lanes.push(lane("w", &[[-200.0, 0.0], [-20.0, 0.0]], &["jw"]));
    lanes.push(jw);
    // A zebra across both lanes just before their junction, held for good.
    m["crosswalks"] = json!([{
        "name": "Zebra",
        "area": { "shape": "box", "center": [190.0, 1.6], "half_extents": [2.0, 4.0] },
        "stop_points": [{ "position": [185.0, 0.0] }, { "position": [185.0, 3.2] }]
    }]);
    let m: MapFile = serde_json::from_value(m).unwrap();
    let config = WorldConfig {
        jam_timeout: 120.0,
        ..WorldConfig::default()
    };
    let mut w = world(&m, config);
    let id = w
        .place_vehicle_on_route("Taxi", &["w", "jw", "a0", "j1", "x1"], 100.0, 10.0)
        .unwrap();
    w.crosswalk_enter("Zebra", "Human_01", OccupantType::NpcPedestrian)
        .unwrap();
    let a1 = w.network().lane_id("a1").unwrap();
    assert!(
        run_until(&mut w, 60.0, |w| vehicle(w, id).path[0] == a1),
        "it changes onto a1 on its way"
    );
    assert!(
        run_until(&mut w, 200.0, |w| w.wait_stats().jam_resolutions == 1),
        "it stands at the zebra until its timeout"
    );
    let v = vehicle(&w, id);
    assert_eq!(
        w.network().lane(v.path[0]).name,
        "x1",
        "moved beyond the zebra"
    );
    assert!(v.pose.x >= 220.0, "its body is on x1: x {}", v.pose.x);
    assert_eq!(w.wait_stats().jam_removals, 0);
}

/// The jam timeout moves the first vehicle of its lane whatever holds it,
/// also the body of another lane standing across its way (as SUMO teleports
/// a lane's first vehicle): here a car held for good by a red light whose
/// stop line lies just past an unmarked crossing, its body across the road
/// of the car that waits for it.
#[test]
fn a_vehicle_waiting_for_a_body_of_another_lane_across_its_way_is_a_jammed_head() {
    let mut north = lane("north", &[[100.0, -100.0], [100.0, 4.0]], &["north_box"]);
    north["stop_line"] = json!([[98.25, 4.0], [101.75, 4.0]]);
    north["traffic_light"] = json!("L");
    let mut north_box = lane("north_box", &[[100.0, 4.0], [100.0, 24.0]], &["north_exit"]);
    north_box["intersection"] = json!(true);
    let m = map(
        vec![
            lane("east", &[[0.0, 0.0], [200.0, 0.0]], &[]),
            north,
            north_box,
            lane("north_exit", &[[100.0, 24.0], [100.0, 200.0]], &[]),
        ],
        json!({
            "road_conflicts": "everywhere",
            "light_groups": [{ "name": "L", "program": { "green": 30, "yellow": 3, "red": 30 } }]
        }),
    );
    let config = WorldConfig {
        jam_timeout: 120.0,
        ..WorldConfig::default()
    };
    let mut w = world(&m, config);
    w.set_light("L", LightControl::Forced(LightColor::Red))
        .unwrap();
    let held = w.place_vehicle("Taxi", "north", 60.0, 10.0).unwrap();
    run_for(&mut w, 20.0);
    let v = vehicle(&w, held);
    assert!(
        v.speed < 0.1 && v.rear_s() < 100.0,
        "the red light holds it across the road: rear at s {:.1}",
        v.rear_s()
    );
    let waiting = w.place_vehicle("Taxi", "east", 40.0, 10.0).unwrap();
    run_for(&mut w, 100.0);
    assert!(
        vehicle(&w, waiting).speed < 0.1,
        "it waits for the body across its way"
    );
    assert!(vehicle(&w, waiting).s < 100.0, "before the crossing");
    run_until(&mut w, 40.0, |w| w.vehicle(waiting).is_none());
    assert!(
        w.vehicle(waiting).is_none(),
        "still waiting 140 s after it stopped"
    );
    assert_eq!(w.wait_stats().jam_resolutions, 1, "counted once");
    assert!(
        w.vehicle(held).is_some(),
        "the one its red light holds stays"
    );
}

/// A one-way ring around a block: four 80 m roads joined at the corners by
/// junction lanes, each road packed with standing taxis from end to start.
/// Each taxi's route turns onto the next road and leaves the ring at that
/// road's end, straight on past the corner; but every queue's head waits for
/// room on the next road, whose queue waits for the one after. Returns the
/// world and the taxis' ids.
fn gridlocked_ring(config: WorldConfig) -> (trafficmesh_sim::World, Vec<u64>) {
    let corners = [[100.0, 0.0], [100.0, 100.0], [0.0, 100.0], [0.0, 0.0]];
    let name = |what: &str, k: usize| format!("{what}{}", k % 4);
    let mut lanes = Vec::new();
    for k in 0..4 {
        let (c0, c1, c2) = (corners[(k + 3) % 4], corners[k], corners[(k + 1) % 4]);
        let at =
            |a: [f64; 2], b: [f64; 2], t: f64| [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
        let (corner, leave, exit) = (name("corner", k), name("leave", k), name("exit", k));
        lanes.push(lane(
            &name("road", k),
            &[at(c0, c1, 0.1), at(c0, c1, 0.9)],
            &[&corner, &leave],
        ));
        let mut turn = lane(
            &corner,
            &[at(c0, c1, 0.9), c1, at(c1, c2, 0.1)],
            &[&name("road", k + 1)],
        );
        turn["intersection"] = json!(true);
        lanes.push(turn);
        let mut straight = lane(&leave, &[at(c0, c1, 0.9), at(c0, c1, 1.1)], &[&exit]);
        straight["intersection"] = json!(true);
        lanes.push(straight);
        lanes.push(lane(&exit, &[at(c0, c1, 1.1), at(c0, c1, 3.0)], &[]));
    }
    let mut w = world(&map(lanes, json!({})), config);
    let mut ids = Vec::new();
    for k in 0..4 {
        let route = [
            name("road", k),
            name("corner", k),
            name("road", k + 1),
            name("leave", k + 1),
            name("exit", k + 1),
        ];
        let route: Vec<&str> = route.iter().map(String::as_str).collect();
        for slot in 0..6 {
            let front = 80.0 - 12.0 * slot as f64;
            ids.push(
                w.place_vehicle_on_route("Taxi", &route, front, 0.0)
                    .unwrap(),
            );
        }
    }
    (w, ids)
}

/// A gridlock through several junctions (no rule holds anyone, so no right
/// of way can be given) is found in the waits and broken as soon as the whole
/// ring has stood for the gridlock patience, long before the jam timeout:
/// one head is moved on, and the ring drains with nobody stuck.
#[test]
fn a_ring_of_full_roads_is_broken_as_a_gridlock_and_drains() {
    let (mut w, ids) = gridlocked_ring(WorldConfig::default());
    let patience = trafficmesh_sim::world::GRIDLOCK_PATIENCE;
    let broken = run_until(&mut w, 90.0, |w| w.wait_stats().jam_resolutions > 0);
    assert!(broken, "the gridlock is still there after 90 s");
    let stats = w.wait_stats();
    assert_eq!(stats.jam_resolutions, 1, "one head moved on: {stats:?}");
    assert_eq!(stats.gridlocks_broken, 1);
    assert!(
        stats.max_wait >= patience && stats.max_wait < trafficmesh_sim::world::STUCK_AFTER,
        "broken when the longest had stood {} s",
        stats.max_wait
    );
    let mut overlaps = 0;
    let drained = run_until(&mut w, 240.0, |w| {
        overlaps += overlapping_pairs(w.network(), w.vehicles(), 0.0).len();
        w.vehicles().is_empty()
    });
    let left: Vec<_> = ids.iter().filter(|&&id| w.vehicle(id).is_some()).collect();
    assert!(
        drained,
        "still in the ring after 240 s: {left:?}, {:?}",
        w.wait_stats()
    );
    // Each break frees one slot, and a ring this full may lock again
    // before those who came around leave: at most once per road, and never
    // with anyone standing for a minute.
    let stats = w.wait_stats();
    assert!(stats.jam_resolutions <= 4, "{stats:?}");
    assert_eq!(stats.gridlocks_broken, stats.jam_resolutions);
    assert!(
        stats.max_wait < trafficmesh_sim::world::STUCK_AFTER,
        "{stats:?}"
    );
    assert_eq!(overlaps, 0, "overlapping pair-ticks");
}
/// Breaking a gridlock teleports a vehicle, as the jam timeout does: a run
/// with the timeout off keeps every vehicle where it is.
#[test]
fn with_the_jam_timeout_at_zero_a_gridlock_is_left_alone() {
    let config = WorldConfig {
        jam_timeout: 0.0,
        ..WorldConfig::default()
    };
    let (mut w, ids) = gridlocked_ring(config);
    run_for(&mut w, 90.0);
    assert_eq!(w.wait_stats().jam_resolutions, 0);
    assert_eq!(w.stuck_vehicles(), ids.len());
}
