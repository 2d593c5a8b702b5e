//! The REST admin against a real cluster (`trafficmesh up` with the admin on a
//! free port), over real HTTP, the way an operator's client talks to it.

mod http;
#[path = "../cluster/support.rs"]
#[allow(dead_code)]
mod support;

use std::collections::HashMap;
use std::time::{Duration, Instant};
use trafficmesh_protocol::topics;

use http::{Api, Auth};
use serde_json::{Value, json};
use support::*;
use trafficmesh_protocol::wire::{Agent, AgentBatch, Event, EventBatch};
use trafficmesh_testkit::ClusterSpec;

fn api(cluster: &Cluster) -> Api {
    Api::new(cluster.admin.as_ref().unwrap())
}

fn wait_until(what: &str, timeout: Duration, mut ok: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !ok() {
        assert!(Instant::now() < deadline, "timed out waiting for: {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn status_and_the_read_endpoints_describe_the_running_cluster() {
    let cluster = Cluster::start_with_admin("adminread", "max_vehicles = 20", false);
    let api = api(&cluster);
    assert_eq!(api.get("/api/v1/health").json()["status"], "ok");

    let status = api.get("/api/v1/status").json();
    assert_eq!(status["cluster"], cluster.name.as_str());
    assert_eq!(status["degraded"], false, "{status}");
    for service in ["stepper", "spawner", "lights", "crosswalks", "admin"] {
        assert_eq!(
            status["services"][service]["alive"], true,
            "{service}: {status}"
        );
    }
    let t0 = status["time"].as_f64().unwrap();
    wait_until("simulation time advances", Duration::from_secs(10), || {
        api.get("/api/v1/status").json()["time"].as_f64().unwrap() > t0 + 1.0
    });
    assert!(status["tick_rate"].is_number() && status["vehicles"].is_u64());

    // Vehicles: the list, a lane filter, a box filter, one by id.
    wait_until("vehicles on the map", Duration::from_secs(30), || {
        api.get("/api/v1/vehicles").json()["count"]
            .as_u64()
            .unwrap()
            >= 3
    });
    let list = api.get("/api/v1/vehicles").json();
    let first = &list["vehicles"][0];
    for field in [
        "id",
        "kind",
        "lane",
        "x",
        "y",
        "yaw",
        "speed",
        "mode",
        "yield_phase",
        "signal",
    ] {
        assert!(!first[field].is_null(), "vehicle lacks {field}: {first}");
    }
    let lane = first["lane"].as_str().unwrap();
    assert!(lane.starts_with("J0_0_"), "lane names, not indices: {lane}");
    let on_lane = api
        .get(&format!("/api/v1/vehicles?lane={}", lane.to_lowercase()))
        .json();
    assert!(on_lane["count"].as_u64().unwrap() >= 1);
    assert!(
        on_lane["vehicles"]
            .as_array()
            .unwrap()
            .iter()
            .all(|v| v["lane"] == lane)
    );
    let (x, y) = (first["x"].as_f64().unwrap(), first["y"].as_f64().unwrap());
    let boxed = api
        .get(&format!(
            "/api/v1/vehicles?bbox={},{},{},{}",
            x - 1.0,
            y - 1.0,
            x + 1.0,
            y + 1.0
        ))
        .json();
    let inside = boxed["vehicles"].as_array().unwrap();
    assert!(
        inside
            .iter()
            .all(|v| (v["x"].as_f64().unwrap() - x).abs() <= 1.0 + 20.0)
    );
    let far = api.get("/api/v1/vehicles?bbox=5000,5000,5001,5001").json();
    assert_eq!(far["count"], 0);
    let id = first["id"].as_u64().unwrap();
    let one = api.get(&format!("/api/v1/vehicles/{id}"));
    if one.status == 200 {
        assert_eq!(one.json()["id"], id);
    } else {
        // It may have left the map between the two requests.
        one.assert_problem(404, &id.to_string());
    }
    api.get("/api/v1/vehicles?bbox=1,2,3")
        .assert_problem(400, "bbox");
    api.get("/api/v1/vehicles?bbox=5,5,1,1")
        .assert_problem(400, "bbox");
    api.get("/api/v1/vehicles?lane=no_such_lane")
        .assert_problem(404, "no_such_lane");
    api.get("/api/v1/vehicles/99999999")
        .assert_problem(404, "99999999");
    assert_eq!(api.get("/api/v1/vehicles/abc").status, 400);
    api.get("/api/v1/no/such/thing")
        .assert_problem(404, "no such endpoint");

    // Lights and crosswalks of the four-way map.
    let lights = api.get("/api/v1/lights").json();
    let groups: Vec<&str> = lights
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["group"].as_str().unwrap())
        .collect();
    assert_eq!(groups, ["J0_0_NS", "J0_0_EW"]);
    wait_until("light colours known", Duration::from_secs(10), || {
        api.get("/api/v1/lights")
            .json()
            .as_array()
            .unwrap()
            .iter()
            .all(|l| ["green", "yellow", "red"].contains(&l["color"].as_str().unwrap_or("")))
    });
    let crosswalks = api.get("/api/v1/crosswalks").json();
    assert_eq!(crosswalks.as_array().unwrap().len(), 4);
    assert!(
        crosswalks
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c["polygon"].as_array().unwrap().len() >= 3)
    );

    // The map for the live view.
    let map = api.get("/api/v1/map").json();
    assert!(map["lanes"].as_array().unwrap().len() > 8);
    assert!(!map["spawn_points"].as_array().unwrap().is_empty());
    assert_eq!(map["kinds"][0]["name"], "Taxi");

    // OpenAPI 3.1 from the code, Swagger UI offline.
    let doc = api.get("/api/v1/openapi.json").json();
    assert!(
        doc["openapi"].as_str().unwrap().starts_with("3.1"),
        "{}",
        doc["openapi"]
    );
    for path in [
        "/api/v1/status",
        "/api/v1/spawn-config",
        "/api/v1/vehicles/remove",
        "/api/v1/lights/{group}/override",
    ] {
        assert!(doc["paths"][path].is_object(), "OpenAPI lacks {path}");
    }
    assert!(doc["paths"]["/api/v1/spawn-config"]["put"]["security"].is_array());
    let ui = api.get("/swagger-ui/");
    assert_eq!(ui.status, 200);
    assert!(ui.body.contains("swagger"), "{}", ui.body);
    let ui_js = api.get("/swagger-ui/swagger-ui-bundle.js");
    assert_eq!(
        ui_js.status, 200,
        "Swagger UI's script is served by the admin"
    );

    // Metrics after a few requests.
    let metrics = api.get("/metrics");
    assert!(metrics.content_type.starts_with("text/plain"));
    for needle in [
        "trafficmesh_tick_duration_seconds_bucket",
        "trafficmesh_vehicles ",
        "trafficmesh_spawns_total",
        "trafficmesh_admin_requests_total{route=\"/api/v1/status\",method=\"GET\",status=\"200\"}",
        "status=\"404\"",
    ] {
        assert!(
            metrics.body.contains(needle),
            "/metrics lacks {needle}:\n{}",
            metrics.body
        );
    }
}

#[test]
fn every_mutating_endpoint_needs_the_token() {
    let cluster = Cluster::start_with_admin("adminauth", "max_vehicles = 10", false);
    let api = api(&cluster);
    let before = api.get("/api/v1/spawn-config").json();
    let calls: [(&str, &str, Value); 7] = [
        (
            "PUT",
            "/api/v1/spawn-config",
            json!({"spawnRates": [], "branchWeights": []}),
        ),
        ("POST", "/api/v1/spawn-config/save", Value::Null),
        ("POST", "/api/v1/spawn-config/load", Value::Null),
        (
            "POST",
            "/api/v1/vehicles/remove",
            json!({"around": "point", "x": 0, "y": 0, "radius": 1000}),
        ),
        ("POST", "/api/v1/restart", json!({"max_vehicles": 0})),
        ("PUT", "/api/v1/ego", json!({"x": 0, "y": 0, "yaw": 0})),
        (
            "POST",
            "/api/v1/lights/J0_0_NS/override",
            json!({"color": "red"}),
        ),
    ];
    for (method, path, body) in &calls {
        let body = body.to_string();
        let missing = api.send(
            method,
            path,
            Auth::None,
            Some("application/json"),
            Some(body.as_bytes()),
        );
        missing.assert_problem(401, "Authorization");
        assert_eq!(missing.header("www-authenticate"), Some("Bearer"));
        let wrong = api.send(
            method,
            path,
            Auth::Bearer("not-the-token-at-all"),
            Some("application/json"),
            Some(body.as_bytes()),
        );
        wrong.assert_problem(401, "not the admin token");
    }
    // Nothing was applied: the config, the lights and the vehicles are as they were.
    assert_eq!(api.get("/api/v1/spawn-config").json(), before);
    assert!(
        !cluster.dir.path().join("traffic_spawn.json").exists(),
        "save ran without a token"
    );
    let lights = api.get("/api/v1/lights").json();
    assert!(
        lights
            .as_array()
            .unwrap()
            .iter()
            .all(|l| l["forced"] == false),
        "{lights}"
    );
    wait_until("vehicles keep spawning", Duration::from_secs(30), || {
        api.get("/api/v1/status").json()["vehicles"]
            .as_u64()
            .unwrap()
            >= 1
    });
}

#[test]
fn bad_bodies_are_problems_that_name_what_is_wrong() {
    let cluster = Cluster::start_with_admin("adminbad", "max_vehicles = 10", false);
    let api = api(&cluster);
    let put = |ct: Option<&str>, body: &[u8]| {
        api.send(
            "PUT",
            "/api/v1/spawn-config",
            Auth::Bearer(TOKEN),
            ct,
            Some(body),
        )
    };
    put(Some("application/json"), b"{\"spawnRates\": [").assert_problem(400, "malformed JSON");
    put(None, b"{}").assert_problem(415, "Content-Type");
    put(
        Some("application/json"),
        br#"{"spawnRates": [{"lane": "J0_0_in_W0", "spawnsPerMinute": "fast"}], "branchWeights": []}"#,
    )
    .assert_problem(422, "spawnsPerMinute");
    let base = cluster.admin.as_ref().unwrap();
    let over_limit =
        http::status_for_announced_length(base, "/api/v1/spawn-config", TOKEN, 2 << 20, false);
    assert_eq!(over_limit, 413, "a 2 MiB body over the 1 MiB limit");
    let within = http::status_for_announced_length(base, "/api/v1/spawn-config", TOKEN, 100, true);
    assert_eq!(
        within, 400,
        "the positive control: 100 blank bytes are read, and are not JSON"
    );
    api.json(
        "POST",
        "/api/v1/restart",
        TOKEN,
        &json!({"max_vehicles": -1}),
    )
    .assert_problem(422, "max_vehicles");
    api.json("POST", "/api/v1/restart", TOKEN, &json!({"max": 3}))
        .assert_problem(422, "max");
    api.json(
        "PUT",
        "/api/v1/ego",
        TOKEN,
        &json!({"x": "east", "y": 0, "yaw": 0}),
    )
    .assert_problem(422, "x");
    api.json(
        "PUT",
        "/api/v1/ego",
        TOKEN,
        &json!({"x": 0, "y": 0, "yaw": 0, "width": -1}),
    )
    .assert_problem(422, "width");
    api.json(
        "POST",
        "/api/v1/vehicles/remove",
        TOKEN,
        &json!({"around": "point", "x": 0, "y": 0, "radius": -5}),
    )
    .assert_problem(422, "radius");
    api.json(
        "POST",
        "/api/v1/vehicles/remove",
        TOKEN,
        &json!({"around": "moon", "radius": 5}),
    )
    .assert_problem(422, "moon");
    api.json(
        "POST",
        "/api/v1/lights/J0_0_NS/override",
        TOKEN,
        &json!({"color": "purple"}),
    )
    .assert_problem(422, "purple");
    api.json(
        "POST",
        "/api/v1/lights/nope/override",
        TOKEN,
        &json!({"color": "red"}),
    )
    .assert_problem(404, "nope");
    api.json(
        "POST",
        "/api/v1/crosswalks/blocked-stop",
        TOKEN,
        &json!({"x": 0, "y": 0}),
    )
    .assert_problem(422, "yaw");
}

/// Spawned events per lane name seen on the bus during `window`.
fn spawns_on(cluster: &Cluster, lane: &str, window: Duration) -> usize {
    runtime().block_on(async {
        let bus = cluster.client().await;
        let events = bus
            .subscribe_ring(&bus.keys().key(&topics::EVENTS), 10_000)
            .await
            .unwrap();
        tokio::time::sleep(window).await;
        let mut count = 0;
        while let Ok(Some(s)) = events.try_recv() {
            let batch: EventBatch = serde_json::from_slice(&s.payload().to_bytes()).unwrap();
            count += batch
                .events
                .iter()
                .filter(|e| matches!(e, Event::Spawned { lane: l, .. } if l == lane))
                .count();
        }
        count
    })
}

fn rates(high_lane_rate: f64) -> Value {
    let lanes = [
        "J0_0_in_E0",
        "J0_0_in_E1",
        "J0_0_in_N0",
        "J0_0_in_N1",
        "J0_0_in_S0",
        "J0_0_in_S1",
        "J0_0_in_W1",
    ];
    let mut spawn_rates: Vec<Value> = lanes
        .iter()
        .map(|l| json!({"lane": l, "spawnsPerMinute": 1.0}))
        .collect();
    spawn_rates.push(json!({"lane": "J0_0_in_W0", "spawnsPerMinute": high_lane_rate}));
    json!({"spawnRates": spawn_rates, "branchWeights": [
        {"fromLane": "J0_0_in_W0", "next": [{"lane": "J0_0_W0_S", "weight": 1.0}]}
    ]})
}

fn rate_of(config: &Value, lane: &str) -> f64 {
    config["spawnRates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["lane"].as_str().unwrap().eq_ignore_ascii_case(lane))
        .map(|r| r["spawnsPerMinute"].as_f64().unwrap())
        .unwrap_or_else(|| panic!("no rate for {lane}: {config}"))
}

#[test]
fn a_spawn_config_put_changes_spawning_and_survives_save_restart_and_load() {
    let cluster = Cluster::start_with_admin("adminspawn", "max_vehicles = 200", false);
    let api = api(&cluster);
    let file = cluster.dir.path().join("traffic_spawn.json");

    // A busy lane: 30 per minute on J0_0_in_W0.
    let applied = api.json("PUT", "/api/v1/spawn-config", TOKEN, &rates(30.0));
    assert_eq!(applied.status, 200, "{}", applied.body);
    assert_eq!(
        rate_of(&api.get("/api/v1/spawn-config").json(), "J0_0_in_W0"),
        30.0
    );
    let busy = spawns_on(&cluster, "J0_0_in_W0", Duration::from_secs(10));
    assert!(busy >= 3, "30/min on J0_0_in_W0 gave {busy} spawns in 10 s");

    // Saved, then the spawner killed: `up` restarts it and it loads the file.
    let saved = api.post_empty("/api/v1/spawn-config/save", TOKEN);
    assert_eq!(saved.status, 200, "{}", saved.body);
    assert_eq!(saved.json()["saved"], file.display().to_string());
    let on_disk: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(rate_of(&on_disk, "J0_0_in_W0"), 30.0);
    let pid = api.get("/api/v1/status").json()["services"]["spawner"]["pid"]
        .as_u64()
        .unwrap();
    unsafe { libc::kill(pid as i32, libc::SIGKILL) };
    wait_until("the spawner restarted", Duration::from_secs(30), || {
        let s = api.get("/api/v1/status").json();
        let spawner = &s["services"]["spawner"];
        spawner["alive"] == true && spawner["pid"].as_u64().is_some_and(|p| p != pid)
    });
    wait_until(
        "the restarted spawner answers",
        Duration::from_secs(20),
        || api.get("/api/v1/spawn-config").status == 200,
    );
    assert_eq!(
        rate_of(&api.get("/api/v1/spawn-config").json(), "J0_0_in_W0"),
        30.0
    );

    // A quiet lane: one per minute, applied but not saved.
    assert_eq!(
        api.json("PUT", "/api/v1/spawn-config", TOKEN, &rates(1.0))
            .status,
        200
    );
    let quiet = spawns_on(&cluster, "J0_0_in_W0", Duration::from_secs(10));
    assert!(
        quiet <= 1,
        "1/min on J0_0_in_W0 gave {quiet} spawns in 10 s"
    );

    // Load brings back the saved one.
    let loaded = api.post_empty("/api/v1/spawn-config/load", TOKEN);
    assert_eq!(loaded.status, 200, "{}", loaded.body);
    assert_eq!(rate_of(&loaded.json(), "J0_0_in_W0"), 30.0);
    assert_eq!(
        rate_of(&api.get("/api/v1/spawn-config").json(), "J0_0_in_W0"),
        30.0
    );

    // A second save keeps the previous file as .bak.
    assert_eq!(
        api.json("PUT", "/api/v1/spawn-config", TOKEN, &rates(12.0))
            .status,
        200
    );
    assert_eq!(
        api.post_empty("/api/v1/spawn-config/save", TOKEN).status,
        200
    );
    let now: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let bak: Value =
        serde_json::from_str(&std::fs::read_to_string(file.with_extension("json.bak")).unwrap())
            .unwrap();
    assert_eq!(
        (rate_of(&now, "J0_0_in_W0"), rate_of(&bak, "J0_0_in_W0")),
        (12.0, 30.0)
    );
}

#[test]
fn a_refused_spawn_config_changes_neither_the_spawner_nor_the_file() {
    let cluster = Cluster::start_with_admin("adminrefuse", "max_vehicles = 10", false);
    let api = api(&cluster);
    let file = cluster.dir.path().join("traffic_spawn.json");
    assert_eq!(
        api.json("PUT", "/api/v1/spawn-config", TOKEN, &rates(6.0))
            .status,
        200
    );
    assert_eq!(
        api.post_empty("/api/v1/spawn-config/save", TOKEN).status,
        200
    );
    let bytes = std::fs::read(&file).unwrap();
    let before = api.get("/api/v1/spawn-config").json();

    let bad = json!({
        "spawnRates": [
            {"lane": "J0_0_in_W0", "spawnsPerMinute": 60.0},
            {"lane": "no_such_lane", "spawnsPerMinute": 1.0},
            {"lane": "J0_0_in_E0", "spawnsPerMinute": -2.0}
        ],
        "branchWeights": [
            {"fromLane": "J0_0_in_N0", "next": []},
            {"fromLane": "J0_0_in_S0", "next": [{"lane": "J0_0_S0_S", "weight": -1.0}]}
        ]
    });
    let refused = api.json("PUT", "/api/v1/spawn-config", TOKEN, &bad);
    refused.assert_problem(422, "no_such_lane");
    let problems = refused.json()["problems"].as_array().unwrap().clone();
    assert!(problems.len() >= 4, "every problem listed: {problems:?}");
    let text = serde_json::to_string(&problems).unwrap();
    for needle in ["no_such_lane", "spawnsPerMinute", "next", "weight"] {
        assert!(
            text.contains(needle),
            "problems do not name {needle}: {text}"
        );
    }
    assert_eq!(
        api.get("/api/v1/spawn-config").json(),
        before,
        "a refused config was applied"
    );
    assert_eq!(std::fs::read(&file).unwrap(), bytes, "the file changed");
}

#[test]
fn the_branch_csv_matches_the_statistics() {
    let cluster = Cluster::start_with_admin("admincsv", "max_vehicles = 30", false);
    let api = api(&cluster);
    wait_until("branch decisions", Duration::from_secs(60), || {
        api.get("/api/v1/status").json()["services"]["spawner"]["details"]["branch_decisions"]
            .as_u64()
            .is_some_and(|n| n >= 10)
    });
    // Freeze the statistics: no vehicles, so no more decisions (a new seed
    // is accepted on the way).
    let restarted = api.json(
        "POST",
        "/api/v1/restart",
        TOKEN,
        &json!({"max_vehicles": 0, "seed": 11}),
    );
    assert_eq!(restarted.status, 200, "{}", restarted.body);
    assert_eq!(restarted.json()["max_vehicles"], 0);
    wait_until("the map empties", Duration::from_secs(10), || {
        api.get("/api/v1/status").json()["vehicles"] == 0
    });
    std::thread::sleep(Duration::from_millis(1500)); // one status period
    let total =
        api.get("/api/v1/status").json()["services"]["spawner"]["details"]["branch_decisions"]
            .as_u64()
            .unwrap();
    let csv = api.get("/api/v1/branch-decisions.csv");
    assert_eq!(csv.status, 200);
    assert!(
        csv.content_type.starts_with("text/csv"),
        "{}",
        csv.content_type
    );
    let mut lines = csv.body.lines();
    assert_eq!(
        lines.next().unwrap(),
        "from_lane,to_lane,selection_mode,decision_count,total_from_lane,total_from_lane_mode,observed_ratio_from_lane,observed_ratio_from_lane_mode,avg_configured_weight,avg_effective_probability"
    );
    let mut sum = 0;
    let mut per_from: HashMap<String, u64> = HashMap::new();
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    for r in &rows {
        let count: u64 = r[3].parse().unwrap();
        sum += count;
        *per_from.entry(r[0].clone()).or_default() += count;
    }
    assert_eq!(
        sum, total,
        "CSV decision counts vs the spawner's statistics"
    );
    for r in &rows {
        assert_eq!(
            r[4].parse::<u64>().unwrap(),
            per_from[&r[0]],
            "total_from_lane of {r:?}"
        );
        let ratio: f64 = r[6].parse().unwrap();
        let expected = r[3].parse::<f64>().unwrap() / per_from[&r[0]] as f64;
        assert!(
            (ratio - expected).abs() < 1e-3,
            "observed_ratio_from_lane of {r:?}"
        );
    }
    // The same bytes as the spawner's own answer on the bus.
    let over_bus = runtime().block_on(async {
        let bus = cluster.client().await;
        let key = bus.keys().key(&trafficmesh_protocol::topics::BRANCH_CSV);
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            // Retried while this new session learns of the spawner's queryable.
            match bus.get_raw::<()>(&key, None, Duration::from_secs(2)).await {
                Ok(bytes) => break bytes,
                Err(e) if Instant::now() > deadline => panic!("{key}: {e}"),
                Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
            }
        }
    });
    assert_eq!(csv.body.as_bytes(), over_bus.as_slice());
}

#[test]
fn vehicles_ego_lights_and_crosswalks_can_be_operated() {
    let cluster = Cluster::start_with_admin("adminops", "max_vehicles = 20", false);
    let api = api(&cluster);
    wait_until("vehicles", Duration::from_secs(30), || {
        api.get("/api/v1/vehicles").json()["count"]
            .as_u64()
            .unwrap()
            >= 3
    });

    // Remove one vehicle by id: counted, and gone from the list.
    let id = api.get("/api/v1/vehicles").json()["vehicles"][0]["id"]
        .as_u64()
        .unwrap();
    let removed = api.json(
        "POST",
        "/api/v1/vehicles/remove",
        TOKEN,
        &json!({"around": "vehicle", "id": id}),
    );
    assert_eq!(removed.status, 200, "{}", removed.body);
    assert_eq!(removed.json()["removed"], 1);
    wait_until(
        "the removed vehicle leaves the list",
        Duration::from_secs(5),
        || api.get(&format!("/api/v1/vehicles/{id}")).status == 404,
    );

    // The ego: far away it removes nothing within 5 m; on the junction, with a
    // radius covering the map, every vehicle.
    let ego = |x: f64, y: f64| {
        api.json(
            "PUT",
            "/api/v1/ego",
            TOKEN,
            &json!({"x": x, "y": y, "yaw": 0.0}),
        )
    };
    assert_eq!(ego(5000.0, 5000.0).status, 204);
    std::thread::sleep(Duration::from_millis(300));
    let none = api.json(
        "POST",
        "/api/v1/vehicles/remove",
        TOKEN,
        &json!({"around": "ego", "radius": 5.0}),
    );
    assert_eq!(none.json()["removed"], 0, "{}", none.body);
    assert_eq!(ego(0.0, 0.0).status, 204);
    std::thread::sleep(Duration::from_millis(300));
    let all = api.json(
        "POST",
        "/api/v1/vehicles/remove",
        TOKEN,
        &json!({"around": "ego", "radius": 10000.0}),
    );
    assert!(all.json()["removed"].as_u64().unwrap() >= 1, "{}", all.body);

    // Restart with a new maximum: the count never goes above it.
    let restarted = api.json(
        "POST",
        "/api/v1/restart",
        TOKEN,
        &json!({"max_vehicles": 2}),
    );
    assert_eq!(restarted.json()["max_vehicles"], 2, "{}", restarted.body);
    for _ in 0..20 {
        assert!(
            api.get("/api/v1/status").json()["vehicles"]
                .as_u64()
                .unwrap()
                <= 2
        );
        std::thread::sleep(Duration::from_millis(100));
    }

    // Lights: force red, see it, back to the program.
    let forced = api.json(
        "POST",
        "/api/v1/lights/J0_0_EW/override",
        TOKEN,
        &json!({"color": "red"}),
    );
    assert_eq!(forced.status, 200, "{}", forced.body);
    assert_eq!(forced.json()["color"], "red");
    assert_eq!(forced.json()["forced"], true);
    wait_until(
        "the forced state in the list",
        Duration::from_secs(5),
        || {
            api.get("/api/v1/lights")
                .json()
                .as_array()
                .unwrap()
                .iter()
                .any(|l| l["group"] == "J0_0_EW" && l["forced"] == true && l["color"] == "red")
        },
    );
    let program = api.json(
        "POST",
        "/api/v1/lights/J0_0_EW/override",
        TOKEN,
        &json!({"program": {"green": 5, "yellow": 1, "red": 6}}),
    );
    assert_eq!(program.status, 200, "{}", program.body);
    assert_eq!(program.json()["forced"], false);
    let back = api.json("POST", "/api/v1/lights/J0_0_EW/override", TOKEN, &json!({}));
    assert_eq!(back.json()["forced"], false, "{}", back.body);

    // Crosswalks: a pedestrian on the west one makes it occupied and blocks a
    // vehicle heading at it; the blocked-stop query says so.
    let approaching = json!({"x": -45.0, "y": -1.75, "yaw": 0.0});
    let clear = api.json(
        "POST",
        "/api/v1/crosswalks/blocked-stop",
        TOKEN,
        &approaching,
    );
    assert_eq!(clear.json()["blocked"], false, "{}", clear.body);
    runtime().block_on(async {
        let bus = cluster.client().await;
        let walker = AgentBatch {
            time: 0.0,
            agents: vec![Agent {
                id: "p1".into(),
                root: "Pedestrian_admin".into(),
                kind: "NPCPedestrian".into(),
                footprint: vec![[-15.3, -0.3], [-14.7, -0.3], [-14.7, 0.3], [-15.3, 0.3]],
            }],
        };
        let deadline = Instant::now() + Duration::from_secs(15);
        loop {
            bus.put(&bus.keys().key_at(&topics::AGENTS, "admintest"), &walker)
                .await
                .unwrap();
            let occupied = tokio::task::block_in_place(|| {
                api.get("/api/v1/crosswalks")
                    .json()
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|c| c["name"] == "J0_0_crosswalk_W" && c["occupied"] == true)
            });
            if occupied {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "the west crosswalk never showed occupied"
            );
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    });
    let blocked = api
        .json(
            "POST",
            "/api/v1/crosswalks/blocked-stop",
            TOKEN,
            &approaching,
        )
        .json();
    assert_eq!(blocked["blocked"], true, "{blocked}");
    assert_eq!(blocked["area"], "J0_0_crosswalk_W");
    assert!(blocked["distance"].as_f64().unwrap() > 0.0);
}

#[test]
fn light_overrides_survive_a_killed_lights_service() {
    let cluster = Cluster::start_with_admin("adminlights", "max_vehicles = 5", false);
    let api = api(&cluster);
    let file = cluster.dir.path().join("light_overrides.json");
    let override_light = |group: &str, body: Value| {
        let r = api.json(
            "POST",
            &format!("/api/v1/lights/{group}/override"),
            TOKEN,
            &body,
        );
        assert_eq!(r.status, 200, "{}", r.body);
    };
    override_light("J0_0_EW", json!({"color": "red"}));
    let program = json!({"green": 7.0, "yellow": 2.0, "red": 9.0, "offset": 0.0});
    override_light("J0_0_NS", json!({ "program": program }));
    // On disk once acknowledged: the REST body's shape, one entry a group.
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let entry = |saved: &Value, group: &str| {
        saved
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["group"] == group)
            .cloned()
    };
    assert_eq!(entry(&saved, "J0_0_EW").unwrap()["color"], "red", "{saved}");
    assert_eq!(
        entry(&saved, "J0_0_NS").unwrap()["program"],
        program,
        "{saved}"
    );

    let lights_pid = || api.get("/api/v1/status").json()["services"]["lights"]["pid"].as_u64();
    wait_until("the lights' pid", Duration::from_secs(10), || {
        lights_pid().is_some()
    });
    let pid = lights_pid().unwrap();
    unsafe { libc::kill(pid as i32, libc::SIGKILL) };
    wait_until("the lights restarted", Duration::from_secs(30), || {
        let s = api.get("/api/v1/status").json();
        let lights = &s["services"]["lights"];
        lights["alive"] == true && lights["pid"].as_u64().is_some_and(|p| p != pid)
    });
    runtime().block_on(async {
        let resumed = "resumed the overrides of light groups ";
        assert!(
            cluster.wait_log(resumed, Duration::from_secs(10)).await,
            "the restarted lights did not take up the overrides:\n{}",
            cluster.log()
        );
        let log = cluster.log();
        let line = log.lines().find(|l| l.contains(resumed)).unwrap();
        assert!(
            line.contains("J0_0_EW") && line.contains("J0_0_NS"),
            "{line}"
        );
        // The new process answers for the group: still forced red.
        let bus = cluster.client().await;
        let key = bus.keys().key_at(&topics::LIGHT_STATE, "J0_0_EW");
        let state: trafficmesh_protocol::wire::LightState = ask(&bus, &key, &()).await;
        assert!(
            state.forced && state.color == trafficmesh_model::LightColor::Red,
            "{state:?}"
        );
    });

    // Back to the map's program: gone from the file, the other one kept.
    override_light("J0_0_EW", json!({}));
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert!(entry(&saved, "J0_0_EW").is_none(), "{saved}");
    assert!(entry(&saved, "J0_0_NS").is_some(), "{saved}");
}

/// Debian's `chromium` (TRAFFICMESH_CHROMIUM overrides). Missing: a notice and
/// a skip, unless TRAFFICMESH_REQUIRE_CHROMIUM=1 (CI) makes it a failure.
fn chromium() -> Option<String> {
    let candidates = std::env::var("TRAFFICMESH_CHROMIUM")
        .into_iter()
        .chain(["chromium".to_string(), "chromium-browser".to_string()]);
    for c in candidates {
        if std::process::Command::new(&c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
        {
            return Some(c);
        }
    }
    if std::env::var("TRAFFICMESH_REQUIRE_CHROMIUM").is_ok_and(|v| v == "1") {
        panic!("TRAFFICMESH_REQUIRE_CHROMIUM=1 but no chromium (apt-get install chromium)");
    }
    eprintln!("NOTICE: skipped: no chromium (apt-get install chromium)");
    None
}

#[test]
fn the_live_map_shows_moving_vehicles_in_headless_chromium() {
    let (Some(browser), Some(python)) = (
        chromium(),
        trafficmesh_testkit::python_with("websocket, PIL", "websocket-client pillow"),
    ) else {
        return;
    };
    let cluster = Cluster::start_with_admin("adminlive", "max_vehicles = 40", true);
    let api = api(&cluster);
    wait_until("vehicles", Duration::from_secs(30), || {
        api.get("/api/v1/vehicles").json()["count"]
            .as_u64()
            .unwrap()
            >= 10
    });
    live_map_check(&python, &browser, &cluster, &[]);
}

#[test]
fn the_live_map_draws_the_reserved_ways_and_the_queues_in_headless_chromium() {
    let (Some(browser), Some(python)) = (
        chromium(),
        trafficmesh_testkit::python_with("websocket, PIL", "websocket-client pillow"),
    ) else {
        return;
    };
    let (_map_dir, map, _, _) = reservation_four_way();
    let cluster = Cluster::start_on_with_admin("adminreserved", &map, "max_vehicles = 30", false);
    live_map_check(&python, &browser, &cluster, &["reservations"]);
}

/// Runs tests/admin/live_map.py (with `extra` arguments) in `browser` on
/// the cluster's live map; it must print OK.
fn live_map_check(python: &str, browser: &str, cluster: &Cluster, extra: &[&str]) {
    let out = std::process::Command::new(python)
        .arg(repo().join("tests/admin/live_map.py"))
        .arg(browser)
        .arg(format!("{}/", cluster.admin.as_ref().unwrap()))
        .arg(cluster.dir.path())
        .args(extra)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("OK"),
        "live map check failed:\n{stdout}\n{stderr}"
    );
}

/// The walkers' walk signals follow the lights service, overrides included:
/// with both groups of the four-way forced green for the cars no walker
/// starts across its crosswalks (on the map's program they would, twice a
/// minute each); forced red, walkers start again.
#[test]
fn walk_signals_follow_the_light_overrides() {
    let cluster = Cluster::launch_spec(ClusterSpec {
        seed: 7,
        stepper: "speed = 4".into(),
        spawner: "max_vehicles = 2".into(),
        pedestrians: true,
        admin_token: Some(TOKEN.into()),
        ..Cluster::spec("walkoverride", &four_way())
    });
    cluster.wait_for_admin();
    let api = api(&cluster);
    let force_both = |color: &str| {
        for group in ["J0_0_EW", "J0_0_NS"] {
            let r = api.json(
                "POST",
                &format!("/api/v1/lights/{group}/override"),
                TOKEN,
                &json!({ "color": color }),
            );
            assert_eq!(r.status, 200, "{}", r.body);
        }
    };
    runtime().block_on(async {
        let bus = cluster.client().await;
        let walkers = bus.subscribe_to(&topics::AGENTS).await.unwrap();
        // The walkers' batches from `from` simulated seconds after the first
        // one received, for `span` seconds: the ids present at the start, and
        // those that started later.
        let watch = |from: f64, span: f64| {
            let (bus, walkers, cluster) = (&bus, &walkers, &cluster);
            async move {
                let deadline = Instant::now() + Duration::from_secs(60);
                let (mut start, mut present, mut started) = (None, None, Vec::new());
                while Instant::now() < deadline {
                    let next = tokio::time::timeout(Duration::from_secs(5), walkers.next(bus));
                    let Ok(Some((source, batch))) = next.await else {
                        panic!("no walkers' batch within 5 s:\n{}", cluster.log());
                    };
                    if source != "pedestrians" {
                        continue;
                    }
                    let begin = *start.get_or_insert(batch.time + from);
                    if batch.time < begin {
                        continue;
                    }
                    let ids: Vec<String> = batch.agents.iter().map(|a| a.id.clone()).collect();
                    let before: &Vec<String> = present.get_or_insert(ids.clone());
                    started.extend(ids.into_iter().filter(|id| !before.contains(id)));
                    if batch.time >= begin + span {
                        started.sort();
                        started.dedup();
                        return started;
                    }
                }
                panic!("the walkers' clock did not run {span} s within 60 s");
            }
        };
        force_both("green");
        // A second for the lights' word to reach the walkers, then 70 s: on
        // the map's program each crosswalk shows its walk signal for half of
        // every 66 s cycle.
        let started = watch(1.0, 70.0).await;
        assert!(
            started.is_empty(),
            "walkers started against a forced green: {started:?}"
        );
        force_both("red");
        let started = watch(1.0, 40.0).await;
        assert!(!started.is_empty(), "no walker started on a forced red");
    });
}
