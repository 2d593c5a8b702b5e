//! Deadlock breaking (the AWSIM reference's FORCING_PRIORITY, "override to break a
//! deadlock"). When stopped vehicles wait on each other in a cycle (each one
//! for its `dominating` vehicle while it yields, else for the body in front of
//! it), the lowest id in the cycle among those held by a rule is let through
//! its junction, and the vehicle it was waiting for holds in FORCING_PRIORITY
//! until the released one has crossed its path. A cycle of bodies alone has
//! nobody a rule could release.

use trafficmesh_model::YieldPhase;

use super::{Perception, Snapshot};
use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

/// Slower than this a vehicle stands (and may be waiting for another).
pub(crate) const STOPPED_SPEED: f64 = 0.05;
/// No vehicle: the wait of one that waits for nobody.
pub const NOBODY: u32 = u32::MAX;
/// The junction a released vehicle goes through when its junction lane has
/// no junction number (a junction lane that crosses no other, as Lanelet2
/// maps have): without it the release would not be remembered, and the
/// vehicle would yield again the next tick and creep.
pub const UNNUMBERED_JUNCTION: u32 = u32::MAX;

/// The vehicle `i` is stopped waiting for this tick (an index; [`NOBODY`] if
/// none), and whether a rule rather than a body holds it. Taken while each
/// perception is made, so that deadlock breaking needs no pass of its own over
/// the vehicles. (A rule's dominating vehicle is one of the junction's
/// members, which right of way looked over.)
pub fn wait_of(snap: &Snapshot, i: usize, p: &Perception) -> Wait {
    if snap.vehicles[i].speed >= STOPPED_SPEED {
        return (NOBODY, false);
    }
    if p.yield_phase.is_yielding() {
        let junction = snap.row[i].junction;
        let rule = p
            .dominating
            .and_then(|id| snap.junctions.index_of(junction, id));
        return rule.map_or((NOBODY, false), |i| (i, true));
    }
    (p.front_vehicle.unwrap_or(NOBODY), false)
}

/// Whom a vehicle waits for, and whether a rule holds it: see [`wait_of`].
pub type Wait = (u32, bool);

/// Finds every waiting cycle in this tick's perceptions and breaks it, before
/// they are applied. Each vehicle waits for at most one other (`waits`, from
/// [`wait_of`]), so the graph is a set of chains ending in cycles, disjoint
/// from each other. Only a cycle with a rule-held member can be broken, and
/// the walk from that member finds it, so the walks start from the rule-held
/// vehicles alone (a few, against thousands queued behind bodies). Returns
/// the number of cycles broken.
pub fn break_cycles(
    net: &LaneNetwork,
    vehicles: &[Vehicle],
    waits: &[Wait],
    perceptions: &mut [Perception],
) -> usize {
    let n = vehicles.len();
    let mut walk_of = vec![NOBODY; n];
    let mut releases: Vec<(usize, usize)> = Vec::new();
    for start in (0..n).filter(|&i| waits[i].1) {
        if walk_of[start] != NOBODY {
            continue;
        }
        let Some(member) = walk_into_cycle(waits, &mut walk_of, start, |_| true) else {
            continue;
        };
        // Release the cycle's lowest id among the rule-held.
        let lowest = cycle_through(waits, member)
            .filter(|&k| waits[k].1)
            .min_by_key(|&k| vehicles[k].id);
        if let Some(lowest) = lowest {
            releases.push((lowest, waits[lowest].0 as usize));
        }
    }
    for &(released, holder) in &releases {
        let v = &vehicles[released];
        let p = &mut perceptions[released];
        p.forced_through = v
            .path
            .iter()
            .find(|&&l| net.lane(l).intersection)
            .map(|&l| net.lane(l).junction.unwrap_or(UNNUMBERED_JUNCTION));
        p.yield_phase = YieldPhase::None;
        p.dominating = None;
        let h = &mut perceptions[holder];
        h.yield_phase = YieldPhase::ForcingPriority;
        h.dominating = Some(v.id);
        h.yield_point = vehicles[holder].front;
    }
    releases.len()
}

/// The cycles whose every member has stood still for `patience` seconds.
/// Mostly cycles of bodies alone, which no rule could release: full lanes
/// around a block, each queue's head waiting for room on the next, through
/// as many junctions as the ring passes. Also a cycle with a rule-held member
/// that [`break_cycles`] released to no avail, because a body stands in its
/// way as well (two vehicles, each with its body across the other's path,
/// one of them yielding to the other): a release moves the released one at
/// once, so a cycle that outlasts the patience is one it did not free.
/// Nobody in one can ever move again without help. Each cycle is given by
/// its members' indices.
pub fn gridlocks(vehicles: &[Vehicle], waits: &[Wait], patience: f64) -> Vec<Vec<usize>> {
    let n = vehicles.len();
    let patient = |i: usize| waits[i].0 != NOBODY && vehicles[i].trip.wait >= patience;
    let mut walk_of = vec![NOBODY; n];
    let mut cycles = Vec::new();
    for start in 0..n {
        if walk_of[start] != NOBODY || !patient(start) {
            continue;
        }
        if let Some(member) = walk_into_cycle(waits, &mut walk_of, start, patient) {
            cycles.push(cycle_through(waits, member).collect());
        }
    }
    cycles
}

/// Follows the waits from `start` while `goes_on` admits the next vehicle,
/// marking each one reached with `start` in `walk_of`. Returns a member of
/// the cycle the walk closes, if it closes one: a walk that reaches a
/// vehicle waiting for nobody, one an earlier walk marked (its cycle, if
/// any, was found then) or one `goes_on` refuses closes none.
fn walk_into_cycle(
    waits: &[Wait],
    walk_of: &mut [u32],
    start: usize,
    goes_on: impl Fn(usize) -> bool,
) -> Option<usize> {
    let mut cur = start;
    loop {
        walk_of[cur] = start as u32;
        let next = waits[cur].0;
        if next == NOBODY {
            return None;
        }
        let next = next as usize;
        if walk_of[next] == start as u32 {
            return Some(next);
        }
        if walk_of[next] != NOBODY || !goes_on(next) {
            return None;
        }
        cur = next;
    }
}

/// The members of the cycle through `member`, in waiting order from it.
fn cycle_through(waits: &[Wait], member: usize) -> impl Iterator<Item = usize> + '_ {
    std::iter::successors(Some(member), move |&k| {
        let next = waits[k].0 as usize;
        (next != member).then_some(next)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{WorldConfig, test_grid_world};

    /// Three vehicles of a grid world that have stood `waits` seconds.
    fn standing_for(waits: [f64; 3]) -> Vec<Vehicle> {
        let mut world = test_grid_world(3, WorldConfig::default());
        while world.vehicles().len() < 3 {
            world.step();
        }
        let mut vehicles = world.vehicles()[..3].to_vec();
        for (v, wait) in vehicles.iter_mut().zip(waits) {
            v.trip.wait = wait;
        }
        vehicles
    }

    #[test]
    fn a_ring_of_bodies_that_stood_the_patience_is_a_gridlock() {
        let vehicles = standing_for([20.0, 15.0, 12.0]);
        let waits = [(1, false), (2, false), (0, false)];
        assert_eq!(gridlocks(&vehicles, &waits, 10.0), vec![vec![0, 1, 2]]);
    }

    #[test]
    fn a_cycle_with_a_rule_held_member_that_outlasts_the_patience_is_a_gridlock() {
        let vehicles = standing_for([20.0, 15.0, 12.0]);
        let waits = [(1, false), (2, true), (0, false)];
        assert_eq!(gridlocks(&vehicles, &waits, 10.0), vec![vec![0, 1, 2]]);
    }

    #[test]
    fn a_cycle_one_member_of_which_moved_within_the_patience_is_not() {
        let vehicles = standing_for([20.0, 4.0, 12.0]);
        let waits = [(1, false), (2, true), (0, false)];
        assert!(gridlocks(&vehicles, &waits, 10.0).is_empty());
    }

    #[test]
    fn a_chain_that_ends_at_a_vehicle_waiting_for_nobody_is_not() {
        let vehicles = standing_for([20.0, 20.0, 20.0]);
        let waits = [(1, false), (2, false), (NOBODY, false)];
        assert!(gridlocks(&vehicles, &waits, 10.0).is_empty());
    }
}
