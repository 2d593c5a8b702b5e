//! Lockstep: each tick waits for the lights, crosswalks and spawner (and any
//! process that answers on `<cluster>/lockstep/step/*`), so the cluster runs
//! the very trajectories of `sim` on the same map, config and seed.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use trafficmesh_protocol::topics;

use trafficmesh_protocol::wire::{LockstepTick, TickReport};

use crate::support::*;

/// `sim`'s trajectory hash for `map`, seed 7 (the test clusters'), walkers
/// on as in the cluster.
fn sim_hash(map: &std::path::Path, duration: f64) -> String {
    let out = trafficmesh_cli(&[
        "sim",
        "--map",
        map.to_str().unwrap(),
        "--seed",
        "7",
        "--duration",
        &duration.to_string(),
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&out).unwrap();
    report["trajectory_hash"].as_str().unwrap().to_string()
}

/// The hash in the stepper's closing line.
fn cluster_hash(log: &str) -> Option<String> {
    let line = log.lines().find(|l| l.contains("ran the duration"))?;
    Some(line.rsplit("trajectory hash ").next()?.trim().to_string())
}

#[test]
fn a_lockstep_cluster_runs_the_trajectories_of_sim() {
    // As fast as possible (lockstep by default there), and paced with
    // lockstep asked for: the same trajectories either way.
    for (name, stepper, duration) in [
        ("ls_fast", "speed = 0\nduration = 60", 60.0),
        (
            "ls_paced",
            "speed = 20\nlockstep = true\nduration = 20",
            20.0,
        ),
    ] {
        let mut cluster = Cluster::start_stepper(name, stepper, true);
        let status = cluster.wait_exit(Duration::from_secs(120));
        let log = cluster.log();
        assert!(
            status.is_some_and(|s| s.success()),
            "{name}: `up` did not end cleanly after the duration ({status:?}):\n{log}"
        );
        let hash = cluster_hash(&log).unwrap_or_else(|| panic!("{name}: no closing line:\n{log}"));
        assert_eq!(
            hash,
            sim_hash(&four_way(), duration),
            "{name}: the cluster's trajectories differ from sim's"
        );
        // The crosswalks answer every tick: their states never go stale.
        assert!(
            !log.contains("went stale"),
            "{name}: crosswalk states went stale:\n{log}"
        );
        assert!(
            log.contains("[Zebra]"),
            "{name}: the walkers never entered a crosswalk:\n{log}"
        );
    }
}

#[test]
fn a_lockstep_cluster_with_a_reservation_intersection_runs_the_trajectories_of_sim() {
    // Every way granted by the intersection service, as `sim` grants it.
    let (_dir, map, _, _) = reservation_four_way();
    let mut cluster = Cluster::launch_spec(trafficmesh_testkit::ClusterSpec {
        seed: 7,
        stepper: "speed = 0\nduration = 60".into(),
        pedestrians: true,
        ..Cluster::spec("ls_reservation", &map)
    });
    let status = cluster.wait_exit(Duration::from_secs(120));
    let log = cluster.log();
    assert!(
        status.is_some_and(|s| s.success()),
        "`up` did not end cleanly after the duration ({status:?}):\n{log}"
    );
    let hash = cluster_hash(&log).unwrap_or_else(|| panic!("no closing line:\n{log}"));
    assert_eq!(
        hash,
        sim_hash(&map, 60.0),
        "the cluster's trajectories differ from sim's"
    );
    assert!(
        !log.contains("no answer from the intersection service"),
        "a round went unanswered:\n{log}"
    );
}

#[test]
fn the_stepper_waits_for_a_process_that_keeps_in_step() {
    let cluster = Cluster::start_stepper("ls_member", "speed = 0", false);
    let rt = runtime();
    rt.block_on(async {
        let bus = Arc::new(cluster.client().await);
        // An external simulator keeps in step: it answers each tick, and
        // holds its answer to one tick for a second, then reads the
        // stepper's tick.
        let seen: Arc<Mutex<Vec<u64>>> = Arc::default();
        let hold_at: Arc<Mutex<Option<u64>>> = Arc::default();
        let tick_while_held: Arc<Mutex<Option<u64>>> = Arc::default();
        let member = {
            let (bus, seen) = (bus.clone(), seen.clone());
            let (hold_at, tick_while_held) = (hold_at.clone(), tick_while_held.clone());
            tokio::spawn(async move {
                let key = bus.keys().key_at(&topics::LOCKSTEP_STEP, "probe");
                let asker = bus.clone();
                asker
                    .answer_ticks(&key, |tick: LockstepTick| {
                        seen.lock().unwrap().push(tick.tick);
                        let hold = *hold_at.lock().unwrap() == Some(tick.tick);
                        let (bus, tick_while_held) = (bus.clone(), tick_while_held.clone());
                        async move {
                            if hold {
                                tokio::time::sleep(Duration::from_secs(1)).await;
                                let stepper = status(&bus, "stepper").await;
                                *tick_while_held.lock().unwrap() = stepper.details["tick"].as_u64();
                            }
                            TickReport::Ready
                        }
                    })
                    .await
                    .unwrap();
            })
        };
        let deadline = Instant::now() + Duration::from_secs(30);
        while seen.lock().unwrap().len() < 200 {
            assert!(
                Instant::now() < deadline,
                "the stepper never asked the probe"
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        // From the tick it joined on, it was asked about every tick in turn.
        let last = {
            let seen = seen.lock().unwrap();
            assert!(
                seen.windows(2).all(|w| w[1] == w[0] + 1),
                "ticks asked out of turn: {:?}",
                &seen[..seen.len().min(50)]
            );
            *seen.last().unwrap()
        };
        let held = last + 100;
        *hold_at.lock().unwrap() = Some(held);
        let deadline = Instant::now() + Duration::from_secs(30);
        while tick_while_held.lock().unwrap().is_none() {
            assert!(
                Instant::now() < deadline,
                "the probe was never asked tick {held}"
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        // The question for tick `held` comes when `held` ticks are done.
        assert_eq!(
            *tick_while_held.lock().unwrap(),
            Some(held),
            "the stepper ran on while the probe held its answer"
        );
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let stepper = status(&bus, "stepper").await;
            if stepper.details["tick"].as_u64().unwrap() > held + 10 {
                let members = stepper.details["lockstep_members"].as_array().unwrap();
                assert!(members.iter().any(|m| m == "probe"), "{members:?}");
                break;
            }
            assert!(
                Instant::now() < deadline,
                "the stepper did not go on after the answer"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        member.abort();
    });
}
