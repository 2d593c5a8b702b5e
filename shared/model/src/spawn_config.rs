//! TrafficSpawnConfig: the AWSIM reference's `traffic_spawn.json`, field for field.
//!
//! Lane names are case-insensitive, `spawnsPerMinute` 0 disables the limit, and
//! branch weights only matter as ratios.

use serde::{Deserialize, Serialize};
use thiserror::Error;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct SpawnRate {
    pub lane: String,
    pub spawns_per_minute: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NextWeight {
    pub lane: String,
    pub weight: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct BranchWeights {
    pub from_lane: String,
    pub next: Vec<NextWeight>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct TrafficSpawnConfig {
    #[serde(default)]
    pub spawn_rates: Vec<SpawnRate>,
    #[serde(default)]
    pub branch_weights: Vec<BranchWeights>,
}

/// Everything wrong with a spawn config, one line per problem.
#[derive(Debug, Error, PartialEq)]
#[error("invalid spawn config:\n  {}", .problems.join("\n  "))]
pub struct SpawnConfigError {
    pub problems: Vec<String>,
}

impl TrafficSpawnConfig {
    /// Checks values and, through `lane_exists`, lane names. Nothing is dropped
    /// silently except zero weights, which the AWSIM reference defines as "never".
    pub fn validate(&self, lane_exists: impl Fn(&str) -> bool) -> Result<(), SpawnConfigError> {
        let mut problems = Vec::new();
        for (i, rate) in self.spawn_rates.iter().enumerate() {
            let at = format!("spawnRates[{i}] (lane '{}')", rate.lane);
            if !lane_exists(&rate.lane) {
                problems.push(format!("{at}: field 'lane': unknown lane '{}'", rate.lane));
            }
            if !(rate.spawns_per_minute.is_finite() && rate.spawns_per_minute >= 0.0) {
                problems.push(format!(
                    "{at}: field 'spawnsPerMinute': must be a number >= 0 (0 = no limit), got {}",
                    rate.spawns_per_minute
                ));
            }
        }
        for (i, branch) in self.branch_weights.iter().enumerate() {
            let at = format!("branchWeights[{i}] (fromLane '{}')", branch.from_lane);
            if !lane_exists(&branch.from_lane) {
                problems.push(format!(
                    "{at}: field 'fromLane': unknown lane '{}'",
                    branch.from_lane
                ));
            }
            if branch.next.is_empty() {
                problems.push(format!("{at}: field 'next': is empty"));
            }
            for (j, next) in branch.next.iter().enumerate() {
                if !lane_exists(&next.lane) {
                    problems.push(format!(
                        "{at}: field 'next[{j}].lane': unknown lane '{}'",
                        next.lane
                    ));
                }
                if !(next.weight.is_finite() && next.weight >= 0.0) {
                    problems.push(format!(
                        "{at}: field 'next[{j}].weight' (lane '{}'): must be a number >= 0, got {}",
                        next.lane, next.weight
                    ));
                }
            }
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(SpawnConfigError { problems })
        }
    }
}
