//! Zebra crossings: an occupied area stops approaching vehicles at its stop point
//! minus the buffer; clearing releases them; the cone, the detection distance and
//! the whitelist decide who is affected.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::{MapFile, SpeedMode};
use trafficmesh_sim::crosswalk::{OccupancyChange, OccupantType};
use trafficmesh_sim::{SimEvent, WorldConfig};

const STOP_X: f64 = 145.0;
const BUFFER: f64 = 1.5;

/// An eastbound road along y = 0 with a crossing at x = 150 (stop point at 145, no
/// heading so that only the AWSIM reference's cone test applies), and a northbound road at x = 135.
fn road_with_crossing() -> MapFile {
    let mut east = lane("east", &[[0.0, 0.0], [400.0, 0.0]], &["junction"]);
    east["speed_limit"] = json!(13.89);
    let mut junction = lane("junction", &[[400.0, 0.0], [420.0, 0.0]], &[]);
    junction["intersection"] = json!(true);
    map(
        vec![
            east,
            junction,
            lane("north", &[[135.0, -200.0], [135.0, 200.0]], &[]),
        ],
        json!({
            "zebra_configs": [{ "name": "walkers", "allowedRootNameSubstrings": ["Human", "Cyclist"] }],
            "crosswalks": [{
                "name": "CrosswalkNorth",
                "area": { "shape": "box", "center": [150.0, 0.0], "half_extents": [2.0, 6.0] },
                "stop_points": [{ "position": [STOP_X, 0.0] }],
                "enable_debug_logs": true,
                "config": "walkers"
            }]
        }),
    )
}

#[test]
fn occupied_zebra_stops_vehicle_at_stop_point_minus_buffer_and_clearing_releases_it() {
    let mut w = world(&road_with_crossing(), WorldConfig::default());
    let id = w.place_vehicle("Van", "east", 40.0, 13.89).unwrap();
    assert_eq!(
        w.crosswalk_enter("CrosswalkNorth", "Human_01", OccupantType::NpcPedestrian)
            .unwrap(),
        OccupancyChange::Entered
    );
    run_for(&mut w, 30.0);
    let v = vehicle(&w, id);
    assert!(v.speed < 0.05, "did not stop: {} m/s", v.speed);
    assert!(v.zebra.is_blocked && v.zebra.area == Some(0));
    let limit = STOP_X - BUFFER;
    assert!(
        v.front.x <= limit,
        "front at {:.2}, beyond stop point minus buffer {limit}",
        v.front.x
    );
    assert!(
        v.front.x >= limit - 5.0,
        "stopped {:.2} m short",
        limit - v.front.x
    );
    let stops: Vec<_> = w
        .drain_events()
        .filter(|e| matches!(e, SimEvent::ZebraStop { id: i, .. } if *i == id))
        .collect();
    assert_eq!(
        stops.len(),
        1,
        "one stop event on the false -> true transition"
    );

    w.crosswalk_exit("CrosswalkNorth", "Human_01").unwrap();
    w.step();
    let cleared = w
        .drain_events()
        .any(|e| matches!(e, SimEvent::ZebraClear { id: i, area: 0 } if i == id));
    assert!(cleared, "no clear event after the pedestrian left");
    assert!(
        run_until(&mut w, 20.0, |w| vehicle(w, id).front.x > 160.0),
        "did not drive on"
    );
}

#[test]
fn vehicles_beyond_detection_distance_or_outside_the_cone_ignore_it() {
    let mut w = world(&road_with_crossing(), WorldConfig::default());
    // 60 m before the stop point: beyond the 40 m detection distance.
    let far = w.place_vehicle("Taxi", "east", 85.0, 13.89).unwrap();
    // Northbound at x = 135, 2 m past the crossing's line: the stop point is 101° off its heading.
    let side = w
        .place_vehicle("Taxi", "north", 202.0 + 4.6, 13.89)
        .unwrap();
    w.crosswalk_enter(
        "CrosswalkNorth",
        "Cyclist_3",
        OccupantType::SimpleCyclistMovement,
    )
    .unwrap();
    w.step();
    for id in [far, side] {
        let v = vehicle(&w, id);
        assert!(
            !v.zebra.is_blocked,
            "vehicle {id} at {:?} sees the crossing",
            v.front
        );
        assert_eq!(v.speed_mode, SpeedMode::Normal);
    }
    // Once the far one comes within 40 m it does stop.
    assert!(run_until(&mut w, 10.0, |w| vehicle(w, far)
        .zebra
        .is_blocked));
    assert!(vehicle(&w, far).front.x > STOP_X - 40.0 - 0.5);
}

#[test]
fn occupants_outside_the_whitelist_or_detected_types_do_not_block() {
    let mut w = world(&road_with_crossing(), WorldConfig::default());
    let id = w.place_vehicle("Taxi", "east", 120.0, 10.0).unwrap();
    let not_whitelisted = w
        .crosswalk_enter(
            "CrosswalkNorth",
            "Taxi(Clone)_7",
            OccupantType::WaypointFollower,
        )
        .unwrap();
    let not_detected = w
        .crosswalk_enter("CrosswalkNorth", "Human_02", OccupantType::Other)
        .unwrap();
    assert_eq!(
        (not_whitelisted, not_detected),
        (OccupancyChange::Ignored, OccupancyChange::Ignored)
    );
    assert!(!w.occupancy().is_occupied(0));
    assert!(
        run_until(&mut w, 10.0, |w| vehicle(w, id).front.x > 160.0),
        "a non-occupant blocked the vehicle"
    );
}

#[test]
fn one_occupant_with_several_colliders_counts_once() {
    let mut w = world(&road_with_crossing(), WorldConfig::default());
    w.crosswalk_enter("CrosswalkNorth", "Human_5", OccupantType::NpcPedestrian)
        .unwrap();
    let again = w
        .crosswalk_enter("CrosswalkNorth", "Human_5", OccupantType::NpcPedestrian)
        .unwrap();
    assert_eq!(again, OccupancyChange::Ignored);
    w.crosswalk_exit("CrosswalkNorth", "Human_5").unwrap();
    assert!(!w.occupancy().is_occupied(0));
}
