//! Vehicles from the newest batch (list, filter, one), and the commands that
//! act on them: remove in radius, restart with a new maximum count.

use axum::Json;
use axum::extract::{Path, Query, State};
use axum::http::StatusCode;
use serde::{Deserialize, Serialize};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{RemoveTarget, RestartRequest, VehicleBatch, VehicleState};
use utoipa::{IntoParams, ToSchema};

use super::{App, AppState};
use crate::problem::{ApiJson, Problem};

#[derive(Serialize, ToSchema)]
pub struct VehicleList {
    pub tick: u64,
    /// Simulation time of the batch, seconds.
    pub time: f64,
    pub count: usize,
    pub vehicles: Vec<VehicleView>,
}

/// One vehicle after the newest tick.
#[derive(Serialize, ToSchema)]
pub struct VehicleView {
    pub id: u64,
    pub kind: String,
    pub lane: String,
    /// Front-bumper arc length on `lane`, metres.
    pub s: f32,
    pub x: f32,
    pub y: f32,
    pub z: f32,
    /// Radians, counter-clockwise from +x.
    pub yaw: f32,
    pub speed: f32,
    pub accel: f32,
    pub length: f32,
    pub width: f32,
    /// NORMAL, SLOW, STOP, SUDDEN_STOP or ABSOLUTE_STOP.
    pub mode: &'static str,
    pub yield_phase: &'static str,
    /// off, left or right.
    pub signal: &'static str,
    pub zebra_blocked: bool,
    pub check_distance: f32,
    /// Metres from (x, y), the rear axle, forward to the front bumper.
    pub front_offset: f32,
    /// The centre of the vehicle's box: `front_offset - length / 2` ahead of
    /// (x, y) along `yaw`.
    pub box_center: [f32; 2],
}

#[derive(Deserialize, IntoParams)]
pub struct Filter {
    /// Only vehicles on this lane (name, case-insensitive).
    lane: Option<String>,
    /// Only vehicles inside `min_x,min_y,max_x,max_y` (metres).
    bbox: Option<String>,
}

fn view(app: &App, v: &VehicleState) -> VehicleView {
    VehicleView {
        id: v.id,
        kind: app.map.kind_name(v.kind).to_string(),
        lane: app.map.lane_name(v.lane).to_string(),
        s: v.s,
        x: v.x,
        y: v.y,
        z: v.z,
        yaw: v.yaw,
        speed: v.speed,
        accel: v.accel,
        length: v.length,
        width: v.width,
        mode: v.mode.as_str(),
        yield_phase: v.yield_phase.as_str(),
        signal: match v.signal {
            trafficmesh_model::TurnSignal::Off => "off",
            trafficmesh_model::TurnSignal::Left => "left",
            trafficmesh_model::TurnSignal::Right => "right",
        },
        zebra_blocked: v.zebra_blocked,
        check_distance: v.check_distance,
        front_offset: v.front_offset,
        box_center: {
            let ahead = v.front_offset - v.length / 2.0;
            [v.x + ahead * v.yaw.cos(), v.y + ahead * v.yaw.sin()]
        },
    }
}

fn newest_batch(app: &App) -> Result<VehicleBatch, Problem> {
    let bytes = app.view.read().batch.clone().ok_or_else(|| {
        Problem::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "no vehicle batch from the stepper yet",
        )
    })?;
    VehicleBatch::decode(&bytes.to_bytes())
        .map_err(|e| Problem::new(StatusCode::BAD_GATEWAY, format!("vehicle batch: {e}")))
}

fn parse_bbox(text: &str) -> Result<[f32; 4], Problem> {
    let bad = || {
        Problem::new(
            StatusCode::BAD_REQUEST,
            format!(
                "query parameter 'bbox': expected min_x,min_y,max_x,max_y in metres, got '{text}'"
            ),
        )
    };
    let numbers: Vec<f32> = text
        .split(',')
        .map(|n| n.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    match numbers[..] {
        [a, b, c, d] if [a, b, c, d].iter().all(|n| n.is_finite()) && a <= c && b <= d => {
            Ok([a, b, c, d])
        }
        _ => Err(bad()),
    }
}

/// Vehicles of the newest batch, optionally on one lane or inside a box.
#[utoipa::path(get, path = "/api/v1/vehicles", tag = "vehicles", params(Filter),
    responses((status = 200, body = VehicleList), (status = 400, body = Problem), (status = 404, body = Problem)))]
pub async fn list(
    State(app): AppState,
    Query(filter): Query<Filter>,
) -> Result<Json<VehicleList>, Problem> {
    let lane = match &filter.lane {
        Some(name) => Some(app.map.net.lane_id(name).ok_or_else(|| {
            Problem::not_found(format!("query parameter 'lane': no lane named '{name}'"))
        })?),
        None => None,
    };
    let bbox = filter.bbox.as_deref().map(parse_bbox).transpose()?;
    let batch = newest_batch(&app)?;
    let vehicles: Vec<VehicleView> = batch
        .vehicles
        .iter()
        .filter(|v| lane.is_none_or(|l| v.lane == l))
        .filter(|v| bbox.is_none_or(|b| v.x >= b[0] && v.y >= b[1] && v.x <= b[2] && v.y <= b[3]))
        .map(|v| view(&app, v))
        .collect();
    Ok(Json(VehicleList {
        tick: batch.tick,
        time: batch.time,
        count: vehicles.len(),
        vehicles,
    }))
}

/// One vehicle of the newest batch.
#[utoipa::path(get, path = "/api/v1/vehicles/{id}", tag = "vehicles",
    params(("id" = u64, Path, description = "Vehicle id")),
    responses((status = 200, body = VehicleView), (status = 404, body = Problem)))]
pub async fn one(State(app): AppState, Path(id): Path<u64>) -> Result<Json<VehicleView>, Problem> {
    let batch = newest_batch(&app)?;
    batch
        .vehicles
        .iter()
        .find(|v| v.id == id)
        .map(|v| Json(view(&app, v)))
        .ok_or_else(|| Problem::not_found(format!("no vehicle {id} in the newest batch")))
}

#[derive(Serialize, Deserialize, ToSchema)]
pub struct Removed {
    /// Vehicles removed; they are gone from the next tick.
    pub removed: usize,
}

/// RemoveVehiclesInRadius around a point, the ego or a vehicle.
#[utoipa::path(post, path = "/api/v1/vehicles/remove", tag = "vehicles", security(("bearer" = [])),
    request_body(content = serde_json::Value, description = "{\"around\": \"point\", x, y, z?, radius} | {\"around\": \"ego\", radius} | {\"around\": \"vehicle\", id}"),
    responses((status = 200, body = Removed), (status = 422, body = Problem)))]
pub async fn remove(
    State(app): AppState,
    ApiJson(target): ApiJson<RemoveTarget>,
) -> Result<Json<Removed>, Problem> {
    if let Some(problem) = target.problem() {
        return Err(Problem::unprocessable(problem));
    }
    let answer = app
        .bus
        .call(&topics::SPAWNER_REMOVE, &target, app.bus_timeout)
        .await?;
    Ok(Json(Removed {
        removed: answer.removed,
    }))
}

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Restart {
    /// The new maximum vehicle count.
    pub max_vehicles: usize,
    /// A new random seed for what follows; unset keeps the run's.
    #[serde(default)]
    pub seed: Option<u64>,
}

#[derive(Serialize, Deserialize, ToSchema)]
pub struct Restarted {
    /// Vehicles removed by the restart.
    pub disposed: usize,
    pub max_vehicles: usize,
}

/// Restart: removes every vehicle and sets a new maximum count.
#[utoipa::path(post, path = "/api/v1/restart", tag = "vehicles", security(("bearer" = [])),
    request_body = Restart,
    responses((status = 200, body = Restarted), (status = 422, body = Problem)))]
pub async fn restart(
    State(app): AppState,
    ApiJson(r): ApiJson<Restart>,
) -> Result<Json<Restarted>, Problem> {
    let request = RestartRequest {
        max_vehicles: r.max_vehicles,
        seed: r.seed,
    };
    let answer = app
        .bus
        .call(&topics::SPAWNER_RESTART, &request, app.bus_timeout)
        .await?;
    app.view.restarted(answer.after_tick);
    Ok(Json(Restarted {
        disposed: answer.disposed,
        max_vehicles: answer.max_vehicles,
    }))
}
