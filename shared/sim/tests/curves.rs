//! Curve detection: SLOW before a sharp curve.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::SpeedMode;
use trafficmesh_sim::WorldConfig;

#[test]
fn slows_before_a_sharp_curve() {
    // 300 m east, then a 90° left curve of radius 15 m, then north.
    let arc: Vec<[f64; 2]> = (0..=9)
        .map(|k| {
            let a = -std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::FRAC_PI_2 / 9.0;
            [300.0 + 15.0 * a.cos(), 15.0 + 15.0 * a.sin()]
        })
        .collect();
    let mut curve = lane("curve", &arc, &["north"]);
    curve["intersection"] = json!(true);
    let m = map(
        vec![
            lane("east", &[[0.0, 0.0], [300.0, 0.0]], &["curve"]),
            curve,
            lane("north", &[[315.0, 15.0], [315.0, 300.0]], &[]),
        ],
        json!({}),
    );
    let mut w = world(&m, WorldConfig::default());
    let id = w.place_vehicle("Taxi", "east", 100.0, 13.89).unwrap();
    w.step();
    assert_eq!(
        vehicle(&w, id).speed_mode,
        SpeedMode::Normal,
        "no curve within 40 m yet"
    );
    let mut slow_from_x = None;
    assert!(run_until(&mut w, 20.0, |w| {
        let v = vehicle(w, id);
        if slow_from_x.is_none() && v.speed_mode == SpeedMode::Slow {
            // Alone on the road with no light: nothing but the curve slows it.
            assert!(
                v.distance_to_front.is_infinite() && !v.stops_at_light,
                "SLOW with an obstacle or a light ahead"
            );
            slow_from_x = Some(v.front.x);
        }
        v.front.x > 300.0
    }));
    let x = slow_from_x.expect("never slowed for the curve");
    assert!(
        (255.0..300.0).contains(&x),
        "SLOW began at x={x:.1}, curve starts at 300"
    );
    let v = vehicle(&w, id);
    assert_eq!(v.speed_mode, SpeedMode::Slow);
    // SLOW brakes at 2 m/s² toward 5 m/s from where the turn enters the 40 m window.
    assert!(v.speed < 11.0, "entered the curve at {:.1} m/s", v.speed);
}
