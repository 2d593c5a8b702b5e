//! Thirty simulated minutes of random traffic on a 5 x 5 signalised grid: no two
//! vehicles ever overlap, and no vehicle stays stopped for ever.

mod support;

use std::collections::HashMap;

use support::*;
use trafficmesh_sim::{SimEvent, WorldConfig};

/// Longer than any wait the grid's rules can cause: a 60 s signal cycle and a queue.
const LONGEST_PLAUSIBLE_STOP: f64 = 240.0;

#[test]
fn grid_5x5_thirty_minutes_no_overlap_and_no_endless_stop() {
    let mut w = grid_world(
        5,
        WorldConfig {
            max_vehicles: 250,
            seed: 3,
            ..WorldConfig::default()
        },
    );
    let mut stopped_since: HashMap<u64, f64> = HashMap::new();
    let (mut despawned, mut peak) = (0, 0);
    while w.time() < 1800.0 {
        w.step();
        despawned += w
            .drain_events()
            .filter(|e| matches!(e, SimEvent::Despawned(_)))
            .count();
        peak = peak.max(w.vehicles().len());
        if !w.ticks().is_multiple_of(5) {
            continue;
        }
        let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.1);
        if let Some(&(a, b)) = pairs.first() {
            let describe = |id| {
                let v = vehicle(&w, id);
                let path: Vec<&str> = v
                    .path
                    .iter()
                    .map(|&l| w.network().lane(l).name.as_str())
                    .collect();
                let prev = v.behind.latest().map(|l| w.network().lane(l).name.as_str());
                format!(
                    "#{id} {} on {path:?} (prev {prev:?}) s={:.1} v={:.1} {:?} {:?} front_gap={:.1}",
                    w.network().kinds[v.kind].name,
                    v.s,
                    v.speed,
                    v.speed_mode,
                    v.yield_phase,
                    v.distance_to_front
                )
            };
            panic!(
                "overlap at t={:.2}:\n  {}\n  {}",
                w.time(),
                describe(a),
                describe(b)
            );
        }
        for v in w.vehicles() {
            if v.speed < 0.05 {
                let since = *stopped_since.entry(v.id).or_insert(w.time());
                assert!(
                    w.time() - since < LONGEST_PLAUSIBLE_STOP,
                    "vehicle {} stopped since t={since:.0} on {} ({:?}, {:?}, front gap {:.1})",
                    v.id,
                    w.network().lane(v.path[0]).name,
                    v.speed_mode,
                    v.yield_phase,
                    v.distance_to_front
                );
            } else {
                stopped_since.remove(&v.id);
            }
        }
    }
    assert!(peak >= 240, "the grid never filled up (peak {peak})");
    assert!(
        despawned > 1000,
        "only {despawned} trips finished in 30 minutes"
    );
}
