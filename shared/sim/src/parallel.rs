//! How the tick's phases share out work: the smallest share worth a thread,
//! and a join that stays on one thread when the world is small.

/// Vehicles below which a parallel phase runs on one thread: waking the other
/// threads for a few hundred vehicles costs more than it saves (a 1,000-vehicle
/// SUMO grid ran faster on one thread than on two).
pub const MIN_VEHICLES_PER_TASK: usize = 1024;

/// `rayon::join(a, b)` when `parallel`, else `a` then `b` on this thread. A
/// world too small for its phases to run on the pool leaves the other
/// workers asleep (see [`crate::World::step`]), and a join would wake one
/// only to hand it a moment's work.
pub fn join_if<RA: Send, RB: Send>(
    parallel: bool,
    a: impl FnOnce() -> RA + Send,
    b: impl FnOnce() -> RB + Send,
) -> (RA, RB) {
    if parallel {
        rayon::join(a, b)
    } else {
        (a(), b())
    }
}
