//! The trajectory hash: one 64-bit digest of every vehicle's pose at every tick,
//! to compare runs (same seed, any thread count: same hash).

use std::hash::Hasher;

use rustc_hash::FxHasher;

use crate::vehicle::Vehicle;

#[derive(Default)]
pub struct TrajectoryHash {
    hasher: FxHasher,
}

impl TrajectoryHash {
    /// Folds in one tick: each vehicle's id and exact pose bits, in vehicle order.
    pub fn add_tick(&mut self, vehicles: &[Vehicle]) {
        self.hasher.write_usize(vehicles.len());
        for v in vehicles {
            self.hasher.write_u64(v.id);
            self.hasher.write_u64(v.pose.x.to_bits());
            self.hasher.write_u64(v.pose.y.to_bits());
            self.hasher.write_u64(v.pose.z.to_bits());
            self.hasher.write_u64(v.pose.yaw.to_bits());
        }
    }

    pub fn finish(&self) -> u64 {
        self.hasher.finish()
    }
}
