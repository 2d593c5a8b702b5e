//! The trajectory hash: one 64-bit digest of every vehicle's pose at every tick,
//! to compare runs (same seed, any thread count: same hash).
//!
//! A tick's digest is a sum of per-vehicle digests, so the motion step can
//! take it in its parallel chunks, while each vehicle's lines are in cache,
//! and the result does not depend on how the vehicles were split.

use std::hash::Hasher;

use rustc_hash::FxHasher;

use crate::rng::mix;
use crate::vehicle::Vehicle;

/// One vehicle's id and exact pose bits, well mixed (the digests are summed,
/// so every bit of the inputs must reach every bit of the output).
pub fn pose_digest(v: &Vehicle) -> u64 {
    // Each step is a bijection of the word (an odd multiplier), so no two
    // inputs that differ in one word meet; the final mix spreads every bit.
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut h = v.id;
    for word in [v.pose.x, v.pose.y, v.pose.z, v.pose.yaw] {
        h = (h ^ word.to_bits()).wrapping_mul(K).rotate_left(29);
    }
    mix(h)
}

#[derive(Clone, Default)]
pub struct TrajectoryHash {
    hasher: FxHasher,
}

impl TrajectoryHash {
    /// Folds in one tick: the vehicles' count and their summed pose digests.
    pub fn add_tick(&mut self, vehicles: &[Vehicle]) {
        let sum = vehicles
            .iter()
            .fold(0u64, |sum, v| sum.wrapping_add(pose_digest(v)));
        self.add_tick_digest(vehicles.len(), sum);
    }

    /// Folds in one tick from its vehicle count and summed [`pose_digest`]s.
    pub fn add_tick_digest(&mut self, vehicle_count: usize, digest_sum: u64) {
        self.hasher.write_usize(vehicle_count);
        self.hasher.write_u64(digest_sum);
    }

    pub fn finish(&self) -> u64 {
        self.hasher.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::populate::populate;
    use crate::world::test_grid_world;
    use crate::{World, WorldConfig};

    fn world() -> World {
        let mut world = test_grid_world(3, WorldConfig::default());
        populate(&mut world, 30);
        world
    }

    #[test]
    fn the_worlds_own_hash_is_the_hash_of_the_poses_after_each_tick() {
        let mut world = world();
        let mut outside = TrajectoryHash::default();
        for tick in 0..200 {
            if tick == 100 {
                // Vehicles leaving: the motion step skips them.
                let p = world.vehicles()[0].front;
                assert!(world.remove_vehicles_near(p, 30.0) > 0);
            }
            world.step();
            outside.add_tick(world.vehicles());
        }
        assert_eq!(world.trajectory_hash(), outside.finish());
    }

    #[test]
    fn any_change_of_a_pose_or_id_changes_the_digest() {
        let world = world();
        let v = &world.vehicles()[0];
        let base = pose_digest(v);
        let mut other = v.clone();
        other.pose.yaw = f64::from_bits(v.pose.yaw.to_bits() ^ 1);
        assert_ne!(pose_digest(&other), base);
        let mut other = v.clone();
        other.id += 1;
        assert_ne!(pose_digest(&other), base);
    }
}
