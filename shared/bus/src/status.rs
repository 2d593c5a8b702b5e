//! Bad-payload counters and the status every service publishes once a second
//! on `<cluster>/status/<service>` and answers as a query.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::Mutex;
use std::time::Duration;
use trafficmesh_protocol::topics;

use trafficmesh_protocol::wire::ServiceStatus;

use crate::{Bus, BusError, Lane};

/// A key's bad payloads are logged at most this often (the first at once):
/// a flood of them must not become a flood of log lines.
const LOG_EVERY: Duration = Duration::from_secs(10);

#[derive(Debug, Default)]
pub struct BadPayloads {
    by_key: Mutex<BTreeMap<String, u64>>,
    /// Per key: when one was last logged, and how many came since.
    logged: Mutex<BTreeMap<String, (std::time::Instant, u64)>>,
}

impl BadPayloads {
    /// Counts one more on `key`, and logs why, unless one on the same key
    /// was logged within [`LOG_EVERY`] (the next line then says how many
    /// came in between).
    pub fn count(&self, key: &str, reason: &str) {
        *self
            .by_key
            .lock()
            .expect("counter lock")
            .entry(key.to_string())
            .or_insert(0) += 1;
        let mut logged = self.logged.lock().expect("log lock");
        let now = std::time::Instant::now();
        match logged.get_mut(key) {
            Some((at, unlogged)) if now.duration_since(*at) < LOG_EVERY => *unlogged += 1,
            Some((at, unlogged)) => {
                tracing::warn!(
                    "dropped bad payload on {key}: {reason} ({} more since the last such line)",
                    *unlogged
                );
                (*at, *unlogged) = (now, 0);
            }
            None => {
                tracing::warn!("dropped bad payload on {key}: {reason}");
                logged.insert(key.to_string(), (now, 0));
            }
        }
    }

    pub fn snapshot(&self) -> (u64, BTreeMap<String, u64>) {
        let map = self.by_key.lock().expect("counter lock").clone();
        (map.values().sum(), map)
    }
}

/// The Zenoh sessions `session` is linked to: its routers and peers, by id.
async fn zenoh_peers(session: &zenoh::Session) -> Vec<String> {
    let info = session.info();
    let mut peers: Vec<String> = info
        .routers_zid()
        .await
        .map(|z| format!("router {z}"))
        .collect();
    peers.extend(info.peers_zid().await.map(|z| format!("peer {z}")));
    peers
}

/// Publishes the service's status once a second and answers gets for it.
/// `details` gives the simulation time and the service's own counters.
pub fn serve_status(
    bus: Arc<Bus>,
    map: Option<u64>,
    details: Arc<dyn Fn() -> (f64, serde_json::Value) + Send + Sync>,
) {
    let host = hostname();
    tokio::spawn(async move {
        let key = bus.keys().key_at(&topics::STATUS, bus.service());
        let (Ok(publisher), Ok(queryable)) = (
            // Once a second: one lost where a link stops draining is
            // replaced by the next, and holds up nobody meanwhile.
            bus.publisher(key.clone(), Lane::Telemetry).await,
            bus.queryable(&key).await,
        ) else {
            tracing::error!("cannot declare {key}");
            return;
        };
        let status = |peers: Vec<String>| {
            let (time, details) = details();
            let (bad_payloads, bad_payloads_by_key) = bus.bad_payloads().snapshot();
            ServiceStatus {
                service: bus.service().to_string(),
                host: host.clone(),
                pid: std::process::id(),
                time,
                bad_payloads,
                bad_payloads_by_key,
                details,
                map: map.map(fingerprint_text),
                peers,
            }
        };
        let mut every_second = tokio::time::interval(Duration::from_secs(1));
        loop {
            tokio::select! {
                _ = every_second.tick() => {
                    let _ = publisher.put(&status(zenoh_peers(bus.session()).await)).await;
                }
                Ok(query) = queryable.recv_async() => {
                    bus.reply(&query, &status(zenoh_peers(bus.session()).await)).await;
                }
            }
        }
    });
}

/// This host's name, as the kernel has it ("?" if it cannot be read).
fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "?".into())
}

/// The services without which a cluster is degraded, unless told otherwise
/// (`--expect` of the admin and of `trafficmesh status`).
pub const REQUIRED_SERVICES: &str = "stepper,spawner,lights,crosswalks";

/// Why a cluster is degraded, one line each: a service of `expected` is not
/// `alive`, the stepper is alive but gave no status (`stepper` None), or it
/// drives on a fail-safe
/// (stale light or crosswalk states, no answer from the intersection
/// service). Empty when healthy. The admin's status and `trafficmesh
/// status` say the same.
pub fn degraded_reasons(
    expected: &[String],
    alive: &std::collections::BTreeSet<String>,
    stepper: Option<&ServiceStatus>,
) -> Vec<String> {
    let mut reasons: Vec<String> = expected
        .iter()
        .filter(|s| !alive.contains(*s))
        .map(|s| format!("{s} is not alive"))
        .collect();
    // Alive but silent: whether its fail-safes are in force is unknown, and
    // that is no healthy cluster.
    if stepper.is_none() && alive.contains("stepper") {
        reasons.push(
            "the stepper is alive but did not answer for its status: its fail-safes are unknown"
                .into(),
        );
    }
    if let Some(stepper) = stepper {
        for (flag, what) in [
            (
                "lights_stale",
                "its light states are stale: every light counts as red",
            ),
            (
                "crosswalks_stale",
                "its crosswalk states are stale: every crosswalk counts as blocked",
            ),
            (
                "intersections_unanswered",
                "the intersection service does not answer: no way is granted",
            ),
        ] {
            if stepper.details.get(flag).and_then(|f| f.as_bool()) == Some(true) {
                reasons.push(format!("the stepper's fail-safe is in force: {what}"));
            }
        }
    }
    reasons
}

/// A map fingerprint as statuses carry it.
fn fingerprint_text(map: u64) -> String {
    format!("{map:016x}")
}

/// The error when `stepper`'s status shows another map than `own`.
fn another_than(stepper: ServiceStatus, own: u64) -> Option<BusError> {
    let ours = fingerprint_text(own);
    match stepper.map {
        Some(theirs) if theirs != ours => Some(BusError::AnotherMap { theirs, ours }),
        _ => None,
    }
}

/// Asks the stepper for its status once, before a service says anything on
/// the bus: an error when it runs another map than `own`. A stepper not (yet)
/// answering is no error; [`another_map`] keeps watching.
pub async fn check_map(bus: &Bus, own: u64) -> Result<(), BusError> {
    let key = bus.keys().key_at(&topics::STATUS, "stepper");
    match bus
        .get::<(), ServiceStatus>(&key, None, Duration::from_secs(1))
        .await
    {
        Ok(status) => another_than(status, own).map_or(Ok(()), Err),
        Err(_) => Ok(()),
    }
}

/// Returns once the stepper reports another map than `own` (a fingerprint):
/// its lane indices would name other lanes here, so the service must stop
/// rather than talk to it. Never returns while the maps agree.
pub async fn another_map(bus: &Bus, own: u64) -> BusError {
    let key = bus.keys().key_at(&topics::STATUS, "stepper");
    let subscriber = match bus.subscribe(&key).await {
        Ok(s) => s,
        Err(e) => return e,
    };
    while let Some(status) = bus.next_latest::<ServiceStatus>(&subscriber).await {
        if let Some(refusal) = another_than(status, own) {
            return refusal;
        }
    }
    std::future::pending().await
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stepper(flags: serde_json::Value) -> ServiceStatus {
        ServiceStatus {
            service: "stepper".into(),
            details: flags,
            ..ServiceStatus::default()
        }
    }

    #[test]
    fn a_cluster_is_degraded_by_a_missing_service_a_silent_stepper_or_a_fail_safe() {
        let expected: Vec<String> = ["stepper", "lights"].map(String::from).to_vec();
        let all: std::collections::BTreeSet<String> = expected.iter().cloned().collect();
        let calm = stepper(serde_json::json!({"lights_stale": false}));
        assert!(degraded_reasons(&expected, &all, Some(&calm)).is_empty());

        let no_lights = ["stepper".to_string()].into_iter().collect();
        let reasons = degraded_reasons(&expected, &no_lights, Some(&calm));
        assert_eq!(reasons, ["lights is not alive"]);

        let silent = degraded_reasons(&expected, &all, None);
        assert_eq!(silent.len(), 1);
        assert!(silent[0].contains("did not answer"), "{silent:?}");

        let stale = stepper(serde_json::json!({"lights_stale": true}));
        let reasons = degraded_reasons(&expected, &all, Some(&stale));
        assert_eq!(reasons.len(), 1);
        assert!(
            reasons[0].contains("every light counts as red"),
            "{reasons:?}"
        );
    }
}
