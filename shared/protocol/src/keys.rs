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

    /// The last chunk of a key (a light group, an area, a service).
    pub fn last_chunk(key: &str) -> &str {
        key.rsplit('/').next().unwrap_or(key)
    }

    /// The named chunk of a key of declaration `d` (`simulators/{name}/proposals`
    /// gives the simulator's name); the last chunk of a key without one.
    pub fn name_in<'k>(d: &impl Pattern, key: &'k str) -> &'k str {
        let pattern = d.pattern();
        match pattern.split('/').position(|chunk| chunk.starts_with('{')) {
            // The cluster's chunk comes first in the key.
            Some(i) => key.split('/').nth(i + 1).unwrap_or(key),
            None => Self::last_chunk(key),
        }
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
        assert_eq!(
            k.key_at(&LIGHT_STATE, "J0_0_NS"),
            "demo/lights/state/J0_0_NS"
        );
        assert_eq!(k.key_all(&LIGHT_STATE), "demo/lights/state/*");
        assert_eq!(k.key(&CLOCK), "demo/clock");
        assert_eq!(
            Keys::name_in(&PROPOSALS, "demo/simulators/py/proposals"),
            "py"
        );
        assert_eq!(Keys::name_in(&AGENTS, "demo/agents/walkers"), "walkers");
        assert_eq!(Keys::last_chunk("demo/status/stepper"), "stepper");
    }
}
