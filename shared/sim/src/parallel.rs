//! How the tick's phases share out work: the smallest share worth a thread,
//! and a join that stays on one thread when the world is small.

/// Vehicles below which a tick runs on one thread: with the other workers
/// kept awake through the tick (`world::awake`), a world this small still
/// pays for handing work over (Bologna's Acosta district, 100 to 700
/// vehicles: its hours of 100 to 250 vehicles went on one thread before).
pub const MIN_VEHICLES_PER_TASK: usize = 128;

/// Vehicles per chunk of a parallel pass in a world large enough for the
/// pool: small enough that two workers end a pass of a few hundred vehicles
/// together (chunks of 256 left one worker a third more work than the other
/// on 400 vehicles), large enough that handing a chunk over stays cheap.
const VEHICLES_PER_CHUNK: usize = 64;

/// The chunk length of a parallel pass over `n` vehicles: one chunk, on one
/// thread, below [`MIN_VEHICLES_PER_TASK`]. A function of `n` alone, so that
/// the chunks, and what is joined from them in order, never depend on the
/// thread count.
pub fn chunk_len(n: usize) -> usize {
    if n < MIN_VEHICLES_PER_TASK {
        n.max(1)
    } else {
        VEHICLES_PER_CHUNK
    }
}

/// Vehicles below which the tick's light passes (grouping the lane index,
/// sorting its lanes, drawing the body grid's boxes, asking for lane
/// choices) run on one thread even when the heavy ones (lane following,
/// perception, motion) share the pool: a few hundred vehicles' worth of such
/// work is shorter than handing it over and pulling the vehicles' lines
/// back to the other core after.
const MIN_VEHICLES_FOR_LIGHT_PASSES: usize = 2048;

/// Whether a light pass over `n` vehicles runs on the pool.
pub fn light_pass_parallel(n: usize) -> bool {
    n >= MIN_VEHICLES_FOR_LIGHT_PASSES
}

/// The minimum piece of a light pass over `n` vehicles: all of them below
/// [`MIN_VEHICLES_FOR_LIGHT_PASSES`].
pub fn light_pass_len(n: usize) -> usize {
    if light_pass_parallel(n) {
        chunk_len(n)
    } else {
        n.max(1)
    }
}

/// How many chunks of [`chunk_len`] a pass over `n` vehicles has.
pub fn chunk_count(n: usize) -> usize {
    n.div_ceil(chunk_len(n))
}

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
