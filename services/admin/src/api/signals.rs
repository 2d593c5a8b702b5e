//! The ego pose, traffic lights (states and overrides) and crosswalks
//! (areas with occupancy, the blocked-stop query).

use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use serde::{Deserialize, Serialize};
use trafficmesh_model::{LightColor, LightProgram};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{
    BlockedStopAnswer, BlockedStopQuery, EgoPose, LightOverride, LightState,
};
use utoipa::ToSchema;

use super::AppState;
use crate::problem::{ApiJson, Problem};

/// Sets the ego pose: the spawner keeps spawns 50 m from it, the stepper treats it as an obstacle.
#[utoipa::path(put, path = "/api/v1/ego", tag = "ego", security(("bearer" = [])), request_body(content = serde_json::Value, description = "`{x, y, z?, yaw, length? 4.9, width? 1.9, front_offset? 3.8}` in map metres and radians"),
    responses((status = 204), (status = 422, body = Problem)))]
pub async fn set_ego(
    State(app): AppState,
    ApiJson(pose): ApiJson<EgoPose>,
) -> Result<StatusCode, Problem> {
    if let Some(problem) = pose.problem() {
        return Err(Problem::unprocessable(problem));
    }
    app.bus.publish(&topics::EGO, &pose).await?;
    Ok(StatusCode::NO_CONTENT)
}

#[derive(Serialize, ToSchema)]
pub struct LightView {
    pub group: String,
    /// green, yellow or red; absent before the lights service published the group.
    pub color: Option<String>,
    pub next_change: Option<f64>,
    pub valid_until: Option<f64>,
    pub forced: bool,
}

fn color_name(c: LightColor) -> String {
    match c {
        LightColor::Green => "green",
        LightColor::Yellow => "yellow",
        LightColor::Red => "red",
    }
    .into()
}

fn light_view(group: &str, state: Option<&LightState>) -> LightView {
    LightView {
        group: group.to_string(),
        color: state.map(|s| color_name(s.color)),
        next_change: state.and_then(|s| s.next_change),
        valid_until: state.map(|s| s.valid_until),
        forced: state.is_some_and(|s| s.forced),
    }
}

/// Every light group of the map with its newest state.
#[utoipa::path(get, path = "/api/v1/lights", tag = "lights", responses((status = 200, body = Vec<LightView>)))]
pub async fn lights(State(app): AppState) -> Json<Vec<LightView>> {
    let v = app.view.read();
    Json(
        app.map
            .net
            .light_groups
            .iter()
            .map(|g| light_view(&g.name, v.lights.get(&g.name)))
            .collect(),
    )
}

/// `{"color": "red"}` forces a colour, `{"program": {green, yellow, red, offset?}}`
/// sets a fixed-time program, `{}` returns to the map's program.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Override {
    #[schema(value_type = Option<String>)]
    #[serde(default)]
    pub color: Option<LightColor>,
    #[schema(value_type = Option<Object>)]
    #[serde(default)]
    pub program: Option<LightProgram>,
}

/// Overrides one light group (force a colour or set a program).
#[utoipa::path(post, path = "/api/v1/lights/{group}/override", tag = "lights", security(("bearer" = [])),
    params(("group" = String, Path, description = "Light group name")), request_body = Override,
    responses((status = 200, body = LightView), (status = 404, body = Problem), (status = 422, body = Problem)))]
pub async fn override_light(
    State(app): AppState,
    Path(group): Path<String>,
    ApiJson(o): ApiJson<Override>,
) -> Result<Json<LightView>, Problem> {
    if app.map.net.light_group(&group).is_none() {
        return Err(Problem::not_found(format!(
            "no light group named '{group}'"
        )));
    }
    let request = LightOverride {
        group: group.clone(),
        color: o.color,
        program: o.program,
    };
    let key = app.bus.keys().key(&topics::LIGHTS_OVERRIDE);
    let state: LightState = app.bus.get(&key, Some(&request), app.bus_timeout).await?;
    Ok(Json(light_view(&group, Some(&state))))
}

#[derive(Serialize, ToSchema)]
pub struct CrosswalkView {
    pub name: String,
    pub polygon: Vec<[f64; 2]>,
    pub stop_points: Vec<[f64; 2]>,
    /// Absent before the crosswalks service published the area.
    pub occupied: Option<bool>,
    /// Root names of the pedestrians and cyclists on it.
    pub occupants: Vec<String>,
    pub valid_until: Option<f64>,
}

/// Every crosswalk area of the map with its occupancy.
#[utoipa::path(get, path = "/api/v1/crosswalks", tag = "crosswalks", responses((status = 200, body = Vec<CrosswalkView>)))]
pub async fn crosswalks(State(app): AppState) -> Json<Vec<CrosswalkView>> {
    let v = app.view.read();
    Json(
        app.map
            .net
            .crosswalks
            .iter()
            .map(|c| {
                let o = v.occupancy.get(&c.name);
                CrosswalkView {
                    name: c.name.clone(),
                    polygon: c.polygon.iter().map(|p| [p.x, p.y]).collect(),
                    stop_points: c
                        .stops
                        .iter()
                        .map(|s| [s.position.x, s.position.y])
                        .collect(),
                    occupied: o.map(|o| o.occupied),
                    occupants: o.map(|o| o.occupants.clone()).unwrap_or_default(),
                    valid_until: o.map(|o| o.valid_until),
                }
            })
            .collect(),
    )
}

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    /// Forward direction, radians counter-clockwise from +x.
    pub yaw: f64,
}

#[derive(Serialize, Deserialize, ToSchema)]
pub struct BlockedStop {
    pub blocked: bool,
    /// Distance to the stop point minus the stop buffer (when blocked).
    pub distance: Option<f64>,
    pub area: Option<String>,
}

/// TryGetBlockedStop for a pose: the nearest occupied crosswalk ahead, if any.
#[utoipa::path(post, path = "/api/v1/crosswalks/blocked-stop", tag = "crosswalks", request_body = Pose,
    responses((status = 200, body = BlockedStop), (status = 422, body = Problem)))]
pub async fn blocked_stop(
    State(app): AppState,
    ApiJson(p): ApiJson<Pose>,
) -> Result<Json<BlockedStop>, Problem> {
    if let Some(field) =
        trafficmesh_protocol::wire::first_non_finite(&[("x", p.x), ("y", p.y), ("yaw", p.yaw)])
    {
        return Err(Problem::unprocessable(format!(
            "field '{field}' is not a finite number"
        )));
    }
    let query = BlockedStopQuery {
        x: p.x,
        y: p.y,
        yaw: p.yaw,
    };
    let key = app.bus.keys().key(&topics::BLOCKED_STOP);
    let a: BlockedStopAnswer = app.bus.get(&key, Some(&query), app.bus_timeout).await?;
    Ok(Json(BlockedStop {
        blocked: a.blocked,
        distance: a.distance,
        area: a.area,
    }))
}
