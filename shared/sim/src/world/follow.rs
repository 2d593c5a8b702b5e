//! Lane following: lane advance and branch choices, with what the tick takes
//! in the same pass while each vehicle is at hand: its right-of-way facts,
//! its junction membership and its lane-index items. The motion pass does it
//! for the next tick (see `motion.rs`); this tick's own pass then follows only
//! the vehicles added since, or all of them when what was done ahead was
//! dropped.

use rayon::prelude::*;
use trafficmesh_model::NpcVehicleConfig;

use super::World;
use crate::branching::{BranchChoice, BranchPolicy};
use crate::cognition::path::{advance_and_extend, give_up_turn, gives_up_turn};
use crate::cognition::right_of_way::{JunctionBuckets, Member, RowInfo};
use crate::events::{DespawnReason, SimEvent};
use crate::lane_change;
use crate::lane_index::ChunkFiller;
use crate::lookahead;
use crate::network::LaneNetwork;
use crate::parallel::chunk_len;
use crate::vehicle::{Vehicle, VehicleId};

impl World {
    /// Lane advance and branch choices: parallel (each vehicle draws from its own
    /// random stream), then recorded in id order. Takes in the same pass,
    /// while each vehicle is at hand, its right-of-way facts, its junction
    /// membership and its lane-index items (a pass of their own each cost
    /// more: the vehicles' lines and paths read again). When the last motion
    /// pass did this for the vehicles it moved, only those added since are
    /// left. Returns the indices of the vehicles flagged for despawn, ascending.
    pub(super) fn follow_lanes(&mut self) -> Vec<usize> {
        let n = self.vehicles.len();
        let chunk = chunk_len(n);
        self.row.resize(n, RowInfo::default());
        let follow = Follow {
            net: &self.net,
            policy: &self.branch_policy,
            motion: &self.config.vehicle,
        };
        let followed = match self.prefollowed.take() {
            Some((done, mut followed)) => {
                // After the others, in the last lists, so that the items stay
                // in list order.
                for i in done..n {
                    let lists = (
                        &mut self.row[i],
                        self.junctions.last_list(),
                        &mut self.index.last_filler(),
                    );
                    follow.vehicle(&mut self.vehicles[i], i, lists, &mut followed);
                }
                followed
            }
            None => self
                .vehicles
                .par_chunks_mut(chunk)
                .zip(self.row.par_chunks_mut(chunk))
                .zip(self.junctions.chunk_lists(n))
                .zip(self.index.chunk_fillers(n))
                .enumerate()
                .map(
                    |(c, (((vehicles, rows), junction_list), mut index_items))| {
                        // In chunks, so that the loop can look at the vehicles ahead of it.
                        let mut followed = Followed::default();
                        for (k, row) in rows.iter_mut().enumerate() {
                            lookahead::paths_ahead(follow.net, vehicles, k);
                            lookahead::conflicts_ahead(follow.net, vehicles, k);
                            let i = c * chunk + k;
                            let lists = (row, &mut *junction_list, &mut index_items);
                            follow.vehicle(&mut vehicles[k], i, lists, &mut followed);
                        }
                        followed
                    },
                )
                // Gathered, then joined in chunk order.
                .collect::<Vec<Followed>>()
                .into_iter()
                .collect(),
        };
        // With those held when what was done ahead was dropped; in id order,
        // whatever the vehicles' order in the list.
        let mut decisions = followed.decisions;
        decisions.append(&mut self.held_choices);
        decisions.sort_by_key(|&(id, _)| id);
        for (id, made) in decisions {
            for choice in made {
                if let Some(stats) = &mut self.branch_stats {
                    stats.record(&choice);
                }
                self.events.push(SimEvent::BranchDecision { id, choice });
            }
        }
        followed.leaving
    }

    /// Drops the lane following the last motion pass did ahead, when its
    /// indices no longer hold or its facts may have changed. The lanes it
    /// advanced and the branches it chose stand: the choices are held for
    /// the next tick to record, as it would have.
    pub(super) fn drop_prefollowed(&mut self) {
        if let Some((_, followed)) = self.prefollowed.take() {
            self.held_choices.extend(followed.decisions);
        }
    }
}

/// What lane following reads besides the vehicle.
pub(super) struct Follow<'a> {
    pub net: &'a LaneNetwork,
    pub policy: &'a BranchPolicy,
    pub motion: &'a NpcVehicleConfig,
}

/// What lane following of some vehicles brings back: the branch choices
/// made (only the vehicles that made one, so that the serial recording costs
/// the choices, not the vehicles) and the vehicles flagged for despawn.
#[derive(Default)]
pub(super) struct Followed {
    decisions: Vec<(VehicleId, Vec<BranchChoice>)>,
    /// Indices of the vehicles flagged for despawn, ascending.
    leaving: Vec<usize>,
}

/// The chunks' results joined in chunk order.
impl FromIterator<Followed> for Followed {
    fn from_iter<I: IntoIterator<Item = Followed>>(chunks: I) -> Self {
        let mut all = Followed::default();
        for mut chunk in chunks {
            all.decisions.append(&mut chunk.decisions);
            all.leaving.append(&mut chunk.leaving);
        }
        all
    }
}

impl Follow<'_> {
    /// Lane following of vehicle `i`, with what the tick takes in the same
    /// pass: its right-of-way facts, junction membership and lane-index items.
    pub(super) fn vehicle(
        &self,
        v: &mut Vehicle,
        i: usize,
        (row, junction_list, index_items): (
            &mut RowInfo,
            &mut Vec<(u32, Member)>,
            &mut ChunkFiller,
        ),
        followed: &mut Followed,
    ) {
        let made = follow_lanes_of(self.net, self.policy, self.motion, v);
        if v.should_despawn {
            followed.leaving.push(i);
        }
        // Also for a vehicle about to leave: it is still perceived, and seen
        // by others, this tick.
        *row = RowInfo::of(v);
        JunctionBuckets::note(junction_list, i, row);
        index_items.add(self.net, v, i);
        if !made.is_empty() {
            followed.decisions.push((v.id, made));
        }
    }
}

/// Lane advance and branch choices of one vehicle (none for one already
/// leaving), with what follows from them; returns the choices made.
fn follow_lanes_of(
    net: &LaneNetwork,
    policy: &BranchPolicy,
    motion: &NpcVehicleConfig,
    v: &mut Vehicle,
) -> Vec<BranchChoice> {
    let mut made = Vec::new();
    if v.should_despawn {
        return made;
    }
    let before = (v.path[0], v.path.get(1).copied());
    if gives_up_turn(net, v) {
        made.extend(give_up_turn(net, policy, v));
    }
    advance_and_extend(net, policy, v, motion, &mut made);
    if before != (v.path[0], v.path.get(1).copied()) {
        lane_change::refresh_first_lanes(net, v);
    }
    if v.should_despawn && v.despawn_reason.is_none() {
        v.despawn_reason = Some(DespawnReason::DeadEnd);
    }
    // A release by deadlock breaking, and impatience, last until the vehicle
    // leaves its junction: this tick it moved from a junction lane onto an
    // ordinary one.
    // (Standing on an ordinary lane right after another junction is not
    // leaving: that dropped each release the tick after it was given, and the
    // two vehicles of a cycle took turns creeping.)
    if before.0 != v.path[0]
        && !net.lane(v.path[0]).intersection
        && v.behind.latest().is_some_and(|p| net.lane(p).intersection)
    {
        v.forced_through = None;
        v.trip.held_by_rule = 0.0;
    }
    made
}
