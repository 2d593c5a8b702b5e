//! The pose drawn moves as a car does on geometry imported maps have: lanes
//! that do not join, kinks between two points, junction lanes of no length,
//! and across lane changes. Every tick is checked by `sim --check`'s checks.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_sim::motion_check::MotionCheck;
use trafficmesh_sim::{World, WorldConfig};

/// Drives vehicle `id` until its front is `past` metres onto `last`, checking
/// every tick; fails on a jump, a turn a car cannot make or an overlap.
fn drive_checked(w: &mut World, id: u64, last: &str, past: f64) {
    let mut check = MotionCheck::default();
    check.observe(w);
    let arrived = run_until(w, 120.0, |w| {
        check.observe(w);
        let v = vehicle(w, id);
        w.network().lane(v.path[0]).name == last && v.s > past
    });
    assert!(arrived, "the vehicle reached {last}");
    assert_smooth(&check);
    assert!(
        check.vehicle_steps > 100,
        "checked {} steps",
        check.vehicle_steps
    );
}

/// No jump, no turn a car cannot make, no overlap.
fn assert_smooth(check: &MotionCheck) {
    for (what, tally) in [
        ("jumps", &check.jumps),
        ("turns", &check.turns),
        ("overlaps", &check.overlaps),
    ] {
        assert_eq!(tally.count, 0, "{what}: {:?}", tally.first);
    }
}

/// Where the pose's origin lies off the centreline of the lane it is on.
fn off_centreline(w: &World, id: u64) -> f64 {
    let v = vehicle(w, id);
    let line = &w.network().lane(v.path[0]).line;
    let origin = glam::DVec2::new(v.pose.x, v.pose.y);
    let on_chord = v.front - v.heading * v.front_offset;
    line.distance_to(on_chord).max(origin.distance(on_chord))
}

#[test]
fn a_lane_that_starts_a_metre_from_the_end_of_the_one_before_is_driven_without_a_jump() {
    let mut j = lane("j", &[[100.0, 0.0], [120.0, 0.0]], &["b"]);
    j["intersection"] = json!(true);
    let m = map(
        vec![
            lane("a", &[[0.0, 0.0], [100.0, 0.0]], &["j"]),
            j,
            lane("b", &[[120.0, 1.0], [300.0, 1.0]], &[]),
        ],
        json!({}),
    );
    let mut w = world(&m, WorldConfig::default());
    let id = w
        .place_vehicle_on_route("Taxi", &["a", "j", "b"], 60.0, 10.0)
        .unwrap();
    drive_checked(&mut w, id, "b", 60.0);
    assert!(
        off_centreline(&w, id) < 0.01,
        "back on b's centreline {:.3} m on",
        off_centreline(&w, id)
    );
}

/// East along `a`, then `j` turns north at a right angle between two
/// points, onto `b`: a taxi at 8 m/s, 40 m before the junction lane.
fn taxi_before_a_right_angle() -> (World, u64) {
    let mut j = lane("j", &[[100.0, 0.0], [120.0, 0.0], [120.0, 20.0]], &["b"]);
    j["intersection"] = json!(true);
    let m = map(
        vec![
            lane("a", &[[0.0, 0.0], [100.0, 0.0]], &["j"]),
            j,
            lane("b", &[[120.0, 20.0], [120.0, 300.0]], &[]),
        ],
        json!({}),
    );
    let mut w = world(&m, WorldConfig::default());
    let id = w
        .place_vehicle_on_route("Taxi", &["a", "j", "b"], 60.0, 8.0)
        .unwrap();
    (w, id)
}

#[test]
fn a_right_angle_between_two_points_is_driven_round() {
    let (mut w, id) = taxi_before_a_right_angle();
    drive_checked(&mut w, id, "b", 40.0);
    let v = vehicle(&w, id);
    assert!(
        (v.pose.yaw - std::f64::consts::FRAC_PI_2).abs() < 0.01,
        "heading north after the corner: {:.3}",
        v.pose.yaw
    );
}

/// A right angle is sharper than a car can turn: the heading lags the path
/// for a few metres, and the body turns about its centre on the path, so that
/// front and rear share the swing off it (turned about its rear axle, the
/// front swung 1.8 m wide, into the lane beside; about its centre, 1.2 m).
#[test]
fn a_body_lagging_a_sharp_corner_swings_neither_end_far_off_the_path() {
    let (mut w, id) = taxi_before_a_right_angle();
    let net = w.network();
    let lines: Vec<_> = ["a", "j", "b"]
        .iter()
        .map(|n| net.lane(net.lane_id(n).unwrap()).line.clone())
        .collect();
    let mut widest: f64 = 0.0;
    let arrived = run_until(&mut w, 60.0, |w| {
        let v = vehicle(w, id);
        let along = glam::DVec2::from_angle(v.pose.yaw) * (v.length * 0.5);
        for end in [v.drawn_centre() + along, v.drawn_centre() - along] {
            let off = lines
                .iter()
                .map(|l| l.distance_to(end))
                .fold(f64::MAX, f64::min);
            widest = widest.max(off);
        }
        w.network().lane(v.path[0]).name == "b" && v.s > 40.0
    });
    assert!(arrived, "the vehicle reached b");
    assert!(
        widest < 1.3,
        "a bumper's centre swung {widest:.2} m off the path"
    );
}

/// SUMO's junction lanes of no length come in stretched to 0.15 m (see the
/// SUMO importer): the lane after starts where the empty lane was, 0.15 m
/// back, here with a left turn.
#[test]
fn a_junction_lane_of_no_length_is_crossed_smoothly() {
    let mut j = lane("j", &[[100.0, 0.0], [100.15, 0.0]], &["b"]);
    j["intersection"] = json!(true);
    let m = map(
        vec![
            lane("a", &[[0.0, 0.0], [100.0, 0.0]], &["j"]),
            j,
            lane("b", &[[100.0, 0.0], [100.0, 200.0]], &[]),
        ],
        json!({}),
    );
    let mut w = world(&m, WorldConfig::default());
    let id = w
        .place_vehicle_on_route("Taxi", &["a", "j", "b"], 60.0, 5.0)
        .unwrap();
    drive_checked(&mut w, id, "b", 40.0);
}

#[test]
fn a_lane_change_eases_across_and_the_one_behind_on_the_lane_left_keeps_clear() {
    let mut w = world(&two_lane_road(), WorldConfig::default());
    let changer = w
        .place_vehicle_on_route("Taxi", &["a0", "j1", "x1"], 60.0, 10.0)
        .unwrap();
    // Close behind on the lane it leaves, faster.
    let behind = w.place_vehicle("Taxi", "a0", 50.0, 12.0).unwrap();
    let mut check = MotionCheck::default();
    let (mut changed_at, mut across_at) = (None, None);
    run_until(&mut w, 30.0, |w| {
        check.observe(w);
        let v = vehicle(w, changer);
        let on_a1 = w.network().lane(v.path[0]).name == "a1";
        if on_a1 && changed_at.is_none() {
            changed_at = Some(v.s);
            assert!(v.pose.y < 0.5, "drawn where it was, at y = {:.2}", v.pose.y);
        }
        if on_a1 && across_at.is_none() && (v.pose.y - 3.2).abs() < 1e-6 {
            across_at = Some(v.s);
        }
        w.vehicle(behind).is_none() || w.network().lane(vehicle(w, changer).path[0]).name == "x1"
    });
    let (from, to) = (
        changed_at.expect("it changed lanes"),
        across_at.expect("it got across"),
    );
    assert!(
        (5.0..60.0).contains(&(to - from)),
        "across in {:.1} m of road",
        to - from
    );
    assert_smooth(&check);
}
