//! Red means stop, on every stop line: a front bumper never goes 0.5 m past a
//! stop line whose group has been red for more than 0.5 s. Judged here from
//! the vehicles' positions and the light states tick by tick, beside the
//! world's own count.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::{DriverModel, LightColor, LightProgram, MapFile};
use trafficmesh_sim::lights::LightControl;
use trafficmesh_sim::{World, WorldConfig};

const STOP_LINE_X: f64 = 190.0;
const PAST_LINE: f64 = 0.5;
const GRACE: f64 = 0.5;

/// Crossings of `line_x + PAST_LINE` by the front bumpers of vehicles driving
/// east along y = 0, while `group` had been red for more than the grace.
struct Judge {
    group: usize,
    line_x: f64,
    fronts: std::collections::HashMap<u64, f64>,
    red_since: Option<f64>,
    crossings: Vec<String>,
    passed: usize,
}

impl Judge {
    fn new(w: &World, group: &str, line_x: f64) -> Judge {
        Judge {
            group: w.network().light_group(group).expect("the group exists"),
            line_x,
            fronts: Default::default(),
            red_since: None,
            crossings: Vec::new(),
            passed: 0,
        }
    }

    /// Steps the world and looks at the light in force during the tick and
    /// where the fronts went.
    fn step(&mut self, w: &mut World) {
        let before = w.time();
        w.step();
        // The states the tick ran with: refreshed at its start.
        let color = w.lights().state(self.group).color;
        self.red_since = match (color, self.red_since) {
            (LightColor::Red, Some(since)) => Some(since),
            (LightColor::Red, None) => Some(before),
            _ => None,
        };
        let mark = self.line_x + PAST_LINE;
        for v in w.vehicles() {
            let was = self.fronts.insert(v.id, v.front.x);
            if was.is_some_and(|x| x < mark) && v.front.x >= mark {
                self.passed += 1;
                if let Some(since) = self.red_since.filter(|s| before - s > GRACE) {
                    self.crossings.push(format!(
                        "vehicle {} at t={before:.2}, {:.2} s into red, {:.2} m/s",
                        v.id,
                        before - since,
                        v.speed
                    ));
                }
            }
        }
    }

    fn run(&mut self, w: &mut World, seconds: f64) {
        let end = w.time() + seconds;
        while w.time() < end {
            self.step(w);
        }
    }

    fn assert_none_on_red(&self, w: &World) {
        assert!(
            self.crossings.is_empty(),
            "crossed on red: {:#?}",
            self.crossings
        );
        assert_eq!(w.red_light_crossings(), 0, "the world counted crossings");
    }
}

#[test]
fn a_queue_creeping_toward_a_light_that_turns_red_stops_for_it() {
    // Short greens of several lengths: each one ends while the queue is
    // still pulling away, its cars at every distance and speed.
    let models = [
        DriverModel::Awsim,
        DriverModel::Realistic(Default::default()),
    ];
    for (model, green) in models
        .into_iter()
        .flat_map(|m| [4.0, 4.5, 5.0, 5.5, 6.0, 6.5, 7.0, 7.5, 8.0].map(|g| (m, g)))
    {
        let mut config = WorldConfig::default();
        config.vehicle.driver_model = model;
        let mut w = world(&signalised_road(), config);
        let program = LightProgram {
            green,
            yellow: 3.0,
            red: 20.0,
            offset: 20.0,
        };
        w.set_light("L", LightControl::Program(program)).unwrap();
        for k in 0..15 {
            w.place_vehicle("Taxi", "approach", 185.0 - 9.0 * k as f64, 0.0)
                .unwrap();
        }
        let mut judge = Judge::new(&w, "L", STOP_LINE_X);
        judge.run(&mut w, 200.0);
        judge.assert_none_on_red(&w);
        assert!(
            judge.passed >= 10,
            "{model:?}, green {green} s: only {} of the queue got through in seven greens",
            judge.passed
        );
    }
}

/// An approach with its stop line at its end (group "A") and, right after,
/// a junction lane with a stop line of its own `gap` metres on (group "B").
fn two_stop_lines(gap: f64) -> MapFile {
    let mut approach = lane("approach", &[[0.0, 0.0], [200.0, 0.0]], &["junction"]);
    approach["stop_line"] = json!([[200.0, -1.75], [200.0, 1.75]]);
    approach["traffic_light"] = json!("A");
    let mut junction = lane("junction", &[[200.0, 0.0], [230.0, 0.0]], &["exit"]);
    junction["intersection"] = json!(true);
    junction["stop_line"] = json!([[200.0 + gap, -1.75], [200.0 + gap, 1.75]]);
    junction["traffic_light"] = json!("B");
    map(
        vec![
            approach,
            junction,
            lane("exit", &[[230.0, 0.0], [600.0, 0.0]], &[]),
        ],
        json!({ "light_groups": [
            { "name": "A", "program": { "green": 30, "yellow": 3, "red": 30 } },
            { "name": "B", "program": { "green": 30, "yellow": 3, "red": 30 } },
        ] }),
    )
}

#[test]
fn a_red_stop_line_at_or_just_after_a_green_one_is_obeyed() {
    for gap in [0.0, 3.0] {
        let mut w = world(&two_stop_lines(gap), WorldConfig::default());
        w.set_light("A", LightControl::Forced(LightColor::Green))
            .unwrap();
        w.set_light("B", LightControl::Forced(LightColor::Red))
            .unwrap();
        let id = w.place_vehicle("Taxi", "approach", 100.0, 13.89).unwrap();
        let mut judge = Judge::new(&w, "B", 200.0 + gap);
        judge.run(&mut w, 30.0);
        let v = vehicle(&w, id);
        assert!(
            v.speed < 0.05 && v.front.x < 200.0 + gap + PAST_LINE,
            "gap {gap}: the front at x={:.2}, {:.2} m/s, past B's red line at x={}",
            v.front.x,
            v.speed,
            200.0 + gap
        );
        judge.assert_none_on_red(&w);
        w.set_light("B", LightControl::Forced(LightColor::Green))
            .unwrap();
        assert!(
            run_until(&mut w, 30.0, |w| vehicle(w, id).front.x > 260.0),
            "gap {gap}: did not go when B turned green"
        );
    }
}

/// A car `distance` metres before the line at `speed` when a 3 s yellow
/// begins: where its front is when red begins, and the judge's verdict.
fn at_yellow(distance: f64, speed: f64) -> (f64, Judge, World) {
    let mut w = world(&signalised_road(), WorldConfig::default());
    let id = w
        .place_vehicle("Taxi", "approach", STOP_LINE_X - distance, speed)
        .unwrap();
    let yellow_at = w.time();
    let program = LightProgram {
        green: 30.0,
        yellow: 3.0,
        red: 30.0,
        offset: yellow_at - 30.0,
    };
    w.set_light("L", LightControl::Program(program)).unwrap();
    let mut judge = Judge::new(&w, "L", STOP_LINE_X);
    judge.run(&mut w, 3.0);
    let front_at_red = vehicle(&w, id).front.x;
    judge.run(&mut w, 20.0);
    (front_at_red, judge, w)
}

#[test]
fn when_yellow_begins_a_car_either_clears_the_line_within_the_yellow_or_stops() {
    // (distance to the line, speed, whether it must be through by red, or
    // stop, or either)
    let bands = [
        (0.3, 0.0, None),           // standing on the line
        (2.0, 0.0, None),           // standing first in the queue
        (2.0, 1.0, None),           // creeping up to it
        (4.0, 13.89, Some(true)),   // inside the absolute-stop distance
        (20.0, 13.89, Some(true)),  // inside the sudden-stop distance
        (6.0, 5.0, Some(true)),     // slow and close: inside it too
        (30.0, 13.89, None),        // just outside it: brakes, may go later
        (40.0, 13.89, Some(false)), // inside the stop distance: brakes
        (80.0, 13.89, Some(false)), // further: brakes gently
    ];
    // And every metre from 20 to 60 m at 50 km/h: one braking for the
    // yellow does not change its mind late and cross after red begins.
    let sweep = (20..60).map(|d| (d as f64, 13.89, None));
    for (distance, speed, through) in bands.into_iter().chain(sweep) {
        let (front_at_red, judge, w) = at_yellow(distance, speed);
        judge.assert_none_on_red(&w);
        if judge.passed > 0 {
            assert!(
                front_at_red > STOP_LINE_X,
                "{distance} m at {speed} m/s: went on, but reached the line after red began"
            );
        }
        match through {
            Some(true) => assert!(
                front_at_red > STOP_LINE_X,
                "{distance} m at {speed} m/s: front at x={front_at_red:.2} when red began"
            ),
            Some(false) => assert!(
                front_at_red < STOP_LINE_X + PAST_LINE,
                "{distance} m at {speed} m/s: crossed at x={front_at_red:.2}, it could stop"
            ),
            None => {}
        }
    }
}
