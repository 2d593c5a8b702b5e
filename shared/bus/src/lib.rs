//! The trafficmesh bus: key expressions, Zenoh session configuration and typed
//! JSON helpers. Payloads are serde_json with the Zenoh encoding
//! `application/json`; commands and answers are reliable, telemetry drops
//! samples rather than slow its publisher.

mod bus;
mod heartbeat;
mod lockstep;
mod ports;
pub mod runtime;
mod session;
mod status;
mod typed;

pub use bus::{Bus, Lane, Publisher};
pub use heartbeat::Vouch;
pub use lockstep::ROUND_TIMEOUT;
pub use ports::free_loopback_port;
pub use session::{BusArgs, DEFAULT_ENDPOINT, Role};
pub use status::{
    BadPayloads, REQUIRED_SERVICES, another_map, check_map, degraded_reasons, serve_status,
};
pub use typed::{Served, Subscription};

use thiserror::Error;

#[derive(Debug, Error)]
pub enum BusError {
    #[error(transparent)]
    ClusterName(#[from] trafficmesh_protocol::KeyError),
    #[error("zenoh config {what}: {reason}")]
    Config { what: String, reason: String },
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error(
        "the stepper runs another map (fingerprint {theirs}, this process's {ours}): its lane indices would name other lanes here; start every service of the cluster with the same map"
    )]
    AnotherMap { theirs: String, ours: String },
    #[error("{key}: no answer within {timeout_ms} ms (is the service running?)")]
    NoAnswer { key: String, timeout_ms: u128 },
    /// An error answer; `problems` lists each problem when the service gave a list.
    #[error("{key}: {message}")]
    Remote {
        key: String,
        message: String,
        problems: Vec<String>,
    },
    #[error("{key}: answer is not valid JSON for {what}: {reason}")]
    BadAnswer {
        key: String,
        what: &'static str,
        reason: String,
    },
}

impl From<zenoh::Error> for BusError {
    fn from(e: zenoh::Error) -> Self {
        BusError::Zenoh(e.to_string())
    }
}
