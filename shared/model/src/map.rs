//! The native map file (`*.map.json`): lanes, light groups, crosswalk areas,
//! zebra-crossing whitelists and the traffic simulators of the scene.
//!
//! docs/maps.md documents this format field by field. [`MapFile::validate`] runs the AWSIM
//! reference's start-up checklist and reports every problem with the element's name.

use std::collections::{HashMap, HashSet};
use std::fmt;

use serde::{Deserialize, Deserializer, Serialize};

use crate::catalog::builtin_kind;
use crate::enums::TurnDirection;

/// A point in the map frame (x east, y north, z up), metres. Written as `[x, y]` or `[x, y, z]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Default)]
pub struct Point(pub [f64; 3]);

impl<'de> Deserialize<'de> for Point {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        match v.as_slice() {
            [x, y] => Ok(Point([*x, *y, 0.0])),
            [x, y, z] => Ok(Point([*x, *y, *z])),
            _ => Err(serde::de::Error::custom(format!(
                "a point is [x, y] or [x, y, z], got {} numbers",
                v.len()
            ))),
        }
    }
}

impl Point {
    pub fn new(x: f64, y: f64) -> Self {
        Point([x, y, 0.0])
    }
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|c| c.is_finite())
    }
    /// Distance to `other` in the ground plane (x, y), metres.
    pub fn ground_distance(&self, other: Point) -> f64 {
        (other.0[0] - self.0[0]).hypot(other.0[1] - self.0[1])
    }
}

fn default_width() -> f64 {
    3.5
}
fn default_speed_limit() -> f64 {
    13.89
}

/// One directed lane: a centreline polyline and its links.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaneDef {
    /// Unique (case-insensitively) name.
    pub name: String,
    /// Centreline, at least two points, in driving order.
    pub waypoints: Vec<Point>,
    #[serde(default = "default_width")]
    pub width: f64,
    /// m/s.
    #[serde(default = "default_speed_limit")]
    pub speed_limit: f64,
    #[serde(default)]
    pub next: Vec<String>,
    /// Optional: derived from every lane's `next`; when given it must agree.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub prev: Vec<String>,
    #[serde(default)]
    pub intersection: bool,
    #[serde(default)]
    pub turn_direction: TurnDirection,
    /// Two points across the lane where vehicles stop; usually near the lane's end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_line: Option<[Point; 2]>,
    /// Light group that controls this lane's stop line.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub traffic_light: Option<String>,
    /// Lanes this lane must yield to (the non-priority side's list).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub right_of_way: Vec<String>,
    /// The vehicle classes allowed on this lane (SUMO's vClass names, e.g.
    /// `bus`); empty: every class.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vehicle_classes: Vec<String>,
    /// Lanes this one crosses at another level, no junction between them (a
    /// bridge over the other, or a tunnel under it): vehicles on the two
    /// never meet. Either lane may list the other.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub crosses_apart: Vec<String>,
}

impl LaneDef {
    /// Length of the centreline in the ground plane, metres.
    pub fn length(&self) -> f64 {
        ground_length(&self.waypoints)
    }
}

/// Length of a polyline in the ground plane, metres.
pub fn ground_length(points: &[Point]) -> f64 {
    points.windows(2).map(|w| w[0].ground_distance(w[1])).sum()
}

/// A fixed-time program: green, then yellow, then red, repeating; `offset`
/// shifts the cycle start (seconds of simulation time at which green begins).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightProgram {
    pub green: f64,
    pub yellow: f64,
    pub red: f64,
    #[serde(default)]
    pub offset: f64,
}

impl LightProgram {
    pub fn cycle(&self) -> f64 {
        self.green + self.yellow + self.red
    }

    /// What is wrong with the program, as (field, problem) pairs; empty when
    /// it can run. Maps and the lights' overrides check programs by this.
    pub fn problems(&self) -> Vec<(&'static str, String)> {
        let mut problems = Vec::new();
        for (field, v) in [
            ("program.green", self.green),
            ("program.yellow", self.yellow),
            ("program.red", self.red),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                problems.push((
                    field,
                    format!("must be a non-negative number of seconds, got {v}"),
                ));
            }
        }
        if !self.offset.is_finite() {
            problems.push((
                "program.offset",
                "must be a finite number of seconds".into(),
            ));
        }
        if !positive(self.cycle()) {
            problems.push(("program", "green + yellow + red must be positive".into()));
        }
        problems
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightGroupDef {
    pub name: String,
    pub program: LightProgram,
}

/// How an intersection lets vehicles through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum IntersectionController {
    /// Its lanes' light groups.
    #[default]
    Lights,
    /// Right of way, its lanes' light groups ignored.
    Priority,
    /// Ways through granted one by one, none overlapping another in space
    /// and time (autonomous intersection management); its lanes' light
    /// groups and right of way ignored.
    Reservation,
}

/// The controller of one intersection: the junction that `lane`, one of
/// its intersection lanes, belongs to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntersectionDef {
    pub lane: String,
    pub controller: IntersectionController,
}

/// The area a crosswalk covers on the ground.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "lowercase", deny_unknown_fields)]
pub enum CrosswalkArea {
    /// Oriented box: centre, half extents along its own x and y, heading in degrees.
    Box {
        center: Point,
        half_extents: [f64; 2],
        #[serde(default)]
        yaw_deg: f64,
    },
    Polygon {
        points: Vec<Point>,
    },
}

/// Where vehicles stop for an occupied crosswalk. `heading_deg`, when given, is the
/// direction of the traffic this stop point is for: vehicles heading more than 90°
/// away from it ignore it (the AWSIM reference's cone test alone also catches vehicles leaving
/// the crossing on the other side of the road).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopPointDef {
    pub position: Point,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heading_deg: Option<f64>,
}

fn default_detection() -> f64 {
    40.0
}
fn default_angle() -> f64 {
    80.0
}
fn default_buffer() -> f64 {
    1.5
}

/// A ZebraCrossingArea. Reads document 002's inspector names too
/// (`maxDetectionDistance`, `forwardAngleTolerance`, `stopBuffer`,
/// `enableDebugLogs`, and one `stopPoint`); written with the names below.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "CrosswalkInput")]
pub struct CrosswalkDef {
    pub name: String,
    pub area: CrosswalkArea,
    /// Defaults to the area's centre when empty (the AWSIM reference: "defaults to the area's own position").
    pub stop_points: Vec<StopPointDef>,
    pub max_detection_distance: f64,
    /// Half-angle of the detection cone, degrees.
    pub forward_angle_tolerance_deg: f64,
    pub stop_buffer: f64,
    pub enable_debug_logs: bool,
    /// Name of the ZebraCrossingConfig (whitelist) this area belongs to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config: Option<String>,
}

/// A crosswalk as written: our names or the document's.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CrosswalkInput {
    name: String,
    area: CrosswalkArea,
    #[serde(default)]
    stop_points: Vec<StopPointDef>,
    /// Document 002's single stop point: a stop point, or just its position.
    #[serde(default, rename = "stopPoint")]
    stop_point: Option<StopPointInput>,
    #[serde(default = "default_detection", alias = "maxDetectionDistance")]
    max_detection_distance: f64,
    #[serde(default = "default_angle", alias = "forwardAngleTolerance")]
    forward_angle_tolerance_deg: f64,
    #[serde(default = "default_buffer", alias = "stopBuffer")]
    stop_buffer: f64,
    #[serde(default, alias = "enableDebugLogs")]
    enable_debug_logs: bool,
    #[serde(default)]
    config: Option<String>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum StopPointInput {
    Full(StopPointDef),
    Position(Point),
}

impl From<CrosswalkInput> for CrosswalkDef {
    fn from(c: CrosswalkInput) -> Self {
        let mut stop_points = c.stop_points;
        stop_points.extend(c.stop_point.map(|p| match p {
            StopPointInput::Full(def) => def,
            StopPointInput::Position(position) => StopPointDef {
                position,
                heading_deg: None,
            },
        }));
        CrosswalkDef {
            name: c.name,
            area: c.area,
            stop_points,
            max_detection_distance: c.max_detection_distance,
            forward_angle_tolerance_deg: c.forward_angle_tolerance_deg,
            stop_buffer: c.stop_buffer,
            enable_debug_logs: c.enable_debug_logs,
            config: c.config,
        }
    }
}

/// A ZebraCrossingConfig: the whitelist shared by its child areas.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct ZebraConfigDef {
    pub name: String,
    #[serde(default)]
    pub allowed_prefabs: Vec<String>,
    #[serde(default)]
    pub allowed_root_name_substrings: Vec<String>,
}

fn yes() -> bool {
    true
}
fn one() -> u32 {
    1
}

/// A traffic simulator of the scene (RandomTrafficSimulator or RouteTrafficSimulator).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum SimulatorDef {
    Random {
        lanes: Vec<String>,
        prefabs: Vec<String>,
        /// 0 = unlimited.
        #[serde(default)]
        maximum_spawns: u32,
        #[serde(default = "yes")]
        enabled: bool,
        /// Spawn points drawn per tick (AWSIM draws one). Large maps need more
        /// to fill up in reasonable time.
        #[serde(default = "one")]
        spawn_attempts_per_tick: u32,
    },
    Route {
        route: Vec<String>,
        prefabs: Vec<String>,
        #[serde(default)]
        maximum_spawns: u32,
        #[serde(default = "yes")]
        enabled: bool,
    },
    /// A timetable (a SUMO demand): each vehicle departs at its time on its
    /// route, or as soon after as its first lane has room.
    Demand { departures: Vec<DepartureDef> },
}

/// One scheduled vehicle of a demand.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepartureDef {
    /// Simulation seconds.
    pub time: f64,
    /// Lanes in driving order, the first one the spawn lane.
    pub route: Vec<String>,
    pub prefab: String,
    /// Lane routes as good as `route` from other lanes of its first road: a
    /// vehicle whose spawn lane has no room departs on one of these that has
    /// (SUMO's `departLane="best"`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub other_routes: Vec<Vec<String>>,
}

impl SimulatorDef {
    /// (field, lanes) and (field, prefabs) lists to check, one pair per list.
    fn checks(&self) -> Vec<(String, &[String], String, Vec<&String>)> {
        match self {
            SimulatorDef::Random { lanes, prefabs, .. } => {
                vec![(
                    "lanes".into(),
                    lanes,
                    "prefabs".into(),
                    prefabs.iter().collect(),
                )]
            }
            SimulatorDef::Route { route, prefabs, .. } => {
                vec![(
                    "route".into(),
                    route,
                    "prefabs".into(),
                    prefabs.iter().collect(),
                )]
            }
            SimulatorDef::Demand { departures } => departures
                .iter()
                .enumerate()
                .flat_map(|(k, d)| {
                    let others = d.other_routes.iter().enumerate().map(move |(j, r)| {
                        (
                            format!("departures[{k}].other_routes[{j}]"),
                            r.as_slice(),
                            format!("departures[{k}].prefab"),
                            vec![&d.prefab],
                        )
                    });
                    std::iter::once((
                        format!("departures[{k}].route"),
                        d.route.as_slice(),
                        format!("departures[{k}].prefab"),
                        vec![&d.prefab],
                    ))
                    .chain(others)
                })
                .collect(),
        }
    }
}

pub const MAP_FORMAT: &str = "trafficmesh-map/1";

fn default_format() -> String {
    MAP_FORMAT.to_string()
}

/// The whole map file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapFile {
    #[serde(default = "default_format")]
    pub format: String,
    #[serde(default)]
    pub name: String,
    pub lanes: Vec<LaneDef>,
    #[serde(default)]
    pub light_groups: Vec<LightGroupDef>,
    #[serde(default)]
    pub crosswalks: Vec<CrosswalkDef>,
    /// Intersections whose control is chosen here rather than by their
    /// lanes (light groups where they have them, else right of way).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub intersections: Vec<IntersectionDef>,
    #[serde(default)]
    pub zebra_configs: Vec<ZebraConfigDef>,
    #[serde(default)]
    pub traffic_simulators: Vec<SimulatorDef>,
    /// Vehicle kinds of the map's own beside the built-in catalogue (a SUMO
    /// scenario's vTypes), by name.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vehicle_kinds: Vec<crate::VehicleKind>,
    /// Which lanes outside the map's junctions get conflict zones ("road"
    /// conflicts, the vehicle nearer the zone going first). Read also under
    /// its earlier name `conflicts_outside_junctions` (`true`: `everywhere`).
    #[serde(
        default,
        alias = "conflicts_outside_junctions",
        skip_serializing_if = "RoadConflicts::is_none"
    )]
    pub road_conflicts: RoadConflicts,
}

/// Where lanes outside the junctions a map marks are kept apart by conflict
/// zones (see docs/maps.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RoadConflicts {
    /// Nowhere: the map models every place where lanes meet as a junction
    /// and lays its lanes at least two trucks' width apart (generated grids).
    #[default]
    None,
    /// Between road lanes running the other way (SUMO imports: every
    /// junction is modelled, but a two-way street's bend, or two streets
    /// drawn side by side, can leave less room than two trucks need to pass).
    Opposing,
    /// Between any lanes whose vehicles could touch (Lanelet2 imports, which
    /// do not mark every place where lanes cross, split or join).
    Everywhere,
}

impl RoadConflicts {
    pub fn is_none(&self) -> bool {
        *self == RoadConflicts::None
    }

    /// Road zones lie only between road lanes, past junctions the map
    /// models with lanes of their own (`Opposing`): one just past a
    /// junction is waited for before it.
    pub fn between_roads_only(self) -> bool {
        self == RoadConflicts::Opposing
    }
}

impl<'de> Deserialize<'de> for RoadConflicts {
    /// `"none"`, `"opposing"` or `"everywhere"`; `false` or `true` as the
    /// earlier `conflicts_outside_junctions` flag was written.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Written;
        impl serde::de::Visitor<'_> for Written {
            type Value = RoadConflicts;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"none\", \"opposing\" or \"everywhere\"")
            }
            fn visit_bool<E: serde::de::Error>(self, everywhere: bool) -> Result<RoadConflicts, E> {
                Ok(if everywhere {
                    RoadConflicts::Everywhere
                } else {
                    RoadConflicts::None
                })
            }
            fn visit_str<E: serde::de::Error>(self, name: &str) -> Result<RoadConflicts, E> {
                match name {
                    "none" => Ok(RoadConflicts::None),
                    "opposing" => Ok(RoadConflicts::Opposing),
                    "everywhere" => Ok(RoadConflicts::Everywhere),
                    _ => Err(E::invalid_value(serde::de::Unexpected::Str(name), &self)),
                }
            }
        }
        d.deserialize_any(Written)
    }
}

/// One thing wrong with a map: the element it is in, the field, and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MapProblem {
    /// e.g. `lane 'N_in_1'`, `light group 'J1'`, `map`.
    pub element: String,
    pub field: String,
    pub message: String,
}

impl fmt::Display for MapProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: field '{}': {}",
            self.element, self.field, self.message
        )
    }
}

struct Problems(Vec<MapProblem>);

impl Problems {
    fn add(&mut self, element: impl Into<String>, field: &str, message: impl Into<String>) {
        self.0.push(MapProblem {
            element: element.into(),
            field: field.to_string(),
            message: message.into(),
        });
    }
}

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// The longest lane a map may have, metres: longer is a point far out of
/// place (a coordinate cut short, another projection), not a road.
pub const MAX_LANE_LENGTH: f64 = 50_000.0;
/// The widest lane, metres (a Lanelet2 lanelet's width is its borders'
/// distance: a real map has one 52 m wide).
pub const MAX_LANE_WIDTH: f64 = 1_000.0;

impl MapFile {
    /// The start-up checklist: every problem, each naming its element and field.
    pub fn validate(&self) -> Result<(), Vec<MapProblem>> {
        let mut p = Problems(Vec::new());
        if self.format != MAP_FORMAT {
            p.add(
                "map",
                "format",
                format!("expected \"{MAP_FORMAT}\", got \"{}\"", self.format),
            );
        }
        if self.lanes.is_empty() {
            p.add(
                "map",
                "lanes",
                "the map has no lanes (the AWSIM reference's TrafficLanes is empty)",
            );
        }
        let names = self.validate_lane_names(&mut p);
        self.validate_lanes(&names, &mut p);
        self.validate_lights(&mut p);
        self.validate_crosswalks(&mut p);
        self.validate_simulators(&names, &mut p);
        self.validate_intersections(&names, &mut p);
        for kind in &self.vehicle_kinds {
            if let Some(problem) = kind.problem() {
                p.add(format!("vehicle kind '{}'", kind.name), "size", problem);
            }
        }
        if p.0.is_empty() { Ok(()) } else { Err(p.0) }
    }

    /// Lowercased lane name -> index; reports empty and duplicate names.
    fn validate_lane_names(&self, p: &mut Problems) -> HashMap<String, usize> {
        let mut names = HashMap::new();
        for (i, lane) in self.lanes.iter().enumerate() {
            if lane.name.trim().is_empty() {
                p.add(format!("lanes[{i}]"), "name", "lane name is empty");
            } else if names.insert(lane.name.to_lowercase(), i).is_some() {
                p.add(
                    format!("lane '{}'", lane.name),
                    "name",
                    "duplicate lane name (names are compared case-insensitively)",
                );
            }
        }
        if !self.lanes.is_empty() && !self.lanes.iter().any(|l| l.intersection) {
            p.add(
                "map",
                "lanes",
                "no lane has \"intersection\": true; at least one is required",
            );
        }
        names
    }

    fn validate_lanes(&self, names: &HashMap<String, usize>, p: &mut Problems) {
        let groups: HashSet<&str> = self.light_groups.iter().map(|g| g.name.as_str()).collect();
        for lane in &self.lanes {
            let el = format!("lane '{}'", lane.name);
            if lane.waypoints.len() < 2 {
                p.add(
                    &el,
                    "waypoints",
                    format!("needs at least 2 points, has {}", lane.waypoints.len()),
                );
            }
            if let Some(i) = lane.waypoints.iter().position(|w| !w.is_finite()) {
                p.add(
                    &el,
                    "waypoints",
                    format!("point {i} is not a finite number"),
                );
            } else if lane.waypoints.len() >= 2 {
                let length = lane.length();
                if length < 0.1 {
                    p.add(&el, "waypoints", format!("lane is only {length:.3} m long"));
                } else if length > MAX_LANE_LENGTH {
                    p.add(
                        &el,
                        "waypoints",
                        format!(
                            "lane is {:.0} km long, more than {:.0} km: a point far out of place?",
                            length / 1000.0,
                            MAX_LANE_LENGTH / 1000.0
                        ),
                    );
                }
            }
            if !positive(lane.width) || lane.width > MAX_LANE_WIDTH {
                p.add(
                    &el,
                    "width",
                    format!(
                        "must be a positive number of metres up to {MAX_LANE_WIDTH}, got {}",
                        lane.width
                    ),
                );
            }
            if !positive(lane.speed_limit) {
                p.add(
                    &el,
                    "speed_limit",
                    format!("must be a positive number of m/s, got {}", lane.speed_limit),
                );
            }
            for (field, list) in [
                ("next", &lane.next),
                ("prev", &lane.prev),
                ("right_of_way", &lane.right_of_way),
                ("crosses_apart", &lane.crosses_apart),
            ] {
                for other in list {
                    if !names.contains_key(&other.to_lowercase()) {
                        p.add(&el, field, format!("unknown lane '{other}'"));
                    }
                }
            }
            if !lane.prev.is_empty() {
                for prev in &lane.prev {
                    if let Some(&j) = names.get(&prev.to_lowercase())
                        && !self.lanes[j]
                            .next
                            .iter()
                            .any(|n| n.eq_ignore_ascii_case(&lane.name))
                    {
                        p.add(
                            &el,
                            "prev",
                            format!("lists '{prev}', but '{prev}' does not list it in next"),
                        );
                    }
                }
            }
            if let Some(line) = &lane.stop_line
                && line.iter().any(|pt| !pt.is_finite())
            {
                p.add(&el, "stop_line", "a point is not a finite number");
            }
            if let Some(g) = &lane.traffic_light
                && !groups.contains(g.as_str())
            {
                p.add(&el, "traffic_light", format!("unknown light group '{g}'"));
            }
        }
    }

    fn validate_intersections(&self, names: &HashMap<String, usize>, p: &mut Problems) {
        for (i, def) in self.intersections.iter().enumerate() {
            let el = format!("intersections[{i}]");
            match names.get(&def.lane.to_lowercase()) {
                None => p.add(&el, "lane", format!("no lane named '{}'", def.lane)),
                Some(&k) if !self.lanes[k].intersection => p.add(
                    &el,
                    "lane",
                    format!("lane '{}' is not an intersection lane", def.lane),
                ),
                Some(_) => {}
            }
        }
    }

    fn validate_lights(&self, p: &mut Problems) {
        let mut seen = HashSet::new();
        for g in &self.light_groups {
            let el = format!("light group '{}'", g.name);
            if !seen.insert(g.name.as_str()) {
                p.add(&el, "name", "duplicate light group name");
            }
            for (field, problem) in g.program.problems() {
                p.add(&el, field, problem);
            }
        }
    }

    fn validate_crosswalks(&self, p: &mut Problems) {
        let configs: HashSet<&str> = self.zebra_configs.iter().map(|c| c.name.as_str()).collect();
        let mut seen = HashSet::new();
        for c in &self.crosswalks {
            let el = format!("crosswalk '{}'", c.name);
            if !seen.insert(c.name.as_str()) {
                p.add(&el, "name", "duplicate crosswalk name");
            }
            match &c.area {
                CrosswalkArea::Box {
                    center,
                    half_extents,
                    yaw_deg,
                } => {
                    if !center.is_finite() || !yaw_deg.is_finite() {
                        p.add(&el, "area", "centre and yaw_deg must be finite numbers");
                    }
                    if !half_extents.iter().all(|&h| positive(h)) {
                        p.add(
                            &el,
                            "area.half_extents",
                            "both half extents must be positive",
                        );
                    }
                }
                CrosswalkArea::Polygon { points } => {
                    if points.len() < 3 || points.iter().any(|pt| !pt.is_finite()) {
                        p.add(
                            &el,
                            "area.points",
                            "a polygon needs at least 3 finite points",
                        );
                    }
                }
            }
            if c.stop_points.iter().any(|s| !s.position.is_finite()) {
                p.add(&el, "stop_points", "a stop point is not a finite number");
            }
            if !positive(c.max_detection_distance) {
                p.add(
                    &el,
                    "max_detection_distance",
                    "must be a positive number of metres",
                );
            }
            if !(c.forward_angle_tolerance_deg.is_finite()
                && (0.0..=180.0).contains(&c.forward_angle_tolerance_deg))
            {
                p.add(
                    &el,
                    "forward_angle_tolerance_deg",
                    "must be between 0 and 180 degrees",
                );
            }
            if !(c.stop_buffer.is_finite() && c.stop_buffer >= 0.0) {
                p.add(
                    &el,
                    "stop_buffer",
                    "must be a non-negative number of metres",
                );
            }
            if let Some(cfg) = &c.config
                && !configs.contains(cfg.as_str())
            {
                p.add(&el, "config", format!("unknown zebra config '{cfg}'"));
            }
        }
    }

    fn validate_simulators(&self, names: &HashMap<String, usize>, p: &mut Problems) {
        if self.traffic_simulators.is_empty() {
            p.add(
                "map",
                "traffic_simulators",
                "no traffic simulator is configured; at least one random, route or demand simulator is required",
            );
        }
        for (i, sim) in self.traffic_simulators.iter().enumerate() {
            let el = format!("traffic_simulators[{i}]");
            if let SimulatorDef::Demand { departures } = sim
                && let Some(k) = departures
                    .iter()
                    .position(|d| !(d.time.is_finite() && d.time >= 0.0))
            {
                p.add(
                    &el,
                    &format!("departures[{k}].time"),
                    "must be a finite number of seconds, not negative",
                );
            }
            for (field, lanes, prefab_field, prefabs) in sim.checks() {
                self.check_simulator_lists(&el, &field, lanes, &prefab_field, &prefabs, names, p);
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn check_simulator_lists(
        &self,
        el: &str,
        field: &str,
        lanes: &[String],
        prefab_field: &str,
        prefabs: &[&String],
        names: &HashMap<String, usize>,
        p: &mut Problems,
    ) {
        {
            if lanes.is_empty() {
                p.add(el, field, "is empty");
            }
            for lane in lanes {
                if !names.contains_key(&lane.to_lowercase()) {
                    p.add(el, field, format!("unknown lane '{lane}'"));
                } else if let Some(&j) = names.get(&lane.to_lowercase())
                    && self.lanes[j].waypoints.len() < 2
                {
                    p.add(el, field, format!("lane '{lane}' has no usable geometry"));
                }
            }
            if prefabs.is_empty() {
                p.add(el, prefab_field, "is empty");
            }
            for prefab in prefabs {
                if builtin_kind(prefab).is_none()
                    && !self.vehicle_kinds.iter().any(|k| k.name == **prefab)
                {
                    let known: Vec<&str> = crate::catalog::builtin_names()
                        .map(|n| -> &str { n })
                        .chain(self.vehicle_kinds.iter().map(|k| k.name.as_str()))
                        .collect();
                    p.add(
                        el,
                        prefab_field,
                        format!(
                            "unknown vehicle kind '{prefab}' (known: {})",
                            known.join(", ")
                        ),
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map file with no lane and `fields` (JSON object members).
    fn road_conflicts(fields: &str) -> Result<RoadConflicts, serde_json::Error> {
        let sep = if fields.is_empty() { "" } else { ", " };
        let json = format!(r#"{{"lanes": []{sep}{fields}}}"#);
        serde_json::from_str::<MapFile>(&json).map(|m| m.road_conflicts)
    }

    #[test]
    fn road_conflicts_read_by_name_and_as_the_earlier_flag() {
        assert_eq!(road_conflicts("").unwrap(), RoadConflicts::None);
        let opposing = r#""road_conflicts": "opposing""#;
        assert_eq!(road_conflicts(opposing).unwrap(), RoadConflicts::Opposing);
        let flag = r#""conflicts_outside_junctions": true"#;
        assert_eq!(road_conflicts(flag).unwrap(), RoadConflicts::Everywhere);
        let off = r#""conflicts_outside_junctions": false"#;
        assert_eq!(road_conflicts(off).unwrap(), RoadConflicts::None);
        let wrong = road_conflicts(r#""road_conflicts": "sometimes""#).unwrap_err();
        assert!(
            wrong.to_string().contains("\"sometimes\"")
                && wrong.to_string().contains("\"opposing\""),
            "{wrong}"
        );
    }
}
