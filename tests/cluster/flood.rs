//! Hostile input: malformed payloads on every key the services read, for
//! 30 s. The services stay up, the stepper keeps real time, vehicles keep
//! driving, and every service counts what it dropped.

use std::time::{Duration, Instant};

use trafficmesh_protocol::topics;

use crate::support::*;

/// Payloads no decoder should take: random bytes, cut-off and mistyped
/// JSON, wrong numbers, and the empty payload.
fn garbage(n: u64) -> Vec<u8> {
    // xorshift: a different payload every time, the same every run.
    let mut x = n.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    match n % 6 {
        0 => (0..next() % 300).map(|_| next() as u8).collect(),
        1 => br#"{"time": 1.0, "vehicles": [{"id": "#.to_vec(),
        2 => br#"{"group": 7, "color": "purple", "valid_until": "soon"}"#.to_vec(),
        3 => br#"{"time": NaN, "x": 1e999, "footprint": [[0, 0]]}"#.to_vec(),
        4 => Vec::new(),
        _ => br#"[1, 2, 3, {"unexpected": true}]"#.to_vec(),
    }
}

#[test]
fn a_flood_of_malformed_payloads_is_counted_and_the_cluster_keeps_real_time() {
    let cluster = Cluster::start("flood", "max_vehicles = 20", true, 1.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::with_traffic(&bus, 3).await;
        let keys = bus.keys().clone();
        let inputs = [
            keys.key(&topics::CLOCK),
            keys.key(&topics::EGO),
            keys.key(&topics::EVENTS),
            keys.key_at(&topics::LIGHT_STATE, "flood"),
            keys.key(&topics::LIGHTS_HEARTBEAT),
            keys.key_at(&topics::OCCUPANCY, "flood"),
            keys.key(&topics::CROSSWALKS_HEARTBEAT),
            keys.key_at(&topics::AGENTS, "flood"),
            keys.key(&topics::SPAWN_CONFIG),
            keys.key_at(&topics::PROPOSALS, "flood"),
        ];
        let services = ["stepper", "spawner", "lights", "crosswalks", "pedestrians"];
        let mut pids = Vec::new();
        for service in services {
            pids.push(status(&bus, service).await.pid);
        }
        let before = batches.latest().await;
        let started = Instant::now();
        let (mut sent, mut n) = (0u64, 0u64);
        let mut slowest_rate = f64::INFINITY;
        let mut next_look = started + Duration::from_secs(5);
        while started.elapsed() < Duration::from_secs(30) {
            for key in &inputs {
                n += 1;
                bus.session().put(key, garbage(n)).await.unwrap();
                sent += 1;
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
            if Instant::now() >= next_look {
                let rate = status(&bus, "stepper").await.details["tick_rate"]
                    .as_f64()
                    .unwrap();
                slowest_rate = slowest_rate.min(rate);
                next_look += Duration::from_secs(5);
            }
        }
        let rate = sent as f64 / started.elapsed().as_secs_f64();
        eprintln!(
            "{sent} malformed payloads in 30 s ({rate:.0}/s); slowest tick rate {slowest_rate:.1}/s"
        );
        // Real time throughout: 50 ticks a simulated second, a second a second.
        assert!(
            slowest_rate > 45.0,
            "the stepper fell to {slowest_rate:.1} ticks/s"
        );
        let after = batches.latest().await;
        assert!(
            after.time - before.time > 25.0,
            "the clock went from {:.1} to {:.1} s in 30 s",
            before.time,
            after.time
        );
        assert!(!after.vehicles.is_empty(), "no vehicles after the flood");
        // Everyone up (the first process still), each counting what it dropped.
        for (service, pid) in services.into_iter().zip(pids) {
            // Every one reads the clock; these read more of the keys.
            let s = status(&bus, service).await;
            assert_eq!(s.pid, pid, "{service} was restarted:\n{}", cluster.log());
            let least = if ["stepper", "spawner", "crosswalks"].contains(&service) {
                100
            } else {
                1
            };
            assert!(
                s.bad_payloads >= least,
                "{service} counted {} bad payloads",
                s.bad_payloads
            );
        }
        // The log says so without a line per payload.
        let lines = cluster.log().matches("dropped bad payload").count();
        assert!(
            lines > 0 && (lines as u64) < sent / 20,
            "{lines} log lines for {sent} bad payloads"
        );
    });
}
