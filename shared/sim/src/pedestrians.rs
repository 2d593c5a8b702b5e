//! Built-in pedestrians and cyclists: they cross the map's crosswalks at a
//! configurable rate so that a cluster shows the zebra behaviour on its own.
//! At a signalised crosswalk they wait at the kerb for their walk signal
//! ([`crate::walk_signal`]). Deterministic for a seed; poses go out as agent
//! footprints.

use glam::DVec2;

use trafficmesh_model::LightColor;

use crate::crosswalk::OccupantType;
use crate::crosswalk_agents::AgentPose;
use crate::geometry::box_corners;
use crate::network::Crosswalk;
use crate::rng::SimRng;
use crate::walk_signal;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PedestrianConfig {
    /// Crossings started per minute on each crosswalk (mean of a Poisson process).
    pub per_minute: f64,
    /// Share of crossings made by cyclists.
    pub cyclist_share: f64,
    pub walk_speed: f64,
    pub cycle_speed: f64,
}

impl Default for PedestrianConfig {
    fn default() -> Self {
        PedestrianConfig {
            per_minute: 2.0,
            cyclist_share: 0.2,
            walk_speed: 1.4,
            cycle_speed: 4.0,
        }
    }
}

#[derive(Clone, Debug)]
struct Walker {
    id: u64,
    cyclist: bool,
    from: DVec2,
    to: DVec2,
    travelled: f64,
    speed: f64,
}

pub struct Pedestrians {
    config: PedestrianConfig,
    /// Each crosswalk's crossing line, from one kerb to the other.
    lines: Vec<(DVec2, DVec2)>,
    /// Each crosswalk's walk signal: the light groups that must show red.
    walk_groups: Vec<Vec<u32>>,
    /// When the next walker comes to each crosswalk (one who came during
    /// its red waits for the walk).
    next_start: Vec<f64>,
    walkers: Vec<Walker>,
    next_id: u64,
    rng: SimRng,
}

impl Pedestrians {
    pub fn new(areas: &[Crosswalk], config: PedestrianConfig, seed: u64) -> Self {
        let mut rng = SimRng::new(seed, 0x7065_6465);
        let lines = areas.iter().map(|a| crossing_line(&a.polygon)).collect();
        let walk_groups = areas.iter().map(|a| a.walk_groups.clone()).collect();
        let next_start = areas
            .iter()
            .map(|_| next_gap(&mut rng, config.per_minute))
            .collect();
        Pedestrians {
            config,
            lines,
            walk_groups,
            next_start,
            walkers: Vec::new(),
            next_id: 0,
            rng,
        }
    }

    /// Advances to time `t` by `dt`: starts the due crossings whose walk
    /// signal shows (`color` gives each light group's colour now), moves
    /// everyone, removes those who arrived.
    pub fn step(&mut self, t: f64, dt: f64, color: impl Fn(u32) -> LightColor) {
        for area in 0..self.lines.len() {
            if self.next_start[area] > t || !walk_signal::may_walk(&self.walk_groups[area], &color)
            {
                continue;
            }
            while self.next_start[area] <= t {
                let cyclist = self.rng.unit() < self.config.cyclist_share;
                let (a, b) = self.lines[area];
                let (from, to) = if self.rng.unit() < 0.5 {
                    (a, b)
                } else {
                    (b, a)
                };
                self.walkers.push(Walker {
                    id: self.next_id,
                    cyclist,
                    from,
                    to,
                    travelled: 0.0,
                    speed: if cyclist {
                        self.config.cycle_speed
                    } else {
                        self.config.walk_speed
                    },
                });
                self.next_id += 1;
                self.next_start[area] += next_gap(&mut self.rng, self.config.per_minute);
            }
        }
        for w in &mut self.walkers {
            w.travelled += w.speed * dt;
        }
        self.walkers.retain(|w| w.travelled < w.from.distance(w.to));
    }

    pub fn count(&self) -> usize {
        self.walkers.len()
    }

    /// Everyone's footprint: a 0.6 m square for a walker, a 1.8 x 0.6 m box for
    /// a cyclist, facing the direction of travel.
    pub fn agents(&self) -> Vec<AgentPose> {
        self.walkers
            .iter()
            .map(|w| {
                let dir = (w.to - w.from).normalize_or_zero();
                let at = w.from + dir * w.travelled;
                let yaw = dir.y.atan2(dir.x);
                let (root, kind, half_length) = if w.cyclist {
                    (
                        format!("Cyclist_{}", w.id),
                        OccupantType::SimpleCyclistMovement,
                        0.9,
                    )
                } else {
                    (
                        format!("Pedestrian_{}", w.id),
                        OccupantType::NpcPedestrian,
                        0.3,
                    )
                };
                AgentPose {
                    id: format!("{}", w.id),
                    root,
                    kind,
                    footprint: box_corners(at, yaw, half_length, 0.3).to_vec(),
                }
            })
            .collect()
    }
}

/// Exponential gap between crossings, in seconds (never when the rate is 0).
fn next_gap(rng: &mut SimRng, per_minute: f64) -> f64 {
    if per_minute <= 0.0 {
        return f64::INFINITY;
    }
    -(1.0 - rng.unit()).ln() * 60.0 / per_minute
}

/// The crossing runs along the polygon's long axis, one metre past each end.
fn crossing_line(polygon: &[DVec2]) -> (DVec2, DVec2) {
    let n = polygon.len();
    let centroid = polygon.iter().copied().sum::<DVec2>() / n.max(1) as f64;
    let axis = (0..n)
        .map(|i| polygon[(i + 1) % n] - polygon[i])
        .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
        .unwrap_or(DVec2::X)
        .normalize_or(DVec2::X);
    let (lo, hi) = polygon
        .iter()
        .map(|p| (*p - centroid).dot(axis))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    (centroid + axis * (lo - 1.0), centroid + axis * (hi + 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_line_spans_the_long_axis_past_both_kerbs() {
        let square = vec![
            DVec2::new(-2.0, -8.0),
            DVec2::new(2.0, -8.0),
            DVec2::new(2.0, 8.0),
            DVec2::new(-2.0, 8.0),
        ];
        let (a, b) = crossing_line(&square);
        assert!((a.distance(b) - 18.0).abs() < 1e-9);
        assert!(a.x.abs() < 1e-9 && b.x.abs() < 1e-9);
    }
}
