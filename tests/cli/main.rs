//! End-to-end tests of the `trafficmesh` binary, run the way a user runs it.

#[path = "../cluster/support.rs"]
#[allow(dead_code)]
mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::{Value, json};

fn trafficmesh(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn repo_file(rel: &str) -> PathBuf {
    trafficmesh_testkit::repo_root().join(rel)
}

fn grid(dir: &Path, size: usize) -> PathBuf {
    let path = dir.join(format!("grid{size}.map.json"));
    let out = trafficmesh(&[
        "gen-grid",
        "--size",
        &size.to_string(),
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    path
}

fn sim_json(map: &Path, extra: &[&str]) -> Value {
    let mut args = vec!["sim", "--map", map.to_str().unwrap(), "--json"];
    args.extend_from_slice(extra);
    let out = trafficmesh(&args);
    assert!(
        out.status.success(),
        "sim failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

#[test]
fn same_seed_same_trajectories_whatever_the_thread_count_and_another_seed_differs() {
    let dir = tempfile::tempdir().unwrap();
    let map = grid(dir.path(), 3);
    let run = |seed: &str, threads: &str| {
        sim_json(
            &map,
            &[
                "--duration",
                "120",
                "--seed",
                seed,
                "--threads",
                threads,
                "--max-vehicles",
                "150",
            ],
        )
    };
    let (one, two, other) = (run("5", "1"), run("5", "2"), run("6", "2"));
    assert!(
        one["vehicle_steps"].as_u64().unwrap() > 100_000,
        "too little traffic to compare: {one}"
    );
    assert_eq!(one["trajectory_hash"], two["trajectory_hash"]);
    assert_eq!(one["vehicle_steps"], two["vehicle_steps"]);
    assert_ne!(one["trajectory_hash"], other["trajectory_hash"]);
}

#[test]
fn the_default_tick_follows_the_driver_model() {
    let net = repo_file("configs/sumo/grid3_crossings.net.xml");
    let tick = |extra: &[&str]| {
        let mut args = vec!["--duration", "30"];
        args.extend_from_slice(extra);
        let v = sim_json(&net, &args);
        (
            v["driver_model"].clone(),
            v["dt"].as_f64().unwrap(),
            v["ticks"].as_u64().unwrap(),
        )
    };
    // A SUMO network drives `realistic` by default, at 10 Hz.
    assert_eq!(tick(&[]), (json!("realistic"), 0.1, 300));
    assert_eq!(
        tick(&["--driver-model", "awsim"]),
        (json!("awsim"), 0.02, 1500)
    );
    assert_eq!(tick(&["--dt", "0.05"]), (json!("realistic"), 0.05, 600));
}

#[test]
fn json_summary_has_the_documented_fields() {
    let v = sim_json(
        &repo_file("configs/maps/four_way.map.json"),
        &["--duration", "60"],
    );
    for key in [
        "vehicle_steps",
        "vehicle_steps_per_sec",
        "ticks",
        "mean_vehicles",
        "max_vehicles",
        "spawned",
        "despawned",
        "trajectory_hash",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["ticks"], 3000);
    assert!(
        v["max_vehicles"].as_u64().unwrap() <= 40,
        "default maxVehicleCount is 40: {v}"
    );
}

#[test]
fn sim_writes_trips_branch_csv_and_final_spawn_config() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let v = sim_json(
        &repo_file("configs/maps/four_way.map.json"),
        &[
            "--duration",
            "300",
            "--spawn-config",
            repo_file("configs/traffic_spawn.json").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let trips = std::fs::read_to_string(out.join("trips.csv")).unwrap();
    let mut rows = trips.lines();
    assert_eq!(
        rows.next(),
        Some(
            "id,kind,spawn_time,despawn_time,distance_m,stops,time_stopped_s,end_reason,depart_delay_s,time_loss_s"
        )
    );
    assert_eq!(
        rows.count() as u64,
        v["spawned"].as_u64().unwrap(),
        "one trip row per spawned vehicle"
    );

    let branches = std::fs::read_to_string(out.join("traffic_branch_decisions.csv")).unwrap();
    assert!(branches.starts_with("from_lane,to_lane,selection_mode,decision_count,total_from_lane,total_from_lane_mode,observed_ratio_from_lane,observed_ratio_from_lane_mode,avg_configured_weight,avg_effective_probability\n"));
    let total: u64 = branches
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse::<u64>().unwrap())
        .sum();
    assert_eq!(total, v["branch_decisions"].as_u64().unwrap());
    assert!(
        branches.contains(",weighted,") && branches.contains(",uniform_no_matching_weights,"),
        "{branches}"
    );

    let saved: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("traffic_spawn.json")).unwrap())
            .unwrap();
    let input: Value = serde_json::from_str(
        &std::fs::read_to_string(repo_file("configs/traffic_spawn.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(saved, input);
}

fn expect_usage_error(args: &[&str], needles: &[&str]) {
    let out = trafficmesh(args);
    assert_eq!(
        out.status.code(),
        Some(2),
        "expected exit code 2 for {args:?}"
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    for needle in needles {
        assert!(stderr.contains(needle), "{needle:?} not in: {stderr}");
    }
}

#[test]
fn malformed_map_is_rejected_naming_field_and_lane() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let unknown_next = write(
        "a.json",
        r#"{"lanes": [{"name": "In", "waypoints": [[0,0],[50,0]], "next": ["Nowhere"]},
                      {"name": "X", "waypoints": [[50,0],[60,0]], "intersection": true, "width": -2}],
            "traffic_simulators": [{"kind": "random", "lanes": ["In"], "prefabs": ["Taxi"]}]}"#,
    );
    expect_usage_error(
        &[
            "sim",
            "--map",
            unknown_next.to_str().unwrap(),
            "--duration",
            "1",
        ],
        &[
            "lane 'In'",
            "field 'next'",
            "unknown lane 'Nowhere'",
            "lane 'X'",
            "field 'width'",
        ],
    );
    let wrong_type = write(
        "b.json",
        r#"{"lanes": [{"name": "Main", "waypoints": [[0,0],[50,0]], "speed_limit": "fast"}]}"#,
    );
    expect_usage_error(
        &[
            "sim",
            "--map",
            wrong_type.to_str().unwrap(),
            "--duration",
            "1",
        ],
        &["lane 'Main'", "speed_limit"],
    );
    let truncated = write("c.json", r#"{"lanes": [{"name": "Main", "waypoi"#);
    expect_usage_error(
        &[
            "sim",
            "--map",
            truncated.to_str().unwrap(),
            "--duration",
            "1",
        ],
        &["not valid JSON", "line 1"],
    );
    expect_usage_error(
        &["sim", "--map", "/nonexistent/map.json", "--duration", "1"],
        &["/nonexistent/map.json", "cannot read"],
    );
    expect_usage_error(&["sim", "--duration", "1"], &["--map"]);
}

#[test]
fn malformed_spawn_config_is_rejected_naming_field_and_lane() {
    let dir = tempfile::tempdir().unwrap();
    let map = repo_file("configs/maps/four_way.map.json");
    let cfg = dir.path().join("spawn.json");
    let check = |text: &str, needles: &[&str]| {
        std::fs::write(&cfg, text).unwrap();
        let args = [
            "sim",
            "--map",
            map.to_str().unwrap(),
            "--duration",
            "1",
            "--spawn-config",
            cfg.to_str().unwrap(),
        ];
        expect_usage_error(&args, needles);
    };
    check(
        r#"{"spawnRates": [{"lane": "j0_0_in_n0", "spawnsPerMinute": -3}],
            "branchWeights": [{"fromLane": "J0_0_in_S0", "next": [{"lane": "Ghost", "weight": 1}]}]}"#,
        &[
            "lane 'j0_0_in_n0'",
            "spawnsPerMinute",
            "fromLane 'J0_0_in_S0'",
            "unknown lane 'Ghost'",
        ],
    );
    check(
        r#"{"spawnRates": [{"lane": "J0_0_in_N0", "spawnsPerMinute": "six"}]}"#,
        &["lane 'J0_0_in_N0'", "spawnsPerMinute"],
    );
}

#[test]
fn bad_numbers_on_the_command_line_are_rejected() {
    let map = repo_file("configs/maps/four_way.map.json");
    let sim = |extra: &[&str], needle: &str| {
        let mut args = vec!["sim", "--map", map.to_str().unwrap()];
        args.extend_from_slice(extra);
        expect_usage_error(&args, &[needle]);
    };
    sim(
        &["--duration", "-5"],
        "--duration must be a positive number",
    );
    sim(&["--duration", "10", "--dt", "0"], "--dt must be in (0, 1]");
    sim(
        &["--duration", "10", "--jam-timeout", "-1"],
        "--jam-timeout must be 0 (never) or a positive number",
    );
    sim(
        &["--duration", "10", "--fixed-speed-limit", "-1"],
        "fixedSpeedLimit must be a positive number",
    );
    sim(
        &["--duration", "10", "--sudden-deceleration", "0"],
        "suddenDeceleration must be a positive number",
    );
    sim(
        &["--duration", "10", "--spawn-distance-to-ego", "-1"],
        "--spawn-distance-to-ego must be a number of metres >= 0",
    );
    expect_usage_error(
        &["gen-grid", "--size", "0"],
        &["--size must be between 1 and 200"],
    );
}

/// `bench bus` streams and pings through a router over TCP and over the
/// secure profile's TLS (certificates from make-certs.sh): every message
/// sent arrives, and both report their figures. A short run: the figures
/// themselves are docs/performance.md's.
#[test]
fn bench_bus_measures_tcp_and_tls() {
    let certs = tempfile::tempdir().unwrap();
    trafficmesh_testkit::make_certs(&certs.path().join("tls"));
    let tls = certs.path().join("tls");
    let out = trafficmesh(&[
        "bench",
        "bus",
        "--tls-dir",
        tls.to_str().unwrap(),
        "--sizes",
        "2516",
        "--seconds",
        "0.3",
        "--pings",
        "50",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let runs = report["runs"].as_array().unwrap();
    let transports: Vec<&str> = runs
        .iter()
        .map(|r| r["transport"].as_str().unwrap())
        .collect();
    assert_eq!(transports, ["tcp", "tls"], "{report}");
    for run in runs {
        assert!(
            run["streams"][0]["messages_per_sec"].as_f64().unwrap() > 100.0,
            "{run}"
        );
        let (p50, p99) = (
            run["round_trip_p50_us"].as_f64().unwrap(),
            run["round_trip_p99_us"].as_f64().unwrap(),
        );
        assert!(p50 > 0.0 && p50 <= p99, "{run}");
    }
    // Without the certificates, a clear error names the missing file.
    let out = trafficmesh(&["bench", "bus", "--tls-dir", "/nonexistent"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("make-certs.sh"));
}

fn saturation(model: &str) -> Value {
    let out = trafficmesh(&["bench", "saturation", "--model", model, "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

/// The realistic model discharges a queue at a green light near the 1,900
/// vehicles per hour per lane of the Highway Capacity Manual; the AWSIM
/// reference's rules at well under that. Loose bounds: a regression in either
/// model cannot pass unnoticed.
#[test]
fn bench_saturation_gives_each_models_discharge_rate() {
    let realistic = saturation("realistic");
    let flow = realistic["saturation_flow_veh_per_hour_per_lane"]
        .as_f64()
        .unwrap();
    assert!((1500.0..=2200.0).contains(&flow), "realistic: {realistic}");
    let awsim = saturation("awsim");
    let flow = awsim["saturation_flow_veh_per_hour_per_lane"]
        .as_f64()
        .unwrap();
    assert!((600.0..=1200.0).contains(&flow), "awsim: {awsim}");
    assert_eq!(awsim["queued"], 20);
}

/// The same four-way intersection under fixed-time lights and under
/// reservations: one row per controller and demand, in the JSON and in the
/// CSV; reservations keep every body apart and serve the demand with less
/// delay than the lights.
#[test]
fn bench_intersection_compares_reservations_with_lights() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("table.csv");
    let plot = dir.path().join("delay.png");
    let out = trafficmesh(&[
        "bench",
        "intersection",
        "--demand",
        "300",
        "--duration",
        "300",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).expect("stdout is one JSON object");
    let rows = v["rows"].as_array().expect("rows");
    let row = |controller: &str| {
        rows.iter()
            .find(|r| r["controller"] == controller)
            .unwrap_or_else(|| panic!("no {controller} row in {v}"))
    };
    let (lights, reserved) = (row("lights"), row("reservation"));
    for r in [lights, reserved] {
        for field in [
            "demand_vphpl",
            "served_vphpl",
            "mean_delay_s",
            "p95_delay_s",
            "collisions",
        ] {
            assert!(r[field].is_number(), "{field} in {r}");
        }
        assert_eq!(r["demand_vphpl"], 300.0);
    }
    assert_eq!(reserved["collisions"], 0, "{reserved}");
    let served = reserved["served_vphpl"].as_f64().unwrap();
    assert!(
        served > 200.0,
        "reservations served {served} of 300 an hour per lane"
    );
    let delay = |r: &Value| r["mean_delay_s"].as_f64().unwrap();
    assert!(
        delay(reserved) < delay(lights),
        "{reserved} against {lights}"
    );
    for field in ["p50", "p99", "max", "per_request_p99"] {
        let us = v["decision_us"][field].as_f64().unwrap_or(-1.0);
        assert!(us > 0.0, "decision_us.{field} in {v}");
    }
    let table = std::fs::read_to_string(&csv).expect("the CSV is written");
    assert_eq!(table.lines().count(), 3, "a header and two rows: {table}");
    assert!(
        table.starts_with(
            "controller,demand_vphpl,served_vphpl,mean_delay_s,p95_delay_s,collisions"
        )
    );
    // The plot: a whole PNG of the size drawn (its header and IHDR chunk).
    let png = std::fs::read(&plot).expect("the plot is written");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let width = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(png[20..24].try_into().unwrap());
    assert_eq!((width, height), (900, 560));
    assert_eq!(
        &png[png.len() - 8..png.len() - 4],
        b"IEND",
        "a truncated PNG"
    );
    assert!(
        !dir.path().join("delay.partial.png").exists(),
        "the temporary file stayed"
    );
}

#[test]
fn bench_intersection_refuses_a_demand_that_is_not_positive() {
    let out = trafficmesh(&["bench", "intersection", "--demand", "300,-5"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--demand"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The figures a traffic engineer reads are in the summary.
#[test]
fn sim_json_reports_insertion_arrival_waiting_and_jams() {
    let dir = tempfile::tempdir().unwrap();
    let map = grid(dir.path(), 3);
    let v = sim_json(&map, &["--duration", "120", "--max-vehicles", "30"]);
    for field in [
        "inserted",
        "arrived",
        "insertion_backlog",
        "max_wait_s",
        "stuck_vehicles",
        "stuck_vehicles_mean",
        "jam_resolutions",
    ] {
        assert!(v[field].is_number(), "{field} missing: {v}");
    }
    assert_eq!(v["inserted"], v["spawned"]);
    assert!(v["arrived"].as_u64().unwrap() <= v["despawned"].as_u64().unwrap());
    assert_eq!(
        v["driver_model"], "awsim",
        "a native map runs the reference's model"
    );
}

/// `sim --check` watches every tick: over ten simulated minutes of the sample
/// map and a generated grid (native geometry, the reference's rules) no pose
/// jumps or turns faster than a car can, no bodies overlap and nobody speeds.
#[test]
fn sim_check_finds_continuous_motion_on_native_maps() {
    let dir = tempfile::tempdir().unwrap();
    for (map, vehicles) in [
        (repo_file("configs/maps/four_way.map.json"), "40"),
        (grid(dir.path(), 3), "120"),
    ] {
        let v = sim_json(
            &map,
            &["--duration", "600", "--max-vehicles", vehicles, "--check"],
        );
        let check = &v["check"];
        assert_eq!(check["ticks"], v["ticks"], "every tick is checked: {check}");
        assert!(check["vehicle_steps"].as_u64().unwrap() > 10_000, "{check}");
        for what in ["jumps", "turns", "overlaps", "speeding", "red_lights"] {
            assert_eq!(
                check[what]["count"],
                0,
                "{what} on {}: {check}",
                map.display()
            );
        }
    }
    let plain = sim_json(
        &repo_file("configs/maps/four_way.map.json"),
        &["--duration", "10"],
    );
    assert!(plain.get("check").is_none(), "only with --check");
}

/// On every real map of `../shared/maps`, ten simulated minutes of random
/// traffic at the lanes' own limits: poses move continuously (no jump, no
/// turn tighter than a car's), nobody drives faster than the lane it is on
/// allows (vehicles slow before a slower lane, not on it), nobody crosses
/// a stop line on red, and no two bodies overlap.
#[test]
fn sim_check_finds_no_jump_overlap_speeding_or_red_light_crossing_on_real_maps() {
    for (file, vehicles) in [
        ("cross.net.xml", "50"),
        ("bologna_acosta/acosta_buslanes.net.xml", "400"),
        ("autoware_intersection_lanelet2_map.osm", "60"),
        ("mapping_example.osm", "150"),
    ] {
        let Some(map) = support::shared_map(file) else {
            return;
        };
        let v = sim_json(
            &map,
            &["--duration", "600", "--max-vehicles", vehicles, "--check"],
        );
        let check = &v["check"];
        assert_eq!(
            v["vehicle_config"]["speedLimitSource"], "LaneletSpeedLimit",
            "{file}"
        );
        assert!(
            check["vehicle_steps"].as_u64().unwrap() > 10_000,
            "{file}: {check}"
        );
        for what in ["jumps", "turns", "overlaps", "speeding", "red_lights"] {
            assert_eq!(check[what]["count"], 0, "{what} on {file}: {}", check[what]);
        }
        assert_eq!(v["red_light_crossings"], 0, "{file}");
        assert_eq!(
            check["relocations"].as_u64(),
            v["jam_resolutions"]
                .as_u64()
                .map(|r| r - v["jam_removals"].as_u64().unwrap()),
            "{file}: vehicles moved on by the jam timeout are counted apart"
        );
    }
}

/// What a foreign map had that is not simulated, or that was made up for
/// it, is said on stderr, never silently dropped: a Lanelet2 map's bicycle
/// lanes and its synthesised signal programs.
#[test]
fn sim_names_what_the_map_import_left_out_or_made_up() {
    let Some(map) = support::shared_map("mapping_example.osm") else {
        return;
    };
    let out = trafficmesh(&["sim", "--map", map.to_str().unwrap(), "--duration", "1"]);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    for needle in [
        "warning: 14 lanelet(s) of subtype 'bicycle_lane' not imported",
        "got a synthesised two-phase program",
    ] {
        assert!(stderr.contains(needle), "{needle:?} not in: {stderr}");
    }
}

/// The README stays the front door: short, opening with the command that
/// runs the cluster and the very test command CI runs, naming only
/// subcommands the binary has and docs files that exist.
#[test]
fn the_readme_is_short_and_its_commands_and_links_exist() {
    let readme = std::fs::read_to_string(repo_file("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(
        lines < 250,
        "README.md has {lines} lines; reference belongs in docs/"
    );

    let opening: Vec<&str> = readme
        .split("```")
        .nth(1)
        .expect("the README opens with a code block")
        .lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .skip(1)
        .collect();
    assert!(
        opening
            .first()
            .is_some_and(|l| l.contains("trafficmesh up")),
        "the first command runs the cluster: {opening:?}"
    );
    let test_command = opening
        .get(1)
        .expect("a second command runs the tests")
        .trim();
    let ci = std::fs::read_to_string(repo_file(".ci/run")).unwrap();
    let ci_last = ci
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap()
        .trim();
    assert_eq!(
        test_command, ci_last,
        "CI runs exactly the README's test command"
    );

    let mut subcommands: Vec<&str> = readme
        .split("trafficmesh ")
        .skip(1)
        .filter_map(|rest| {
            rest.split(|c: char| !c.is_ascii_lowercase() && c != '-')
                .next()
        })
        .filter(|w| !w.is_empty() && *w != "simulates")
        .collect();
    subcommands.sort();
    subcommands.dedup();
    assert!(subcommands.contains(&"sim") && subcommands.contains(&"up"));
    for sub in subcommands {
        let out = trafficmesh(&[sub, "--help"]);
        assert!(
            out.status.success(),
            "the README names `trafficmesh {sub}`, which the binary does not have: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    for link in readme.split("](").skip(1) {
        let target = link.split(')').next().unwrap();
        if target.starts_with("http") || target.starts_with('#') {
            continue;
        }
        let path = target.split('#').next().unwrap();
        assert!(
            repo_file(path).exists(),
            "the README links to {path}, which does not exist"
        );
    }
}

/// A cluster.toml in `dir` from the shipped one: `map` and `spawn_config`
/// as given, the endpoint on `port`, the gRPC server on a free port, no
/// admin; `extra` appended.
fn cluster_toml(dir: &Path, map: &Path, spawn_config: &Path, port: u16, extra: &str) -> PathBuf {
    let shipped = std::fs::read_to_string(repo_file("configs/cluster.toml")).unwrap();
    let mut text = String::new();
    let mut section = String::new();
    for line in shipped.lines() {
        if line.starts_with('[') {
            section = line.to_string();
        }
        let key = line.split('=').next().unwrap_or("").trim();
        let line = match (section.as_str(), key) {
            ("", "map") => format!("map = \"{}\"", map.display()),
            ("", "endpoint") => format!("endpoint = \"tcp/127.0.0.1:{port}\""),
            ("[spawner]", "spawn_config") => {
                format!("spawn_config = \"{}\"", spawn_config.display())
            }
            ("[spawner]", "branch_csv") => {
                format!("branch_csv = \"{}\"", dir.join("branches.csv").display())
            }
            ("[admin]", "enabled") => "enabled = false".into(),
            // Tests run side by side: each cluster's gRPC server gets a port of its own.
            ("[traffic_service]", "listen") => {
                format!("listen = \"127.0.0.1:{}\"", support::free_port())
            }
            _ => line.to_string(),
        };
        text += &line;
        text.push('\n');
    }
    text += extra;
    let path = dir.join("cluster.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `trafficmesh up` with these arguments, stopped with SIGINT after `secs`
/// unless it ends first: (exit code, stderr, whether it ended by itself).
fn up_for(args: &[&std::ffi::OsStr], secs: f64) -> (Option<i32>, String, bool) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .arg("up")
        .args(args)
        .current_dir(repo_file(""))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs_f64(secs);
    let mut ended = true;
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
            ended = false;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).to_string(),
        ended,
    )
}

/// `up` checks every service's configuration before it starts anything: a
/// spawn config naming lanes its map lacks, or a setting a service would
/// refuse, ends it at once with one message naming the file, the entry and
/// the fix, and nothing started.
#[test]
fn up_refuses_a_bad_configuration_at_once_and_starts_nothing() {
    let Some(net) = cross_net() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let spawn = repo_file("configs/traffic_spawn.json");
    let toml = cluster_toml(dir.path(), &net, &spawn, support::free_port(), "");
    let (code, stderr, ended) = up_for(&["--config".as_ref(), toml.as_os_str()], 10.0);
    assert!(ended, "up did not exit: {stderr}");
    assert_eq!(code, Some(2), "{stderr}");
    for needle in ["traffic_spawn.json", "unknown lane 'J0_0_in_N0'", "fix:"] {
        assert!(stderr.contains(needle), "no '{needle}' in: {stderr}");
    }
    assert!(
        !stderr.contains("started (pid"),
        "a service was started: {stderr}"
    );

    let toml = cluster_toml(
        dir.path(),
        &repo_file("configs/maps/four_way.map.json"),
        &spawn,
        support::free_port(),
        "",
    );
    let text = std::fs::read_to_string(&toml)
        .unwrap()
        .replace("per_minute = 2.0", "per_minute = -1");
    std::fs::write(&toml, text).unwrap();
    let (code, stderr, ended) = up_for(&["--config".as_ref(), toml.as_os_str()], 10.0);
    assert!(ended && code == Some(2), "{code:?}: {stderr}");
    assert!(
        stderr.contains("pedestrians.per_minute must be a number >= 0, got -1"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("started (pid"),
        "a service was started: {stderr}"
    );
}

/// `up --map` with a map of one's own and the shipped spawn config (written
/// for the sample map): the cluster starts with the map's own, empty, spawn
/// config and says so; nothing exits or is restarted.
#[test]
fn up_with_a_map_of_ones_own_starts_with_an_empty_spawn_config() {
    let Some(net) = cross_net() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let spawn = dir.path().join("traffic_spawn.json");
    std::fs::copy(repo_file("configs/traffic_spawn.json"), &spawn).unwrap();
    let toml = cluster_toml(
        dir.path(),
        &repo_file("configs/maps/four_way.map.json"),
        &spawn,
        support::free_port(),
        "",
    );
    let (code, stderr, ended) = up_for(
        &[
            "--config".as_ref(),
            toml.as_os_str(),
            "--map".as_ref(),
            net.as_os_str(),
        ],
        6.0,
    );
    assert!(!ended, "up ended by itself ({code:?}): {stderr}");
    assert!(
        stderr.contains("is written for another map")
            && stderr.contains(&format!(
                "{}",
                dir.path().join("traffic_spawn.cross.json").display()
            )),
        "{stderr}"
    );
    for service in ["stepper", "spawner", "lights", "crosswalks"] {
        assert!(
            stderr.contains(&format!("{service} started (pid")),
            "{service} not started: {stderr}"
        );
    }
    assert!(
        !stderr.contains("exited") && !stderr.contains("restarting"),
        "a service exited: {stderr}"
    );
}

/// A service that exits with the configuration-error code (here: a Zenoh
/// config file it cannot parse) is never restarted: `up` stops the cluster
/// and says which service could not run.
#[test]
fn up_stops_the_cluster_when_a_service_cannot_run_with_its_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let zenoh = dir.path().join("broken.json5");
    std::fs::write(&zenoh, "{ this is not json5").unwrap();
    let toml = cluster_toml(
        dir.path(),
        &repo_file("configs/maps/four_way.map.json"),
        &repo_file("configs/traffic_spawn.json"),
        support::free_port(),
        "",
    );
    let text = std::fs::read_to_string(&toml).unwrap().replace(
        "# zenoh_config = \"deploy/zenoh/client.json5\"",
        &format!("zenoh_config = \"{}\"", zenoh.display()),
    );
    std::fs::write(&toml, text).unwrap();
    let (code, stderr, ended) = up_for(&["--config".as_ref(), toml.as_os_str()], 20.0);
    assert!(ended, "up kept running: {stderr}");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("cannot run with the configuration given"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("restarting"),
        "a service was restarted: {stderr}"
    );
}

/// `../shared/maps/cross.net.xml`, by its absolute path (`up` runs elsewhere).
fn cross_net() -> Option<PathBuf> {
    support::shared_map("cross.net.xml").map(|p| p.canonicalize().unwrap())
}

/// AWSIM's NPCVehicleConfig is a setting: `sim` takes the four accelerations
/// (the inspector's fields), reports the config in force, and they act.
#[test]
fn sim_takes_the_npc_vehicle_config_and_reports_it() {
    let map = repo_file("configs/maps/four_way.map.json");
    let reference = sim_json(&map, &["--duration", "60"]);
    assert_eq!(
        reference["vehicle_config"]["acceleration"], 3.0,
        "{reference}"
    );
    assert_eq!(
        reference["vehicle_config"]["absoluteDeceleration"], 20.0,
        "{reference}"
    );
    let gentle = sim_json(
        &map,
        &[
            "--duration",
            "60",
            "--acceleration",
            "1.5",
            "--deceleration",
            "1.0",
        ],
    );
    let config = &gentle["vehicle_config"];
    assert_eq!(
        (
            config["acceleration"].as_f64(),
            config["deceleration"].as_f64()
        ),
        (Some(1.5), Some(1.0)),
        "{gentle}"
    );
    assert_eq!(
        config["suddenDeceleration"], 4.0,
        "the others keep the reference's"
    );
    assert_ne!(
        gentle["trajectory_hash"], reference["trajectory_hash"],
        "other accelerations, other trajectories"
    );
}

/// `sim --pedestrians` runs the built-in walkers and cyclists in the headless
/// run: they occupy the zebra crossings, vehicles stop for them with the AWSIM
/// reference's log lines, and the run stays deterministic by seed.
#[test]
fn sim_runs_pedestrians_that_stop_vehicles_at_zebras() {
    let map = repo_file("configs/maps/four_way.map.json");
    let run = |pedestrians: &str| {
        let out = trafficmesh(&[
            "sim",
            "--map",
            map.to_str().unwrap(),
            "--duration",
            "180",
            "--seed",
            "3",
            "--pedestrians",
            pedestrians,
            "--json",
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{stderr}");
        let summary: Value = serde_json::from_slice(&out.stdout).unwrap();
        (summary["trajectory_hash"].clone(), stderr)
    };
    let (hash, log) = run("10");
    assert!(
        log.contains("[Zebra] '") && log.contains("entered 'J0_0_crosswalk_"),
        "walkers enter the crosswalks: {log}"
    );
    assert!(
        log.contains("[NPC Zebra] Vehicle '")
            && log.contains("stopping for zebra 'J0_0_crosswalk_"),
        "a vehicle stops for them: {log}"
    );
    assert_eq!(run("10").0, hash, "the same seed gives the same run");
    let (without, quiet) = run("0");
    assert_ne!(without, hash, "the walkers change the traffic");
    assert!(!quiet.contains("[NPC Zebra]"), "no walkers, no zebra stops");
}
