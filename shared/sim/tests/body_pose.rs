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

/// North up x = 0 to the origin, a junction lane turning right by `degrees`
/// on a `radius` m arc, then a straight lane on in the new heading.
fn sharp_turn(degrees: f64, radius: f64) -> trafficmesh_model::MapFile {
    let turn_points: Vec<[f64; 2]> = (0..=12)
        .map(|k| {
            let a = degrees.to_radians() * f64::from(k) / 12.0;
            [radius - radius * a.cos(), radius * a.sin()]
        })
        .collect();
    let end = turn_points[12];
    let heading = std::f64::consts::FRAC_PI_2 - degrees.to_radians();
    let far = [
        end[0] + 100.0 * heading.cos(),
        end[1] + 100.0 * heading.sin(),
    ];
    let mut turn = lane("turn", &turn_points, &["out"]);
    turn["intersection"] = json!(true);
    map(
        vec![
            lane("in", &[[0.0, -100.0], [0.0, 0.0]], &["turn"]),
            turn,
            lane("out", &[end, far], &[]),
        ],
        json!({}),
    )
}

fn realistic() -> WorldConfig {
    WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            driver_model: trafficmesh_model::DriverModel::by_name("realistic").unwrap(),
            ..Default::default()
        },
        ..WorldConfig::default()
    }
}

#[test]
fn a_truck_across_a_sharp_turn_is_drawn_centred_and_its_follower_keeps_clear() {
    // The truck stops behind the ego, its body across a 150-degree turn,
    // drawn straight and centred on the chord between its bumpers; a car
    // comes up behind it and stops where the truck is drawn, not only where
    // its rear bumper is on the way.
    let m = sharp_turn(150.0, 2.5);
    let mut w = world(&m, realistic());
    let out = w
        .network()
        .lane(w.network().lane_id("out").unwrap())
        .clone();
    let (at, _) = out.line.point_at(6.5);
    let yaw = {
        let d = out.line.point_at(7.0).0 - at;
        d.y.atan2(d.x)
    };
    w.set_ego(Some(trafficmesh_sim::Ego::car(at.x, at.y, yaw)));
    let truck = w.place_vehicle("Truck_2t", "in", 70.0, 8.0).unwrap();
    let car = w.place_vehicle("Taxi", "in", 45.0, 8.0).unwrap();
    let mut worst = Vec::new();
    run_until(&mut w, 60.0, |w| {
        worst.extend(
            overlapping_pairs(w.network(), w.vehicles(), 0.1)
                .into_iter()
                .map(|p| (w.time(), p)),
        );
        false
    });
    let (t, c) = (vehicle(&w, truck), vehicle(&w, car));
    assert!(t.speed < 0.01 && c.speed < 0.01, "both stopped");
    assert!(
        (t.front - t.back).length() < t.length - 1.0,
        "the truck stands across the turn"
    );
    let midway = 0.5 * (t.front + t.back);
    assert!(
        t.drawn_centre().distance(midway) < 0.05,
        "drawn centre {:?}, the chord's middle {midway:?}",
        t.drawn_centre()
    );
    assert!(
        worst.is_empty(),
        "overlapping bodies: {:?}",
        &worst[..worst.len().min(3)]
    );
}
