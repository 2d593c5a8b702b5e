//! The key-expression scheme: every key starts with the cluster name, so
//! several clusters share one Zenoh network without seeing each other.
//! docs/cluster.md's "Bus" table documents each key's direction, rate and payload.

use thiserror::Error;

/// A cluster name that is not one plain key chunk.
#[derive(Debug, Error)]
#[error("cluster name '{0}' must be one key chunk: no '/', '*', '$', '?', '#' or spaces")]
pub struct KeyError(pub String);

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Keys {
    cluster: String,
}

impl Keys {
    /// Checks that `cluster` is one plain key chunk.
    pub fn new(cluster: &str) -> Result<Self, KeyError> {
        if !is_plain_chunk(cluster) {
            return Err(KeyError(cluster.to_string()));
        }
        Ok(Keys {
            cluster: cluster.to_string(),
        })
    }

    pub fn cluster(&self) -> &str {
        &self.cluster
    }

    fn key(&self, rest: &str) -> String {
        format!("{}/{rest}", self.cluster)
    }

    /// Every key of the cluster.
    pub fn all(&self) -> String {
        self.key("**")
    }
    pub fn clock(&self) -> String {
        self.key("clock")
    }
    pub fn vehicles(&self) -> String {
        self.key("vehicles")
    }
    pub fn events(&self) -> String {
        self.key("events")
    }
    pub fn ego(&self) -> String {
        self.key("ego")
    }
    pub fn spawn_config(&self) -> String {
        self.key("spawner/config")
    }
    pub fn spawner(&self, command: &str) -> String {
        self.key(&format!("spawner/{command}"))
    }
    pub fn stepper(&self, command: &str) -> String {
        self.key(&format!("stepper/{command}"))
    }
    pub fn light_state(&self, group: &str) -> String {
        self.key(&format!("lights/state/{group}"))
    }
    pub fn light_states(&self) -> String {
        self.key("lights/state/*")
    }
    pub fn lights_heartbeat(&self) -> String {
        self.key("lights/heartbeat")
    }
    pub fn lights_override(&self) -> String {
        self.key("lights/override")
    }
    pub fn occupancy(&self, area: &str) -> String {
        self.key(&format!("crosswalks/occupancy/{area}"))
    }
    pub fn occupancies(&self) -> String {
        self.key("crosswalks/occupancy/*")
    }
    pub fn crosswalks_heartbeat(&self) -> String {
        self.key("crosswalks/heartbeat")
    }
    pub fn blocked_stop(&self) -> String {
        self.key("crosswalks/blocked_stop")
    }
    pub fn agents(&self, source: &str) -> String {
        self.key(&format!("agents/{source}"))
    }
    pub fn all_agents(&self) -> String {
        self.key("agents/*")
    }
    pub fn proposals(&self, simulator: &str) -> String {
        self.key(&format!("simulators/{simulator}/proposals"))
    }
    pub fn all_proposals(&self) -> String {
        self.key("simulators/*/proposals")
    }
    pub fn proposal_results(&self, simulator: &str) -> String {
        self.key(&format!("simulators/{simulator}/results"))
    }
    pub fn status(&self, service: &str) -> String {
        self.key(&format!("status/{service}"))
    }
    pub fn all_status(&self) -> String {
        self.key("status/*")
    }
    pub fn alive(&self, service: &str) -> String {
        self.key(&format!("alive/{service}"))
    }
    pub fn all_alive(&self) -> String {
        self.key("alive/*")
    }
    /// Where a lockstep member answers the stepper's tick query.
    pub fn lockstep_member(&self, member: &str) -> String {
        self.key(&format!("lockstep/step/{member}"))
    }
    pub fn lockstep_members(&self) -> String {
        self.key("lockstep/step/*")
    }
    /// Where an agent source in lockstep answers the crosswalks' tick query.
    pub fn lockstep_agents(&self, source: &str) -> String {
        self.key(&format!("lockstep/agents/{source}"))
    }
    pub fn lockstep_all_agents(&self) -> String {
        self.key("lockstep/agents/*")
    }

    /// The last chunk of a key (a light group, an area, a service).
    pub fn last_chunk(key: &str) -> &str {
        key.rsplit('/').next().unwrap_or(key)
    }

    /// The simulator name of a proposals key.
    pub fn simulator_of(key: &str) -> Option<&str> {
        let mut parts = key.rsplit('/');
        (parts.next() == Some("proposals"))
            .then(|| parts.next())
            .flatten()
    }
}

/// Names used in keys (light groups, areas, services) must be one plain chunk.
pub fn is_plain_chunk(name: &str) -> bool {
    !name.is_empty()
        && !name
            .chars()
            .any(|c| matches!(c, '/' | '*' | '$' | '?' | '#') || c.is_whitespace())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cluster_name_must_be_one_plain_chunk() {
        assert!(Keys::new("demo").is_ok());
        for bad in ["", "a/b", "a*", "a b", "$x"] {
            assert!(Keys::new(bad).is_err(), "{bad:?} accepted");
        }
        let k = Keys::new("demo").unwrap();
        assert_eq!(k.light_state("J0_0_NS"), "demo/lights/state/J0_0_NS");
        assert_eq!(
            Keys::simulator_of("demo/simulators/py/proposals"),
            Some("py")
        );
        assert_eq!(Keys::last_chunk("demo/status/stepper"), "stepper");
    }
}
