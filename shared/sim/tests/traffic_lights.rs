//! Traffic lights, Vienna convention: red stops at the line, green goes,
//! yellow commits inside the sudden-stop distance and stops outside it.

mod support;

use support::*;
use trafficmesh_model::LightColor;
use trafficmesh_sim::WorldConfig;
use trafficmesh_sim::decision::StopDistances;
use trafficmesh_sim::lights::LightControl;

const STOP_LINE_X: f64 = 190.0;

#[test]
fn stops_before_red_stop_line_and_goes_on_green() {
    let mut w = world(&signalised_road(), WorldConfig::default());
    w.set_light("L", LightControl::Forced(LightColor::Red))
        .unwrap();
    let id = w.place_vehicle("Taxi", "approach", 60.0, 13.89).unwrap();
    run_for(&mut w, 40.0);
    let v = vehicle(&w, id);
    assert!(v.speed < 0.05, "still moving at {} m/s", v.speed);
    assert!(
        v.front.x < STOP_LINE_X,
        "front at x={} is past the stop line",
        v.front.x
    );
    assert!(
        v.front.x > STOP_LINE_X - 6.0,
        "stopped {} m short of the line",
        STOP_LINE_X - v.front.x
    );

    w.set_light("L", LightControl::Forced(LightColor::Green))
        .unwrap();
    assert!(
        run_until(&mut w, 30.0, |w| vehicle(w, id).front.x > 260.0),
        "did not go on green"
    );
}

fn yellow_scenario(distance_to_line: f64) -> (bool, f64) {
    let mut w = world(&signalised_road(), WorldConfig::default());
    let id = w
        .place_vehicle("Taxi", "approach", STOP_LINE_X - distance_to_line, 13.89)
        .unwrap();
    w.set_light("L", LightControl::Forced(LightColor::Yellow))
        .unwrap();
    let passed = run_until(&mut w, 30.0, |w| vehicle(w, id).front.x > STOP_LINE_X + 5.0);
    (passed, vehicle(&w, id).front.x)
}

#[test]
fn yellow_commits_inside_sudden_stop_distance() {
    let sudden = StopDistances::at(13.89, &Default::default()).sudden;
    let (passed, _) = yellow_scenario(sudden - 5.0);
    assert!(
        passed,
        "a vehicle {:.1} m from the line at 50 km/h must commit",
        sudden - 5.0
    );
}

#[test]
fn yellow_stops_outside_sudden_stop_distance() {
    let stop = StopDistances::at(13.89, &Default::default()).stop;
    let (passed, x) = yellow_scenario(stop + 10.0);
    assert!(!passed, "drove through a yellow it could stop for");
    assert!(x < STOP_LINE_X, "stopped past the line at x={x}");
}

#[test]
fn remote_lights_are_red_until_vouched_for_and_red_again_when_the_vouch_expires() {
    let mut w = world(&signalised_road(), WorldConfig::default());
    w.use_remote_lights();
    assert!(w.lights_stale());
    let id = w.place_vehicle("Taxi", "approach", 60.0, 13.89).unwrap();
    run_for(&mut w, 30.0);
    assert!(
        vehicle(&w, id).front.x < STOP_LINE_X,
        "crossed an unvouched light"
    );
    assert!(vehicle(&w, id).speed < 0.05);

    let until = w.time() + 5.0;
    w.set_remote_light("L", LightColor::Green, until, None)
        .unwrap();
    assert!(!w.lights_stale());
    assert!(
        run_until(&mut w, 4.0, |w| vehicle(w, id).speed > 1.0),
        "did not go on a vouched green"
    );
    let left = until - w.time();
    run_for(&mut w, left + 0.1);
    assert!(w.lights_stale(), "the green outlived its validity");
}

#[test]
fn a_heartbeat_does_not_vouch_for_a_colour_past_its_announced_end() {
    // A green announced to end at t0+3 whose change never came (lost in a
    // partition): heartbeats keep the other groups' colours, not this one.
    let mut w = world(&signalised_road(), WorldConfig::default());
    w.use_remote_lights();
    let t0 = w.time();
    w.set_remote_light("L", LightColor::Green, t0 + 5.0, Some(t0 + 3.0))
        .unwrap();
    run_for(&mut w, 2.0);
    w.extend_remote_lights(w.time() + 1.5);
    assert!(!w.lights_stale(), "a colour before its end is vouched for");
    // At t0+4 the vouch (to t0+3.5) has run out, past the colour's end: a
    // heartbeat now leaves it stale, red.
    run_for(&mut w, 2.0);
    assert!(w.lights_stale());
    w.extend_remote_lights(w.time() + 5.0);
    assert!(
        w.lights_stale(),
        "a heartbeat revived a colour past its end"
    );
    let g = w.network().light_group("L").unwrap();
    assert_eq!(w.lights().state(g).color, LightColor::Red);
    // The group's state coming again brings it back.
    w.set_remote_light("L", LightColor::Red, w.time() + 5.0, Some(w.time() + 20.0))
        .unwrap();
    assert!(!w.lights_stale());
}
