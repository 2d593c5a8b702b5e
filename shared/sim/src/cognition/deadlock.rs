//! Deadlock breaking (the seed's FORCING_PRIORITY, "override to break a
//! deadlock"). When stopped vehicles wait on each other in a cycle (each one's
//! `dominating` vehicle is the next), the lowest id in the cycle is let through
//! its junction, and the vehicle it was waiting for holds in FORCING_PRIORITY
//! until the released one has crossed its path.

use rustc_hash::FxHashMap;
use trafficmesh_model::YieldPhase;

use crate::network::LaneNetwork;
use crate::vehicle::{Vehicle, VehicleId};

const STOPPED_SPEED: f64 = 0.05;

/// Returns the number of cycles broken.
pub fn break_cycles(net: &LaneNetwork, vehicles: &mut [Vehicle]) -> usize {
    let waiting: FxHashMap<VehicleId, (usize, VehicleId)> = vehicles
        .iter()
        .enumerate()
        .filter(|(_, v)| v.yield_phase.is_yielding() && v.speed < STOPPED_SPEED)
        .filter_map(|(i, v)| v.dominating.map(|d| (v.id, (i, d))))
        .collect();
    let mut ids: Vec<VehicleId> = waiting.keys().copied().collect();
    ids.sort_unstable();
    let mut released = Vec::new();
    for &start in &ids {
        let mut cycle = vec![start];
        let mut cur = start;
        while let Some(&(_, next)) = waiting.get(&cur) {
            if next == start {
                if cycle.iter().min() == Some(&start) {
                    released.push(start);
                }
                break;
            }
            if cycle.contains(&next) || cycle.len() > 64 {
                break;
            }
            cycle.push(next);
            cur = next;
        }
    }
    for &id in &released {
        let (i, holder) = waiting[&id];
        let v = &mut vehicles[i];
        v.forced_through = v
            .path
            .iter()
            .find(|&&l| net.lane(l).intersection)
            .and_then(|&l| net.lane(l).junction);
        v.yield_phase = YieldPhase::None;
        v.dominating = None;
        let h = &mut vehicles[waiting[&holder].0];
        h.yield_phase = YieldPhase::ForcingPriority;
        h.dominating = Some(id);
        h.yield_point = h.front;
    }
    released.len()
}
