//! The `realistic` driver model (IDM) keeps the reference's rules: it stops
//! before a red stop line, queues without touching the car ahead, goes on
//! green, and keeps to the speed limit.

mod support;

use support::*;
use trafficmesh_model::{DriverModel, LightColor, NpcVehicleConfig};
use trafficmesh_sim::lights::LightControl;
use trafficmesh_sim::{World, WorldConfig};

fn realistic_world() -> World {
    let config = WorldConfig {
        vehicle: NpcVehicleConfig {
            driver_model: DriverModel::by_name("realistic").unwrap(),
            ..NpcVehicleConfig::default()
        },
        ..WorldConfig::default()
    };
    world(&signalised_road(), config)
}

#[test]
fn a_realistic_queue_stops_before_the_red_line_without_overlap_and_leaves_on_green() {
    let mut w = realistic_world();
    w.set_light("L", LightControl::Forced(LightColor::Red))
        .unwrap();
    let ids: Vec<u64> = (0..6)
        .map(|k| {
            w.place_vehicle("Hatchback", "approach", 150.0 - 25.0 * k as f64, 13.0)
                .unwrap()
        })
        .collect();
    let mut fastest: f64 = 0.0;
    for _ in 0..(60.0 / 0.02) as usize {
        w.step();
        assert!(
            overlapping_pairs(w.network(), w.vehicles(), 0.05).is_empty(),
            "overlap at {:.2} s",
            w.time()
        );
        fastest = w.vehicles().iter().map(|v| v.speed).fold(fastest, f64::max);
    }
    assert!(fastest <= 13.89 + 1e-9, "over the limit: {fastest} m/s");
    let head = vehicle(&w, ids[0]);
    assert!(
        head.speed < 0.05,
        "the head did not stop: {} m/s",
        head.speed
    );
    assert!(
        head.front.x <= 190.0 && head.front.x > 187.0,
        "the head stopped at {:.2}, not just before the line at 190",
        head.front.x
    );
    w.set_light("L", LightControl::Forced(LightColor::Green))
        .unwrap();
    run_until(&mut w, 60.0, |w| {
        ids.iter()
            .all(|&id| w.vehicle(id).is_none_or(|v| v.front.x > 200.0))
    });
    for &id in &ids {
        assert!(
            w.vehicle(id).is_none_or(|v| v.front.x > 200.0),
            "vehicle {id} did not cross on green"
        );
    }
}
