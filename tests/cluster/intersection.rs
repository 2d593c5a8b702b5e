//! A reservation intersection served by the intersection service over the
//! bus: traffic crosses on the ways it grants; with the service killed no
//! vehicle enters and those at the stop lines wait; restarted, it grants
//! again. An overlap check runs on every vehicle batch throughout.

use std::collections::HashSet;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec2;
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::VehicleBatch;

use crate::support::*;

/// A vehicle's body: centre, heading, half length and half width.
fn body(v: &trafficmesh_protocol::wire::VehicleState) -> (DVec2, DVec2, f64, f64) {
    let heading = DVec2::from_angle(v.yaw as f64);
    let centre = DVec2::new(v.x as f64, v.y as f64)
        + heading * (v.front_offset as f64 - v.length as f64 / 2.0);
    (centre, heading, v.length as f64 / 2.0, v.width as f64 / 2.0)
}

/// Do two oriented rectangles overlap (separating axis test)?
fn overlap(a: (DVec2, DVec2, f64, f64), b: (DVec2, DVec2, f64, f64)) -> bool {
    let reach = |(_, h, l, w): (DVec2, DVec2, f64, f64), axis: DVec2| {
        l * h.dot(axis).abs() + w * h.perp().dot(axis).abs()
    };
    let d = b.0 - a.0;
    [a.1, a.1.perp(), b.1, b.1.perp()]
        .into_iter()
        .all(|axis| d.dot(axis).abs() < reach(a, axis) + reach(b, axis))
}

/// Pairs of vehicles overlapping inside the junction in `b`.
fn overlaps_inside(b: &VehicleBatch, inside: &HashSet<u32>) -> Vec<(u64, u64)> {
    let ins: Vec<_> = b
        .vehicles
        .iter()
        .filter(|v| inside.contains(&v.lane))
        .collect();
    let mut found = Vec::new();
    for (i, a) in ins.iter().enumerate() {
        for c in &ins[i + 1..] {
            if overlap(body(a), body(c)) {
                found.push((a.id, c.id));
            }
        }
    }
    found
}

fn in_lanes(b: &VehicleBatch, lanes: &HashSet<u32>) -> usize {
    b.vehicles
        .iter()
        .filter(|v| lanes.contains(&v.lane))
        .count()
}

/// Simulated seconds after which every vehicle granted a way before the
/// service died is through.
const GRANTED_THROUGH: f64 = 12.0;

#[test]
fn killing_the_intersection_service_stops_entries_and_a_restart_lets_traffic_cross() {
    let (_map_dir, map, inside, approaches) = reservation_four_way();
    // The restart waits long enough for the junction to empty first, and
    // then some, even on a loaded machine.
    let cluster = Cluster::launch_spec(trafficmesh_testkit::ClusterSpec {
        seed: 7,
        stepper: "speed = 2".into(),
        spawner: "max_vehicles = 24".into(),
        restart_backoff_ms: 15_000,
        ..Cluster::spec("killintersection", &map)
    });
    runtime().block_on(async {
        let bus = cluster.client().await;
        // Every batch, checked for bodies overlapping inside the junction.
        let overlaps: Arc<Mutex<Vec<(f64, u64, u64)>>> = Arc::default();
        let checked = Arc::new(Mutex::new(0u64));
        let all = bus
            .subscribe_ring(&bus.keys().key(&topics::VEHICLES), 10_000)
            .await
            .unwrap();
        {
            let (overlaps, checked, inside) = (overlaps.clone(), checked.clone(), inside.clone());
            tokio::spawn(async move {
                while let Ok(sample) = all.recv_async().await {
                    let b = VehicleBatch::decode(&sample.payload().to_bytes()).unwrap();
                    for (a, c) in overlaps_inside(&b, &inside) {
                        overlaps.lock().unwrap().push((b.time, a, c));
                    }
                    *checked.lock().unwrap() += 1;
                }
            });
        }
        let batches = Batches::new(&bus).await;
        batches
            .until(
                Duration::from_secs(60),
                "traffic through the junction",
                |b| in_lanes(b, &inside) > 0,
            )
            .await;
        let stepper_unanswered = || async {
            status(&bus, "stepper").await.details["intersections_unanswered"]
                .as_bool()
                .unwrap()
        };
        assert!(!stepper_unanswered().await);
        let pid = status(&bus, "intersection").await.pid;
        let killed_at = batches.latest().await.time;
        unsafe { libc::kill(pid as i32, libc::SIGKILL) };
        let deadline = Instant::now() + Duration::from_secs(5);
        while !stepper_unanswered().await {
            assert!(
                Instant::now() < deadline,
                "the stepper never noticed the intersection service gone"
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // Those granted before go through (a way is granted at most 60 m
        // before the entry: 12 s is ample); after that nobody enters, and
        // the heads of the approaches stand at their stop lines.
        let (mut waiting, mut judged) = (0, 0);
        let health = cluster.health("2");
        assert_eq!(health["degraded"], true, "{health}");
        assert_eq!(health["services"]["stepper"]["alive"], true, "{health}");
        let degraded_seen = health["reasons"].to_string();
        while stepper_unanswered().await {
            let b = batches.latest().await;
            if b.time < killed_at + GRANTED_THROUGH {
                continue;
            }
            judged += 1;
            assert_eq!(
                in_lanes(&b, &inside),
                0,
                "a vehicle entered without a way granted (t={:.2}, killed at {killed_at:.2})",
                b.time
            );
            waiting = waiting.max(
                b.vehicles
                    .iter()
                    .filter(|v| approaches.contains(&v.lane) && v.speed < 0.1)
                    .count(),
            );
        }
        assert!(
            judged >= 10,
            "only {judged} batches while the service was down"
        );
        assert!(waiting >= 2, "vehicles did not wait at the stop lines");
        // While it was down, `trafficmesh status` said why.
        assert!(
            degraded_seen.contains("intersection service does not answer"),
            "trafficmesh status did not name the fail-safe: {degraded_seen}"
        );
        assert_ne!(status(&bus, "intersection").await.pid, pid);
        batches
            .until(Duration::from_secs(30), "traffic crosses again", |b| {
                in_lanes(b, &inside) > 0
            })
            .await;
        // And keeps crossing: the restarted service's grants stay apart too.
        tokio::time::sleep(Duration::from_secs(10)).await;
        let granted = status(&bus, "intersection").await.details["granted"]
            .as_u64()
            .unwrap();
        assert!(
            granted >= 3,
            "only {granted} ways granted after the restart"
        );
        assert!(*checked.lock().unwrap() > 1000, "too few batches checked");
        let found = overlaps.lock().unwrap().clone();
        assert!(found.is_empty(), "overlaps inside the junction: {found:?}");
    });
}

#[test]
fn the_overlap_check_tells_bodies_in_each_other_from_bodies_apart() {
    let car = |x: f64, y: f64, yaw: f64| (DVec2::new(x, y), DVec2::from_angle(yaw), 2.25, 0.9);
    assert!(
        overlap(car(0.0, 0.0, 0.0), car(4.0, 0.0, 0.0)),
        "nose in tail"
    );
    assert!(
        !overlap(car(0.0, 0.0, 0.0), car(4.6, 0.0, 0.0)),
        "a gap between"
    );
    // Crossing at right angles: apart only once clear of the other's width.
    assert!(overlap(car(0.0, 0.0, 0.0), car(0.0, 3.0, FRAC_PI_2)));
    assert!(!overlap(car(0.0, 0.0, 0.0), car(0.0, 3.3, FRAC_PI_2)));
    // Diagonal: the corners decide, not the centres' distance alone.
    assert!(!overlap(car(0.0, 0.0, 0.0), car(3.8, 2.8, FRAC_PI_4)));
}
