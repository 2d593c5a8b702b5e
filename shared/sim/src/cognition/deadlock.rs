//! Deadlock breaking (the seed's FORCING_PRIORITY, "override to break a
//! deadlock"). When stopped vehicles wait on each other in a cycle (each one's
//! `dominating` vehicle is the next), the lowest id in the cycle is let through
//! its junction, and the vehicle it was waiting for holds in FORCING_PRIORITY
//! until the released one has crossed its path.

use trafficmesh_model::YieldPhase;

use crate::network::LaneNetwork;
use crate::vehicle::Vehicle;

const STOPPED_SPEED: f64 = 0.05;

/// The vehicle `v` is stopped waiting for, as an index (vehicles are sorted by id).
fn waits_for(vehicles: &[Vehicle], v: &Vehicle) -> Option<usize> {
    if !(v.yield_phase.is_yielding() && v.speed < STOPPED_SPEED) {
        return None;
    }
    let id = v.dominating?;
    vehicles.binary_search_by_key(&id, |o| o.id).ok()
}

/// Finds every waiting cycle in one pass over the "waits for" links (each vehicle
/// has at most one, so the graph is a set of chains ending in cycles) and breaks
/// it. Returns the number of cycles broken.
pub fn break_cycles(net: &LaneNetwork, vehicles: &mut [Vehicle]) -> usize {
    const UNSEEN: u32 = u32::MAX;
    let n = vehicles.len();
    // Which walk first reached each vehicle; a walk that meets itself found a cycle.
    let mut walk_of = vec![UNSEEN; n];
    let mut releases: Vec<(usize, usize)> = Vec::new();
    for start in 0..n {
        if walk_of[start] != UNSEEN {
            continue;
        }
        let mut cur = start;
        loop {
            walk_of[cur] = start as u32;
            let Some(next) = waits_for(vehicles, &vehicles[cur]) else { break };
            if walk_of[next] == start as u32 {
                // A new cycle through `next`: release its lowest id (lowest index).
                let mut lowest = next;
                let mut k = waits_for(vehicles, &vehicles[next]).expect("on a cycle");
                while k != next {
                    lowest = lowest.min(k);
                    k = waits_for(vehicles, &vehicles[k]).expect("on a cycle");
                }
                let holder = waits_for(vehicles, &vehicles[lowest]).expect("on a cycle");
                releases.push((lowest, holder));
                break;
            }
            if walk_of[next] != UNSEEN {
                break;
            }
            cur = next;
        }
    }
    for &(released, holder) in &releases {
        let id = vehicles[released].id;
        let v = &mut vehicles[released];
        v.forced_through = v
            .path
            .iter()
            .find(|&&l| net.lane(l).intersection)
            .and_then(|&l| net.lane(l).junction);
        v.yield_phase = YieldPhase::None;
        v.dominating = None;
        let h = &mut vehicles[holder];
        h.yield_phase = YieldPhase::ForcingPriority;
        h.dominating = Some(id);
        h.yield_point = h.front;
    }
    releases.len()
}
