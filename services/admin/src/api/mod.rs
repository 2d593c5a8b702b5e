//! The REST API under `/api/v1`, the OpenAPI document generated from these
//! handlers, Swagger UI, `/metrics` and the live map.

mod auth;
mod cluster;
mod map;
mod signals;
mod spawn;
mod vehicles;

use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::{DefaultBodyLimit, State};
use axum::http::{StatusCode, header};
use axum::response::IntoResponse;
use axum::routing::{get, post, put};
use metrics_exporter_prometheus::PrometheusHandle;
use tower_http::cors::CorsLayer;
use tower_http::timeout::TimeoutLayer;
use trafficmesh_bus::Bus;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi};
use utoipa_swagger_ui::SwaggerUi;

use crate::live;
use crate::mapinfo::MapInfo;
use crate::problem::Problem;
use crate::view::ClusterView;

pub struct App {
    pub bus: Arc<Bus>,
    pub view: Arc<ClusterView>,
    pub map: MapInfo,
    pub token: String,
    pub metrics: PrometheusHandle,
    /// Services whose absence makes the cluster degraded.
    pub expected: Vec<String>,
    /// How long a request waits for a service's answer on the bus.
    pub bus_timeout: Duration,
}

pub type AppState = State<Arc<App>>;

pub struct Limits {
    pub max_body_bytes: usize,
    pub request_timeout: Duration,
    /// Origins allowed by CORS; empty = CORS off (same origin only).
    pub cors_origins: Vec<String>,
}

#[derive(OpenApi)]
#[openapi(
    info(
        title = "trafficmesh admin",
        description = "Operate a running trafficmesh cluster. Every mutating endpoint needs `Authorization: Bearer <token>`. Errors are RFC 9457 problem details."
    ),
    paths(
        cluster::health,
        cluster::status,
        spawn::get_config,
        spawn::put_config,
        spawn::save_config,
        spawn::load_config,
        spawn::branch_csv,
        vehicles::list,
        vehicles::one,
        vehicles::remove,
        vehicles::restart,
        signals::set_ego,
        signals::lights,
        signals::override_light,
        signals::crosswalks,
        signals::blocked_stop,
        map::map,
    ),
    modifiers(&BearerAuth)
)]
pub struct ApiDoc;

struct BearerAuth;

impl Modify for BearerAuth {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let components = openapi.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "bearer",
            SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
        );
    }
}

pub fn router(app: Arc<App>, limits: &Limits) -> Router {
    let mutating = Router::new()
        .route("/spawn-config", put(spawn::put_config))
        .route("/spawn-config/save", post(spawn::save_config))
        .route("/spawn-config/load", post(spawn::load_config))
        .route("/vehicles/remove", post(vehicles::remove))
        .route("/restart", post(vehicles::restart))
        .route("/ego", put(signals::set_ego))
        .route("/lights/{group}/override", post(signals::override_light))
        .route_layer(axum::middleware::from_fn_with_state(
            app.clone(),
            auth::require_token,
        ));
    let api = Router::new()
        .route("/health", get(cluster::health))
        .route("/status", get(cluster::status))
        .route("/spawn-config", get(spawn::get_config))
        .route("/branch-decisions.csv", get(spawn::branch_csv))
        .route("/vehicles", get(vehicles::list))
        .route("/vehicles/{id}", get(vehicles::one))
        .route("/lights", get(signals::lights))
        .route("/crosswalks", get(signals::crosswalks))
        .route("/crosswalks/blocked-stop", post(signals::blocked_stop))
        .route("/map", get(map::map))
        .route("/live", get(live::socket))
        .merge(mutating)
        .fallback(|| async { Problem::not_found("no such endpoint") });
    let mut router = Router::new()
        .nest("/api/v1", api)
        .route("/metrics", get(metrics_text))
        .merge(live::pages())
        .with_state(app)
        .merge(SwaggerUi::new("/swagger-ui").url("/api/v1/openapi.json", ApiDoc::openapi()))
        .layer(axum::middleware::from_fn(crate::metrics::track_requests))
        .layer(DefaultBodyLimit::max(limits.max_body_bytes))
        .layer(axum::middleware::from_fn_with_state(
            limits.max_body_bytes,
            refuse_announced_oversize,
        ))
        .layer(TimeoutLayer::with_status_code(
            StatusCode::REQUEST_TIMEOUT,
            limits.request_timeout,
        ));
    if !limits.cors_origins.is_empty() {
        let origins = limits
            .cors_origins
            .iter()
            .filter_map(|o| o.parse().ok())
            .collect::<Vec<axum::http::HeaderValue>>();
        router = router.layer(
            CorsLayer::new()
                .allow_origin(origins)
                .allow_headers([header::AUTHORIZATION, header::CONTENT_TYPE])
                .allow_methods(tower_http::cors::Any),
        );
    }
    router
}

/// Refuses a body whose Content-Length is over the limit before reading it
/// (bodies without one are cut at the limit by `DefaultBodyLimit`).
async fn refuse_announced_oversize(
    State(limit): State<usize>,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> axum::response::Response {
    let announced = request
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    match announced {
        Some(n) if n > limit as u64 => Problem::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            format!("the request body of {n} bytes is over the limit of {limit} bytes"),
        )
        .into_response(),
        _ => next.run(request).await,
    }
}

async fn metrics_text(State(app): AppState) -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        app.metrics.render(),
    )
}
