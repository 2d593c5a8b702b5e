//! Car following: a vehicle closes on a stopped one and halts behind it, never overlapping.

mod support;

use support::*;
use trafficmesh_model::LightColor;
use trafficmesh_sim::WorldConfig;
use trafficmesh_sim::lights::LightControl;

#[test]
fn follows_stopped_vehicle_without_overlap() {
    let mut w = world(&signalised_road(), WorldConfig::default());
    w.set_light("L", LightControl::Forced(LightColor::Red))
        .unwrap();
    let leader = w.place_vehicle("Truck_2t", "approach", 185.0, 0.0).unwrap();
    let follower = w.place_vehicle("Taxi", "approach", 20.0, 13.89).unwrap();
    for _ in 0..(40.0 / 0.02) as usize {
        w.step();
        let (l, f) = (vehicle(&w, leader), vehicle(&w, follower));
        let gap = l.back.x - f.front.x;
        assert!(
            gap > 0.5,
            "follower's front within {gap:.2} m of the leader's rear at t={:.2}",
            w.time()
        );
        assert!(overlapping_pairs(w.network(), w.vehicles(), 0.0).is_empty());
    }
    let (l, f) = (vehicle(&w, leader), vehicle(&w, follower));
    assert!(f.speed < 0.05, "follower still moving at {}", f.speed);
    let gap = l.back.x - f.front.x;
    // Queued vehicles rest 7-8.5 m from the leader's rear (reference, section 4.4).
    assert!((5.5..=9.0).contains(&gap), "resting gap {gap:.2} m");
}
