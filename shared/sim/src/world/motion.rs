//! The motion pass: Decision, Control and Visualization of every vehicle,
//! and, while each is at hand, its trajectory digest and the next tick's
//! lane following.

use rayon::prelude::*;
use trafficmesh_model::NpcVehicleConfig;

use super::World;
use super::follow::{Follow, Followed};
use super::red_lights::{RedLightCrossing, crossed_on_red};
use super::squeeze::SQUEEZE_SPEED;
use crate::cognition::Perception;
use crate::cognition::curve::is_turning;
use crate::cognition::right_of_way::RowInfo;
use crate::control::{cap_travel, speed_limit, step_speed, update_pose};
use crate::decision::decide;
use crate::lights::Lights;
use crate::lookahead;
use crate::network::LaneNetwork;
use crate::parallel::{chunk_count, chunk_len};
use crate::pose::Moved;
use crate::trajectory::pose_digest;
use crate::vehicle::Vehicle;
use crate::visualization::update_trip;

impl World {
    /// Moves every vehicle by its perception and returns the sum of the
    /// trajectory digests of those that stay. `leaving` (ascending) are the
    /// vehicles that leave at the end of this tick: they do not move. With
    /// `follow_ahead`, also does the next tick's lane following. Notes the
    /// tick's red-light crossings.
    pub(super) fn move_and_follow(
        &mut self,
        perceptions: &[Perception],
        leaving: &[usize],
        follow_ahead: bool,
    ) -> u64 {
        let (dt, time, lights) = (self.config.dt, self.time, &self.lights);
        // The motion pass also does the next tick's lane following while each
        // vehicle is at hand, for the vehicles that stay: at the index each
        // will have once those leaving at the end of this tick are gone.
        let n = self.vehicles.len();
        let staying = n - leaving.len();
        let chunk = chunk_len(n);
        let chunks = chunk_count(n);
        let mut kept: Vec<usize> = (0..chunks).map(|c| chunk.min(n - c * chunk)).collect();
        for &i in leaving {
            kept[i / chunk] -= 1;
        }
        // Each chunk's stayers: where they start in the list that remains,
        // and their rows there.
        let mut stayers = Vec::with_capacity(chunks);
        let mut rows_left: &mut [RowInfo] = &mut self.row[..staying];
        for count in kept {
            let start = staying - rows_left.len();
            let (rows, rest) = std::mem::take(&mut rows_left).split_at_mut(count);
            stayers.push((start, rows));
            rows_left = rest;
        }
        let follow = Follow {
            net: &self.net,
            policy: &self.branch_policy,
            motion: &self.config.vehicle,
        };
        // In chunks, so that each loop can look at the vehicles ahead of it.
        // Takes the trajectory digests of the vehicles that stay on the way.
        let chunks: Vec<(u64, Followed, Vec<RedLightCrossing>)> = self
            .vehicles
            .par_chunks_mut(chunk)
            .zip(perceptions.par_chunks(chunk))
            .zip(stayers)
            .zip(self.junctions.chunk_lists(n))
            .zip(self.index.chunk_fillers(n))
            .map(
                |((((vehicles, perceptions), (start, rows)), junction_list), mut index_items)| {
                    let (net, config) = (follow.net, follow.motion);
                    let mut digest_sum = 0u64;
                    let mut followed = Followed::default();
                    let mut on_red = Vec::new();
                    let mut stayed = 0;
                    for (k, p) in perceptions.iter().enumerate() {
                        lookahead::paths_ahead(net, vehicles, k);
                        lookahead::vertices_and_conflicts_ahead(net, vehicles, k);
                        let v = &mut vehicles[k];
                        if let Some(c) = move_vehicle(net, config, (dt, time, lights), v, p) {
                            on_red.push(c);
                        }
                        if v.should_despawn {
                            continue;
                        }
                        digest_sum = digest_sum.wrapping_add(pose_digest(v));
                        if follow_ahead {
                            let lists = (&mut rows[stayed], &mut *junction_list, &mut index_items);
                            follow.vehicle(v, start + stayed, lists, &mut followed);
                        }
                        stayed += 1;
                    }
                    debug_assert_eq!(stayed, rows.len(), "the leaving list matches the flags");
                    (digest_sum, followed, on_red)
                },
            )
            .collect();
        let digest_sum = chunks.iter().fold(0u64, |sum, c| sum.wrapping_add(c.0));
        self.red_crossings.clear();
        let followed: Followed = chunks
            .into_iter()
            .map(|(_, chunk, on_red)| {
                self.red_crossings.extend(on_red);
                chunk
            })
            .collect();
        self.red_crossing_count += self.red_crossings.len() as u64;
        self.row.truncate(staying);
        self.prefollowed = follow_ahead.then_some((staying, followed));
        digest_sum
    }
}

/// Decision, Control and Visualization of one vehicle, after its perception;
/// a stop line it crossed on red, if it did.
fn move_vehicle(
    net: &LaneNetwork,
    config: &NpcVehicleConfig,
    (dt, time, lights): (f64, f64, &Lights),
    v: &mut Vehicle,
    p: &Perception,
) -> Option<RedLightCrossing> {
    p.apply(v);
    if v.should_despawn {
        return None;
    }
    let (s_before, speed_before) = (v.s, v.speed);
    let (mode, stops) = decide(v, config, || is_turning(net, v));
    v.speed_mode = mode;
    // One lookup of the lane's limit for the speed step and the trip's time loss.
    let limit = speed_limit(net, v, config);
    // Squeezing past bodies beside its way, it inches past them.
    let allowed = if v.is_squeezing(time) {
        limit.min(SQUEEZE_SPEED)
    } else {
        limit
    };
    step_speed(net, v, config, &stops, allowed, dt);
    cap_travel(v, s_before, p.travel_cap, dt);
    let moved = Moved {
        distance: v.s - s_before,
        from_speed: speed_before,
    };
    update_pose(net, v, moved);
    update_trip(v, dt, limit);
    crossed_on_red(net, lights, time, v, s_before)
}
