//! The services that keep no road of their own, each killed in turn (the
//! crosswalks, the pedestrians, the admin): `up` restarts it; meanwhile
//! nothing else falls, the stepper's fail-safe holds where it must and
//! `trafficmesh status` says so, and within 5 s of its return the cluster is
//! healthy again with nothing saved lost.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use serde_json::Value;
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::CrosswalkOccupancy;

use crate::support::*;

/// Each live service's pid.
fn pids(health: &Value) -> BTreeMap<String, u64> {
    health["services"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(_, s)| s["alive"] == true)
        .filter_map(|(name, s)| Some((name.clone(), s["pid"].as_u64()?)))
        .collect()
}

#[test]
fn each_service_killed_in_turn_comes_back_and_nothing_else_falls() {
    // Restarted after 3 s: past the 2 s validity, so the fail-safe shows.
    let cluster = Cluster::launch_spec(trafficmesh_testkit::ClusterSpec {
        seed: 7,
        stepper: "speed = 1".into(),
        spawner: "max_vehicles = 20".into(),
        pedestrians: true,
        admin_token: Some(TOKEN.into()),
        restart_backoff_ms: 3000,
        ..Cluster::spec("killeach", &four_way())
    });
    cluster.wait_for_admin();
    let admin = cluster.admin.clone().unwrap();
    let spawn_config = cluster.dir.path().join("traffic_spawn.json");
    let config_before = std::fs::read(&spawn_config).ok();
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::with_traffic(&bus, 3).await;
        let (road_before, since) = (batches.latest().await.time, Instant::now());
        let areas = status(&bus, "crosswalks").await.details["areas"]
            .as_u64()
            .unwrap() as usize;
        for victim in ["crosswalks", "pedestrians", "admin"] {
            let h = tokio::task::block_in_place(|| cluster.health("1"));
            let before = pids(&h);
            for s in [
                "stepper",
                "spawner",
                "lights",
                "crosswalks",
                "pedestrians",
                "admin",
            ] {
                assert!(before.contains_key(s), "{s} not alive before: {h}");
            }
            let pid = before[victim];
            unsafe { libc::kill(pid as i32, libc::SIGKILL) };

            // The fault in force: stale crosswalks count as blocked, and
            // `trafficmesh status` says the cluster is degraded.
            if victim == "crosswalks" {
                let deadline = Instant::now() + Duration::from_secs(5);
                loop {
                    let h = tokio::task::block_in_place(|| cluster.health("1"));
                    if h["degraded"] == true
                        && h["reasons"]
                            .to_string()
                            .contains("crosswalk states are stale")
                    {
                        break;
                    }
                    assert!(
                        Instant::now() < deadline,
                        "no fail-safe for the killed crosswalks: {h}"
                    );
                }
            }

            // Back: a new process, and healthy within 5 s of its return.
            let deadline = Instant::now() + Duration::from_secs(30);
            let back = loop {
                let s = status(&bus, victim).await;
                if s.pid != pid as u32 {
                    break Instant::now();
                }
                assert!(Instant::now() < deadline, "{victim} was not restarted");
                tokio::time::sleep(Duration::from_millis(100)).await;
            };
            let after = loop {
                let h = tokio::task::block_in_place(|| cluster.health("1"));
                if h["degraded"] == false && h["services"][victim]["alive"] == true {
                    break h;
                }
                assert!(
                    back.elapsed() < Duration::from_secs(5),
                    "not healthy 5 s after {victim} came back: {h}\n{}",
                    cluster.log()
                );
            };
            eprintln!(
                "{victim}: healthy {:.1} s after its restart",
                back.elapsed().as_secs_f64()
            );
            // Nothing else fell meanwhile.
            let now = pids(&after);
            for (name, p) in before.iter().filter(|(n, _)| *n != victim) {
                assert_eq!(now.get(name), Some(p), "{name} restarted too: {after}");
            }
            match victim {
                // The new one answers for every crosswalk at once.
                "crosswalks" => {
                    let key = bus.keys().key_all(&topics::OCCUPANCY);
                    let all: Vec<CrosswalkOccupancy> =
                        bus.get_each(&key, Duration::from_secs(2)).await.unwrap();
                    assert_eq!(all.len(), areas, "{all:?}");
                }
                // The walkers are heard again by the crosswalks.
                "pedestrians" => {
                    let deadline = Instant::now() + Duration::from_secs(10);
                    while status(&bus, "crosswalks").await.details["sources"] == 0 {
                        assert!(
                            Instant::now() < deadline,
                            "the restarted pedestrians are not heard"
                        );
                        tokio::time::sleep(Duration::from_millis(100)).await;
                    }
                }
                // The admin answers, and takes commands with the token.
                "admin" => {
                    let set_ego = tokio::task::block_in_place(|| {
                        ureq::put(format!("{admin}/api/v1/ego"))
                            .header("Authorization", format!("Bearer {TOKEN}"))
                            .send_json(serde_json::json!({"x": 900.0, "y": 900.0, "yaw": 0.0}))
                    });
                    assert_eq!(set_ego.unwrap().status(), 204);
                }
                _ => unreachable!(),
            }
        }
        // Nothing saved lost, and the road went on all along (in real
        // time, give or take).
        assert_eq!(std::fs::read(&spawn_config).ok(), config_before);
        let road_after = batches.latest().await.time;
        let wall = since.elapsed().as_secs_f64();
        assert!(
            road_after - road_before > 0.8 * wall,
            "the road fell behind: t={road_before:.1} -> {road_after:.1} in {wall:.1} s"
        );
    });
}
