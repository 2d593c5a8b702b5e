//! `/metrics` in the Prometheus text format: the cluster's figures as the bus
//! carries them, and the admin's own REST requests.

use std::time::{Duration, Instant};

use axum::extract::{MatchedPath, Request};
use axum::middleware::Next;
use axum::response::Response;
use metrics::{counter, gauge, histogram};
use metrics_exporter_prometheus::{Matcher, PrometheusBuilder, PrometheusHandle};
use trafficmesh_protocol::wire::{Clock, Event, ServiceStatus};

/// Tick durations around the 20 ms real-time budget at 50 Hz.
const TICK_BUCKETS: &[f64] = &[
    0.0005, 0.001, 0.002, 0.005, 0.01, 0.015, 0.02, 0.03, 0.05, 0.1, 0.25,
];
const REQUEST_BUCKETS: &[f64] = &[
    0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.5, 1.0, 5.0,
];

/// Installs the process-wide recorder; the handle renders `/metrics`.
pub fn install() -> anyhow::Result<PrometheusHandle> {
    let handle = PrometheusBuilder::new()
        .set_buckets_for_metric(
            Matcher::Full("trafficmesh_tick_duration_seconds".into()),
            TICK_BUCKETS,
        )?
        .set_buckets_for_metric(
            Matcher::Full("trafficmesh_admin_request_duration_seconds".into()),
            REQUEST_BUCKETS,
        )?
        .install_recorder()?;
    // Histograms drain their buffers on upkeep; without the HTTP listener nobody else calls it.
    let upkeep = handle.clone();
    tokio::spawn(async move {
        loop {
            tokio::time::sleep(Duration::from_secs(5)).await;
            upkeep.run_upkeep();
        }
    });
    Ok(handle)
}

pub fn record_clock(c: &Clock) {
    histogram!("trafficmesh_tick_duration_seconds").record(c.tick_ms / 1e3);
    gauge!("trafficmesh_vehicles").set(c.vehicles as f64);
    gauge!("trafficmesh_simulation_time_seconds").set(c.time);
    gauge!("trafficmesh_tick_rate_hz").set(c.tick_rate);
}

pub fn record_events(events: &[Event]) {
    for e in events {
        match e {
            Event::Spawned { kind, .. } => {
                counter!("trafficmesh_spawns_total", "kind" => kind.clone()).increment(1)
            }
            Event::Despawned { reason, .. } => {
                counter!("trafficmesh_despawns_total", "reason" => reason.clone()).increment(1)
            }
            _ => {}
        }
    }
}

/// Counters the services keep themselves, taken from their status.
pub fn record_status(s: &ServiceStatus) {
    for (key, n) in &s.bad_payloads_by_key {
        counter!("trafficmesh_bad_payloads_total", "service" => s.service.clone(), "key" => key.clone())
            .absolute(*n);
    }
    if s.service == "spawner"
        && let Some(rejected) = s.details.get("rejected").and_then(|r| r.as_object())
    {
        for (reason, n) in rejected {
            if let Some(n) = n.as_u64() {
                counter!("trafficmesh_spawns_rejected_total", "reason" => reason.clone())
                    .absolute(n);
            }
        }
    }
}

/// Counts every REST request by route template, method and status.
pub async fn track_requests(request: Request, next: Next) -> Response {
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map(|p| p.as_str().to_string())
        .unwrap_or_else(|| "unmatched".into());
    let method = request.method().to_string();
    let started = Instant::now();
    let response = next.run(request).await;
    let status = response.status().as_u16().to_string();
    histogram!("trafficmesh_admin_request_duration_seconds", "route" => route.clone())
        .record(started.elapsed().as_secs_f64());
    counter!("trafficmesh_admin_requests_total", "route" => route, "method" => method, "status" => status)
        .increment(1);
    response
}
