//! Software prefetch hints. A tick at 10,000 vehicles waits on memory, not on
//! arithmetic: each vehicle reads lanes and lane-index entries scattered over
//! tens of megabytes, in an order the hardware cannot guess. The loops over
//! vehicles know it a few vehicles ahead and ask for those lines early. A hint
//! never faults and never changes a result.

/// Asks for the cache line at `p`.
#[inline(always)]
pub fn hint(p: *const u8) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: SSE is part of every x86_64 target, and a prefetch of any
        // address neither faults nor writes.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p.cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Asks for the cache line holding `value`.
#[inline(always)]
pub fn line<T>(value: &T) {
    hint((value as *const T).cast());
}

/// Lane bytes the passes over vehicles read, in 64-byte lines: the per-tick
/// fields, the inline geometry, the conflict list and right of way (see
/// `network::Lane`'s layout; a test there keeps them within).
pub const LANE_LINES: usize = 4;
