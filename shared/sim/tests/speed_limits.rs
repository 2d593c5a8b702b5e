//! SpeedLimitSource: NORMAL mode drives at the lane's limit or at the fixed
//! speed; with the lanes' limits, a car is down to a slower lane's limit by
//! the time it enters it.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::{DriverModel, NpcVehicleConfig, SpeedLimitSource};
use trafficmesh_sim::WorldConfig;

fn cruise_speed(source: SpeedLimitSource) -> f64 {
    let mut slow = lane("slow", &[[0.0, 0.0], [2000.0, 0.0]], &["end"]);
    slow["speed_limit"] = json!(8.0);
    let mut end = lane("end", &[[2000.0, 0.0], [2020.0, 0.0]], &[]);
    end["intersection"] = json!(true);
    let motion = NpcVehicleConfig {
        speed_limit_source: source,
        ..NpcVehicleConfig::default()
    };
    let mut w = world(
        &map(vec![slow, end], json!({})),
        WorldConfig {
            vehicle: motion,
            ..WorldConfig::default()
        },
    );
    let id = w.place_vehicle("Taxi", "slow", 10.0, 0.0).unwrap();
    run_for(&mut w, 20.0);
    vehicle(&w, id).speed
}

#[test]
fn lanelet_source_uses_the_lane_limit_and_fixed_source_the_fixed_speed() {
    assert!((cruise_speed(SpeedLimitSource::LaneletSpeedLimit) - 8.0).abs() < 1e-9);
    assert!((cruise_speed(SpeedLimitSource::FixedSpeedLimit) - 13.89).abs() < 1e-9);
}

/// The speed a car crosses into a 5 m/s junction lane at, coming at 13.89 m/s
/// along a 200 m road, with each lane's limit in force.
fn entry_speed(model: DriverModel) -> f64 {
    let road = lane("road", &[[0.0, 0.0], [200.0, 0.0]], &["turn"]);
    let mut turn = lane("turn", &[[200.0, 0.0], [210.0, 0.0]], &["exit"]);
    turn["speed_limit"] = json!(5.0);
    turn["intersection"] = json!(true);
    let exit = lane("exit", &[[210.0, 0.0], [600.0, 0.0]], &[]);
    let motion = NpcVehicleConfig {
        speed_limit_source: SpeedLimitSource::LaneletSpeedLimit,
        driver_model: model,
        ..NpcVehicleConfig::default()
    };
    let mut w = world(
        &map(vec![road, turn, exit], json!({})),
        WorldConfig {
            vehicle: motion,
            ..WorldConfig::default()
        },
    );
    let id = w.place_vehicle("Taxi", "road", 20.0, 13.89).unwrap();
    let mut fastest_on_turn: f64 = 0.0;
    run_until(&mut w, 60.0, |w| {
        let v = vehicle(w, id);
        let on = w.network().lane(v.path[0]).name.clone();
        if on == "turn" {
            fastest_on_turn = fastest_on_turn.max(v.speed);
        }
        on == "exit"
    });
    fastest_on_turn
}

#[test]
fn a_car_slows_for_a_slower_lane_before_it_not_on_it() {
    for model in [
        DriverModel::Awsim,
        DriverModel::Realistic(Default::default()),
    ] {
        let speed = entry_speed(model);
        assert!(
            speed <= 5.0 + 1e-9,
            "{model:?}: {speed:.3} m/s on the 5 m/s lane"
        );
        assert!(speed > 4.0, "{model:?}: crawled through at {speed:.3} m/s");
    }
}
