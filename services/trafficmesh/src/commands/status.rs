//! `trafficmesh status [--json]`: the cluster's health from any host: each
//! service that is alive or expected, with its host, pid, how far its clock
//! lags the stepper's, and its error count (payloads it dropped), and
//! whether the cluster is degraded and why (the admin's rules).

use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use anyhow::Result;
use clap::Args;
use serde::Serialize;
use trafficmesh_bus::{Bus, BusArgs, Role};
use trafficmesh_protocol::Keys;
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::ServiceStatus;

#[derive(Args)]
pub struct StatusArgs {
    #[command(flatten)]
    bus: BusArgs,
    /// Services whose absence makes the cluster degraded.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = trafficmesh_bus::REQUIRED_SERVICES
    )]
    expect: Vec<String>,
    /// Print one JSON object: `{cluster, degraded, reasons, time, services:
    /// {name: {alive, host, pid, lag_s, errors, peers}}}`.
    #[arg(long)]
    json: bool,
    /// How long to wait for every expected service to answer, seconds.
    #[arg(long, default_value_t = 2.0)]
    timeout: f64,
}

#[derive(Serialize)]
struct Health {
    cluster: String,
    degraded: bool,
    reasons: Vec<String>,
    /// The stepper's simulation time, seconds.
    time: Option<f64>,
    services: BTreeMap<String, ServiceHealth>,
}

#[derive(Serialize)]
struct ServiceHealth {
    alive: bool,
    host: Option<String>,
    pid: Option<u32>,
    /// Simulated seconds its clock is behind the stepper's (services that
    /// follow the clock; none for those without one). The answers come a
    /// few hundred milliseconds apart: read it to about half a second.
    lag_s: Option<f64>,
    /// Payloads it dropped as unusable.
    errors: u64,
    /// The Zenoh sessions it is linked to (`router <zid>`, `peer <zid>`).
    peers: Vec<String>,
}

pub fn run(a: StatusArgs) -> Result<()> {
    a.bus.keys()?;
    if !(a.timeout.is_finite() && a.timeout > 0.0) {
        anyhow::bail!("--timeout must be a positive number of seconds");
    }
    let wait = Duration::from_secs_f64(a.timeout);
    let health = trafficmesh_bus::runtime::tokio_runtime(1)?.block_on(async {
        let bus = Bus::open(&a.bus, Role::Member, "status").await?;
        bus.wait_for_peer(wait).await;
        let keys = bus.keys().clone();
        // A session just opened meets the others one by one, and a
        // service's status can reach it before its liveliness token: ask
        // again until every expected service is alive and the live ones
        // and the ones that answered are the same, or the wait is over.
        let deadline = tokio::time::Instant::now() + wait;
        let mut alive = BTreeSet::new();
        let mut statuses = BTreeMap::new();
        loop {
            alive.extend(live_services(&bus, &keys).await);
            for s in bus
                .get_each::<ServiceStatus>(
                    &keys.key_all(&topics::STATUS),
                    Duration::from_millis(300),
                )
                .await?
            {
                statuses.insert(s.service.clone(), s);
            }
            if heard_all(&a.expect, &alive, &statuses) || tokio::time::Instant::now() >= deadline {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        anyhow::Ok(health(keys.cluster(), &a.expect, &alive, &statuses))
    })?;
    if a.json {
        println!("{}", serde_json::to_string(&health)?);
    } else {
        print!("{}", text(&health));
    }
    Ok(())
}

/// Every expected service is alive, and the live services and those that
/// answered for their status are the same.
fn heard_all(
    expected: &[String],
    alive: &BTreeSet<String>,
    statuses: &BTreeMap<String, ServiceStatus>,
) -> bool {
    expected.iter().all(|e| alive.contains(e)) && alive.iter().eq(statuses.keys())
}

/// The services whose liveliness tokens are present.
pub async fn live_services(bus: &Bus, keys: &Keys) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    if let Ok(replies) = bus
        .session()
        .liveliness()
        .get(keys.key_all(&topics::ALIVE))
        .timeout(Duration::from_millis(300))
        .await
    {
        while let Ok(r) = replies.recv_async().await {
            if let Ok(s) = r.result() {
                names.insert(Keys::last_chunk(s.key_expr().as_str()).to_string());
            }
        }
    }
    names
}

fn health(
    cluster: &str,
    expected: &[String],
    alive: &BTreeSet<String>,
    statuses: &BTreeMap<String, ServiceStatus>,
) -> Health {
    let stepper = statuses.get("stepper");
    let time = stepper.map(|s| s.time);
    let names: BTreeSet<&String> = alive
        .iter()
        .chain(statuses.keys())
        .chain(expected)
        .collect();
    let services = names
        .into_iter()
        .map(|name| {
            let status = statuses.get(name);
            let lag = match (time, status) {
                // Answers a few hundred milliseconds apart can put a
                // service ahead of the stepper: that is no lag.
                (Some(now), Some(s)) if name != "stepper" && s.time > 0.0 => {
                    Some((now - s.time).max(0.0))
                }
                _ => None,
            };
            let health = ServiceHealth {
                alive: alive.contains(name),
                host: status.map(|s| s.host.clone()),
                pid: status.map(|s| s.pid),
                lag_s: lag,
                errors: status.map_or(0, |s| s.bad_payloads),
                peers: status.map_or_else(Vec::new, |s| s.peers.clone()),
            };
            (name.clone(), health)
        })
        .collect();
    let reasons = trafficmesh_bus::degraded_reasons(expected, alive, stepper);
    Health {
        cluster: cluster.to_string(),
        degraded: !reasons.is_empty(),
        reasons,
        time,
        services,
    }
}

fn text(h: &Health) -> String {
    let mut out = format!(
        "cluster {}: {}{}\n",
        h.cluster,
        if h.degraded { "DEGRADED" } else { "ok" },
        h.time.map_or(String::new(), |t| format!(" at t={t:.1} s"))
    );
    for r in &h.reasons {
        out.push_str(&format!("  - {r}\n"));
    }
    out.push_str(&format!(
        "{:<14} {:<6} {:<20} {:>8} {:>8} {:>7}  {}\n",
        "service", "alive", "host", "pid", "lag_s", "errors", "zenoh links"
    ));
    for (name, s) in &h.services {
        out.push_str(&format!(
            "{:<14} {:<6} {:<20} {:>8} {:>8} {:>7}  {}\n",
            name,
            if s.alive { "yes" } else { "NO" },
            s.host.as_deref().unwrap_or("-"),
            s.pid.map_or("-".into(), |p| p.to_string()),
            s.lag_s.map_or("-".into(), |l| format!("{l:.2}")),
            s.errors,
            s.peers.len()
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(service: &str) -> (String, ServiceStatus) {
        let s = ServiceStatus {
            service: service.to_string(),
            ..Default::default()
        };
        (service.to_string(), s)
    }

    /// A service that answered for its status before its liveliness token
    /// reached the session is not yet heard in full: ask again, else it
    /// would be reported as not alive.
    #[test]
    fn a_service_that_answered_but_is_not_yet_seen_alive_is_asked_again() {
        let statuses: BTreeMap<_, _> = [status("stepper"), status("admin")].into();
        let alive: BTreeSet<String> = ["stepper".to_string()].into();
        assert!(!heard_all(&[], &alive, &statuses));
        let alive: BTreeSet<String> = ["stepper".to_string(), "admin".into()].into();
        assert!(heard_all(&[], &alive, &statuses));
        assert!(!heard_all(&["lights".into()], &alive, &statuses));
    }
}
