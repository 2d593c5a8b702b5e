//! Deadlock breaking (the seed's FORCING_PRIORITY, "override to break a
//! deadlock"). When stopped vehicles wait on each other in a cycle (each one's
//! `dominating` vehicle is the next), the lowest id in the cycle is let through
//! its junction, and the vehicle it was waiting for holds in FORCING_PRIORITY
//! until the released one has crossed its path.

use rayon::prelude::*;
use trafficmesh_model::YieldPhase;

use super::Perception;
use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

const STOPPED_SPEED: f64 = 0.05;
const NOBODY: u32 = u32::MAX;

/// Finds every waiting cycle in this tick's perceptions and breaks it, before
/// they are applied. Each vehicle waits for at most one other, so the graph is a
/// set of chains ending in cycles: one pass finds them all. Returns the number
/// of cycles broken.
pub fn break_cycles(
    net: &LaneNetwork,
    vehicles: &[Vehicle],
    perceptions: &mut [Perception],
) -> usize {
    // Index of the vehicle each one is stopped waiting for (vehicles are sorted by id).
    let waits: Vec<u32> = vehicles
        .par_iter()
        .zip(perceptions.par_iter())
        .map(|(v, p)| {
            let waiting = p.yield_phase.is_yielding() && v.speed < STOPPED_SPEED;
            p.dominating
                .filter(|_| waiting)
                .and_then(|id| vehicles.binary_search_by_key(&id, |o| o.id).ok())
                .map_or(NOBODY, |i| i as u32)
        })
        .collect();
    let n = vehicles.len();
    let mut walk_of = vec![NOBODY; n];
    let mut releases: Vec<(usize, usize)> = Vec::new();
    for start in 0..n {
        if walk_of[start] != NOBODY || waits[start] == NOBODY {
            continue;
        }
        let mut cur = start;
        loop {
            walk_of[cur] = start as u32;
            let next = waits[cur];
            if next == NOBODY {
                break;
            }
            let next = next as usize;
            if walk_of[next] == start as u32 {
                // A new cycle through `next`: release its lowest id (lowest index).
                let mut lowest = next;
                let mut k = waits[next] as usize;
                while k != next {
                    lowest = lowest.min(k);
                    k = waits[k] as usize;
                }
                releases.push((lowest, waits[lowest] as usize));
                break;
            }
            if walk_of[next] != NOBODY {
                break;
            }
            cur = next;
        }
    }
    for &(released, holder) in &releases {
        let v = &vehicles[released];
        let p = &mut perceptions[released];
        p.forced_through = v
            .path
            .iter()
            .find(|&&l| net.lane(l).intersection)
            .and_then(|&l| net.lane(l).junction);
        p.yield_phase = YieldPhase::None;
        p.dominating = None;
        let h = &mut perceptions[holder];
        h.yield_phase = YieldPhase::ForcingPriority;
        h.dominating = Some(v.id);
        h.yield_point = vehicles[holder].front;
    }
    releases.len()
}
