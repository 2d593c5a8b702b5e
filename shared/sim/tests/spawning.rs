//! Spawning: ego distance, per-lane rate limits, branch weights,
//! RemoveVehiclesInRadius and Restart.

mod support;

use glam::DVec2;
use serde_json::json;
use support::*;
use trafficmesh_model::{BranchWeights, MapFile, NextWeight, SpawnRate, TrafficSpawnConfig};
use trafficmesh_sim::branching::BranchStats;
use trafficmesh_sim::world::{QueuedSpawn, SpawnRejection};
use trafficmesh_sim::{Ego, SimEvent, WorldConfig};

/// Four parallel eastbound feeder lanes (y = 0, 10, 20, 30), each forking at
/// x = 300 into `<f>_a` (straight on) and `<f>_b` (bending off); a random
/// simulator spawns on the feeders.
fn forks() -> MapFile {
    let mut lanes = Vec::new();
    let feeders: Vec<String> = (0..4).map(|k| format!("F{k}")).collect();
    for (k, f) in feeders.iter().enumerate() {
        let y = k as f64 * 10.0;
        lanes.push(lane(
            f,
            &[[0.0, y], [300.0, y]],
            &[&format!("{f}_a"), &format!("{f}_b")],
        ));
        let mut a = lane(&format!("{f}_a"), &[[300.0, y], [400.0, y]], &[]);
        a["intersection"] = json!(true);
        lanes.push(a);
        lanes.push(lane(
            &format!("{f}_b"),
            &[[300.0, y], [340.0, y + 4.0], [400.0, y + 4.0]],
            &[],
        ));
    }
    let mut m = map(lanes, json!({}));
    m.traffic_simulators = vec![serde_json::from_value(json!({
        "kind": "random", "lanes": feeders, "prefabs": ["Taxi", "SmallCar", "Van"], "spawn_attempts_per_tick": 4
    }))
    .unwrap()];
    m
}

#[test]
fn no_spawn_within_50_m_of_the_ego() {
    let mut w = world(
        &forks(),
        WorldConfig {
            max_vehicles: 100,
            ..WorldConfig::default()
        },
    );
    // 40 m from F1's start, 41 m from F0's and F2's, more than 50 m from F3's.
    w.set_ego(Some(Ego::car(0.0, -30.0, 0.0)));
    let mut near = Vec::new();
    let mut far = 0;
    for _ in 0..(120.0 / 0.02) as usize {
        w.step();
        let events: Vec<SimEvent> = w.drain_events().collect();
        for e in events {
            if let SimEvent::Spawned { lane, .. } = e {
                let start = w.network().lane(lane).line.point(0);
                if start.distance(DVec2::new(0.0, -30.0)) < 50.0 {
                    near.push(w.network().lane(lane).name.clone());
                } else {
                    far += 1;
                }
            }
        }
    }
    assert!(
        near.is_empty(),
        "spawned within 50 m of the ego on {near:?}"
    );
    assert!(
        far > 5,
        "the lane far from the ego spawned only {far} vehicles"
    );
    assert!(w.spawn_stats().too_close_to_ego > 0);
}

#[test]
fn a_lane_at_6_spawns_per_minute_gets_at_most_6_a_minute() {
    let mut w = world(
        &forks(),
        WorldConfig {
            max_vehicles: 200,
            ..WorldConfig::default()
        },
    );
    let config = TrafficSpawnConfig {
        spawn_rates: vec![
            SpawnRate {
                lane: "f2".into(),
                spawns_per_minute: 6.0,
            },
            SpawnRate {
                lane: "F3".into(),
                spawns_per_minute: 0.0,
            },
        ],
        branch_weights: vec![],
    };
    w.set_spawn_config(config).unwrap();
    let mut limited = Vec::new();
    let mut unlimited = 0;
    for _ in 0..(300.0 / 0.02) as usize {
        w.step();
        let (l2, l3) = (
            w.network().lane_id("F2").unwrap(),
            w.network().lane_id("F3").unwrap(),
        );
        for e in w.drain_events() {
            match e {
                SimEvent::Spawned { lane, time, .. } if lane == l2 => limited.push(time),
                SimEvent::Spawned { lane, .. } if lane == l3 => unlimited += 1,
                _ => {}
            }
        }
    }
    for window in limited.windows(7) {
        assert!(
            window[6] - window[0] >= 60.0 - 1e-6,
            "7 spawns within a minute: {window:?}"
        );
    }
    // The limit is the binding constraint, not clearance: close to 6 a minute.
    assert!(
        limited.len() >= 27,
        "only {} spawns in 5 minutes",
        limited.len()
    );
    assert!(
        unlimited > 2 * limited.len(),
        "spawnsPerMinute 0 must mean no limit ({unlimited} spawns)"
    );
}

#[test]
fn weights_2_to_1_give_2_to_1_frequencies() {
    let mut w = world(
        &forks(),
        WorldConfig {
            max_vehicles: 200,
            seed: 7,
            ..WorldConfig::default()
        },
    );
    let branch = |f: &str| BranchWeights {
        from_lane: f.into(),
        next: vec![
            NextWeight {
                lane: format!("{f}_A"),
                weight: 2.0,
            },
            NextWeight {
                lane: format!("{f}_b"),
                weight: 1.0,
            },
        ],
    };
    w.set_spawn_config(TrafficSpawnConfig {
        spawn_rates: vec![],
        branch_weights: (0..4).map(|k| branch(&format!("F{k}"))).collect(),
    })
    .unwrap();
    run_for(&mut w, 900.0);
    let net = w.network();
    let (mut a, mut b) = (0u64, 0u64);
    for k in 0..4 {
        let f = net.lane_id(&format!("F{k}")).unwrap();
        a += w
            .branch_stats()
            .expect("a world with simulators keeps them")
            .count(f, net.lane_id(&format!("F{k}_a")).unwrap());
        b += w
            .branch_stats()
            .expect("a world with simulators keeps them")
            .count(f, net.lane_id(&format!("F{k}_b")).unwrap());
    }
    let n = (a + b) as f64;
    assert!(n >= 500.0, "only {n} decisions");
    let observed = a as f64 / n;
    let sigma = (2.0 / 9.0 / n).sqrt();
    assert!(
        (observed - 2.0 / 3.0).abs() < 4.0 * sigma,
        "observed {observed:.3} of {n} for weight 2/3"
    );
    let csv = w.branch_csv();
    assert!(
        csv.lines().any(|l| l.starts_with("F0,F0_a,weighted,")),
        "{csv}"
    );
    // Read back (a restarted spawner's), the statistics write the same CSV.
    let read = BranchStats::from_csv(net, &csv).unwrap();
    assert_eq!(read.total(), w.branch_stats().unwrap().total());
    assert_eq!(read.to_csv(net), csv);
    // A CSV that does not fit the map is refused, naming the line.
    let wrong = csv.replacen("F0,F0_a", "F0,nowhere", 1);
    let err = BranchStats::from_csv(net, &wrong).unwrap_err();
    assert!(err.contains("nowhere") && err.contains("line "), "{err}");
    assert!(BranchStats::from_csv(net, "not,a,header\n").is_err());
}

#[test]
fn uniform_choices_are_labelled_uniform_no_config() {
    let mut w = world(
        &forks(),
        WorldConfig {
            max_vehicles: 50,
            ..WorldConfig::default()
        },
    );
    run_for(&mut w, 120.0);
    let csv = w.branch_csv();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert!(!rows.is_empty());
    assert!(
        rows.iter()
            .all(|r| r.split(',').nth(2) == Some("uniform_no_config")),
        "{csv}"
    );
}

#[test]
fn remove_vehicles_in_radius_returns_the_count_and_they_are_gone_next_tick() {
    let mut w = world(
        &forks(),
        WorldConfig {
            max_vehicles: 200,
            ..WorldConfig::default()
        },
    );
    w.set_ego(Some(Ego::car(-500.0, -500.0, 0.0)));
    run_for(&mut w, 60.0);
    let center = DVec2::new(150.0, 15.0);
    let inside: Vec<u64> = w
        .vehicles()
        .iter()
        .filter(|v| DVec2::new(v.pose.x, v.pose.y).distance(center) <= 60.0)
        .map(|v| v.id)
        .collect();
    assert!(inside.len() >= 3, "scene too empty: {}", inside.len());
    let total = w.vehicles().len();
    assert_eq!(w.remove_vehicles_near(center, 60.0), inside.len());
    w.step();
    for id in &inside {
        assert!(
            w.vehicle(*id).is_none(),
            "vehicle {id} still there after the next tick"
        );
    }
    assert!(w.vehicles().len() >= total - inside.len());
}

#[test]
fn restart_resets_state_with_the_new_maximum() {
    let mut w = world(
        &forks(),
        WorldConfig {
            max_vehicles: 12,
            ..WorldConfig::default()
        },
    );
    assert!(run_until(&mut w, 60.0, |w| w.vehicles().len() == 12));
    let before = w.vehicles().iter().map(|v| v.id).max().unwrap();
    w.restart(3, None);
    assert!(w.vehicles().is_empty());
    let mut peak = 0;
    run_for(&mut w, 60.0);
    for _ in 0..500 {
        w.step();
        peak = peak.max(w.vehicles().len());
    }
    assert_eq!(peak, 3, "the new maximum is 3");
    assert!(
        w.vehicles().iter().all(|v| v.id > before),
        "ids keep counting after a restart"
    );
}

#[test]
fn spawn_config_with_unknown_lane_is_rejected_and_nothing_changes() {
    let mut w = world(&forks(), WorldConfig::default());
    let bad = TrafficSpawnConfig {
        spawn_rates: vec![SpawnRate {
            lane: "F1".into(),
            spawns_per_minute: -1.0,
        }],
        branch_weights: vec![BranchWeights {
            from_lane: "Nope".into(),
            next: vec![],
        }],
    };
    let err = w.set_spawn_config(bad).unwrap_err().to_string();
    for expected in [
        "lane 'F1'",
        "spawnsPerMinute",
        "fromLane 'Nope'",
        "unknown lane 'Nope'",
        "'next': is empty",
    ] {
        assert!(err.contains(expected), "missing {expected:?} in: {err}");
    }
    assert_eq!(w.spawn_config(), TrafficSpawnConfig::default());
}

/// RemoveVehiclesInRadius around the ego measures from the ego's own height:
/// on a road 12 m up, the vehicles within a few metres of an ego there go.
#[test]
fn remove_around_an_ego_on_an_elevated_road_uses_its_height() {
    let mut map = serde_json::to_value(forks()).unwrap();
    for lane in map["lanes"].as_array_mut().unwrap() {
        for p in lane["waypoints"].as_array_mut().unwrap() {
            p[2] = json!(12.0);
        }
    }
    let map: MapFile = serde_json::from_value(map).unwrap();
    let mut w = world(
        &map,
        WorldConfig {
            max_vehicles: 200,
            ..WorldConfig::default()
        },
    );
    run_for(&mut w, 60.0);
    let target = w.vehicles()[0].clone();
    assert!((target.pose.z - 12.0).abs() < 1e-9, "the road is 12 m up");
    let mut ego = Ego::car(target.pose.x, target.pose.y, target.pose.yaw);
    ego.pose.z = 12.0;
    w.set_ego(Some(ego));
    let near: Vec<u64> = w
        .vehicles()
        .iter()
        .filter(|v| {
            DVec2::new(v.pose.x, v.pose.y).distance(DVec2::new(target.pose.x, target.pose.y)) <= 8.0
        })
        .map(|v| v.id)
        .collect();
    assert_eq!(w.remove_vehicles_around_ego(8.0), Some(near.len()));
    w.step();
    assert!(
        w.vehicle(target.id).is_none(),
        "the vehicle at the ego is gone"
    );
}

/// Restart with a new seed draws what follows from other random streams,
/// the same ones for the same seed; without one the run's seed goes on.
#[test]
fn restart_with_a_new_seed_changes_what_follows_deterministically() {
    let run = |seed: Option<u64>| {
        let mut w = world(
            &forks(),
            WorldConfig {
                max_vehicles: 60,
                ..WorldConfig::default()
            },
        );
        run_for(&mut w, 30.0);
        w.restart(60, seed);
        run_for(&mut w, 60.0);
        w.trajectory_hash()
    };
    assert_eq!(run(Some(9)), run(Some(9)), "the same seed, the same run");
    assert_ne!(run(Some(9)), run(None), "a new seed, other traffic");
    assert_eq!(run(None), run(None));
}

#[test]
fn a_world_without_simulators_leaves_the_branch_statistics_to_the_spawner() {
    // The stepper's world: the spawner service keeps the only statistics,
    // from the decisions the world reports as events.
    let mut w = world(&forks(), WorldConfig::default()).without_simulators();
    for k in 0..4 {
        w.place_vehicle("Taxi", &format!("F{k}"), 250.0, 10.0)
            .unwrap();
    }
    let mut decisions = 0;
    for _ in 0..500 {
        w.step();
        decisions += w
            .drain_events()
            .filter(|e| matches!(e, SimEvent::BranchDecision { .. }))
            .count();
    }
    assert_eq!(decisions, 4, "each vehicle chose a branch once");
    assert!(w.branch_stats().is_none());
    assert_eq!(w.branch_csv().lines().count(), 1, "the header alone");
}

/// A road along y = 0 (through a junction at x = 200), and a lane that
/// begins just beside it heading away (south from (98, -0.5)): no rule joins
/// the two, but a body on the road
/// reaches over where a wide body at the lane's start would stand.
fn lane_beginning_beside_a_road() -> MapFile {
    let mut junction = lane("junction", &[[200.0, 0.0], [220.0, 0.0]], &["exit"]);
    junction["intersection"] = json!(true);
    map(
        vec![
            lane("road", &[[0.0, 0.0], [200.0, 0.0]], &["junction"]),
            junction,
            lane("exit", &[[220.0, 0.0], [400.0, 0.0]], &[]),
            lane("side", &[[98.0, -0.5], [98.0, -100.0]], &[]),
        ],
        json!({}),
    )
}

/// A truck is not spawned where its body would stand on a body of another
/// lane (a car passing the lane's start), and is once that body has gone.
#[test]
fn no_spawn_onto_a_body_of_another_lane_beside_the_spawn_point() {
    let mut w = world(&lane_beginning_beside_a_road(), WorldConfig::default());
    let passing = w.place_vehicle("Taxi", "road", 100.5, 0.0).unwrap();
    w.step();
    let truck = w.kind_index("Truck_2t").expect("the catalogue's truck");
    let side = w.network().lane_id("side").expect("the side lane");
    let order = QueuedSpawn {
        kind: truck,
        lane: side,
        route: None,
        max_vehicles: 10,
    };
    w.queue_spawn(order.clone());
    w.step();
    assert_eq!(
        w.take_spawn_results(),
        [Err(SpawnRejection::NotSpawnable)],
        "the car's body stands where the truck's would"
    );
    let gone = run_until(&mut w, 30.0, |w| vehicle(w, passing).back.x > 110.0);
    assert!(gone, "the car drives on");
    w.queue_spawn(order);
    w.step();
    let admitted = w.take_spawn_results();
    assert!(
        matches!(admitted[..], [Ok(_)]),
        "clear again, the truck spawns: {admitted:?}"
    );
    assert_no_overlap(&w);
}
