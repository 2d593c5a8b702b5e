//! Regrouping the vehicle list by lane, for memory locality. Every pass of a
//! tick reads, for each vehicle, its lanes, their lane-index entries and the
//! facts of the vehicles around it. In spawn order those lie scattered over
//! tens of megabytes; grouped by lane, neighbours in the list share most of
//! them. Nothing the simulation decides depends on the list's order (where
//! it could, as between level bodies, ids decide), so the trajectories are
//! the same with or without it.

use super::World;
use crate::parallel::chunk_len;
use rayon::prelude::*;

/// Ticks between regroupings: a vehicle changes lanes every few seconds, so
/// once a simulated second keeps the list grouped at a small cost (one pass
/// and one move of each vehicle that changed place).
pub const DEFAULT_INTERVAL: u64 = 50;

impl World {
    /// Whether the tick under way ends by regrouping the list: every
    /// `regroup_interval` ticks.
    pub(super) fn regroup_due(&self) -> bool {
        let interval = self.config.regroup_interval;
        interval > 0 && (self.ticks + 1).is_multiple_of(interval)
    }

    /// Orders the vehicles by the lane they are on, keeping their order
    /// within a lane (any order would do: none decides anything). At the end
    /// of a tick whose motion pass did not follow the lanes ahead, so that
    /// nothing is at the old places.
    pub(super) fn regroup_by_lane(&mut self) {
        debug_assert!(self.prefollowed.is_none(), "nothing done ahead");
        // Lane and place packed in one integer: the sort compares no tuples
        // and reads no vehicle.
        let mut keys: Vec<u64> = self
            .vehicles
            .par_iter()
            .with_min_len(chunk_len(self.vehicles.len()))
            .enumerate()
            .map(|(i, v)| (u64::from(v.path[0]) << 32) | i as u64)
            .collect();
        keys.par_sort_unstable();
        // The low half is the place, below 2^32 (the list's length is).
        let mut order: Vec<u32> = keys.into_iter().map(|key| key as u32).collect();
        permute(&mut self.vehicles, &mut order);
    }
}

/// Reorders `items` so that the item at `order[k]` comes to k, following
/// each cycle of the permutation: one swap per item that moves, and no
/// second list. Leaves `order` as the identity.
fn permute<T>(items: &mut [T], order: &mut [u32]) {
    for start in 0..order.len() {
        let mut at = start;
        loop {
            let from = order[at] as usize;
            order[at] = at as u32;
            if from == start || from == at {
                break;
            }
            // `from` still holds its own item: the cycle has not reached it.
            items.swap(at, from);
            at = from;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::permute;
    use crate::WorldConfig;
    use crate::lane_index::LaneIndex;
    use crate::world::test_grid_world;

    /// Two bodies level on a lane (a lane-change ghost beside its twin is
    /// the case that happens) come in id order out of the lane index,
    /// whichever of them lies first in the list.
    #[test]
    fn level_bodies_on_a_lane_are_indexed_in_id_order() {
        let mut world = test_grid_world(2, WorldConfig::default());
        let net = world.network();
        let lane = net.lanes.iter().find(|l| !l.intersection).expect("a road");
        let (name, lane_id) = (lane.name.clone(), net.lane_id(&lane.name).expect("named"));
        let first = world.place_vehicle("Taxi", &name, 30.0, 0.0).unwrap();
        let second = world.place_vehicle("Taxi", &name, 30.0, 0.0).unwrap();
        for reversed in [false, true] {
            if reversed {
                world.vehicles.reverse();
            }
            let mut index = LaneIndex::empty(world.net.lanes.len());
            index.rebuild(&world.net, &world.vehicles);
            let ids: Vec<_> = (index.on_lane(lane_id).iter())
                .map(|o| world.vehicles[o.vehicle as usize].id)
                .collect();
            assert_eq!(ids, [first, second], "list reversed: {reversed}");
        }
    }

    #[test]
    fn permute_moves_each_item_to_its_place() {
        let mut items: Vec<char> = "abcdefgh".chars().collect();
        // Two cycles and two fixed points.
        let mut order = vec![3, 0, 2, 1, 6, 7, 4, 5];
        permute(&mut items, &mut order);
        assert_eq!(items.iter().collect::<String>(), "dacbghef");
        assert_eq!(order, (0..8).collect::<Vec<u32>>());
    }
}
