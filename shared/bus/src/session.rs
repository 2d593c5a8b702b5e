//! Zenoh session configuration from flags or a file. The default is the
//! embedded cluster: peer mode on loopback, no multicast, one well-known
//! endpoint (the stepper listens there, everybody else connects to it and
//! listens on a port of its own so that peers meet directly through gossip).

use std::path::PathBuf;

use clap::Args;
use zenoh::Config;

use crate::BusError;
use trafficmesh_protocol::Keys;

/// The endpoint of the embedded cluster.
pub const DEFAULT_ENDPOINT: &str = "tcp/127.0.0.1:7447";

/// Bus flags every service and client command takes.
#[derive(Args, Clone, Debug)]
pub struct BusArgs {
    /// Cluster name: the first chunk of every key, so clusters can share a network.
    #[arg(long, env = "TRAFFICMESH_CLUSTER", default_value = "trafficmesh")]
    pub cluster: String,
    /// A Zenoh config file (JSON5). Flags below override its mode and endpoints.
    #[arg(long, env = "TRAFFICMESH_ZENOH_CONFIG")]
    pub zenoh_config: Option<PathBuf>,
    /// Zenoh mode: peer, client (behind a router) or router.
    #[arg(long)]
    pub mode: Option<String>,
    /// Endpoints to connect to (repeatable), e.g. tcp/10.0.0.5:7447.
    #[arg(long = "connect", env = "TRAFFICMESH_CONNECT", value_delimiter = ',')]
    pub connect: Vec<String>,
    /// Endpoints to listen on (repeatable). Default: the well-known endpoint for
    /// the stepper, a free loopback port for the others.
    #[arg(long = "listen", env = "TRAFFICMESH_LISTEN", value_delimiter = ',')]
    pub listen: Vec<String>,
}

/// How a process takes part in the embedded default topology.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Listens on the well-known endpoint (the stepper).
    Hub,
    /// Connects to the well-known endpoint.
    Member,
}

impl BusArgs {
    pub fn keys(&self) -> Result<Keys, BusError> {
        Ok(Keys::new(&self.cluster)?)
    }

    /// The Zenoh config: the file if given, else the embedded default; then the flags.
    pub fn zenoh_config(&self, role: Role) -> Result<Config, BusError> {
        let mut config = match &self.zenoh_config {
            Some(path) => config_file(path)?,
            None => embedded_default(role)?,
        };
        if let Some(mode) = &self.mode {
            if !matches!(mode.as_str(), "peer" | "client" | "router") {
                return Err(BusError::Config {
                    what: "--mode".into(),
                    reason: format!("'{mode}' is not peer, client or router"),
                });
            }
            insert(
                &mut config,
                "mode",
                &serde_json::to_string(mode).expect("string"),
            )?;
        }
        if !self.connect.is_empty() {
            let eps: Vec<String> = self.connect.iter().map(|e| with_fast_retry(e)).collect();
            insert(
                &mut config,
                "connect/endpoints",
                &serde_json::to_string(&eps).expect("list"),
            )?;
        }
        if !self.listen.is_empty() {
            insert(
                &mut config,
                "listen/endpoints",
                &serde_json::to_string(&self.listen).expect("list"),
            )?;
        }
        Ok(config)
    }
}

/// Reads a Zenoh config file with its `${VAR}`s replaced by the
/// environment's values: one file serves every service of a deployment,
/// each naming its own certificate, password or cluster
/// (`${TRAFFICMESH_IDENTITY}`). A variable that is not set is an error that
/// names it.
fn config_file(path: &std::path::Path) -> Result<Config, BusError> {
    let error = |reason: String| BusError::Config {
        what: path.display().to_string(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
    let text = expand_env(&text, |name| std::env::var(name).ok()).map_err(error)?;
    Config::from_json5(&text).map_err(|e| error(e.to_string()))
}

/// `text` with each `${NAME}` replaced by `lookup(NAME)`.
fn expand_env(text: &str, lookup: impl Fn(&str) -> Option<String>) -> Result<String, String> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("${") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 2..];
        let end = after.find('}').ok_or_else(|| {
            format!(
                "'${{' without a closing '}}': {}",
                &rest[start..].lines().next().unwrap_or("")
            )
        })?;
        let name = &after[..end];
        let value = lookup(name).ok_or_else(|| {
            format!("it uses ${{{name}}}, and the environment variable {name} is not set")
        })?;
        out.push_str(&value);
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

fn embedded_default(role: Role) -> Result<Config, BusError> {
    let mut config = Config::default();
    insert(&mut config, "mode", "\"peer\"")?;
    insert(&mut config, "scouting/multicast/enabled", "false")?;
    let (listen, connect) = match role {
        Role::Hub => (vec![DEFAULT_ENDPOINT.to_string()], vec![]),
        Role::Member => (
            vec!["tcp/127.0.0.1:0".to_string()],
            vec![with_fast_retry(DEFAULT_ENDPOINT)],
        ),
    };
    insert(
        &mut config,
        "listen/endpoints",
        &serde_json::to_string(&listen).expect("list"),
    )?;
    insert(
        &mut config,
        "connect/endpoints",
        &serde_json::to_string(&connect).expect("list"),
    )?;
    Ok(config)
}

/// Re-dial quickly when the other side starts later or restarts (zenoh's
/// default first retry is after a second).
fn with_fast_retry(endpoint: &str) -> String {
    if endpoint.contains('#') {
        endpoint.to_string()
    } else {
        format!("{endpoint}#retry_period_init_ms=50;retry_period_max_ms=500")
    }
}

fn insert(config: &mut Config, key: &str, json: &str) -> Result<(), BusError> {
    config
        .insert_json5(key, json)
        .map_err(|e| BusError::Config {
            what: key.to_string(),
            reason: e.to_string(),
        })
}

#[cfg(test)]
mod tests {
    use super::expand_env;

    #[test]
    fn environment_variables_in_a_config_are_expanded_and_a_missing_one_is_named() {
        let env = |name: &str| (name == "ID").then(|| "stepper".to_string());
        assert_eq!(
            expand_env("{ a: \"${ID}.pem\", b: \"${ID}\" }", env).unwrap(),
            "{ a: \"stepper.pem\", b: \"stepper\" }"
        );
        let missing = expand_env("{ key: \"${TLS_DIR}/ca.pem\" }", env).unwrap_err();
        assert!(missing.contains("TLS_DIR is not set"), "{missing}");
        assert!(expand_env("{ a: \"${ID\" }", env).is_err());
        assert_eq!(expand_env("no variables", env).unwrap(), "no variables");
    }
}
