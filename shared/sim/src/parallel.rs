//! How the tick's phases share out work: the smallest share worth a thread,
//! and a join that stays on one thread when the world is small.

/// Vehicles below which a parallel phase runs on one thread, and the share of
/// one task above: with the other workers kept awake through the tick
/// (`world::awake`), a share this small still pays for handing it over
/// (Bologna's Acosta district, 400 to 700 vehicles, a quarter shorter on two
/// threads than with 1,024; a 1,000-vehicle grid 40% more vehicle-steps per
/// second).
pub const MIN_VEHICLES_PER_TASK: usize = 256;

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
