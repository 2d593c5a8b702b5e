//! Health of the admin itself, and the cluster's status from the view.

use std::collections::BTreeMap;

use axum::Json;
use axum::extract::State;
use serde::Serialize;
use utoipa::ToSchema;

use super::AppState;

#[derive(Serialize, ToSchema)]
pub struct Health {
    /// Always "ok": the admin is up and answering.
    pub status: &'static str,
}

/// The admin is up.
#[utoipa::path(get, path = "/api/v1/health", tag = "cluster", responses((status = 200, body = Health)))]
pub async fn health() -> Json<Health> {
    Json(Health { status: "ok" })
}

#[derive(Serialize, ToSchema)]
pub struct ClusterStatus {
    pub cluster: String,
    /// A required service is not alive, or the stepper drives on a fail-safe
    /// (stale light or crosswalk states, no intersection service answering).
    pub degraded: bool,
    /// Why the cluster is degraded, one line each.
    pub reasons: Vec<String>,
    /// Simulation time of the newest clock (seconds), absent before the first tick.
    pub time: Option<f64>,
    pub tick: Option<u64>,
    /// Ticks per wall-clock second over the last second.
    pub tick_rate: Option<f64>,
    /// Duration of the newest tick, milliseconds.
    pub tick_ms: Option<f64>,
    pub vehicles: Option<usize>,
    pub services: BTreeMap<String, ServiceView>,
}

#[derive(Serialize, ToSchema)]
pub struct ServiceView {
    /// Its liveliness token is present.
    pub alive: bool,
    /// The host it runs on.
    pub host: Option<String>,
    pub pid: Option<u32>,
    /// Seconds since its last status (published at 1 Hz).
    pub status_age_s: Option<f64>,
    pub bad_payloads: u64,
    pub bad_payloads_by_key: BTreeMap<String, u64>,
    /// The service's own counters, as it reports them.
    #[schema(value_type = Object)]
    pub details: serde_json::Value,
}

/// How long a service's last status speaks for it: five of its once-a-second
/// statuses.
const STATUS_FRESH: std::time::Duration = std::time::Duration::from_secs(5);

/// Which services are alive, whether the cluster is degraded, simulation time,
/// tick rate, vehicle count and bad-payload counters. Answered from the admin's
/// view of the bus, without a round trip.
#[utoipa::path(get, path = "/api/v1/status", tag = "cluster", responses((status = 200, body = ClusterStatus)))]
pub async fn status(State(app): AppState) -> Json<ClusterStatus> {
    let v = app.view.read();
    let mut services: BTreeMap<String, ServiceView> = BTreeMap::new();
    for name in v.alive.iter().chain(v.statuses.keys()).chain(&app.expected) {
        let status = v.statuses.get(name);
        services.entry(name.clone()).or_insert_with(|| ServiceView {
            alive: v.alive.contains(name),
            host: status.map(|(s, _)| s.host.clone()),
            pid: status.map(|(s, _)| s.pid),
            status_age_s: status.map(|(_, at)| at.elapsed().as_secs_f64()),
            bad_payloads: status.map_or(0, |(s, _)| s.bad_payloads),
            bad_payloads_by_key: status
                .map(|(s, _)| s.bad_payloads_by_key.clone())
                .unwrap_or_default(),
            details: status.map_or(serde_json::Value::Null, |(s, _)| s.details.clone()),
        });
    }
    // A status older than a few of its seconds says nothing of now.
    let stepper = v
        .statuses
        .get("stepper")
        .filter(|(_, at)| at.elapsed() < STATUS_FRESH)
        .map(|(s, _)| s);
    let reasons = trafficmesh_bus::degraded_reasons(&app.expected, &v.alive, stepper);
    let clock = v.clock.as_ref();
    Json(ClusterStatus {
        cluster: app.bus.keys().cluster().to_string(),
        degraded: !reasons.is_empty(),
        reasons,
        time: clock.map(|c| c.time),
        tick: clock.map(|c| c.tick),
        tick_rate: clock.map(|c| c.tick_rate),
        tick_ms: clock.map(|c| c.tick_ms),
        vehicles: clock.map(|c| c.vehicles),
        services,
    })
}
