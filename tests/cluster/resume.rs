//! A stepper killed mid-run resumes from its last snapshot: `up` restarts
//! it, and the road carries on from where it was saved, with the same
//! vehicles, instead of starting empty at t=0.

use std::collections::HashSet;
use std::time::{Duration, Instant};

use crate::support::*;

#[test]
fn a_killed_stepper_resumes_from_its_snapshot_with_its_vehicles() {
    let dir = tempfile::tempdir().unwrap();
    let snapshot = dir.path().join("road.json");
    let stepper = format!(
        "speed = 1\nsnapshot = {:?}\nsnapshot_every = 1.0",
        snapshot.display().to_string()
    );
    let cluster = Cluster::start_stepper("resume", &stepper, false);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::with_traffic(&bus, 6).await;
        let deadline = Instant::now() + Duration::from_secs(20);
        while !snapshot.exists() {
            assert!(
                Instant::now() < deadline,
                "no snapshot saved:\n{}",
                cluster.log()
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // A second or two more, so that the saved road has traffic too.
        tokio::time::sleep(Duration::from_millis(1500)).await;
        let before = batches.latest().await;
        let pid = status(&bus, "stepper").await.pid;
        unsafe { libc::kill(pid as i32, libc::SIGKILL) };

        assert!(
            cluster
                .wait_log("resumed from the snapshot of tick", Duration::from_secs(30))
                .await,
            "the restarted stepper did not resume:\n{}",
            cluster.log()
        );
        let deadline = Instant::now() + Duration::from_secs(20);
        let restarted = loop {
            let s = status(&bus, "stepper").await;
            if s.pid != pid {
                break s;
            }
            assert!(Instant::now() < deadline, "the stepper was not restarted");
            tokio::time::sleep(Duration::from_millis(100)).await;
        };
        let from = restarted.details["resumed_from_tick"]
            .as_u64()
            .expect("resumed_from_tick");
        let lost = restarted.details["ticks_lost"]
            .as_u64()
            .expect("ticks_lost");
        // Saved once a simulated second: at most that, and the kill's
        // moment, lost (dt 0.02 s: 50 ticks a second).
        assert!(lost <= 150, "{lost} ticks lost");
        assert!(
            from as f64 * 0.02 >= before.time - 2.5,
            "resumed from tick {from}, the road was at t={:.1} s",
            before.time
        );
        // The road goes on from there with the vehicles it had.
        let now_us = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_micros() as u64;
        let after = batches
            .until(
                Duration::from_secs(20),
                "a batch of the restarted stepper",
                |b| b.sent_unix_us > now_us,
            )
            .await;
        assert!(
            after.time >= before.time - 2.5,
            "the clock started again at t={}",
            after.time
        );
        let had: HashSet<u64> = before.vehicles.iter().map(|v| v.id).collect();
        let kept = after
            .vehicles
            .iter()
            .filter(|v| had.contains(&v.id))
            .count();
        assert!(
            kept * 2 >= had.len(),
            "{kept} of the {} vehicles came back: {:?} -> {:?}",
            had.len(),
            had,
            after.vehicles.iter().map(|v| v.id).collect::<Vec<_>>()
        );
    });
}

/// The decisions a branch-decision CSV counts.
fn decisions_in(csv: &str) -> u64 {
    csv.lines()
        .skip(1)
        .filter_map(|l| l.split(',').nth(3)?.parse::<u64>().ok())
        .sum()
}

#[test]
fn a_killed_spawner_keeps_its_branch_statistics() {
    let cluster = Cluster::start("spawnerstats", "max_vehicles = 30", false, 4.0);
    let csv = cluster.dir.path().join("traffic_branch_decisions.csv");
    runtime().block_on(async {
        let bus = cluster.client().await;
        // Written every few seconds while decisions come in.
        let deadline = Instant::now() + Duration::from_secs(60);
        let saved = loop {
            let n = std::fs::read_to_string(&csv).map_or(0, |t| decisions_in(&t));
            if n >= 5 {
                break n;
            }
            assert!(
                Instant::now() < deadline,
                "no branch statistics saved:\n{}",
                cluster.log()
            );
            tokio::time::sleep(Duration::from_millis(200)).await;
        };
        let pid = status(&bus, "spawner").await.pid;
        // What is on disk at the kill is what the next spawner starts from.
        let on_disk = decisions_in(&std::fs::read_to_string(&csv).unwrap());
        assert!(on_disk >= saved);
        unsafe { libc::kill(pid as i32, libc::SIGKILL) };
        // The restarted one says what it resumed: all that was on disk
        // (more if a write slipped in before the kill).
        assert!(
            cluster
                .wait_log(" branch decisions from ", Duration::from_secs(20))
                .await,
            "the restarted spawner did not resume:\n{}",
            cluster.log()
        );
        let log = cluster.log();
        let resumed: u64 = log
            .lines()
            .find_map(|l| l.split("resumed ").nth(1)?.split(' ').next()?.parse().ok())
            .expect("a count in the resume line");
        assert!(
            resumed >= on_disk,
            "resumed {resumed} of the {on_disk} saved decisions"
        );
        let deadline = Instant::now() + Duration::from_secs(20);
        let restarted = loop {
            let s = status(&bus, "spawner").await;
            if s.pid != pid {
                break s;
            }
            assert!(Instant::now() < deadline, "the spawner was not restarted");
            tokio::time::sleep(Duration::from_millis(100)).await;
        };
        let now = restarted.details["branch_decisions"].as_u64().unwrap();
        assert!(
            now >= on_disk,
            "{now} decisions after the restart, {on_disk} saved"
        );
    });
}
