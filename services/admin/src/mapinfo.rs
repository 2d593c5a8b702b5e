//! The map as the admin needs it: names for the indices in vehicle batches, and
//! the geometry the live map draws (computed once, served as one JSON document).

use std::collections::BTreeMap;

use serde::Serialize;
use trafficmesh_model::catalog::{builtin_kind, builtin_names};
use trafficmesh_sim::LaneNetwork;
use trafficmesh_sim::network::SimulatorSpec;
use utoipa::ToSchema;

pub struct MapInfo {
    pub net: LaneNetwork,
    /// Catalogue names by the `kind` code of a vehicle batch.
    pub kind_names: Vec<&'static str>,
    /// `GET /api/v1/map`, serialised once.
    pub geometry_json: String,
}

/// What the live map draws. Coordinates are map metres, `[x, y]`.
#[derive(Serialize, ToSchema)]
pub struct MapGeometry {
    pub name: String,
    /// Bounding box `[min_x, min_y, max_x, max_y]`.
    pub bounds: [f64; 4],
    pub lanes: Vec<LaneShape>,
    pub crosswalks: Vec<CrosswalkShape>,
    /// Light groups by name, each with the stop-line centres of its lanes.
    pub lights: BTreeMap<String, Vec<[f64; 2]>>,
    /// Starts of the lanes the map's simulators spawn on (the AWSIM reference's showSpawnPoints).
    pub spawn_points: Vec<SpawnPoint>,
    /// The catalogue by vehicle `kind` code.
    pub kinds: Vec<KindShape>,
}

#[derive(Serialize, ToSchema)]
pub struct KindShape {
    pub name: String,
    /// Pose origin (rear axle) to front bumper, metres: where the box sits on the pose.
    pub front: f64,
}

#[derive(Serialize, ToSchema)]
pub struct LaneShape {
    pub name: String,
    pub points: Vec<[f64; 2]>,
    pub width: f64,
    pub intersection: bool,
}

#[derive(Serialize, ToSchema)]
pub struct CrosswalkShape {
    pub name: String,
    pub polygon: Vec<[f64; 2]>,
    pub stop_points: Vec<[f64; 2]>,
}

#[derive(Serialize, ToSchema)]
pub struct SpawnPoint {
    pub lane: String,
    pub x: f64,
    pub y: f64,
}

impl MapInfo {
    pub fn new(net: LaneNetwork) -> MapInfo {
        let geometry = geometry(&net);
        MapInfo {
            geometry_json: serde_json::to_string(&geometry).expect("map geometry serialises"),
            kind_names: builtin_names().collect(),
            net,
        }
    }

    pub fn lane_name(&self, lane: u32) -> &str {
        self.net
            .lanes
            .get(lane as usize)
            .map_or("?", |l| l.name.as_str())
    }

    pub fn kind_name(&self, kind: u16) -> &str {
        self.kind_names.get(kind as usize).copied().unwrap_or("?")
    }
}

fn xy(p: glam::DVec2) -> [f64; 2] {
    [p.x, p.y]
}

fn geometry(net: &LaneNetwork) -> MapGeometry {
    let lanes: Vec<LaneShape> = net
        .lanes
        .iter()
        .map(|l| LaneShape {
            name: l.name.clone(),
            points: l.line.points().map(xy).collect(),
            width: l.width,
            intersection: l.intersection,
        })
        .collect();
    let mut bounds = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in lanes.iter().flat_map(|l| &l.points) {
        bounds = [
            bounds[0].min(p[0]),
            bounds[1].min(p[1]),
            bounds[2].max(p[0]),
            bounds[3].max(p[1]),
        ];
    }
    let mut lights: BTreeMap<String, Vec<[f64; 2]>> = net
        .light_groups
        .iter()
        .map(|g| (g.name.clone(), Vec::new()))
        .collect();
    for lane in &net.lanes {
        if let Some(g) = lane.light() {
            let (p, _) = lane.line.point_at(lane.light_stop_s());
            lights
                .entry(net.light_groups[g as usize].name.clone())
                .or_default()
                .push(xy(p));
        }
    }
    let mut spawn_lanes: Vec<u32> = net
        .simulators
        .iter()
        .flat_map(|s| match s {
            SimulatorSpec::Random { lanes, .. } => lanes.clone(),
            SimulatorSpec::Route { route, .. } => route.first().copied().into_iter().collect(),
            SimulatorSpec::Demand { departures } => departures
                .iter()
                .flat_map(|d| d.routes.iter().map(|r| r[0]))
                .collect(),
        })
        .collect();
    spawn_lanes.sort_unstable();
    spawn_lanes.dedup();
    MapGeometry {
        name: net.name.clone(),
        bounds,
        lanes,
        crosswalks: net
            .crosswalks
            .iter()
            .map(|c| CrosswalkShape {
                name: c.name.clone(),
                polygon: c.polygon.iter().copied().map(xy).collect(),
                stop_points: c.stops.iter().map(|s| xy(s.position)).collect(),
            })
            .collect(),
        lights,
        spawn_points: spawn_lanes
            .into_iter()
            .map(|l| {
                let lane = net.lane(l);
                let p = lane.line.point(0);
                SpawnPoint {
                    lane: lane.name.clone(),
                    x: p.x,
                    y: p.y,
                }
            })
            .collect(),
        kinds: builtin_names()
            .filter_map(builtin_kind)
            .map(|k| KindShape {
                name: k.name,
                front: k.front,
            })
            .collect(),
    }
}
