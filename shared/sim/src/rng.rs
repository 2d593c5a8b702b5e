//! Seeded random streams. Every simulator and every vehicle owns one, so draws
//! never depend on thread scheduling or on other entities.

use rand_core::Rng;
use rand_pcg::Pcg64Mcg;

#[derive(Clone, Debug)]
pub struct SimRng(Pcg64Mcg);

/// SplitMix64 finaliser: spreads (seed, stream) over the generator's state.
pub(crate) use trafficmesh_model::hash::splitmix as mix;

impl SimRng {
    /// A stream determined by the run's seed and the owner's stream number.
    pub fn new(seed: u64, stream: u64) -> Self {
        let hi = mix(seed ^ trafficmesh_model::hash::GOLDEN);
        let lo = mix(stream.wrapping_add(hi));
        // The MCG state must be odd.
        SimRng(Pcg64Mcg::new(((hi as u128) << 64) | (lo as u128) | 1))
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        debug_assert!(n > 0);
        ((self.0.next_u64() as u128 * n as u128) >> 64) as usize
    }
}
