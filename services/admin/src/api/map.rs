//! The map's geometry for the live map (and any other client).

use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;

use super::AppState;
use crate::mapinfo::MapGeometry;

/// Lanes, crosswalks, light stop lines, spawn points and vehicle kind names.
#[utoipa::path(get, path = "/api/v1/map", tag = "map", responses((status = 200, body = MapGeometry)))]
pub async fn map(State(app): AppState) -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "application/json")],
        app.map.geometry_json.clone(),
    )
}
