//! The spawn config (get, put, save, load) and the branch-decision CSV, all
//! answered by the spawner over the bus.

use axum::Json;
use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;
use serde::Serialize;
use trafficmesh_model::TrafficSpawnConfig;
use trafficmesh_protocol::topics;
use utoipa::ToSchema;

use super::AppState;
use crate::problem::{ApiJson, Problem};

/// The spawn config in force.
#[utoipa::path(get, path = "/api/v1/spawn-config", tag = "spawn config",
    responses((status = 200, body = serde_json::Value, description = "the AWSIM reference's traffic_spawn.json: spawnRates [{lane, spawnsPerMinute}], branchWeights [{fromLane, next: [{lane, weight}]}]"), (status = 503, body = Problem)))]
pub async fn get_config(State(app): AppState) -> Result<Json<TrafficSpawnConfig>, Problem> {
    let key = app.bus.keys().key(&topics::SPAWN_CONFIG);
    Ok(Json(
        app.bus.get::<(), _>(&key, None, app.bus_timeout).await?,
    ))
}

/// Replaces the spawn config. Unknown lanes, negative or non-finite rates and
/// weights, and empty `next` lists are refused with 422 listing every problem;
/// nothing is applied then.
#[utoipa::path(put, path = "/api/v1/spawn-config", tag = "spawn config", security(("bearer" = [])),
    request_body(content = serde_json::Value, description = "the AWSIM reference's traffic_spawn.json: spawnRates [{lane, spawnsPerMinute}], branchWeights [{fromLane, next: [{lane, weight}]}]"),
    responses((status = 200, body = serde_json::Value, description = "the AWSIM reference's traffic_spawn.json: spawnRates [{lane, spawnsPerMinute}], branchWeights [{fromLane, next: [{lane, weight}]}]"), (status = 422, body = Problem), (status = 401, body = Problem)))]
pub async fn put_config(
    State(app): AppState,
    ApiJson(config): ApiJson<TrafficSpawnConfig>,
) -> Result<Json<TrafficSpawnConfig>, Problem> {
    let key = app
        .bus
        .keys()
        .key(&trafficmesh_protocol::topics::SPAWN_CONFIG_SET);
    Ok(Json(
        app.bus.get(&key, Some(&config), app.bus_timeout).await?,
    ))
}

#[derive(Serialize, serde::Deserialize, ToSchema)]
pub struct Saved {
    /// The file written (atomically; the previous version kept as `.bak`).
    #[schema(value_type = String)]
    pub saved: serde_json::Value,
}

/// Save Spawn Config JSON: writes the config in force to the spawner's file.
#[utoipa::path(post, path = "/api/v1/spawn-config/save", tag = "spawn config", security(("bearer" = [])),
    responses((status = 200, body = Saved), (status = 422, body = Problem)))]
pub async fn save_config(State(app): AppState) -> Result<Json<Saved>, Problem> {
    let key = app
        .bus
        .keys()
        .key(&trafficmesh_protocol::topics::SPAWN_CONFIG_SAVE);
    Ok(Json(
        app.bus.get::<(), _>(&key, None, app.bus_timeout).await?,
    ))
}

/// Load Spawn Config JSON: reads the spawner's file and applies it.
#[utoipa::path(post, path = "/api/v1/spawn-config/load", tag = "spawn config", security(("bearer" = [])),
    responses((status = 200, body = serde_json::Value, description = "the AWSIM reference's traffic_spawn.json: spawnRates [{lane, spawnsPerMinute}], branchWeights [{fromLane, next: [{lane, weight}]}]"), (status = 422, body = Problem)))]
pub async fn load_config(State(app): AppState) -> Result<Json<TrafficSpawnConfig>, Problem> {
    let key = app
        .bus
        .keys()
        .key(&trafficmesh_protocol::topics::SPAWN_CONFIG_LOAD);
    Ok(Json(
        app.bus.get::<(), _>(&key, None, app.bus_timeout).await?,
    ))
}

/// The branch-decision statistics as CSV: the bytes the spawner writes on shutdown.
#[utoipa::path(get, path = "/api/v1/branch-decisions.csv", tag = "spawn config",
    responses((status = 200, content_type = "text/csv", body = String)))]
pub async fn branch_csv(State(app): AppState) -> Result<impl IntoResponse, Problem> {
    let key = app
        .bus
        .keys()
        .key(&trafficmesh_protocol::topics::BRANCH_CSV);
    let bytes = app.bus.get_raw::<()>(&key, None, app.bus_timeout).await?;
    Ok((
        [
            (header::CONTENT_TYPE, "text/csv; charset=utf-8"),
            (
                header::CONTENT_DISPOSITION,
                "attachment; filename=\"traffic_branch_decisions.csv\"",
            ),
        ],
        bytes,
    ))
}
