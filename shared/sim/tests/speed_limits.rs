//! SpeedLimitSource: NORMAL mode drives at the lane's limit or at the fixed speed.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::{NpcVehicleConfig, SpeedLimitSource};
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
