//! Branch choice at forks (weighted by the spawn config, else uniform) and the
//! branch-decision statistics with their CSV export.

use std::collections::BTreeMap;
use std::fmt::Write;

use rustc_hash::FxHashMap;
use trafficmesh_model::TrafficSpawnConfig;

use crate::network::{LaneId, LaneNetwork};
use crate::rng::SimRng;

/// How a branch was chosen: the AWSIM reference's four `selection_mode` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SelectionMode {
    Weighted,
    UniformNoConfig,
    UniformNoMatchingWeights,
    UniformWeightedFallback,
}

impl SelectionMode {
    pub fn parse(name: &str) -> Option<Self> {
        [
            SelectionMode::Weighted,
            SelectionMode::UniformNoConfig,
            SelectionMode::UniformNoMatchingWeights,
            SelectionMode::UniformWeightedFallback,
        ]
        .into_iter()
        .find(|m| m.as_str() == name)
    }

    pub fn as_str(self) -> &'static str {
        match self {
            SelectionMode::Weighted => "weighted",
            SelectionMode::UniformNoConfig => "uniform_no_config",
            SelectionMode::UniformNoMatchingWeights => "uniform_no_matching_weights",
            SelectionMode::UniformWeightedFallback => "uniform_weighted_fallback",
        }
    }
}

/// One branch decision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BranchChoice {
    pub from: LaneId,
    pub to: LaneId,
    pub mode: SelectionMode,
    /// The chosen lane's normalised weight in the config (0 when not configured).
    pub configured_weight: f64,
    /// Probability the chosen lane had at decision time.
    pub probability: f64,
}

/// Branch weights of the loaded spawn config, normalised per from-lane.
#[derive(Clone, Debug, Default)]
pub struct BranchPolicy {
    loaded: bool,
    weights: FxHashMap<LaneId, Vec<(LaneId, f64)>>,
}

impl BranchPolicy {
    /// No config loaded: every choice is uniform.
    pub fn none() -> Self {
        Self::default()
    }

    /// Compiles a validated config: zero weights dropped, the rest normalised.
    pub fn from_config(net: &LaneNetwork, config: &TrafficSpawnConfig) -> Self {
        let mut weights: FxHashMap<LaneId, Vec<(LaneId, f64)>> = FxHashMap::default();
        for branch in &config.branch_weights {
            let Some(from) = net.lane_id(&branch.from_lane) else {
                continue;
            };
            let entry = weights.entry(from).or_default();
            for next in &branch.next {
                if let Some(to) = net.lane_id(&next.lane)
                    && next.weight > 0.0
                {
                    entry.push((to, next.weight));
                }
            }
        }
        weights.retain(|_, list| !list.is_empty());
        for list in weights.values_mut() {
            let sum: f64 = list.iter().map(|w| w.1).sum();
            for w in list.iter_mut() {
                w.1 /= sum;
            }
        }
        BranchPolicy {
            loaded: true,
            weights,
        }
    }

    /// Chooses among `options` (two or more) leaving `from`.
    pub fn choose(&self, from: LaneId, options: &[LaneId], rng: &mut SimRng) -> BranchChoice {
        let uniform = |mode, rng: &mut SimRng, configured: &dyn Fn(LaneId) -> f64| {
            let to = options[rng.below(options.len())];
            BranchChoice {
                from,
                to,
                mode,
                configured_weight: configured(to),
                probability: 1.0 / options.len() as f64,
            }
        };
        if !self.loaded {
            return uniform(SelectionMode::UniformNoConfig, rng, &|_| 0.0);
        }
        let Some(list) = self.weights.get(&from) else {
            return uniform(SelectionMode::UniformNoMatchingWeights, rng, &|_| 0.0);
        };
        let configured = |to: LaneId| list.iter().find(|w| w.0 == to).map_or(0.0, |w| w.1);
        let matching: Vec<(LaneId, f64)> = list
            .iter()
            .copied()
            .filter(|w| options.contains(&w.0))
            .collect();
        let total: f64 = matching.iter().map(|w| w.1).sum();
        if matching.is_empty() || total <= 0.0 {
            return uniform(SelectionMode::UniformNoMatchingWeights, rng, &configured);
        }
        let r = rng.unit() * total;
        let mut running = 0.0;
        for &(to, w) in &matching {
            running += w;
            if running >= r {
                return BranchChoice {
                    from,
                    to,
                    mode: SelectionMode::Weighted,
                    configured_weight: w,
                    probability: w / total,
                };
            }
        }
        uniform(SelectionMode::UniformWeightedFallback, rng, &configured)
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    count: u64,
    weight_sum: f64,
    probability_sum: f64,
}

/// Counts of branch decisions per (from, to, mode).
#[derive(Clone, Debug, Default)]
pub struct BranchStats {
    rows: BTreeMap<(LaneId, LaneId, SelectionMode), Tally>,
}

pub const BRANCH_CSV_HEADER: &str = "from_lane,to_lane,selection_mode,decision_count,total_from_lane,total_from_lane_mode,observed_ratio_from_lane,observed_ratio_from_lane_mode,avg_configured_weight,avg_effective_probability";

impl BranchStats {
    pub fn record(&mut self, c: &BranchChoice) {
        let t = self.rows.entry((c.from, c.to, c.mode)).or_default();
        t.count += 1;
        t.weight_sum += c.configured_weight;
        t.probability_sum += c.probability;
    }

    /// Decisions from `from` to `to`, all modes.
    pub fn count(&self, from: LaneId, to: LaneId) -> u64 {
        self.rows
            .iter()
            .filter(|((f, t, _), _)| *f == from && *t == to)
            .map(|(_, v)| v.count)
            .sum()
    }

    pub fn total(&self) -> u64 {
        self.rows.values().map(|t| t.count).sum()
    }

    /// The statistics a CSV of [`BranchStats::to_csv`] holds, read back (the
    /// spawner's after a restart): counts exactly, the weight and
    /// probability sums from their averages. An error names the line and
    /// what is wrong with it.
    pub fn from_csv(net: &LaneNetwork, text: &str) -> Result<BranchStats, String> {
        let mut reader = csv::ReaderBuilder::new().from_reader(text.as_bytes());
        let header = reader.headers().map_err(|e| format!("header: {e}"))?;
        if header.iter().collect::<Vec<_>>().join(",") != BRANCH_CSV_HEADER {
            return Err(format!("header is not {BRANCH_CSV_HEADER}"));
        }
        let mut stats = BranchStats::default();
        for (k, record) in reader.records().enumerate() {
            let line = k + 2;
            let record = record.map_err(|e| format!("line {line}: {e}"))?;
            let lane = |i: usize| {
                net.lane_id(&record[i])
                    .ok_or_else(|| format!("line {line}: no lane '{}' on this map", &record[i]))
            };
            let number = |i: usize| -> Result<f64, String> {
                record[i]
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && *x >= 0.0)
                    .ok_or_else(|| format!("line {line}: '{}' is not a number", &record[i]))
            };
            let (from, to) = (lane(0)?, lane(1)?);
            let mode = SelectionMode::parse(&record[2])
                .ok_or_else(|| format!("line {line}: '{}' is no selection mode", &record[2]))?;
            let count: u64 = record[3]
                .parse()
                .map_err(|_| format!("line {line}: '{}' is not a count", &record[3]))?;
            let n = count as f64;
            let t = stats.rows.entry((from, to, mode)).or_default();
            t.count += count;
            t.weight_sum += number(8)? * n;
            t.probability_sum += number(9)? * n;
        }
        Ok(stats)
    }

    /// The CSV, header first, one row per (from_lane, to_lane, selection_mode),
    /// sorted by lane names then mode; ratios and averages with 6 decimals.
    pub fn to_csv(&self, net: &LaneNetwork) -> String {
        let mut from_totals: FxHashMap<LaneId, u64> = FxHashMap::default();
        let mut mode_totals: FxHashMap<(LaneId, SelectionMode), u64> = FxHashMap::default();
        for ((from, _, mode), t) in &self.rows {
            *from_totals.entry(*from).or_default() += t.count;
            *mode_totals.entry((*from, *mode)).or_default() += t.count;
        }
        let mut rows: Vec<_> = self.rows.iter().collect();
        rows.sort_by(|a, b| {
            let key = |r: &(&(LaneId, LaneId, SelectionMode), &Tally)| {
                (
                    net.lane(r.0.0).name.clone(),
                    net.lane(r.0.1).name.clone(),
                    r.0.2,
                )
            };
            key(a).cmp(&key(b))
        });
        let mut out = String::from(BRANCH_CSV_HEADER);
        out.push('\n');
        for ((from, to, mode), t) in rows {
            let total = from_totals[from];
            let total_mode = mode_totals[&(*from, *mode)];
            let n = t.count as f64;
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6}",
                csv_field(&net.lane(*from).name),
                csv_field(&net.lane(*to).name),
                mode.as_str(),
                t.count,
                total,
                total_mode,
                n / total as f64,
                n / total_mode as f64,
                t.weight_sum / n,
                t.probability_sum / n,
            );
        }
        out
    }
}

/// Quotes a field that holds a comma, quote or line break (RFC 4180).
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
