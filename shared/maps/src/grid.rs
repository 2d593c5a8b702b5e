//! Generator of N x N signalised grids: two lanes per direction, right-hand
//! traffic, a junction every `block` metres, boundary roads that bring traffic
//! in and take it out of the grid.
//!
//! At each junction the inner (left) lane turns left or goes straight and the
//! outer (right) lane goes straight or turns right; left turns yield to the
//! oncoming straight and right-turning lanes. North-south and east-west
//! approaches have their own light group: 25 s green, 3 s yellow, 32 s red,
//! offset by half a cycle, which leaves 2 s all-red between phases.

use std::f64::consts::FRAC_PI_2;

use trafficmesh_model::TurnDirection;
use trafficmesh_model::map::{
    CrosswalkArea, CrosswalkDef, LaneDef, LightGroupDef, LightProgram, MAP_FORMAT, MapFile, Point,
    RoadConflicts, SimulatorDef, StopPointDef, ZebraConfigDef,
};

pub const LANE_WIDTH: f64 = 3.5;
/// Distance from a junction centre to where approach lanes end.
const JUNCTION_RADIUS: f64 = 12.0;
/// With crosswalks, stop lines sit this far from the centre, before the crossing.
const STOP_LINE_WITH_CROSSWALK: f64 = 19.0;
const CROSSWALK_CENTER: f64 = 15.0;
const TURN_SAMPLES: usize = 12;

#[derive(Clone, Debug)]
pub struct GridOptions {
    /// Junctions per side.
    pub size: usize,
    /// Distance between neighbouring junction centres, metres.
    pub block: f64,
    /// Length of the roads entering and leaving the grid, metres.
    pub boundary: f64,
    /// A zebra crossing on every approach.
    pub crosswalks: bool,
    pub speed_limit: f64,
}

impl Default for GridOptions {
    fn default() -> Self {
        GridOptions {
            size: 5,
            block: 200.0,
            boundary: 100.0,
            crosswalks: false,
            speed_limit: 13.89,
        }
    }
}

#[derive(Clone, Copy)]
struct Dir(usize);

const DIRS: [Dir; 4] = [Dir(0), Dir(1), Dir(2), Dir(3)];

impl Dir {
    fn letter(self) -> char {
        ['E', 'N', 'W', 'S'][self.0]
    }
    fn unit(self) -> (f64, f64) {
        let a = self.0 as f64 * FRAC_PI_2;
        (a.cos().round(), a.sin().round())
    }
    fn left(self) -> Dir {
        Dir((self.0 + 1) % 4)
    }
    fn right(self) -> Dir {
        Dir((self.0 + 3) % 4)
    }
    fn opposite(self) -> Dir {
        Dir((self.0 + 2) % 4)
    }
    /// The right-hand normal: where lanes of this direction lie.
    fn right_normal(self) -> (f64, f64) {
        let (x, y) = self.unit();
        (y, -x)
    }
    fn is_north_south(self) -> bool {
        self.0 % 2 == 1
    }
}

fn p(x: f64, y: f64) -> Point {
    Point::new(x, y)
}

fn offset(k: usize) -> f64 {
    (k as f64 + 0.5) * LANE_WIDTH
}

fn jname(i: usize, j: usize) -> String {
    format!("J{i}_{j}")
}

/// Approach lane heading `d` into junction (i, j), lane k.
fn approach(i: usize, j: usize, d: Dir, k: usize) -> String {
    format!("{}_in_{}{k}", jname(i, j), d.letter())
}

/// Boundary road leaving the grid from junction (i, j) heading `d`.
fn exit_road(i: usize, j: usize, d: Dir, k: usize) -> String {
    format!("{}_out_{}{k}", jname(i, j), d.letter())
}

fn connector(i: usize, j: usize, d: Dir, k: usize, turn: char) -> String {
    format!("{}_{}{k}_{turn}", jname(i, j), d.letter())
}

/// Cubic Bézier from a (heading da) to b (heading db).
fn curve(a: (f64, f64), da: (f64, f64), b: (f64, f64), db: (f64, f64)) -> Vec<Point> {
    let chord = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    let h = chord * 0.39;
    let c1 = (a.0 + da.0 * h, a.1 + da.1 * h);
    let c2 = (b.0 - db.0 * h, b.1 - db.1 * h);
    (0..=TURN_SAMPLES)
        .map(|n| {
            let t = n as f64 / TURN_SAMPLES as f64;
            let u = 1.0 - t;
            let w = [u * u * u, 3.0 * u * u * t, 3.0 * u * t * t, t * t * t];
            p(
                w[0] * a.0 + w[1] * c1.0 + w[2] * c2.0 + w[3] * b.0,
                w[0] * a.1 + w[1] * c1.1 + w[2] * c2.1 + w[3] * b.1,
            )
        })
        .collect()
}

fn lane(name: String, waypoints: Vec<Point>, speed_limit: f64) -> LaneDef {
    LaneDef {
        name,
        waypoints,
        width: LANE_WIDTH,
        speed_limit,
        next: Vec::new(),
        prev: Vec::new(),
        intersection: false,
        turn_direction: TurnDirection::Straight,
        stop_line: None,
        traffic_light: None,
        right_of_way: Vec::new(),
        vehicle_classes: Vec::new(),
        crosses_apart: Vec::new(),
    }
}

/// Builds the grid map. Junction (i, j) is centred at (i * block, j * block).
pub fn grid_map(o: &GridOptions) -> MapFile {
    let n = o.size;
    let center = |i: usize, j: usize| (i as f64 * o.block, j as f64 * o.block);
    let inside = |i: isize, j: isize| i >= 0 && j >= 0 && (i as usize) < n && (j as usize) < n;
    let neighbour = |i: usize, j: usize, d: Dir| {
        let (dx, dy) = d.unit();
        (i as isize + dx as isize, j as isize + dy as isize)
    };
    let stop_at = if o.crosswalks {
        STOP_LINE_WITH_CROSSWALK
    } else {
        JUNCTION_RADIUS + 1.0
    };
    let mut lanes: Vec<LaneDef> = Vec::new();
    let mut light_groups = Vec::new();
    let mut crosswalks = Vec::new();

    for i in 0..n {
        for j in 0..n {
            let c = center(i, j);
            let jn = jname(i, j);
            for (g, ns) in [("NS", true), ("EW", false)] {
                let offset_s = if ns { 0.0 } else { 30.0 };
                light_groups.push(LightGroupDef {
                    name: format!("{jn}_{g}"),
                    program: LightProgram {
                        green: 25.0,
                        yellow: 3.0,
                        red: 32.0,
                        offset: offset_s,
                    },
                });
            }
            for d in DIRS {
                let (ux, uy) = d.unit();
                let (rx, ry) = d.right_normal();
                // Approach lanes heading d into this junction, from the neighbour behind
                // or from the grid's edge.
                let (bi, bj) = neighbour(i, j, d.opposite());
                let from_far = if inside(bi, bj) {
                    o.block - JUNCTION_RADIUS
                } else {
                    JUNCTION_RADIUS + o.boundary
                };
                for k in 0..2 {
                    let off = offset(k);
                    let start = (
                        c.0 - ux * from_far + rx * off,
                        c.1 - uy * from_far + ry * off,
                    );
                    let end = (
                        c.0 - ux * JUNCTION_RADIUS + rx * off,
                        c.1 - uy * JUNCTION_RADIUS + ry * off,
                    );
                    let mut l = lane(
                        approach(i, j, d, k),
                        vec![p(start.0, start.1), p(end.0, end.1)],
                        o.speed_limit,
                    );
                    let sl = (c.0 - ux * stop_at, c.1 - uy * stop_at);
                    let half = LANE_WIDTH * 0.5;
                    l.stop_line = Some([
                        p(sl.0 + rx * (off - half), sl.1 + ry * (off - half)),
                        p(sl.0 + rx * (off + half), sl.1 + ry * (off + half)),
                    ]);
                    l.traffic_light = Some(format!(
                        "{jn}_{}",
                        if d.is_north_south() { "NS" } else { "EW" }
                    ));
                    let moves: &[(char, Dir, TurnDirection)] = if k == 0 {
                        &[
                            ('L', d.left(), TurnDirection::Left),
                            ('S', d, TurnDirection::Straight),
                        ]
                    } else {
                        &[
                            ('S', d, TurnDirection::Straight),
                            ('R', d.right(), TurnDirection::Right),
                        ]
                    };
                    for &(t, out, turn) in moves {
                        l.next.push(connector(i, j, d, k, t));
                        let (ox, oy) = out.unit();
                        let (orx, ory) = out.right_normal();
                        let exit_start = (
                            c.0 + ox * JUNCTION_RADIUS + orx * off,
                            c.1 + oy * JUNCTION_RADIUS + ory * off,
                        );
                        let waypoints = if t == 'S' {
                            vec![p(end.0, end.1), p(exit_start.0, exit_start.1)]
                        } else {
                            curve(end, (ux, uy), exit_start, (ox, oy))
                        };
                        let mut conn = lane(connector(i, j, d, k, t), waypoints, o.speed_limit);
                        conn.intersection = true;
                        conn.turn_direction = turn;
                        let (ni, nj) = neighbour(i, j, out);
                        conn.next.push(if inside(ni, nj) {
                            approach(ni as usize, nj as usize, out, k)
                        } else {
                            exit_road(i, j, out, k)
                        });
                        if t == 'L' {
                            let opp = d.opposite();
                            conn.right_of_way = vec![
                                connector(i, j, opp, 0, 'S'),
                                connector(i, j, opp, 1, 'S'),
                                connector(i, j, opp, 1, 'R'),
                            ];
                        }
                        lanes.push(conn);
                    }
                    lanes.push(l);
                }
                // Boundary road leaving the grid heading d.
                let (ni, nj) = neighbour(i, j, d);
                if !inside(ni, nj) {
                    for k in 0..2 {
                        let off = offset(k);
                        let start = (
                            c.0 + ux * JUNCTION_RADIUS + rx * off,
                            c.1 + uy * JUNCTION_RADIUS + ry * off,
                        );
                        let end = (start.0 + ux * o.boundary, start.1 + uy * o.boundary);
                        lanes.push(lane(
                            exit_road(i, j, d, k),
                            vec![p(start.0, start.1), p(end.0, end.1)],
                            o.speed_limit,
                        ));
                    }
                }
                if o.crosswalks {
                    crosswalks.push(crosswalk(c, d, &jn));
                }
            }
        }
    }
    lanes.sort_by(|a, b| a.name.cmp(&b.name));
    let spawn_lanes: Vec<String> = lanes
        .iter()
        .filter(|l| !l.intersection)
        .map(|l| l.name.clone())
        .collect();
    let attempts = (spawn_lanes.len() / 40).max(1) as u32;
    MapFile {
        road_conflicts: RoadConflicts::None,
        vehicle_kinds: Vec::new(),
        intersections: Vec::new(),
        format: MAP_FORMAT.to_string(),
        name: format!("grid {n}x{n}, {} m blocks", o.block),
        lanes,
        light_groups,
        zebra_configs: if o.crosswalks {
            vec![ZebraConfigDef {
                name: "pedestrians".into(),
                allowed_prefabs: vec![],
                allowed_root_name_substrings: vec![
                    "Human".into(),
                    "Pedestrian".into(),
                    "Cyclist".into(),
                    "Bicycle".into(),
                ],
            }]
        } else {
            vec![]
        },
        crosswalks,
        traffic_simulators: vec![SimulatorDef::Random {
            lanes: spawn_lanes,
            prefabs: ["Taxi", "Hatchback", "SmallCar", "Van", "Truck_2t"]
                .map(String::from)
                .to_vec(),
            maximum_spawns: 0,
            enabled: true,
            spawn_attempts_per_tick: attempts,
        }],
    }
}

/// A crossing over the road on the approach side `d` of the junction at `c`, with
/// a stop point for each direction of traffic.
fn crosswalk(c: (f64, f64), d: Dir, jn: &str) -> CrosswalkDef {
    let (ux, uy) = d.unit();
    let (rx, ry) = d.right_normal();
    let center = (c.0 - ux * CROSSWALK_CENTER, c.1 - uy * CROSSWALK_CENTER);
    let inbound = (
        c.0 - ux * STOP_LINE_WITH_CROSSWALK + rx * LANE_WIDTH,
        c.1 - uy * STOP_LINE_WITH_CROSSWALK + ry * LANE_WIDTH,
    );
    let outbound = (
        c.0 - ux * (JUNCTION_RADIUS - 1.0) - rx * LANE_WIDTH,
        c.1 - uy * (JUNCTION_RADIUS - 1.0) - ry * LANE_WIDTH,
    );
    let heading = d.0 as f64 * 90.0;
    CrosswalkDef {
        name: format!("{jn}_crosswalk_{}", d.opposite().letter()),
        area: CrosswalkArea::Box {
            center: p(center.0, center.1),
            half_extents: [2.0, 2.0 * LANE_WIDTH + 1.0],
            yaw_deg: heading,
        },
        stop_points: vec![
            StopPointDef {
                position: p(inbound.0, inbound.1),
                heading_deg: Some(heading),
            },
            StopPointDef {
                position: p(outbound.0, outbound.1),
                heading_deg: Some(heading + 180.0),
            },
        ],
        max_detection_distance: 40.0,
        forward_angle_tolerance_deg: 80.0,
        stop_buffer: 1.5,
        enable_debug_logs: true,
        config: Some("pedestrians".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_valid_and_sized() {
        for size in [1, 2, 3] {
            let map = grid_map(&GridOptions {
                size,
                crosswalks: true,
                ..GridOptions::default()
            });
            map.validate().unwrap();
            // Per junction: 8 approach lanes and 16 connectors; 2 exit lanes per boundary side.
            assert_eq!(map.lanes.len(), size * size * 24 + 4 * size * 2);
            assert_eq!(map.light_groups.len(), size * size * 2);
        }
    }
}
