//! The cluster end to end: `trafficmesh up` starts the real services; the
//! tests talk to them over Zenoh as a user's client would.

// Shared with tests/admin, which uses a different part of it.
#[allow(dead_code)]
mod support;

mod faults;
mod flood;
mod intersection;
mod lockstep;
mod resume;

use std::collections::HashSet;
use std::time::{Duration, Instant};
use trafficmesh_protocol::topics;

use support::*;
use trafficmesh_model::LightColor;
use trafficmesh_protocol::wire::{
    Agent, AgentBatch, CrosswalkOccupancy, EgoPose, Event, EventBatch, LightOverride, LightState,
    RemoveAnswer, RemoveTarget, VehicleBatch,
};

/// Lanes inside the junction (the "box"), by map index.
fn box_lanes() -> HashSet<u32> {
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(four_way()).unwrap()).unwrap();
    m["lanes"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .filter(|(_, l)| l["intersection"].as_bool().unwrap_or(false))
        .map(|(i, _)| i as u32)
        .collect()
}

fn in_box(b: &VehicleBatch, lanes: &HashSet<u32>) -> usize {
    b.vehicles
        .iter()
        .filter(|v| lanes.contains(&v.lane))
        .count()
}

async fn set_light(
    bus: &trafficmesh_bus::Bus,
    group: &str,
    color: Option<LightColor>,
) -> LightState {
    let o = LightOverride {
        group: group.into(),
        color,
        program: None,
    };
    ask(bus, &bus.keys().key(&topics::LIGHTS_OVERRIDE), &o).await
}

#[test]
fn vehicles_spawn_up_to_the_maximum_and_no_further() {
    let cluster = Cluster::start("max", "max_vehicles = 12", false, 4.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::new(&bus).await;
        batches
            .until(Duration::from_secs(60), "12 vehicles", |b| {
                b.vehicles.len() == 12
            })
            .await;
        let until = Instant::now() + Duration::from_secs(3);
        while Instant::now() < until {
            let b = batches.latest().await;
            assert!(
                b.vehicles.len() <= 12,
                "{} vehicles with a maximum of 12",
                b.vehicles.len()
            );
        }
    });
}

#[test]
fn a_vehicle_stops_at_red_and_goes_on_green() {
    let cluster = Cluster::start("red", "max_vehicles = 30", false, 2.0);
    let junction = box_lanes();
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::with_traffic(&bus, 10).await;
        for g in ["J0_0_NS", "J0_0_EW"] {
            assert_eq!(
                set_light(&bus, g, Some(LightColor::Red)).await.color,
                LightColor::Red
            );
        }
        // Those already in the junction leave; then vehicles wait at the stop lines.
        batches
            .until(
                Duration::from_secs(30),
                "junction empty with vehicles waiting",
                |b| in_box(b, &junction) == 0 && b.vehicles.iter().any(|v| v.speed < 0.1),
            )
            .await;
        let until = Instant::now() + Duration::from_secs(3);
        while Instant::now() < until {
            let b = batches.latest().await;
            assert_eq!(
                in_box(&b, &junction),
                0,
                "a vehicle entered the junction on red"
            );
        }
        set_light(&bus, "J0_0_NS", Some(LightColor::Green)).await;
        batches
            .until(Duration::from_secs(20), "a vehicle enters on green", |b| {
                in_box(b, &junction) > 0
            })
            .await;
    });
}

fn pedestrian(root: &str, x: f64, y: f64) -> Agent {
    Agent {
        id: root.to_lowercase(),
        root: root.into(),
        kind: "NPCPedestrian".into(),
        footprint: vec![
            [x - 0.3, y - 0.3],
            [x + 0.3, y - 0.3],
            [x + 0.3, y + 0.3],
            [x - 0.3, y + 0.3],
        ],
    }
}

#[test]
fn a_pedestrian_on_a_crosswalk_stops_traffic_until_it_leaves() {
    let cluster = Cluster::start("zebra", "max_vehicles = 30", false, 2.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let keys = bus.keys().clone();
        let batches = Batches::with_traffic(&bus, 10).await;
        let events = bus
            .subscribe_ring(&keys.key(&topics::EVENTS), 10_000)
            .await
            .unwrap();
        // Keep every light green so only the pedestrian stops anyone.
        for g in ["J0_0_NS", "J0_0_EW"] {
            set_light(&bus, g, Some(LightColor::Green)).await;
        }
        let walker = AgentBatch {
            time: 0.0,
            agents: vec![pedestrian("Pedestrian_test", -15.0, 0.0)],
        };
        let mut stopped: Option<u64> = None;
        let deadline = Instant::now() + Duration::from_secs(40);
        while stopped.is_none() {
            assert!(
                Instant::now() < deadline,
                "no vehicle stopped for the pedestrian"
            );
            bus.put(&keys.key_at(&topics::AGENTS, "test"), &walker)
                .await
                .unwrap();
            while let Ok(Some(s)) = events.try_recv() {
                let batch: EventBatch = serde_json::from_slice(&s.payload().to_bytes()).unwrap();
                for e in batch.events {
                    if let Event::ZebraStop { id, area, .. } = e
                        && area == "J0_0_crosswalk_W"
                    {
                        stopped = Some(id);
                    }
                }
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        let id = stopped.unwrap();
        assert!(
            cluster
                .wait_log(
                    "stopping for zebra 'J0_0_crosswalk_W'",
                    Duration::from_secs(5)
                )
                .await,
            "the AWSIM reference's stop line is missing from the log"
        );
        assert!(
            cluster
                .wait_log(
                    "[Zebra] 'Pedestrian_test' entered 'J0_0_crosswalk_W'",
                    Duration::from_secs(5)
                )
                .await
        );
        // While the pedestrian stays, that vehicle comes to a stop before the crossing.
        let settle = Instant::now() + Duration::from_secs(15);
        loop {
            bus.put(&keys.key_at(&topics::AGENTS, "test"), &walker)
                .await
                .unwrap();
            let b = batches.latest().await;
            let v = b
                .vehicles
                .iter()
                .find(|v| v.id == id)
                .expect("stopped vehicle still there");
            if v.speed < 0.1 {
                assert!(v.zebra_blocked);
                assert!(
                    v.x < -15.0 - 2.0,
                    "stopped past the crosswalk's edge at x={}",
                    v.x
                );
                break;
            }
            assert!(Instant::now() < settle, "vehicle {id} never came to a stop");
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // The pedestrian leaves: the source reports nobody.
        bus.put(
            &keys.key_at(&topics::AGENTS, "test"),
            &AgentBatch {
                time: 0.0,
                agents: vec![],
            },
        )
        .await
        .unwrap();
        assert!(
            cluster
                .wait_log("cleared zebra 'J0_0_crosswalk_W'", Duration::from_secs(10))
                .await
        );
        batches
            .until(Duration::from_secs(20), "the vehicle drives on", |b| {
                b.vehicles
                    .iter()
                    .find(|v| v.id == id)
                    .is_none_or(|v| v.speed > 1.0)
            })
            .await;
    });
}

#[test]
fn an_occupant_outside_the_whitelist_does_not_block() {
    let cluster = Cluster::start("whitelist", "max_vehicles = 5", false, 1.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let keys = bus.keys().clone();
        status(&bus, "crosswalks").await;
        let occupancy = |name: &'static str| {
            let bus = &bus;
            async move {
                let all: Vec<CrosswalkOccupancy> = bus
                    .get_each(
                        &bus.keys().key_all(&topics::OCCUPANCY),
                        Duration::from_secs(2),
                    )
                    .await
                    .unwrap();
                all.into_iter()
                    .find(|o| o.area == name)
                    .expect("area answered")
            }
        };
        // A detected type but a root name no whitelist entry matches.
        let stranger = AgentBatch {
            time: 0.0,
            agents: vec![pedestrian("TruckCollider", -15.0, 0.0)],
        };
        bus.put(&keys.key_at(&topics::AGENTS, "test"), &stranger)
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(500)).await;
        assert!(
            !occupancy("J0_0_crosswalk_W").await.occupied,
            "non-whitelisted root counted"
        );
        // Control: a whitelisted root on the same spot does count.
        let walker = AgentBatch {
            time: 0.0,
            agents: vec![pedestrian("Human_1", -15.0, 0.0)],
        };
        bus.put(&keys.key_at(&topics::AGENTS, "test"), &walker)
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(500)).await;
        let o = occupancy("J0_0_crosswalk_W").await;
        assert!(o.occupied);
        assert_eq!(o.occupants, vec!["Human_1".to_string()]);
    });
}

#[test]
fn remove_vehicles_in_radius_over_the_bus_returns_the_count_and_they_vanish() {
    let cluster = Cluster::start("remove", "max_vehicles = 20", false, 2.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::new(&bus).await;
        let before = batches.traffic(8).await;
        let ids: HashSet<u64> = before.vehicles.iter().map(|v| v.id).collect();
        let target = RemoveTarget::Point {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            radius: 1000.0,
        };
        let answer: RemoveAnswer = ask(
            &bus,
            &bus.keys()
                .key(&trafficmesh_protocol::topics::SPAWNER_REMOVE),
            &target,
        )
        .await;
        assert!(
            answer.removed >= ids.len(),
            "removed {} of at least {}",
            answer.removed,
            ids.len()
        );
        tokio::time::sleep(Duration::from_millis(300)).await;
        let after = batches.latest().await;
        assert!(
            after.vehicles.iter().all(|v| !ids.contains(&v.id)),
            "removed vehicles still published"
        );
        let none: RemoveAnswer = ask(
            &bus,
            &bus.keys()
                .key(&trafficmesh_protocol::topics::SPAWNER_REMOVE),
            &RemoveTarget::Point {
                x: 5000.0,
                y: 5000.0,
                z: 0.0,
                radius: 1.0,
            },
        )
        .await;
        assert_eq!(none.removed, 0);
    });
}

#[test]
fn killing_the_lights_stops_traffic_and_a_restart_lets_it_flow() {
    // The restart waits longer than the 2 s validity, so the fail-safe shows.
    let cluster = Cluster::start_with_backoff("killlights", "max_vehicles = 30", false, 1.0, 4000);
    let junction = box_lanes();
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::new(&bus).await;
        batches
            .until(
                Duration::from_secs(60),
                "traffic through the junction",
                |b| in_box(b, &junction) > 0,
            )
            .await;
        let pid = status(&bus, "lights").await.pid;
        unsafe { libc::kill(pid as i32, libc::SIGKILL) };
        // Within the 2 s validity the stepper counts every group red.
        let stepper_stale = || async {
            status(&bus, "stepper").await.details["lights_stale"]
                .as_bool()
                .unwrap()
        };
        let deadline = Instant::now() + Duration::from_secs(5);
        while !stepper_stale().await {
            assert!(
                Instant::now() < deadline,
                "stepper never noticed the silent lights"
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // `up` restarts the lights; traffic flows again.
        assert!(
            cluster
                .wait_log("lights exited", Duration::from_secs(5))
                .await
        );
        let deadline = Instant::now() + Duration::from_secs(20);
        while stepper_stale().await {
            assert!(Instant::now() < deadline, "lights never came back");
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        assert_ne!(status(&bus, "lights").await.pid, pid);
        batches
            .until(Duration::from_secs(60), "traffic flows again", |b| {
                in_box(b, &junction) > 0
            })
            .await;
    });
}

#[test]
fn stale_lights_count_as_red_at_the_stop_line() {
    // With the lights service frozen (no states, no heartbeat), nothing may enter the junction.
    let cluster = Cluster::start("nolights", "max_vehicles = 20", false, 4.0);
    let junction = box_lanes();
    runtime().block_on(async {
        let bus = cluster.client().await;
        let batches = Batches::with_traffic(&bus, 5).await;
        let pid = status(&bus, "lights").await.pid;
        // Stop the lights for good: SIGSTOP keeps the process, so `up` does not restart it.
        unsafe { libc::kill(pid as i32, libc::SIGSTOP) };
        batches
            .until(Duration::from_secs(40), "junction empty", |b| {
                in_box(b, &junction) == 0
            })
            .await;
        let until = Instant::now() + Duration::from_secs(4);
        while Instant::now() < until {
            assert_eq!(
                in_box(&batches.latest().await, &junction),
                0,
                "entered on a stale light"
            );
        }
        unsafe { libc::kill(pid as i32, libc::SIGCONT) };
    });
}

#[test]
fn sigterm_to_the_spawner_writes_a_complete_branch_csv() {
    let mut cluster = Cluster::start("csv", "max_vehicles = 30", false, 4.0);
    let csv_path = cluster.dir.path().join("traffic_branch_decisions.csv");
    runtime().block_on(async {
        let bus = cluster.client().await;
        let deadline = Instant::now() + Duration::from_secs(60);
        while status(&bus, "spawner").await.details["branch_decisions"]
            .as_u64()
            .unwrap()
            < 10
        {
            assert!(Instant::now() < deadline, "no branch decisions");
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        let pid = status(&bus, "spawner").await.pid;
        unsafe { libc::kill(pid as i32, libc::SIGTERM) };
        assert!(
            cluster
                .wait_log("branch-decision rows to", Duration::from_secs(10))
                .await
        );
    });
    cluster.stop();
    let text = std::fs::read_to_string(&csv_path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "from_lane,to_lane,selection_mode,decision_count,total_from_lane,total_from_lane_mode,observed_ratio_from_lane,observed_ratio_from_lane_mode,avg_configured_weight,avg_effective_probability"
    );
    let rows: Vec<&str> = lines.collect();
    assert!(!rows.is_empty());
    let mut total = 0;
    for r in &rows {
        let f: Vec<&str> = r.split(',').collect();
        assert_eq!(f.len(), 10, "short row: {r}");
        total += f[3].parse::<u64>().unwrap();
    }
    assert!(total >= 10, "{total} decisions in the CSV");
    assert!(text.ends_with('\n'));
}

#[test]
fn bad_payloads_are_counted_and_dropped_and_nothing_crashes() {
    let cluster = Cluster::start("bad", "max_vehicles = 5", false, 1.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let keys = bus.keys().clone();
        let stepper_pid = status(&bus, "stepper").await.pid;
        let spawner_pid = status(&bus, "spawner").await.pid;
        for key in [keys.key(&topics::EGO), keys.key_at(&topics::LIGHT_STATE, "J0_0_NS"), keys.key_at(&topics::PROPOSALS, "py"), keys.key_at(&topics::AGENTS, "bad")] {
            subscriber_on(&bus, &key).await;
        }
        let session = bus.session();
        session.put(keys.key(&topics::EGO), "{not json").await.unwrap();
        session.put(keys.key(&topics::EGO), r#"{"x": 1e999, "y": 0, "yaw": 0}"#).await.unwrap();
        bus.put(&keys.key_at(&topics::LIGHT_STATE, "J0_0_NS"), &serde_json::json!({"group": "nope", "color": "green", "next_change": null, "valid_until": 1e9, "forced": false})).await.unwrap();
        bus.put(&keys.key_at(&topics::PROPOSALS, "py"), &serde_json::json!({"proposals": [{"tag": "a", "lane": "no_such_lane", "kind": "Taxi"}]})).await.unwrap();
        bus.put(&keys.key_at(&topics::AGENTS, "bad"), &serde_json::json!({"time": 0, "agents": [{"id": "a", "root": "Human", "type": "NPCPedestrian", "footprint": [[0, 0]]}]})).await.unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let stepper = status(&bus, "stepper").await;
            let spawner = status(&bus, "spawner").await;
            let crosswalks = status(&bus, "crosswalks").await;
            let ego_key = keys.key(&topics::EGO);
            let done = stepper.bad_payloads_by_key.get(&ego_key).copied().unwrap_or(0) >= 2
                && stepper.bad_payloads_by_key.contains_key(&keys.key_at(&topics::LIGHT_STATE, "J0_0_NS"))
                && spawner.bad_payloads_by_key.contains_key(&keys.key_at(&topics::PROPOSALS, "py"))
                && crosswalks.bad_payloads_by_key.contains_key(&keys.key_at(&topics::AGENTS, "bad"));
            if done {
                assert_eq!(stepper.pid, stepper_pid, "stepper restarted");
                assert_eq!(spawner.pid, spawner_pid, "spawner restarted");
                break;
            }
            assert!(Instant::now() < deadline, "bad payloads not all counted: {stepper:?} {spawner:?} {crosswalks:?}");
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        assert!(cluster.log().contains("dropped bad payload on"));
        // And the good ones still work.
        let ego = EgoPose { x: 0.0, y: 0.0, z: 0.0, yaw: 0.0, length: 4.9, width: 1.9, front_offset: 3.8 };
        bus.put(&keys.key(&topics::EGO), &ego).await.unwrap();
    });
}

#[test]
fn python_clients_subscribe_and_act_as_an_external_simulator() {
    let Some(python) = trafficmesh_testkit::python_with("zenoh", "eclipse-zenoh==1.10.2") else {
        return;
    };
    // Spawner without its own map simulators' competition on the test lane is
    // not needed: the external ones propose on a lane and compete with each other.
    let cluster = Cluster::start("python", "max_vehicles = 40", false, 1.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        status(&bus, "spawner").await;
        status(&bus, "lights").await;
    });
    let map = four_way();
    let args = [
        cluster.endpoint.as_str(),
        &cluster.name,
        &map.to_string_lossy(),
    ];
    let stdout = python_client(&python, "external_simulator.py", &args);
    assert!(stdout.contains("OK"), "{stdout}");
}

/// `trafficmesh up` starts the traffic service on the cluster's map: a
/// runtime's gRPC client finds the map among the scenes and drives a session,
/// and a Zenoh subscriber on the cluster's bus and the admin's live map see
/// its actors.
#[test]
fn up_starts_the_traffic_service_on_the_clusters_map() {
    let Some(python) = trafficmesh_testkit::python_with(
        "grpc_tools, zenoh, websocket",
        "grpcio-tools==1.85.1 eclipse-zenoh==1.10.2 websocket-client==1.9.2",
    ) else {
        return;
    };
    let port = free_port();
    let cluster = Cluster::launch_spec(trafficmesh_testkit::ClusterSpec {
        traffic_service_port: Some(port),
        admin_token: Some(TOKEN.into()),
        ..Cluster::spec("grpc", &four_way())
    });
    cluster.wait_for_admin();
    let out = std::process::Command::new(python)
        .arg(repo().join("tests/cluster/traffic_service.py"))
        .arg(repo().join("services/traffic-grpc/proto"))
        .arg(format!("127.0.0.1:{port}"))
        .args([&cluster.endpoint, &cluster.name])
        .arg(cluster.admin.as_ref().unwrap())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("OK"),
        "traffic_service.py:\n{stdout}\n{}\ncluster log:\n{}",
        String::from_utf8_lossy(&out.stderr),
        cluster.log()
    );
}

/// Late joiners see the current light colours and crosswalk occupancy at
/// once, not at the next change: `trafficmesh watch` started after the
/// cluster prints every light's colour in its first line, and a Python
/// client has them all within a second of opening its session.
#[test]
fn late_joiners_see_every_light_and_crosswalk_at_once() {
    let cluster = Cluster::start("late", "", false, 1.0);
    runtime().block_on(async {
        let bus = cluster.client().await;
        status(&bus, "lights").await;
        status(&bus, "crosswalks").await;
    });
    // Long enough that the states were published well before we join.
    std::thread::sleep(Duration::from_secs(2));
    let line = trafficmesh_cli(&[
        "watch",
        "--count",
        "1",
        "--cluster",
        &cluster.name,
        "--connect",
        &cluster.endpoint,
    ]);
    let counts: Vec<u32> = line
        .split("lights green/yellow/red=")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no light counts in: {line}"))
        .split('/')
        .map(|n| n.parse().unwrap())
        .collect();
    assert_eq!(counts.iter().sum::<u32>(), 2, "both light groups: {line}");
    assert!(
        line.contains("crosswalks occupied=0/4"),
        "four crosswalks: {line}"
    );

    let Some(python) = trafficmesh_testkit::python_with("zenoh", "eclipse-zenoh==1.10.2") else {
        return;
    };
    let stdout = python_client(
        &python,
        "late_joiner.py",
        &[&cluster.endpoint, &cluster.name],
    );
    assert!(stdout.contains("lights=2 crosswalks=4"), "{stdout}");
    let seconds = figure(&stdout, "seconds");
    assert!(seconds < 1.0, "the states took {seconds} s: {stdout}");
}

/// cluster.toml sets AWSIM's NPCVehicleConfig for the stepper and
/// spawnDistanceToEgo for the spawner; both report what is in force.
#[test]
fn cluster_toml_sets_the_npc_vehicle_config_and_the_spawn_distance() {
    let cluster = Cluster::start(
        "vehcfg",
        "spawn_distance_to_ego = 80.0\n[vehicle]\nacceleration = 2.5\nsudden_deceleration = 5.0",
        false,
        1.0,
    );
    runtime().block_on(async {
        let bus = cluster.client().await;
        let stepper = status(&bus, "stepper").await;
        let config = &stepper.details["vehicle_config"];
        assert_eq!(config["acceleration"], 2.5, "{config}");
        assert_eq!(config["suddenDeceleration"], 5.0, "{config}");
        assert_eq!(
            config["deceleration"], 2.0,
            "unset keeps the reference's: {config}"
        );
        let spawner = status(&bus, "spawner").await;
        assert_eq!(
            spawner.details["spawn_distance_to_ego"], 80.0,
            "{:?}",
            spawner.details
        );
    });
}

/// The stepper drives at an imported map's own lane limits (cross.net.xml:
/// 11.11, 15.28 and 19.44 m/s) unless cluster.toml says
/// `speed_limit_source = "fixed"`: then at the fixed 13.89 m/s.
#[test]
fn the_stepper_drives_at_the_lane_limits_of_an_imported_map_unless_told() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let net = net.canonicalize().unwrap();
    for (source, extra) in [
        ("fixed", "[vehicle]\nspeed_limit_source = \"fixed\""),
        ("lanelet", ""),
    ] {
        let cluster = Cluster::start_on_with_admin(&format!("limits_{source}"), &net, extra, false);
        let top = runtime().block_on(async {
            let bus = cluster.client().await;
            let batches = Batches::with_traffic(&bus, 3).await;
            let mut top = 0f32;
            let deadline = Instant::now() + Duration::from_secs(20);
            while Instant::now() < deadline {
                for v in batches.latest().await.vehicles {
                    top = top.max(v.speed);
                }
            }
            top
        });
        match source {
            "fixed" => assert!(
                (12.0..=13.9).contains(&top),
                "fixed 13.89 m/s: the fastest drove {top}"
            ),
            _ => assert!(
                (15.0..=19.45).contains(&top),
                "lane limits up to 19.44 m/s: the fastest drove {top}"
            ),
        }
    }
}

/// A service started with another map than the stepper's refuses the
/// cluster: the stepper's lane indices would name other lanes there.
#[test]
fn a_service_with_another_map_than_the_steppers_refuses_to_join() {
    let cluster = Cluster::start("another_map", "", false, 1.0);
    let lights = std::path::Path::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .with_file_name("trafficmesh-lights");
    let other = repo().join("configs/sumo/grid3_crossings.net.xml");
    let mut child = std::process::Command::new(lights)
        .args(["--cluster", &cluster.name, "--connect", &cluster.endpoint])
        .arg("--map")
        .arg(&other)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("trafficmesh-lights starts");
    let until = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > until {
            let _ = child.kill();
            panic!("a lights service with another map kept running for 30 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(!status.success(), "it exits with an error: {stderr}");
    assert!(
        stderr.contains("the stepper runs another map"),
        "the error says why: {stderr}"
    );
    // The cluster itself goes on with its own lights.
    runtime().block_on(async {
        let bus = cluster.client().await;
        let until = Instant::now() + Duration::from_secs(20);
        loop {
            let states: Vec<LightState> = bus
                .get_each(
                    &bus.keys().key_all(&topics::LIGHT_STATE),
                    Duration::from_secs(2),
                )
                .await
                .unwrap();
            if states.iter().any(|s| s.group == "J0_0_NS") {
                break;
            }
            assert!(
                Instant::now() < until,
                "the cluster's own lights answer: {states:?}\n{}",
                cluster.log()
            );
        }
    });
}

/// Red means stop on the generated 10 x 10 grid: an independent Python judge
/// reads the map file, the vehicle batches and the light states from the bus
/// over ten simulated minutes and finds no front bumper 0.5 m past a stop
/// line more than 0.5 s into red; the stepper counts none either.
#[test]
fn no_vehicle_crosses_a_stop_line_on_red_on_the_grid() {
    let Some(python) = trafficmesh_testkit::python_with("zenoh", "eclipse-zenoh==1.10.2") else {
        return;
    };
    let maps = tempfile::tempdir().unwrap();
    let grid = maps.path().join("grid10.map.json");
    trafficmesh_cli(&["gen-grid", "--size", "10", "--out", grid.to_str().unwrap()]);
    let cluster = Cluster::launch_spec(trafficmesh_testkit::ClusterSpec {
        stepper: "speed = 4".into(),
        spawner: "max_vehicles = 400".into(),
        ..Cluster::spec("redgrid", &grid)
    });
    runtime().block_on(async {
        let bus = cluster.client().await;
        status(&bus, "lights").await;
        status(&bus, "stepper").await;
    });
    let args = [
        cluster.endpoint.as_str(),
        &cluster.name,
        &grid.to_string_lossy(),
        "600",
    ];
    let stdout = python_client(&python, "red_light_judge.py", &args);
    let figure = |name: &str| figure(&stdout, name);
    assert_eq!(figure("restarts"), 0.0, "the stepper restarted:\n{stdout}");
    assert!(figure("seconds") >= 600.0, "judged too short: {stdout}");
    assert!(figure("reds") >= 100.0, "too few red phases seen: {stdout}");
    assert!(
        figure("crossings") >= 500.0,
        "too few stop-line crossings: {stdout}"
    );
    assert_eq!(figure("on_red"), 0.0, "crossed on red:\n{stdout}");
    let counted = runtime().block_on(async {
        let bus = cluster.client().await;
        status(&bus, "stepper").await.details["red_light_crossings"].clone()
    });
    assert_eq!(
        counted, 0,
        "the stepper counted red-light crossings; judge: {stdout}"
    );
}
