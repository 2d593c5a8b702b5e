//! AddTrafficSimulator: user-defined simulators join the spawn loop and the
//! priority system ("single simulator or priority sort -> highest wins").

mod support;

use std::sync::{Arc, Mutex};

use serde_json::json;
use support::*;
use trafficmesh_sim::network::LaneNetwork;
use trafficmesh_sim::spawn::{SpawnProposal, TrafficSimulator};
use trafficmesh_sim::{SimEvent, WorldConfig};

/// Proposes one Taxi at the start of lane 0 every tick and counts its spawns.
struct Always {
    spawned: Arc<Mutex<u32>>,
}

impl TrafficSimulator for Always {
    fn is_enabled(&self) -> bool {
        true
    }
    fn propose(&mut self, net: &LaneNetwork, _time: f64, out: &mut Vec<SpawnProposal>) {
        let kind = net
            .kinds
            .iter()
            .position(|k| k.name == "Taxi")
            .expect("Taxi is in the map's kinds");
        out.push(SpawnProposal {
            lane: 0,
            kind,
            route: None,
            slot: 0,
        });
    }
    fn spawned(&mut self, _slot: usize) {
        *self.spawned.lock().unwrap() += 1;
    }
}

#[test]
fn simulators_competing_for_one_spawn_point_take_turns_by_priority() {
    let mut road = lane("road", &[[0.0, 0.0], [500.0, 0.0]], &["end"]);
    road["speed_limit"] = json!(13.89);
    let mut end = lane("end", &[[500.0, 0.0], [520.0, 0.0]], &[]);
    end["intersection"] = json!(true);
    let mut w = world(
        &map(vec![road, end], json!({})),
        WorldConfig {
            max_vehicles: 100,
            ..WorldConfig::default()
        },
    );
    let (a, b) = (Arc::new(Mutex::new(0)), Arc::new(Mutex::new(0)));
    w.add_traffic_simulator(Box::new(Always { spawned: a.clone() }));
    w.add_traffic_simulator(Box::new(Always { spawned: b.clone() }));
    let mut spawns = 0;
    for _ in 0..(120.0 / 0.02) as usize {
        w.step();
        spawns += w
            .drain_events()
            .filter(|e| matches!(e, SimEvent::Spawned { .. }))
            .count();
    }
    let (a, b) = (*a.lock().unwrap(), *b.lock().unwrap());
    assert_eq!(a + b, spawns as u32);
    assert!(
        spawns >= 20,
        "only {spawns} spawns: the clearance check should pass every second or so"
    );
    // The winner's priority resets to 0 and the loser's grows: they alternate.
    assert!(
        a.abs_diff(b) <= 1,
        "first simulator spawned {a}, second {b}"
    );
    assert!(w.spawn_stats().lost_priority > 0);
}
