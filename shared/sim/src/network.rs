//! The lane network compiled from a validated [`MapFile`]: lane ids instead of
//! names, arc lengths, stop-line positions, junctions and conflict zones.

use glam::DVec2;
use rustc_hash::FxHashMap;
use trafficmesh_model::map::{
    CrosswalkArea, IntersectionController, IntersectionDef, MapFile, SimulatorDef,
};
use trafficmesh_model::{
    LightProgram, MapProblem, RoadConflicts, TurnDirection, VehicleKind, ZebraConfigDef,
    builtin_kind,
};

use crate::conflicts::{Conflict, find_conflicts_and_junctions};
use crate::geometry::{Polyline, box_corners};

pub type LaneId = u32;

/// A lane at run time. `repr(C)` keeps the fields every pass of a tick reads
/// about each lane of a path in the first cache line, then the inline geometry
/// (straight lanes, turning), the conflicts and right of way: the four lines
/// the passes prefetch ([`crate::prefetch::LANE_LINES`]). Names and the rest follow.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Lane {
    length: f64,
    /// Where a signalised lane stops its traffic (stop line, else the lane end).
    light_stop: f64,
    pub speed_limit: f64,
    /// What holds vehicles at this lane's stop point.
    pub control: StopControl,
    /// Junction this intersection lane belongs to.
    pub junction: Option<u32>,
    pub intersection: bool,
    pub turn: TurnDirection,
    /// Some of `conflicts` are road conflicts (outside right of way).
    pub road_conflicts: bool,
    pub line: Polyline,
    /// Where other lanes come close enough for two vehicles to touch.
    pub conflicts: Vec<Conflict>,
    // What right of way reads about a junction lane.
    pub right_of_way: Vec<LaneId>,
    /// Centre of the stop line, if the lane has one.
    pub stop_center: Option<DVec2>,
    pub next: Vec<LaneId>,
    pub prev: Vec<LaneId>,
    pub name: String,
    pub width: f64,
    /// Arc length of the stop line along this lane.
    pub stop_s: Option<f64>,
    /// The vehicle classes allowed here; empty: all.
    pub vehicle_classes: Vec<String>,
    /// The lanes of the same road beside this one (see [`crate::siblings`]).
    pub siblings: Vec<LaneId>,
    /// Followed as it leads, this lane never leads anywhere else (see
    /// [`crate::loops`]).
    pub in_closed_loop: bool,
    /// The lanes this one crosses at another level (sorted): see
    /// [`LaneNetwork::lanes_apart`].
    pub crosses_apart: Vec<LaneId>,
}

/// What holds a vehicle at a lane's stop point (the stop line, else for a
/// light its end, for a reservation its start): the intersection's
/// controller, chosen per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopControl {
    #[default]
    Free,
    /// A light group (an index into [`LaneNetwork::light_groups`]).
    Light(u32),
    /// A reservation intersection (an index into
    /// [`LaneNetwork::reservation_junctions`]): red until a way is granted.
    Reservation(u32),
}

impl Lane {
    pub fn length(&self) -> f64 {
        self.length
    }

    /// The light group at this lane's stop point, if any.
    pub fn light(&self) -> Option<u32> {
        match self.control {
            StopControl::Light(group) => Some(group),
            _ => None,
        }
    }

    /// The reservation intersection this junction lane belongs to, if any.
    pub fn reservation(&self) -> Option<u32> {
        match self.control {
            StopControl::Reservation(k) => Some(k),
            _ => None,
        }
    }

    /// The reference's `stopPoint(i)`: the stop line's centre, else waypoint i.
    pub fn stop_point(&self, i: usize) -> DVec2 {
        self.stop_center
            .unwrap_or(self.line.point(i.min(self.line.point_count() - 1)))
    }

    /// Stop position of a signalised lane: its stop line, else its end.
    pub fn light_stop_s(&self) -> f64 {
        self.light_stop
    }
}

#[derive(Clone, Debug)]
pub struct LightGroup {
    pub name: String,
    pub program: LightProgram,
}

/// One stop point of a crosswalk, with the optional direction of its traffic.
#[derive(Clone, Copy, Debug)]
pub struct CrosswalkStop {
    pub position: DVec2,
    pub heading: Option<DVec2>,
}

/// A ZebraCrossingArea's geometry and parameters.
#[derive(Clone, Debug)]
pub struct Crosswalk {
    pub name: String,
    pub polygon: Vec<DVec2>,
    pub stops: Vec<CrosswalkStop>,
    pub max_detection_distance: f64,
    /// cos of the cone half-angle.
    pub cos_tolerance: f64,
    pub stop_buffer: f64,
    pub debug_logs: bool,
    /// Whitelist of the parent ZebraCrossingConfig (empty lists allow all).
    pub whitelist: ZebraConfigDef,
    /// The light groups whose red is the walkers' walk signal (empty:
    /// unsignalised; see [`crate::walk_signal`]).
    pub walk_groups: Vec<u32>,
}

/// A traffic simulator of the scene with lane ids and vehicle kinds resolved.
#[derive(Clone, Debug)]
pub enum SimulatorSpec {
    Random {
        lanes: Vec<LaneId>,
        kinds: Vec<usize>,
        maximum_spawns: u32,
        enabled: bool,
        attempts_per_tick: u32,
    },
    Route {
        route: Vec<LaneId>,
        kinds: Vec<usize>,
        maximum_spawns: u32,
        enabled: bool,
    },
    /// Departures in time order.
    Demand { departures: Vec<Departure> },
}

/// One vehicle of a timetable.
#[derive(Clone, Debug)]
pub struct Departure {
    pub time: f64,
    /// Equally good lane routes, the preferred one first; the vehicle
    /// departs on the first lane of one that has room.
    pub routes: Vec<std::sync::Arc<[LaneId]>>,
    pub kind: usize,
}

/// Sets each listed intersection's controller on its lanes: with `priority`
/// or `reservation` the light groups of its lanes, and of the lanes leading
/// into it, no longer apply. Returns the reservation junctions in the map's
/// order (a junction listed twice counts once, its last controller
/// winning).
fn apply_controllers(
    lanes: &mut [Lane],
    defs: &[IntersectionDef],
    by_name: &FxHashMap<String, LaneId>,
) -> Vec<u32> {
    let mut chosen: Vec<(u32, IntersectionController)> = Vec::new();
    for def in defs {
        let lane = by_name[&def.lane.to_lowercase()] as usize;
        let Some(junction) = lanes[lane].junction else {
            continue;
        };
        chosen.retain(|&(j, _)| j != junction);
        chosen.push((junction, def.controller));
    }
    let mut reserved = Vec::new();
    for (junction, controller) in chosen {
        if controller == IntersectionController::Lights {
            continue;
        }
        let control = if controller == IntersectionController::Reservation {
            reserved.push(junction);
            StopControl::Reservation((reserved.len() - 1) as u32)
        } else {
            StopControl::Free
        };
        let members: Vec<usize> = (0..lanes.len())
            .filter(|&i| lanes[i].junction == Some(junction))
            .collect();
        for &i in &members {
            lanes[i].control = control;
            for p in lanes[i].prev.clone() {
                if lanes[p as usize].light().is_some() {
                    lanes[p as usize].control = StopControl::Free;
                }
            }
        }
    }
    reserved
}

#[derive(Clone, Debug)]
pub struct LaneNetwork {
    pub name: String,
    pub lanes: Vec<Lane>,
    by_name: FxHashMap<String, LaneId>,
    pub light_groups: Vec<LightGroup>,
    pub crosswalks: Vec<Crosswalk>,
    pub simulators: Vec<SimulatorSpec>,
    /// Vehicle kinds used by the simulators (the built-in catalogue).
    pub kinds: Vec<VehicleKind>,
    pub junction_count: u32,
    /// Some lanes cross others at another level (nearly no map has any:
    /// then the bodies' checks read no lane for it).
    crossings_apart: bool,
    /// The junctions under reservation control, in the map's order.
    pub reservation_junctions: Vec<u32>,
    /// Which lanes outside junctions have conflict zones.
    pub road_conflicts: RoadConflicts,
}

impl LaneNetwork {
    /// Validates the map (the start-up checklist) and compiles it.
    pub fn build(map: &MapFile) -> Result<Self, Vec<MapProblem>> {
        map.validate()?;
        let by_name: FxHashMap<String, LaneId> = map
            .lanes
            .iter()
            .enumerate()
            .map(|(i, l)| (l.name.to_lowercase(), i as LaneId))
            .collect();
        let id = |name: &String| by_name[&name.to_lowercase()];
        let group_index: FxHashMap<&str, usize> = map
            .light_groups
            .iter()
            .enumerate()
            .map(|(i, g)| (g.name.as_str(), i))
            .collect();
        let mut lanes: Vec<Lane> = map
            .lanes
            .iter()
            .map(|def| {
                let points = def
                    .waypoints
                    .iter()
                    .map(|p| DVec2::new(p.0[0], p.0[1]))
                    .collect();
                let heights = def.waypoints.iter().map(|p| p.0[2]).collect();
                let line = Polyline::new(points, heights);
                let stop_center = def
                    .stop_line
                    .map(|[a, b]| DVec2::new(a.0[0] + b.0[0], a.0[1] + b.0[1]) * 0.5);
                let stop_s = stop_center.map(|c| line.project(c));
                Lane {
                    length: line.length(),
                    light_stop: stop_s.unwrap_or(line.length()),
                    name: def.name.clone(),
                    stop_s,
                    stop_center,
                    line,
                    width: def.width,
                    speed_limit: def.speed_limit,
                    next: def.next.iter().map(id).collect(),
                    prev: Vec::new(),
                    intersection: def.intersection,
                    turn: def.turn_direction,
                    control: def.traffic_light.as_deref().map_or(StopControl::Free, |g| {
                        StopControl::Light(group_index[g] as u32)
                    }),
                    right_of_way: def.right_of_way.iter().map(id).collect(),
                    junction: None,
                    conflicts: Vec::new(),
                    road_conflicts: false,
                    vehicle_classes: def.vehicle_classes.clone(),
                    siblings: Vec::new(),
                    in_closed_loop: false,
                    crosses_apart: Vec::new(),
                }
            })
            .collect();
        for (i, def) in map.lanes.iter().enumerate() {
            for other in &def.crosses_apart {
                let j = id(other);
                lanes[i].crosses_apart.push(j);
                lanes[j as usize].crosses_apart.push(i as LaneId);
            }
        }
        for lane in &mut lanes {
            lane.crosses_apart.sort_unstable();
            lane.crosses_apart.dedup();
        }
        for i in 0..lanes.len() {
            for n in lanes[i].next.clone() {
                if !lanes[n as usize].prev.contains(&(i as LaneId)) {
                    lanes[n as usize].prev.push(i as LaneId);
                }
            }
        }
        let siblings = crate::siblings::find(&lanes);
        for (lane, siblings) in lanes.iter_mut().zip(siblings) {
            lane.siblings = siblings;
        }
        let in_closed_loop = crate::loops::find(&lanes);
        for (lane, looped) in lanes.iter_mut().zip(in_closed_loop) {
            lane.in_closed_loop = looped;
        }
        let junction_count = find_conflicts_and_junctions(&mut lanes, map.road_conflicts);
        let reservation_junctions = apply_controllers(&mut lanes, &map.intersections, &by_name);

        // The map's own kinds first, so that their names win over the catalogue's.
        let mut kinds: Vec<VehicleKind> = map.vehicle_kinds.clone();
        let mut kind_index = |name: &str| intern_kind(&mut kinds, name).expect("validated");
        let simulators = map
            .traffic_simulators
            .iter()
            .map(|s| match s {
                SimulatorDef::Random {
                    lanes,
                    prefabs,
                    maximum_spawns,
                    enabled,
                    spawn_attempts_per_tick,
                } => SimulatorSpec::Random {
                    lanes: lanes.iter().map(id).collect(),
                    kinds: prefabs.iter().map(|p| kind_index(p)).collect(),
                    maximum_spawns: *maximum_spawns,
                    enabled: *enabled,
                    attempts_per_tick: (*spawn_attempts_per_tick).max(1),
                },
                SimulatorDef::Route {
                    route,
                    prefabs,
                    maximum_spawns,
                    enabled,
                } => SimulatorSpec::Route {
                    route: route.iter().map(id).collect(),
                    kinds: prefabs.iter().map(|p| kind_index(p)).collect(),
                    maximum_spawns: *maximum_spawns,
                    enabled: *enabled,
                },
                SimulatorDef::Demand { departures } => {
                    let mut departures: Vec<_> = departures
                        .iter()
                        .map(|d| Departure {
                            time: d.time,
                            routes: std::iter::once(&d.route)
                                .chain(&d.other_routes)
                                .map(|r| r.iter().map(id).collect())
                                .collect(),
                            kind: kind_index(&d.prefab),
                        })
                        .collect();
                    departures.sort_by(|a, b| a.time.total_cmp(&b.time));
                    SimulatorSpec::Demand { departures }
                }
            })
            .collect();

        let crosswalks = map
            .crosswalks
            .iter()
            .map(|c| {
                let (polygon, center) = match &c.area {
                    CrosswalkArea::Box {
                        center,
                        half_extents,
                        yaw_deg,
                    } => {
                        let ctr = DVec2::new(center.0[0], center.0[1]);
                        let corners = box_corners(
                            ctr,
                            yaw_deg.to_radians(),
                            half_extents[0],
                            half_extents[1],
                        );
                        (corners.to_vec(), ctr)
                    }
                    CrosswalkArea::Polygon { points } => {
                        let pts: Vec<DVec2> =
                            points.iter().map(|p| DVec2::new(p.0[0], p.0[1])).collect();
                        let ctr = pts.iter().copied().sum::<DVec2>() / pts.len() as f64;
                        (pts, ctr)
                    }
                };
                let mut stops: Vec<CrosswalkStop> = c
                    .stop_points
                    .iter()
                    .map(|s| CrosswalkStop {
                        position: DVec2::new(s.position.0[0], s.position.0[1]),
                        heading: s.heading_deg.map(|h| DVec2::from_angle(h.to_radians())),
                    })
                    .collect();
                if stops.is_empty() {
                    stops.push(CrosswalkStop {
                        position: center,
                        heading: None,
                    });
                }
                let whitelist = c
                    .config
                    .as_ref()
                    .and_then(|name| map.zebra_configs.iter().find(|z| &z.name == name))
                    .cloned()
                    .unwrap_or_default();
                Crosswalk {
                    name: c.name.clone(),
                    walk_groups: crate::walk_signal::walk_groups(&lanes, &polygon),
                    polygon,
                    stops,
                    max_detection_distance: c.max_detection_distance,
                    cos_tolerance: c.forward_angle_tolerance_deg.to_radians().cos(),
                    stop_buffer: c.stop_buffer,
                    debug_logs: c.enable_debug_logs,
                    whitelist,
                }
            })
            .collect();

        let crossings_apart = lanes.iter().any(|l| !l.crosses_apart.is_empty());
        Ok(LaneNetwork {
            name: map.name.clone(),
            crossings_apart,
            lanes,
            by_name,
            light_groups: map
                .light_groups
                .iter()
                .map(|g| LightGroup {
                    name: g.name.clone(),
                    program: g.program,
                })
                .collect(),
            crosswalks,
            simulators,
            kinds,
            junction_count,
            reservation_junctions,
            road_conflicts: map.road_conflicts,
        })
    }

    /// Case-insensitive lane lookup.
    pub fn lane_id(&self, name: &str) -> Option<LaneId> {
        self.by_name.get(&name.to_lowercase()).copied()
    }

    pub fn lane(&self, id: LaneId) -> &Lane {
        &self.lanes[id as usize]
    }

    /// The two lanes cross at different levels, a bridge over the other
    /// (the map's `crosses_apart`): bodies on them never meet.
    pub fn lanes_apart(&self, a: LaneId, b: LaneId) -> bool {
        self.crossings_apart && self.lane(a).crosses_apart.binary_search(&b).is_ok()
    }

    /// A fingerprint of what the bus addresses by index or name: the lanes in
    /// order (name, successors, length to the millimetre), the light groups
    /// and the crosswalks. Two processes agree on lane indices only when their
    /// fingerprints do.
    pub fn fingerprint(&self) -> u64 {
        let mut h = trafficmesh_model::hash::Fnv1a::default();
        h.eat(&(self.lanes.len() as u64).to_le_bytes());
        for l in &self.lanes {
            h.eat(l.name.as_bytes());
            h.eat(&[0]);
            for n in &l.next {
                h.eat(&n.to_le_bytes());
            }
            h.eat(&((l.length() * 1000.0).round() as i64).to_le_bytes());
        }
        let names = self.light_groups.iter().map(|g| &g.name);
        for name in names.chain(self.crosswalks.iter().map(|c| &c.name)) {
            h.eat(name.as_bytes());
            h.eat(&[0]);
        }
        h.0
    }

    /// Is `other` a sibling of `lane` right beside it, not one further across?
    /// A lane change crosses one lane at a time, so only to such a lane.
    pub fn beside(&self, lane: LaneId, other: LaneId) -> bool {
        let l = self.lane(lane);
        l.siblings.contains(&other)
            && self.lane(other).line.point(0).distance(l.line.point(0)) < 1.5 * l.width.max(2.5)
    }

    /// The siblings of `lane` right beside it (see [`LaneNetwork::beside`]).
    pub fn lanes_beside(&self, lane: LaneId) -> impl Iterator<Item = LaneId> + '_ {
        let l = self.lane(lane);
        l.siblings
            .iter()
            .copied()
            .filter(move |&s| self.beside(lane, s))
    }

    /// May vehicles of kind `kind` drive on `lane`?
    pub fn allows(&self, lane: LaneId, kind: usize) -> bool {
        let classes = &self.lane(lane).vehicle_classes;
        classes.is_empty()
            || trafficmesh_model::catalog::class_allowed(classes, self.kinds[kind].vehicle_class())
    }

    pub fn light_group(&self, name: &str) -> Option<usize> {
        self.light_groups.iter().position(|g| g.name == name)
    }

    pub fn crosswalk(&self, name: &str) -> Option<usize> {
        self.crosswalks.iter().position(|c| c.name == name)
    }

    /// Kind index of a kind of the map's own (a route file's vType), adding
    /// it if its name is new; a known name keeps its kind.
    pub fn add_kind(&mut self, kind: VehicleKind) -> usize {
        match self.kinds.iter().position(|k| k.name == kind.name) {
            Some(i) => i,
            None => {
                self.kinds.push(kind);
                self.kinds.len() - 1
            }
        }
    }

    /// Kind index for a vehicle kind name, adding a built-in kind if needed.
    pub fn kind_index(&mut self, name: &str) -> Option<usize> {
        intern_kind(&mut self.kinds, name)
    }
}

/// Index of the kind `name` in `kinds`, appending a built-in kind on first use.
fn intern_kind(kinds: &mut Vec<VehicleKind>, name: &str) -> Option<usize> {
    if let Some(i) = kinds.iter().position(|k| k.name == name) {
        return Some(i);
    }
    let kind = builtin_kind(name)?;
    Some(match kinds.iter().position(|k| k.name == kind.name) {
        Some(i) => i,
        None => {
            kinds.push(kind);
            kinds.len() - 1
        }
    })
}

#[cfg(test)]
mod layout_tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::prefetch::LANE_LINES;

    /// The prefetches ask for a lane's first lines by count: what the passes
    /// read must stay within them when fields move.
    #[test]
    fn the_fields_a_tick_reads_lie_in_the_lines_prefetched() {
        let end = |offset: usize, size: usize| offset + size;
        assert!(end(offset_of!(Lane, road_conflicts), 1) <= 64);
        assert!(end(offset_of!(Lane, speed_limit), 8) <= 64);
        let within = 64 * LANE_LINES;
        assert!(end(offset_of!(Lane, line), size_of::<Polyline>()) <= within);
        assert!(end(offset_of!(Lane, conflicts), size_of::<Vec<Conflict>>()) <= within);
        assert!(end(offset_of!(Lane, right_of_way), size_of::<Vec<LaneId>>()) <= within);
        assert!(end(offset_of!(Lane, stop_center), size_of::<Option<DVec2>>()) <= within);
    }
}
