//! A vehicle's way through the intersection as time goes on: from where it
//! is when it asks (its front some metres before the path's start, at its
//! speed), driven forward Euler at a fixed step with its acceleration up to
//! the lane's limit, its body at each step a rectangle on the path a
//! little larger than the vehicle, until its rear has left the path.

use glam::DVec2;

use crate::geometry::{Obb, Polyline};

pub use trafficmesh_model::reservation::Approach;

/// Margins of the reserved rectangles and the integration step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Margins {
    /// Added to the body on each side, metres.
    pub space: f64,
    /// Added to the body at each end, metres: two bodies on their plans
    /// keep twice this between them, room for a driver's standstill gap.
    pub along: f64,
    /// A rectangle also holds the slots this many seconds before and after
    /// its own, seconds.
    pub time: f64,
    /// Forward Euler step, seconds.
    pub step: f64,
}

impl Default for Margins {
    fn default() -> Self {
        Margins {
            space: 0.5,
            along: 1.5,
            time: 0.5,
            step: 0.1,
        }
    }
}

/// The longest way through that is planned, seconds: a vehicle slower than
/// that asks again when it is nearer or faster.
pub const HORIZON: f64 = 60.0;

/// One step of the plan: the body, and the front's place and speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Seconds after the request.
    pub t: f64,
    /// Metres of the path the front has driven (negative: before it).
    pub s: f64,
    pub speed: f64,
    pub body: Obb,
}

/// A way through as planned: the speed at every step from the request, and
/// the steps on which the body is on the path.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// Speed at `k` steps after the request, m/s.
    pub speeds: Vec<f64>,
    /// From the first step on which the body reaches the path to the last
    /// before its rear leaves it.
    pub steps: Vec<Step>,
}

/// The plan of a vehicle approaching as `a` says; `None` when it would not
/// get through within [`HORIZON`].
pub fn plan(path: &Polyline, a: &Approach, m: &Margins) -> Option<Plan> {
    let mut plan = Plan::default();
    let (mut s, mut speed, mut t) = (-a.to_entry, a.speed, 0.0);
    let exit = path.length() + a.length;
    while t <= HORIZON {
        plan.speeds.push(speed);
        if s > 0.0 {
            plan.steps.push(Step {
                t,
                s,
                speed,
                body: body_at(path, s, a, m),
            });
        }
        // Forward Euler: the place moves at this step's speed.
        s += speed * m.step;
        speed = (speed + a.accel * m.step).min(a.max_speed);
        t += m.step;
        if s >= exit {
            return Some(plan);
        }
    }
    None
}

/// The body with its front `s` along the path, on the chord to its back
/// (beyond the ends, along the end segments), larger by the margins.
pub fn body_at(path: &Polyline, s: f64, a: &Approach, m: &Margins) -> Obb {
    let front: DVec2 = path.point_at(s).0;
    let back: DVec2 = path.point_at(s - a.length).0;
    let mut body = Obb::on_chord(back, front, (a.length, a.width), 0.0);
    body.half_length += m.along;
    body.half_width += m.space;
    body
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(length: f64) -> Polyline {
        Polyline::new(vec![DVec2::ZERO, DVec2::new(length, 0.0)], vec![0.0, 0.0])
    }

    fn car(to_entry: f64, speed: f64) -> Approach {
        Approach {
            to_entry,
            speed,
            accel: 2.0,
            max_speed: 10.0,
            length: 4.0,
            width: 2.0,
        }
    }

    #[test]
    fn a_car_at_the_limit_crosses_at_it_and_its_body_is_larger_by_the_margins() {
        let steps = plan(&straight(20.0), &car(5.0, 10.0), &Margins::default())
            .unwrap()
            .steps;
        // In from 0.5 s (5 m to go at 10 m/s), out once the rear passes
        // 20 m: 5 + 20 + 4 = 29 m, at 2.9 s.
        let (first, last) = (steps[0], steps[steps.len() - 1]);
        assert!((first.t - 0.6).abs() < 1e-9, "first step at {}", first.t);
        assert!(last.t < 2.9 && last.t > 2.7, "last step at {}", last.t);
        assert!(steps.iter().all(|s| s.speed == 10.0));
        assert!(
            (first.body.half_length - 3.5).abs() < 1e-9,
            "2 + 1.5 at each end"
        );
        assert!(
            (first.body.half_width - 1.5).abs() < 1e-9,
            "1 + 0.5 on each side"
        );
    }

    #[test]
    fn a_car_standing_at_the_line_speeds_up_through() {
        let steps = plan(&straight(20.0), &car(0.0, 0.0), &Margins::default())
            .unwrap()
            .steps;
        assert!(steps.windows(2).all(|w| w[1].speed >= w[0].speed));
        assert!(steps.last().unwrap().speed > 5.0);
        // 24 m from standing at 2 m/s²: about 4.9 s.
        let t = steps.last().unwrap().t;
        assert!((t - 4.9).abs() < 0.2, "{t}");
    }

    #[test]
    fn the_speeds_start_at_the_request() {
        let p = plan(&straight(20.0), &car(30.0, 4.0), &Margins::default()).unwrap();
        assert_eq!(p.speeds[0], 4.0);
        assert!((p.speeds[10] - 6.0).abs() < 1e-9, "2 m/s² for 1 s");
        assert!(p.speeds.len() > p.steps.len());
    }

    #[test]
    fn a_car_that_would_take_longer_than_the_horizon_gets_no_plan() {
        let mut crawling = car(0.0, 0.0);
        crawling.accel = 0.0;
        assert!(plan(&straight(20.0), &crawling, &Margins::default()).is_none());
    }
}
