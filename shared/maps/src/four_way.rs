//! A generated four-way intersection with several lanes per approach, run
//! by lights, right of way or reservations: the layout of
//! `trafficmesh bench intersection` (autonomous intersection management
//! against fixed-time lights).

use serde_json::{Value, json};
use trafficmesh_model::{IntersectionController, MapFile};

/// The layout.
#[derive(Clone, Debug)]
pub struct FourWayOptions {
    /// Lanes per approach: the rightmost turns right or goes straight on, the
    /// leftmost turns left or goes straight on, those between go straight on.
    pub lanes: usize,
    pub lane_width: f64,
    /// Length of each approach up to its stop line, and of each exit, metres.
    pub approach: f64,
    pub exit: f64,
    /// Speed limits: straight on (and on the roads), right and left turns, m/s.
    pub speed_limit: f64,
    pub right_turn_speed: f64,
    pub left_turn_speed: f64,
    /// Fixed-time lights, two phases (east-west, then north-south, each
    /// with its left turns yielding): green seconds per phase, then 3 s of
    /// yellow.
    pub green: f64,
    pub controller: IntersectionController,
}

impl Default for FourWayOptions {
    fn default() -> Self {
        FourWayOptions {
            lanes: 3,
            lane_width: 3.5,
            approach: 300.0,
            exit: 200.0,
            speed_limit: 25.0,
            right_turn_speed: 8.0,
            left_turn_speed: 11.0,
            green: 30.0,
            controller: IntersectionController::Lights,
        }
    }
}

/// Yellow seconds of each phase.
const YELLOW: f64 = 3.0;
/// Points along each turn's curve.
const TURN_POINTS: usize = 16;

/// A movement through the intersection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Movement {
    Straight,
    Right,
    Left,
}

/// Lane names: approach `d` (0 from the west, 1 from the south, 2 from the
/// east, 3 from the north), lane `k` (0 the rightmost).
pub fn approach_lane(d: usize, k: usize) -> String {
    format!("in_{d}_{k}")
}

/// The intersection lane of a movement from approach `d`, lane `k`.
pub fn movement_lane(d: usize, k: usize, m: Movement) -> String {
    let tag = match m {
        Movement::Straight => "s",
        Movement::Right => "r",
        Movement::Left => "l",
    };
    format!("j_{d}_{k}_{tag}")
}

/// The exit lane `k` of the road leaving towards heading `e` (as approach
/// `e` heads: 0 east, 1 north, 2 west, 3 south).
pub fn exit_lane(e: usize, k: usize) -> String {
    format!("out_{e}_{k}")
}

/// The movements lane `k` of `lanes` offers.
pub fn movements_of(k: usize, lanes: usize) -> Vec<Movement> {
    let mut m = vec![Movement::Straight];
    if k == 0 {
        m.push(Movement::Right);
    }
    if k + 1 == lanes {
        m.push(Movement::Left);
    }
    m
}

/// The route of a vehicle from approach `d`, lane `k`, taking movement `m`.
pub fn route(d: usize, k: usize, m: Movement) -> [String; 3] {
    let exit = match m {
        Movement::Straight => exit_lane(d, k),
        Movement::Right => exit_lane((d + 3) % 4, k),
        Movement::Left => exit_lane((d + 1) % 4, k),
    };
    [approach_lane(d, k), movement_lane(d, k, m), exit]
}

/// The map.
pub fn four_way_map(o: &FourWayOptions) -> MapFile {
    let n = o.lanes;
    let half = n as f64 * o.lane_width + 2.0;
    // In an approach's own frame (driving along +x, the intersection's
    // centre at the origin), lane k runs this far right of the centreline.
    let offset = |k: usize| -(o.lane_width * (n - k) as f64 - 0.5 * o.lane_width);
    let turn = |d: usize| std::f64::consts::FRAC_PI_2 * d as f64;
    let place = |d: usize, x: f64, y: f64| {
        let (s, c) = turn(d).sin_cos();
        [x * c - y * s, x * s + y * c]
    };
    let line = |d: usize, pts: &[(f64, f64)]| -> Vec<[f64; 2]> {
        pts.iter().map(|&(x, y)| place(d, x, y)).collect()
    };
    let curve = |d: usize, a: (f64, f64), corner: (f64, f64), b: (f64, f64)| -> Vec<[f64; 2]> {
        (0..=TURN_POINTS)
            .map(|i| {
                let t = i as f64 / TURN_POINTS as f64;
                let u = 1.0 - t;
                let x = u * u * a.0 + 2.0 * u * t * corner.0 + t * t * b.0;
                let y = u * u * a.1 + 2.0 * u * t * corner.1 + t * t * b.1;
                place(d, x, y)
            })
            .collect()
    };
    let group = |d: usize| if d.is_multiple_of(2) { "EW" } else { "NS" };
    let mut lanes: Vec<Value> = Vec::new();
    for d in 0..4 {
        for k in 0..n {
            let y = offset(k);
            let moves = movements_of(k, n);
            lanes.push(json!({
                "name": approach_lane(d, k),
                "waypoints": line(d, &[(-half - o.approach, y), (-half, y)]),
                "width": o.lane_width,
                "speed_limit": o.speed_limit,
                "next": moves.iter().map(|&m| movement_lane(d, k, m)).collect::<Vec<_>>(),
            }));
            for m in moves {
                let (points, limit, direction) = match m {
                    Movement::Straight => {
                        (line(d, &[(-half, y), (half, y)]), o.speed_limit, "straight")
                    }
                    Movement::Right => (
                        curve(d, (-half, y), (y, y), (y, -half)),
                        o.right_turn_speed,
                        "right",
                    ),
                    Movement::Left => (
                        curve(d, (-half, y), (-y, y), (-y, half)),
                        o.left_turn_speed,
                        "left",
                    ),
                };
                let stop = line(
                    d,
                    &[
                        (-half, y - 0.5 * o.lane_width),
                        (-half, y + 0.5 * o.lane_width),
                    ],
                );
                lanes.push(json!({
                    "name": movement_lane(d, k, m),
                    "waypoints": points,
                    "width": o.lane_width,
                    "speed_limit": limit,
                    "intersection": true,
                    "turn_direction": direction,
                    "stop_line": stop,
                    "traffic_light": group(d),
                    "next": [route(d, k, m)[2].clone()],
                }));
            }
            lanes.push(json!({
                "name": exit_lane(d, k),
                "waypoints": line(d, &[(half, y), (half + o.exit, y)]),
                "width": o.lane_width,
                "speed_limit": o.speed_limit,
                "next": [],
            }));
        }
    }
    let red = o.green + YELLOW;
    let map = json!({
        "format": trafficmesh_model::map::MAP_FORMAT,
        "name": format!("four-way intersection, {n} lanes per approach"),
        "lanes": lanes,
        "light_groups": [
            { "name": "EW", "program": { "green": o.green, "yellow": YELLOW, "red": red } },
            { "name": "NS", "program": { "green": o.green, "yellow": YELLOW, "red": red, "offset": red } },
        ],
        "traffic_simulators": [{ "kind": "random", "lanes": [approach_lane(0, 0)], "prefabs": ["Hatchback"], "enabled": false }],
        "intersections": [{ "lane": movement_lane(0, 0, Movement::Straight), "controller": o.controller }],
    });
    serde_json::from_value(map).expect("the generated four-way map is well-formed")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_movement_ends_on_its_exit_lane_and_the_map_loads() {
        let o = FourWayOptions::default();
        let map = four_way_map(&o);
        map.validate().expect("valid");
        let lane = |name: &str| map.lanes.iter().find(|l| l.name == name).unwrap();
        for d in 0..4 {
            for k in 0..o.lanes {
                for m in movements_of(k, o.lanes) {
                    let [_, through, exit] = route(d, k, m);
                    let (end, start) = (
                        *lane(&through).waypoints.last().unwrap(),
                        lane(&exit).waypoints[0],
                    );
                    assert!(end.ground_distance(start) < 1e-9, "{through} -> {exit}");
                }
            }
        }
        // 4 approaches x (3 straight + 1 right + 1 left) movements.
        assert_eq!(map.lanes.iter().filter(|l| l.intersection).count(), 20);
    }
}
