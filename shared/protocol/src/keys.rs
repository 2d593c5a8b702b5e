//! The key-expression scheme: every key starts with the cluster name, so
//! several clusters share one Zenoh network without seeing each other; the
//! rest is a declaration's pattern ([`crate::topics`]).

use thiserror::Error;

use crate::topics::*;

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

    fn key_of(&self, rest: &str) -> String {
        format!("{}/{rest}", self.cluster)
    }

    /// The key of a declaration without a named chunk.
    pub fn key(&self, d: &impl Pattern) -> String {
        debug_assert!(!d.pattern().contains('{'), "{} needs a name", d.pattern());
        self.key_of(d.pattern())
    }

    /// The key of a declaration with its named chunk filled in.
    pub fn key_at(&self, d: &impl Pattern, name: &str) -> String {
        self.key_of(&fill(d.pattern(), name))
    }

    /// The key expression matching every name of a declaration.
    pub fn key_all(&self, d: &impl Pattern) -> String {
        self.key_of(&fill(d.pattern(), "*"))
    }

    /// Every key of the cluster.
    pub fn all(&self) -> String {
        self.key_of("**")
    }
    pub fn clock(&self) -> String {
        self.key(&CLOCK)
    }
    pub fn vehicles(&self) -> String {
        self.key(&VEHICLES)
    }
    pub fn events(&self) -> String {
        self.key(&EVENTS)
    }
    pub fn ego(&self) -> String {
        self.key(&EGO)
    }
    pub fn spawn_config(&self) -> String {
        self.key(&SPAWN_CONFIG)
    }
    pub fn light_state(&self, group: &str) -> String {
        self.key_at(&LIGHT_STATE, group)
    }
    pub fn light_states(&self) -> String {
        self.key_all(&LIGHT_STATE)
    }
    pub fn lights_heartbeat(&self) -> String {
        self.key(&LIGHTS_HEARTBEAT)
    }
    pub fn lights_override(&self) -> String {
        self.key(&LIGHTS_OVERRIDE)
    }
    pub fn occupancy(&self, area: &str) -> String {
        self.key_at(&OCCUPANCY, area)
    }
    pub fn occupancies(&self) -> String {
        self.key_all(&OCCUPANCY)
    }
    pub fn crosswalks_heartbeat(&self) -> String {
        self.key(&CROSSWALKS_HEARTBEAT)
    }
    pub fn blocked_stop(&self) -> String {
        self.key(&BLOCKED_STOP)
    }
    pub fn agents(&self, source: &str) -> String {
        self.key_at(&AGENTS, source)
    }
    pub fn all_agents(&self) -> String {
        self.key_all(&AGENTS)
    }
    pub fn proposals(&self, simulator: &str) -> String {
        self.key_at(&PROPOSALS, simulator)
    }
    pub fn all_proposals(&self) -> String {
        self.key_all(&PROPOSALS)
    }
    pub fn proposal_results(&self, simulator: &str) -> String {
        self.key_at(&PROPOSAL_RESULTS, simulator)
    }
    pub fn status(&self, service: &str) -> String {
        self.key_at(&STATUS, service)
    }
    pub fn all_status(&self) -> String {
        self.key_all(&STATUS)
    }
    pub fn alive(&self, service: &str) -> String {
        self.key_at(&ALIVE, service)
    }
    pub fn all_alive(&self) -> String {
        self.key_all(&ALIVE)
    }
    /// Where a lockstep member answers the stepper's tick query.
    pub fn lockstep_member(&self, member: &str) -> String {
        self.key_at(&LOCKSTEP_STEP, member)
    }
    pub fn lockstep_members(&self) -> String {
        self.key_all(&LOCKSTEP_STEP)
    }
    /// Where an agent source in lockstep answers the crosswalks' tick query.
    pub fn lockstep_agents(&self, source: &str) -> String {
        self.key_at(&LOCKSTEP_AGENTS, source)
    }
    pub fn lockstep_all_agents(&self) -> String {
        self.key_all(&LOCKSTEP_AGENTS)
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

/// `pattern` with its `{name}` chunk replaced by `name`.
fn fill(pattern: &str, name: &str) -> String {
    match (pattern.find('{'), pattern.find('}')) {
        (Some(open), Some(close)) => format!("{}{name}{}", &pattern[..open], &pattern[close + 1..]),
        _ => pattern.to_string(),
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
