//! The vehicles' order in the world's list is a matter of memory locality
//! only: regrouped by lane at any interval, or never, a busy grid gives the
//! same trajectories and the same events in the same order.

mod support;

use support::*;
use trafficmesh_sim::populate::populate;
use trafficmesh_sim::{SimEvent, WorldConfig};

struct Run {
    hash: u64,
    events: Vec<SimEvent>,
    /// The list was out of id order after some tick.
    reordered: bool,
}

fn run(regroup_interval: u64) -> Run {
    let mut w = grid_world(
        6,
        WorldConfig {
            max_vehicles: 2600,
            seed: 5,
            regroup_interval,
            ..WorldConfig::default()
        },
    );
    // Full enough for queues at every junction, yields and deadlocks.
    populate(&mut w, 2500);
    let (mut events, mut reordered) = (Vec::new(), false);
    for _ in 0..3000 {
        w.step();
        events.extend(w.drain_events());
        reordered |= !w.vehicles().is_sorted_by_key(|v| v.id);
    }
    Run {
        hash: w.trajectory_hash(),
        events,
        reordered,
    }
}

#[test]
fn regrouping_the_vehicle_list_changes_no_trajectory_and_no_event() {
    let never = run(0);
    assert!(
        !never.reordered,
        "without regrouping the list keeps id order"
    );
    let count = |r: &Run, what: fn(&SimEvent) -> bool| r.events.iter().filter(|e| what(e)).count();
    assert!(count(&never, |e| matches!(e, SimEvent::Despawned(_))) > 100);
    assert!(count(&never, |e| matches!(e, SimEvent::BranchDecision { .. })) > 100);
    for interval in [50, 7] {
        let regrouped = run(interval);
        assert!(
            regrouped.reordered,
            "every {interval} ticks: the list was regrouped"
        );
        assert_eq!(
            regrouped.hash, never.hash,
            "every {interval} ticks: trajectories"
        );
        let first_difference =
            (regrouped.events.iter().zip(&never.events)).position(|(a, b)| a != b);
        if let Some(k) = first_difference {
            let around = |events: &[SimEvent]| {
                events[k.saturating_sub(1)..(k + 2).min(events.len())].to_vec()
            };
            panic!(
                "every {interval} ticks: event {k} differs: {:?} against {:?}",
                around(&regrouped.events),
                around(&never.events)
            );
        }
        assert_eq!(
            regrouped.events.len(),
            never.events.len(),
            "every {interval} ticks: event count"
        );
    }
}
