//! Reservation intersections in the world: a vehicle enters only on a way
//! granted, never overlapping another's, and the choice of controller per
//! intersection (lights, priority, reservation).

mod support;

use serde_json::{Value, json};
use support::*;
use trafficmesh_sim::{World, WorldConfig};

/// A four-way junction 20 m across, one lane per approach (100 m each),
/// straight on from every side and a right turn from the west, with a light
/// group per axis; `controller` chooses how the junction is run.
fn crossing(controller: &str) -> trafficmesh_model::MapFile {
    let inter = |name: &str, points: &[[f64; 2]], next: &str, light: &str| {
        let mut l = lane(name, points, &[next]);
        l["intersection"] = json!(true);
        l["traffic_light"] = json!(light);
        // The stop line across its start.
        let ([x0, y0], [x1, y1]) = (points[0], points[1]);
        let len = (x1 - x0).hypot(y1 - y0);
        let (nx, ny) = (-(y1 - y0) / len * 1.6, (x1 - x0) / len * 1.6);
        l["stop_line"] = json!([[x0 + nx, y0 + ny], [x0 - nx, y0 - ny]]);
        l
    };
    let lanes: Vec<Value> = vec![
        lane("w_in", &[[-110.0, -1.6], [-10.0, -1.6]], &["we", "wr"]),
        lane("s_in", &[[1.6, -110.0], [1.6, -10.0]], &["sn"]),
        lane("e_in", &[[110.0, 1.6], [10.0, 1.6]], &["ew"]),
        lane("n_in", &[[-1.6, 110.0], [-1.6, 10.0]], &["ns"]),
        inter("we", &[[-10.0, -1.6], [10.0, -1.6]], "e_out", "EW"),
        inter(
            "wr",
            &[[-10.0, -1.6], [-1.6, -1.6], [-1.6, -10.0]],
            "s_out",
            "EW",
        ),
        inter("sn", &[[1.6, -10.0], [1.6, 10.0]], "n_out", "NS"),
        inter("ew", &[[10.0, 1.6], [-10.0, 1.6]], "w_out", "EW"),
        inter("ns", &[[-1.6, 10.0], [-1.6, -10.0]], "s_out", "NS"),
        lane("e_out", &[[10.0, -1.6], [110.0, -1.6]], &[]),
        lane("n_out", &[[1.6, 10.0], [1.6, 110.0]], &[]),
        lane("w_out", &[[-10.0, 1.6], [-110.0, 1.6]], &[]),
        lane("s_out", &[[-1.6, -10.0], [-1.6, -110.0]], &[]),
    ];
    map(
        lanes,
        json!({
            "light_groups": [
                { "name": "EW", "program": { "green": 20, "yellow": 3, "red": 23 } },
                { "name": "NS", "program": { "green": 20, "yellow": 3, "red": 23, "offset": 23 } },
            ],
            "intersections": [{ "lane": "we", "controller": controller }],
        }),
    )
}

const ROUTES: [[&str; 3]; 5] = [
    ["w_in", "we", "e_out"],
    ["w_in", "wr", "s_out"],
    ["s_in", "sn", "n_out"],
    ["e_in", "ew", "w_out"],
    ["n_in", "ns", "s_out"],
];

/// Places a taxi at 10 m/s 5 m into `route`'s first lane, unless the queue
/// there has backed up to the lane's start; returns whether it did.
fn place_where_free(w: &mut World, route: &[&str]) -> bool {
    let start = w.network().lane_id(route[0]).unwrap();
    let free = w
        .vehicles()
        .iter()
        .all(|v| (v.path[0] != start && v.shadow != Some(start)) || v.rear_s() > 15.0);
    if free {
        w.place_vehicle_on_route("Taxi", route, 5.0, 10.0).unwrap();
    }
    free
}

/// Is any part of the body within the junction's 20 m square?
fn inside(v: &trafficmesh_sim::Vehicle) -> bool {
    v.footprint(0.0)
        .iter()
        .any(|c| c.x.abs() < 10.0 && c.y.abs() < 10.0)
}

/// Runs until every vehicle has left, failing on any overlap; returns, per
/// vehicle id, the times its body was first and last inside the junction.
fn run_out(w: &mut World, seconds: f64) -> Vec<(u64, f64, f64)> {
    let mut seen: Vec<(u64, f64, f64)> = Vec::new();
    let done = run_until(w, seconds, |w| {
        let overlaps = overlapping_pairs(w.network(), w.vehicles(), 0.05);
        assert!(
            overlaps.is_empty(),
            "overlap at t={:.2}: {overlaps:?}",
            w.time()
        );
        for v in w.vehicles().iter().filter(|v| inside(v)) {
            match seen.iter_mut().find(|(id, _, _)| *id == v.id) {
                Some(s) => s.2 = w.time(),
                None => seen.push((v.id, w.time(), w.time())),
            }
        }
        w.vehicles().is_empty()
    });
    assert!(done, "everyone gets through within {seconds} s");
    seen
}

#[test]
fn two_arriving_together_on_crossing_ways_go_one_after_the_other() {
    let mut w = world(&crossing("reservation"), WorldConfig::default());
    let west = w
        .place_vehicle_on_route("Taxi", &ROUTES[0], 60.0, 10.0)
        .unwrap();
    let south = w
        .place_vehicle_on_route("Taxi", &ROUTES[2], 60.0, 10.0)
        .unwrap();
    let seen = run_out(&mut w, 60.0);
    let span = |id| *seen.iter().find(|s| s.0 == id).expect("it crossed");
    let (a, b) = (span(west), span(south));
    let (first, second) = if a.1 < b.1 { (a, b) } else { (b, a) };
    // The first went straight through; the second waited at its line (both
    // at the same distance and speed, they would have met in the middle).
    assert!(first.1 < 6.0, "the first entered at {:.1} s", first.1);
    assert!(second.1 > first.1 + 1.0, "{first:?} {second:?}");
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

/// A vehicle on every approach every `every` seconds for two minutes, then
/// until all have left; fails on any overlap. Returns how many crossed and
/// the world.
fn stream(controller: &str, every: f64) -> (usize, World) {
    stream_with(controller, every, WorldConfig::default())
}

fn stream_with(controller: &str, every: f64, config: WorldConfig) -> (usize, World) {
    let mut w = world(&crossing(controller), config);
    let mut placed = 0;
    let mut next = 0.0;
    while w.time() < 400.0 {
        if w.time() >= next && w.time() < 120.0 {
            // One per approach; from the west straight on and right in turn.
            let west = if placed % 2 == 0 { 0 } else { 1 };
            for route in [west, 2, 3, 4].map(|k| &ROUTES[k]) {
                if place_where_free(&mut w, route) {
                    placed += 1;
                }
            }
            next += every;
        }
        w.step();
        let overlaps = overlapping_pairs(w.network(), w.vehicles(), 0.05);
        assert!(
            overlaps.is_empty(),
            "{controller}: overlap at t={:.2}: {overlaps:?}",
            w.time()
        );
        if w.time() > 120.0 && w.vehicles().is_empty() {
            break;
        }
    }
    assert!(
        w.vehicles().is_empty(),
        "{controller}: {} still on the map",
        w.vehicles().len()
    );
    (placed, w)
}

#[test]
fn a_stream_from_every_side_gets_through_without_an_overlap() {
    // 600 vehicles an hour on each approach: no queue backs up to its start.
    let (placed, w) = stream("reservation", 6.0);
    assert_eq!(placed, 80, "queues backed up");
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

#[test]
fn realistic_drivers_keep_to_their_grants_too() {
    let config = WorldConfig {
        dt: 0.1,
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: trafficmesh_model::DriverModel::Realistic(Default::default()),
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    let (placed, w) = stream_with("reservation", 6.0, config);
    assert_eq!(placed, 80, "queues backed up");
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

#[test]
fn the_same_junction_runs_on_its_lights_when_they_are_chosen() {
    let (placed, w) = stream("lights", 6.0);
    assert!(placed >= 40, "only {placed} placed");
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

#[test]
fn priority_and_reservation_junctions_ignore_their_lanes_lights() {
    // The north-south light is red for the first 23 s.
    let entered = |controller: &str| {
        let mut w = world(&crossing(controller), WorldConfig::default());
        let id = w
            .place_vehicle_on_route("Taxi", &ROUTES[2], 60.0, 10.0)
            .unwrap();
        let mut at = None;
        run_until(&mut w, 60.0, |w| {
            if w.vehicle(id).is_some_and(inside) {
                at.get_or_insert(w.time());
            }
            at.is_some()
        });
        at.expect("it entered")
    };
    assert!(entered("lights") >= 23.0, "lights: entered on red");
    for controller in ["priority", "reservation"] {
        let at = entered(controller);
        assert!(at < 10.0, "{controller}: held until {at:.1} s");
    }
}

#[test]
fn a_controller_for_a_lane_that_is_not_in_an_intersection_is_refused() {
    let mut m = serde_json::to_value(crossing("reservation")).unwrap();
    m["intersections"] = json!([{ "lane": "w_in", "controller": "reservation" }]);
    let map: trafficmesh_model::MapFile = serde_json::from_value(m).unwrap();
    let problems = trafficmesh_sim::LaneNetwork::build(&map).unwrap_err();
    assert!(
        problems
            .iter()
            .any(|p| p.field == "lane" && p.message.contains("not an intersection lane")),
        "{problems:?}"
    );
}

/// The crossing with a kind of its own, 5 m long, of SUMO's class
/// `emergency` or not.
fn crossing_with_an_ambulance(emergency: bool) -> trafficmesh_model::MapFile {
    let mut m = serde_json::to_value(crossing("reservation")).unwrap();
    let mut kind = json!({ "name": "Ambulance", "front": 4.0, "length": 5.0, "width": 2.0 });
    if emergency {
        kind["class"] = json!("emergency");
    }
    m["vehicle_kinds"] = json!([kind]);
    serde_json::from_value(m).unwrap()
}

/// Seconds from the ambulance's placing, at the back of a queue of three
/// standing on the south approach, to its entering the intersection, with
/// streams crossing from the west and the east (a vehicle each every 2 s,
/// from 20 s before).
fn ambulance_enters(emergency: bool) -> f64 {
    let mut w = world(
        &crossing_with_an_ambulance(emergency),
        WorldConfig::default(),
    );
    let mut next = 0.0;
    let mut ambulance = None;
    while w.time() < 140.0 {
        if w.time() >= next {
            for route in [&ROUTES[0], &ROUTES[3]] {
                place_where_free(&mut w, route);
            }
            next += 2.0;
        }
        if ambulance.is_none() && w.time() >= 20.0 {
            for s in [95.0, 88.0, 81.0] {
                w.place_vehicle_on_route("Taxi", &ROUTES[2], s, 0.0)
                    .unwrap();
            }
            let id = w
                .place_vehicle_on_route("Ambulance", &ROUTES[2], 73.0, 0.0)
                .unwrap();
            ambulance = Some((id, w.time()));
        }
        w.step();
        let overlaps = overlapping_pairs(w.network(), w.vehicles(), 0.05);
        assert!(
            overlaps.is_empty(),
            "overlap at t={:.2}: {overlaps:?}",
            w.time()
        );
        if let Some((id, placed)) = ambulance
            && w.vehicle(id).is_some_and(inside)
        {
            return w.time() - placed;
        }
    }
    panic!("the ambulance never entered (emergency: {emergency})");
}

#[test]
fn an_emergency_vehicle_has_its_lane_served_ahead_of_a_crossing_stream() {
    let (plain, emergency) = (ambulance_enters(false), ambulance_enters(true));
    assert!(
        emergency + 5.0 < plain,
        "the ambulance entered at {emergency:.1} s as an emergency vehicle, at {plain:.1} s as another"
    );
}
