//! Map import: SUMO networks against SUMO's own reader, imported signal
//! programs obeyed by the simulation, and broken files rejected with the
//! line and element named. Third-party maps are read from ../shared/maps.

#[path = "../../shared/sim/tests/support/mod.rs"]
mod sim_support;
#[path = "../cluster/support.rs"]
#[allow(dead_code)]
mod support;

mod hostile;
mod permitted_turns;

use std::path::{Path, PathBuf};
use std::process::Command;

use support::{repo, shared_map};
use trafficmesh_model::LightColor;
use trafficmesh_sim::crosswalk::OccupantType;
use trafficmesh_sim::geometry::point_in_polygon;
use trafficmesh_sim::{SimEvent, World, WorldConfig};

/// Runs one of the Python checkers beside this file; it must print OK.
fn python_check(python: &str, script: &str, args: &[&Path]) {
    let check = Command::new(python)
        .arg(repo().join("tests/maps").join(script))
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success() && stdout.contains("OK"),
        "{stdout}\n{}",
        String::from_utf8_lossy(&check.stderr)
    );
}

fn import(file: &Path, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .arg("import")
        .arg(file)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// A world on `net` with the default configuration but `seed` and `max_vehicles`.
fn world_of(net: trafficmesh_sim::LaneNetwork, seed: u64, max_vehicles: usize) -> World {
    World::new(
        net,
        WorldConfig {
            seed,
            max_vehicles,
            ..WorldConfig::default()
        },
    )
}

/// No two vehicles of the world overlap now (`what` names the run).
fn assert_no_overlaps(world: &World, what: &str) {
    let pairs = sim_support::overlapping_pairs(world.network(), world.vehicles(), 0.1);
    let net = world.network();
    let describe = |id: u64| {
        let v = world.vehicle(id).unwrap();
        let lanes: Vec<&str> = v.path.iter().map(|&l| net.lane(l).name.as_str()).collect();
        format!(
            "#{id} {:?}/{:?} on {lanes:?} s={:.1} v={:.1} ({:.1}, {:.1})",
            v.yield_phase, v.speed_mode, v.s, v.speed, v.pose.x, v.pose.y
        )
    };
    assert!(
        pairs.is_empty(),
        "{what}: overlapping vehicles at t={:.2}: {}",
        world.time(),
        pairs
            .iter()
            .map(|&(a, b)| format!("{} / {}", describe(a), describe(b)))
            .collect::<Vec<_>>()
            .join("; ")
    );
}

/// Imports `file` to `out`, which must fail with exit code 2; the message.
fn rejected(file: &Path, out: &Path) -> String {
    let bad = import(file, out);
    let err = String::from_utf8_lossy(&bad.stderr).into_owned();
    assert_eq!(bad.status.code(), Some(2), "{err}");
    err
}

/// Imports `file` to `out`, which must succeed; the printed summary.
fn import_summary(file: &Path, out: &Path) -> String {
    let imported = import(file, out);
    assert!(
        imported.status.success(),
        "{}",
        String::from_utf8_lossy(&imported.stderr)
    );
    String::from_utf8_lossy(&imported.stdout).into_owned()
}

#[test]
fn cross_net_imports_as_sumolib_reads_it() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let Some(python) = trafficmesh_testkit::python_with("sumolib", "sumolib==1.28.0") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cross.map.json");
    let summary = import_summary(&net, &out);
    assert!(summary.contains("4 light groups"), "{summary}");
    assert!(
        summary.contains("U-turn"),
        "the dropped U-turns are reported: {summary}"
    );
    python_check(&python, "check_sumo_import.py", &[&net, &out]);
}

/// The committed 3 x 3 grid with sidewalks and crossings (netgenerate; the
/// command is in configs/sumo/make_scenarios.sh).
fn grid_with_crossings() -> PathBuf {
    repo().join("configs/sumo/grid3_crossings.net.xml")
}

#[test]
fn grid_with_crossings_imports_as_sumolib_reads_it() {
    let Some(python) = trafficmesh_testkit::python_with("sumolib", "sumolib==1.28.0") else {
        return;
    };
    let net = grid_with_crossings();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("grid3.map.json");
    let summary = import_summary(&net, &out);
    assert!(summary.contains("20 crosswalks"), "{summary}");
    assert!(
        summary.contains("sidewalks") && summary.contains("walking area"),
        "what is left out is said: {summary}"
    );
    python_check(&python, "check_sumo_import.py", &[&net, &out]);
}

/// A pedestrian on every crossing of the grid: no vehicle's front enters one
/// and vehicles stop for them; once they have left, traffic crosses again.
#[test]
fn pedestrians_on_imported_crossings_stop_traffic_until_they_leave() {
    let net = trafficmesh_service::load_network(&grid_with_crossings()).unwrap();
    let areas: Vec<(String, Vec<glam::DVec2>)> = net
        .crosswalks
        .iter()
        .map(|c| (c.name.clone(), c.polygon.clone()))
        .collect();
    assert_eq!(areas.len(), 20);
    let mut world = world_of(net, 11, 60);
    let pedestrian = |area: &str| format!("NPCPedestrian_{area}");
    for (name, _) in &areas {
        world
            .crosswalk_enter(name, &pedestrian(name), OccupantType::NpcPedestrian)
            .unwrap();
    }
    let mut stops = 0;
    while world.time() < 120.0 {
        world.step();
        for v in world.vehicles() {
            for (name, polygon) in &areas {
                assert!(
                    !point_in_polygon(v.front, polygon),
                    "vehicle {} drove into occupied crossing {name} at t={:.2}",
                    v.id,
                    world.time()
                );
            }
        }
        stops += world
            .drain_events()
            .filter(|e| matches!(e, SimEvent::ZebraStop { .. }))
            .count();
    }
    assert!(stops >= 10, "vehicles stop for the pedestrians: {stops}");
    for (name, _) in &areas {
        world.crosswalk_exit(name, &pedestrian(name)).unwrap();
    }
    let mut crossed = std::collections::HashSet::new();
    while world.time() < 240.0 {
        world.step();
        for v in world.vehicles() {
            if areas
                .iter()
                .any(|(_, polygon)| point_in_polygon(v.front, polygon))
            {
                crossed.insert(v.id);
            }
        }
    }
    assert!(
        crossed.len() >= 10,
        "traffic crosses once they have left: {} vehicles",
        crossed.len()
    );
}

/// Runs the world for `seconds`; every vehicle that comes onto a signalised
/// lane must do so on green or yellow, or in the first second of red (one that
/// committed on yellow, as the AWSIM reference's yellow rule says, may reach the line just
/// after the change). Returns how many vehicles entered each signalised lane.
fn entries_past_signals(
    world: &mut World,
    seconds: f64,
) -> std::collections::HashMap<trafficmesh_sim::LaneId, usize> {
    let signalised: Vec<(trafficmesh_sim::LaneId, usize)> = (0..world.network().lanes.len())
        .filter_map(|l| {
            let lane = l as trafficmesh_sim::LaneId;
            Some((lane, world.network().lane(lane).light()? as usize))
        })
        .collect();
    let group_of: std::collections::HashMap<_, _> = signalised.iter().copied().collect();
    let mut entered: std::collections::HashMap<trafficmesh_sim::LaneId, usize> =
        signalised.iter().map(|&(l, _)| (l, 0)).collect();
    let mut on: std::collections::HashMap<u64, trafficmesh_sim::LaneId> = Default::default();
    let mut red_since = vec![f64::NEG_INFINITY; world.lights().len()];
    let end = world.time() + seconds;
    while world.time() < end {
        // The colours the vehicles see during the coming tick.
        let colors: Vec<LightColor> = (0..world.lights().len())
            .map(|g| world.lights().state(g).color)
            .collect();
        for (g, c) in colors.iter().enumerate() {
            if *c != LightColor::Red {
                red_since[g] = f64::INFINITY;
            } else if red_since[g] == f64::INFINITY {
                red_since[g] = world.time();
            }
        }
        world.step();
        for v in world.vehicles() {
            let lane = v.path[0];
            let Some(&group) = group_of.get(&lane) else {
                continue;
            };
            if on.insert(v.id, lane) != Some(lane) {
                *entered.get_mut(&lane).unwrap() += 1;
                let red_for = world.time() - red_since[group];
                assert!(
                    colors[group] != LightColor::Red || red_for <= 1.0,
                    "vehicle {} entered {} {red_for:.2} s into red at t={:.2}",
                    v.id,
                    world.network().lane(lane).name,
                    world.time()
                );
            }
        }
    }
    entered
}

/// Vehicles enter the signalised junction of cross.net.xml only on green or
/// yellow of the imported program, and every signal link lets some through.
#[test]
fn vehicles_on_cross_net_obey_the_imported_signal_program() {
    let Some(path) = shared_map("cross.net.xml") else {
        return;
    };
    let net = trafficmesh_service::load_network(&path).unwrap();
    let junction_lanes: Vec<trafficmesh_sim::LaneId> = (0..4)
        .map(|k| net.lane_id(&format!(":junction_{k}_0")).unwrap())
        .collect();
    let mut world = world_of(net, 3, 80);
    let entered = entries_past_signals(&mut world, 600.0);
    let counts: Vec<usize> = junction_lanes.iter().map(|l| entered[l]).collect();
    assert!(
        counts.iter().all(|&n| n >= 5),
        "every approach gets green: {counts:?}"
    );
}

/// Routed vehicles of a SUMO demand pass the grid's nine signalised junctions
/// only on green or yellow of the imported programs.
#[test]
fn routed_vehicles_on_the_grid_obey_the_imported_signal_programs() {
    let (net, _) =
        trafficmesh_service::load_network_with_routes(&grid_with_crossings(), Some(&grid_demand()))
            .unwrap();
    let mut world = world_of(net, 4, 100_000);
    let entered = entries_past_signals(&mut world, 900.0);
    let used = entered.values().filter(|&&n| n > 0).count();
    assert!(
        used * 2 >= entered.len(),
        "most signal links let vehicles through: {used} of {}",
        entered.len()
    );
}

#[test]
fn broken_sumo_files_are_rejected_naming_line_and_element() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.map.json");

    let err = rejected(&repo().join("tests/maps/bad_lane.net.xml"), &out);
    assert!(
        err.contains("line 9") && err.contains("<lane id='b_0'>") && err.contains("'shape'"),
        "{err}"
    );

    let garbage = dir.path().join("garbage.net.xml");
    std::fs::write(
        &garbage,
        "<net><edge id='a'>\n<lane id='a_0' shape='0,0 1,1'></edge></net>",
    )
    .unwrap();
    let err = rejected(&garbage, &out);
    assert!(
        err.contains("line 2") && err.contains("not well-formed XML"),
        "{err}"
    );

    if let Some(net) = shared_map("cross.net.xml") {
        let text = std::fs::read_to_string(net).unwrap();
        let truncated = dir.path().join("truncated.net.xml");
        std::fs::write(&truncated, &text[..text.len() / 2]).unwrap();
        let err = rejected(&truncated, &out);
        assert!(
            err.contains("truncated.net.xml") && err.contains("line "),
            "{err}"
        );
    }
    assert!(!out.exists(), "nothing is written for a broken file");
}

fn check_lanelet2(file: &str, ten_minutes_without_overlaps: bool) {
    let Some(osm) = shared_map(file) else { return };
    let Some(python) = trafficmesh_testkit::python_with("xml", "(the standard library)") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("map.json");
    let summary = import_summary(&osm, &out);
    // Deterministic: a second import writes the same bytes.
    let again = dir.path().join("again.json");
    import_summary(&osm, &again);
    assert!(
        std::fs::read(&out).unwrap() == std::fs::read(&again).unwrap(),
        "{file}: two imports differ"
    );
    assert!(
        summary.contains("synthesised two-phase program"),
        "the synthesised timing is said: {summary}"
    );
    python_check(&python, "check_lanelet2_import.py", &[&osm, &out]);

    if !ten_minutes_without_overlaps {
        return;
    }
    // Ten simulated minutes without two vehicles overlapping, for several seeds.
    for seed in 1..=5 {
        let net = trafficmesh_service::load_network(&osm).unwrap();
        let mut world = world_of(net, seed, 40);
        let what = format!("{file}, seed {seed}");
        let mut spawned = 0;
        while world.time() < 600.0 {
            world.step();
            spawned = spawned.max(world.vehicles().iter().map(|v| v.id + 1).max().unwrap_or(0));
            if world.ticks().is_multiple_of(5) {
                assert_no_overlaps(&world, &what);
            }
        }
        assert!(
            spawned >= 40,
            "{what}: traffic flows ({spawned} vehicles in 10 minutes)"
        );
    }
}

#[test]
fn autoware_lanelet2_map_imports_and_runs_ten_minutes_without_overlaps() {
    check_lanelet2("autoware_intersection_lanelet2_map.osm", true);
}

/// Lanelets here cross, split, join, fold back in hairpins and run closer
/// than two trucks side by side, mostly outside anything tagged a junction:
/// the conflicts outside junctions keep the vehicles apart.
#[test]
fn lanelet2_mapping_example_imports_and_runs_ten_minutes_without_overlaps() {
    check_lanelet2("mapping_example.osm", true);
}

#[test]
fn broken_lanelet2_files_are_rejected_naming_line_and_element() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.map.json");
    let err = rejected(&repo().join("tests/maps/missing_way.osm"), &out);
    assert!(
        err.contains("line 12") && err.contains("<relation id='10'>") && err.contains("way 99"),
        "{err}"
    );
    if let Some(osm) = shared_map("mapping_example.osm") {
        let text = std::fs::read_to_string(osm).unwrap();
        let truncated = dir.path().join("truncated.osm");
        std::fs::write(&truncated, &text[..text.len() / 3]).unwrap();
        let err = rejected(&truncated, &out);
        assert!(
            err.contains("truncated.osm") && err.contains("not well-formed XML"),
            "{err}"
        );
    }
    assert!(!out.exists());
}

/// A SUMO demand runs as written: every vehicle departs, follows its route
/// through the signalised junction and leaves the map at the route's end.
#[test]
fn a_sumo_route_file_runs_its_vehicles_along_their_routes_and_out() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .args(["sim", "--map"])
        .arg(&net)
        .arg("--routes")
        .arg(repo().join("tests/maps/cross.rou.xml"))
        .args(["--duration", "300", "--json", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("1 trip(s) without a route left out"),
        "{stderr}"
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["spawned"], 11, "{summary}");
    assert_eq!(
        summary["despawned"], 11,
        "every vehicle left at its route's end: {summary}"
    );
    assert_eq!(
        summary["branch_decisions"], 0,
        "nobody chose a branch: {summary}"
    );
    let trips = std::fs::read_to_string(dir.path().join("trips.csv")).unwrap();
    let truck = trips.lines().filter(|l| l.contains(",truck,")).count();
    assert_eq!(truck, 1, "the vType 'truck' is a kind of its own:\n{trips}");
    let car = trips.lines().filter(|l| l.contains(",car,")).count();
    assert_eq!(car, 10, "the flow's vType 'car':\n{trips}");
    assert_eq!(
        trips.lines().filter(|l| l.contains(",route_end,")).count(),
        11,
        "{trips}"
    );
}

/// Values no real file holds, found by the hostile-input tests: each a
/// clear error naming the file and what is wrong, at once, where they made
/// `sim` run out of memory or build for hours. A vehicle or route id given
/// twice is refused too, as SUMO refuses it.
#[test]
fn absurd_values_in_a_route_file_or_a_map_are_refused_at_once() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let routes = std::fs::read_to_string(repo().join("tests/maps/cross.rou.xml")).unwrap();
    let sim = |map: &Path, routes: Option<&Path>| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_trafficmesh"));
        command.args(["sim", "--duration", "5", "--map"]).arg(map);
        if let Some(routes) = routes {
            command.arg("--routes").arg(routes);
        }
        let out = command.output().unwrap();
        assert!(!out.status.success(), "accepted");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    for (from, to, needle) in [
        (
            r#"begin="0""#,
            r#"begin="-1e308""#,
            "attribute 'begin': -1e308 is negative",
        ),
        (
            r#"end="60""#,
            r#"end="1e300""#,
            "more than the 10000000 vehicles a flow may have (begin 0, end 1e300)",
        ),
        (
            r#"length="4.5""#,
            r#"length="1e20""#,
            "vType 'car': length 100000000000000000000 m",
        ),
        (
            r#"<vType id="car""#,
            r#"<vType id="car" accel="1e300""#,
            "accel must be a positive number up to 50",
        ),
        (
            r#"<flow id="stream""#,
            r#"<vehicle id="first" type="car" depart="1" route="west_east"/><flow id="stream""#,
            "another vehicle with the id 'first' exists",
        ),
        (
            r#"<vehicle id="first""#,
            r#"<route id="west_east" edges="51o 1i"/><vehicle id="first""#,
            "another route with the id 'west_east' exists",
        ),
    ] {
        let file = dir.path().join("absurd.rou.xml");
        std::fs::write(&file, routes.replacen(from, to, 1)).unwrap();
        let err = sim(&net, Some(&file));
        assert!(
            err.contains("absurd.rou.xml") && err.contains(needle),
            "{to}: {err}"
        );
    }
    // A lanelet's point put 9,000 km away (a coordinate with digits too many).
    if let Some(osm) = shared_map("autoware_intersection_lanelet2_map.osm") {
        let text = std::fs::read_to_string(osm).unwrap();
        let node = text.find("<node id=\"3006260\"").unwrap();
        let x = node + text[node..].find("<tag k=\"local_x\" v=\"").unwrap() + 20;
        let file = dir.path().join("far.osm");
        std::fs::write(&file, format!("{}9000{}", &text[..x], &text[x..])).unwrap();
        let err = sim(&file, None);
        assert!(
            err.contains("far.osm") && err.contains("a point far out of place?"),
            "{err}"
        );
    }
}

/// Bologna's network copied into a temporary directory, where `run_flows`
/// writes its route file beside it. None (skipped) without the shared maps.
fn acosta_copy() -> Option<(tempfile::TempDir, PathBuf)> {
    let acosta = shared_map("bologna_acosta/acosta_buslanes.net.xml")?;
    let dir = tempfile::tempdir().unwrap();
    let net = dir.path().join("acosta.net.xml");
    std::fs::copy(&acosta, &net).unwrap();
    Some((dir, net))
}

/// A route file none of whose vehicles can drive its route (cars on
/// Bologna's bus lane) is refused with why: the vehicles left out and the
/// reason, said once.
#[test]
fn a_route_file_with_no_usable_route_says_why() {
    let Some(net) = shared_map("bologna_acosta/acosta_buslanes.net.xml") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let routes = dir.path().join("cars_on_the_bus_lane.rou.xml");
    std::fs::write(
        &routes,
        "<routes>\n  <vType id=\"car\"/>\n  <flow id=\"cars_on_77\" type=\"car\" begin=\"0\" end=\"60\" vehsPerHour=\"600\"><route edges=\"77[0] 53[1][0]\"/></flow>\n</routes>\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .args(["sim", "--duration", "5", "--map"])
        .arg(&net)
        .arg("--routes")
        .arg(&routes)
        .output()
        .unwrap();
    assert!(!out.status.success(), "accepted");
    let err = String::from_utf8_lossy(&out.stderr);
    let error = err
        .lines()
        .skip_while(|l| !l.starts_with("error:"))
        .collect::<Vec<_>>()
        .join("\n");
    for needle in [
        "cars_on_the_bus_lane.rou.xml",
        "no vehicle or flow with a usable route",
        "on lanes open to their vehicle class",
        "cars_on_77",
    ] {
        assert!(error.contains(needle), "{needle}: {error}");
    }
    assert_eq!(error.matches("usable route").count(), 1, "{error}");
}

/// The same demand in the cluster: the spawner takes the route file, and the
/// vehicles drive their routes and leave without choosing a branch.
#[test]
fn a_sumo_route_file_drives_the_cluster_spawner() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let routes = repo().join("tests/maps/cross.rou.xml");
    let cluster = support::Cluster::start_on_with_admin(
        "routes",
        &net,
        &format!("routes = \"{}\"", routes.display()),
        false,
    );
    let base = cluster.admin.clone().unwrap();
    let spawner = || -> serde_json::Value {
        let mut r = ureq::get(format!("{base}/api/v1/status")).call().unwrap();
        let s: serde_json::Value = r.body_mut().read_json().unwrap();
        s["services"]["spawner"]["details"].clone()
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while spawner()["spawned"].as_u64().unwrap_or(0) < 11 {
        assert!(
            std::time::Instant::now() < deadline,
            "the demand's 11 vehicles did not all spawn: {}",
            spawner()
        );
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
    let details = spawner();
    assert_eq!(details["spawned"], 11, "no more than the demand: {details}");
    assert_eq!(
        details["branch_decisions"], 0,
        "route vehicles choose no branch: {details}"
    );
}

/// randomTrips on the grid: a departure every 2 s for 600 s (300 vehicles), and
/// every 1.5 s (400, near what the grid carries: SUMO's vehicles wait a quarter
/// of their trip).
fn grid_demand() -> PathBuf {
    repo().join("configs/sumo/grid3_crossings.rou.xml")
}

fn saturated_grid_demand() -> PathBuf {
    repo().join("configs/sumo/grid3_crossings_saturated.rou.xml")
}

/// The 400 routed vehicles of a SUMO demand near the grid's capacity all reach
/// their route's end, and no two ever overlap: junctions whose turns SUMO splits
/// (a left turn waiting inside the junction) neither lock up nor let vehicles
/// through each other, and the lane changes routes need (112 of them) find gaps
/// or swap.
#[test]
fn a_sumo_demand_on_a_signalised_grid_runs_to_its_end_without_gridlock() {
    let (net, _) = trafficmesh_service::load_network_with_routes(
        &grid_with_crossings(),
        Some(&saturated_grid_demand()),
    )
    .unwrap();
    let mut world = world_of(net, 2, 100_000);
    let mut finished = 0;
    while world.time() < 1200.0 {
        world.step();
        finished += world
            .drain_events()
            .filter(|e| {
                matches!(e, SimEvent::Despawned(t) if t.reason == trafficmesh_sim::DespawnReason::RouteEnd)
            })
            .count();
        if world.ticks().is_multiple_of(5) {
            assert_no_overlaps(&world, "grid demand");
        }
    }
    assert_eq!(
        finished,
        400,
        "every vehicle finishes its route; {} still on the map",
        world.vehicles().len()
    );
}

/// `bench vs-sumo` runs SUMO itself (eclipse-sumo from PyPI) and trafficmesh
/// on the same grid and demand: both complete every trip, and trafficmesh's
/// mean travel and waiting times are within a quarter of SUMO's. (Nearer the
/// grid's capacity they part: the reference's car following keeps 8.5 m at
/// standstill and restarts slowly, so its junctions pass fewer vehicles than
/// SUMO's; docs/performance.md gives the figures.)
#[test]
fn trip_statistics_on_a_sumo_demand_are_in_sumos_range() {
    let (net, routes) = (grid_with_crossings(), grid_demand());
    let args = [
        "--duration".as_ref(),
        "1200".as_ref(),
        "--net".as_ref(),
        net.as_os_str(),
        "--routes".as_ref(),
        routes.as_os_str(),
    ];
    let Some(report) = vs_sumo(&args) else {
        return;
    };
    let (theirs, ours) = (&report["sumo"], &report["trafficmesh"]);
    assert_eq!(theirs["trips_completed"], 300, "{report}");
    assert_eq!(ours["trips_completed"], 300, "{report}");
    for figure in ["mean_travel_time_s", "mean_waiting_time_s"] {
        let ratio = ours[figure].as_f64().unwrap() / theirs[figure].as_f64().unwrap();
        assert!(
            (0.8..=1.25).contains(&ratio),
            "{figure}: trafficmesh / SUMO = {ratio:.2}: {report}"
        );
    }
    assert!(report["speedup"].as_f64().unwrap() > 1.0, "{report}");
}

/// The first 15 simulated minutes of Bologna's Acosta district as its authors
/// ship it, against SUMO's own run of the same window: as many vehicles
/// inserted and arrived, trips as long and as much waiting, within a few per
/// cent, and no jam resolution.
#[test]
fn acostas_first_fifteen_minutes_match_sumos() {
    let Some(cfg) = shared_map("bologna_acosta/run.sumocfg") else {
        return;
    };
    let args = [
        "--sumocfg".as_ref(),
        cfg.as_os_str(),
        "--duration".as_ref(),
        "900".as_ref(),
    ];
    let Some(report) = vs_sumo(&args) else {
        return;
    };
    let (theirs, ours) = (&report["sumo"], &report["trafficmesh"]);
    let ratio = |figure: &str| ours[figure].as_f64().unwrap() / theirs[figure].as_f64().unwrap();
    for (figure, range) in [
        ("inserted", 0.95..=1.05),
        ("trips_completed", 0.85..=1.15),
        ("mean_travel_time_s", 0.85..=1.15),
        ("mean_waiting_time_s", 0.8..=1.2),
    ] {
        let r = ratio(figure);
        assert!(
            range.contains(&r),
            "{figure}: trafficmesh / SUMO = {r:.2}: {report}"
        );
    }
    assert_eq!(ours["jam_resolutions"], 0, "{report}");
}

/// Acosta's demand as lane routes: a route takes a lane change only where no
/// route through the same edges does without one, and never on a lane too
/// short to wait on for a gap (netconvert's 0.2 m pieces; one there locked
/// the district's 204 corridor for good).
#[test]
fn acosta_lane_routes_change_lanes_only_where_needed_and_where_there_is_room() {
    let Some(dir) = shared_map("bologna_acosta") else {
        return;
    };
    let imported = trafficmesh_maps::import_map(&dir.join("acosta_buslanes.net.xml")).unwrap();
    let map = imported.map;
    let demand = trafficmesh_maps::load_routes(&dir.join("acosta.rou.xml"), &map).unwrap();
    let trafficmesh_model::SimulatorDef::Demand { departures } = demand.simulator else {
        panic!("a route file is a demand");
    };
    let lane = |name: &str| map.lanes.iter().find(|l| l.name == name).unwrap();
    let mut changes = 0;
    for d in &departures {
        for pair in d.route.windows(2) {
            let from = lane(&pair[0]);
            if from.next.contains(&pair[1]) {
                continue;
            }
            changes += 1;
            assert!(
                from.length() >= 10.0,
                "a lane change on {} ({:.2} m) in route {:?}",
                from.name,
                from.length(),
                d.route
            );
        }
    }
    // The corridor that locked: 204a[0] to 204[1][0] goes through on one lane.
    let corridor = departures
        .iter()
        .find(|d| d.route.iter().any(|l| l.starts_with("204b[0]_")))
        .expect("a route through 204b[0]");
    let at = corridor
        .route
        .iter()
        .position(|l| l.starts_with("204b[0]_"))
        .unwrap();
    assert!(
        lane(&corridor.route[at])
            .next
            .contains(&corridor.route[at + 1]),
        "a lane change on the 0.2 m lane: {:?}",
        corridor.route
    );
    assert!(changes > 0, "the demand has routes that need a lane change");
}

/// A SUMO scenario as shipped, on cross.net.xml: the additional file's
/// tlLogic replaces the network's (red for the first 100 s), its
/// vTypeDistribution is drawn from per vehicle with the run's seed, what is
/// not simulated is named, and the configuration's end ends the run.
#[test]
fn a_sumocfg_runs_its_net_routes_programs_and_vehicle_types() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_cross_scenario(dir.path(), &net);
    let run = |seed: &str| {
        let out_dir = dir.path().join(format!("out{seed}"));
        let out = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
            .args(["sim", "--sumocfg"])
            .arg(&cfg)
            .args(["--seed", seed, "--json", "--out"])
            .arg(&out_dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{stderr}");
        let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let trips = std::fs::read_to_string(out_dir.join("trips.csv")).unwrap();
        (summary, trips, stderr)
    };
    let (summary, trips, stderr) = run("1");
    assert!(
        stderr.contains("1 tlLogic program(s) from the additional files replace the network's"),
        "{stderr}"
    );
    assert!(
        stderr.contains("read but not simulated: 1 e1Detector"),
        "{stderr}"
    );
    assert_eq!(summary["driver_model"], "realistic", "{summary}");
    assert!(
        (summary["simulated_seconds"].as_f64().unwrap() - 300.0).abs() < 0.1,
        "the configuration's end: {summary}"
    );
    assert_eq!(summary["inserted"], 10, "{summary}");
    assert_eq!(summary["arrived"], 10, "{summary}");
    let rows: Vec<&str> = trips.lines().skip(1).collect();
    let first: Vec<&str> = rows
        .iter()
        .find(|r| r.starts_with("0,"))
        .unwrap()
        .split(',')
        .collect();
    let arrival: f64 = first[3].parse().unwrap();
    assert!(
        arrival > 130.0,
        "the replacement program holds the first car at red for 100 s: it arrived at {arrival}"
    );
    let kinds = |trips: &str| -> Vec<String> {
        trips
            .lines()
            .skip(1)
            .map(|r| r.split(',').nth(1).unwrap().to_string())
            .collect()
    };
    let drawn = kinds(&trips);
    assert!(
        drawn.iter().all(|k| k == "short" || k == "long"),
        "{drawn:?}"
    );
    assert!(
        drawn.iter().any(|k| k == "short") && drawn.iter().any(|k| k == "long"),
        "both members drawn: {drawn:?}"
    );
    let (_, again, _) = run("1");
    assert_eq!(kinds(&again), drawn, "the same seed draws the same types");
    let others: Vec<Vec<String>> = ["2", "3"].iter().map(|s| kinds(&run(s).1)).collect();
    assert!(
        others.iter().any(|o| *o != drawn),
        "another seed draws other types"
    );

    // SUMO runs the same configuration the same way: the replacement program
    // holds its first car too, and both sides count the same trips.
    let Some(report) = vs_sumo(&["--sumocfg".as_ref(), cfg.as_os_str()]) else {
        return;
    };
    assert!(
        !dir.path().join("out.xml").exists(),
        "the benchmark wrote the scenario's detector output into the scenario's folder"
    );
    for side in ["sumo", "trafficmesh"] {
        let f = &report[side];
        assert_eq!(f["inserted"], 10, "{side}: {report}");
        assert_eq!(f["trips_completed"], 10, "{side}: {report}");
        assert_eq!(f["jam_resolutions"], 0, "{side}: {report}");
        assert!(
            f["last_arrival_s"].as_f64().unwrap() > 130.0,
            "{side} ran the replacement program: {report}"
        );
    }
}

/// A small SUMO scenario on cross.net.xml in `dir`: a flow of ten from west
/// to east (vTypeDistribution `mix` of `short` and `long`), an additional
/// file whose tlLogic keeps the junction red for the first 100 s and which
/// holds a detector, begin 0 and end 300. Returns the `.sumocfg`.
fn write_cross_scenario(dir: &Path, net: &Path) -> PathBuf {
    std::fs::write(
        dir.join("types.add.xml"),
        r#"<additional>
    <vTypeDistribution id="mix">
        <vType id="short" length="4" accel="2.6" decel="4.5" probability="0.5"/>
        <vType id="long" length="9" width="2.5" accel="1.5" decel="4" probability="0.5"/>
    </vTypeDistribution>
    <tlLogic id="junction" type="static" programID="late" offset="0">
        <phase duration="100" state="rrrr"/>
        <phase duration="60" state="GGGG"/>
        <phase duration="4" state="yyyy"/>
    </tlLogic>
    <e1Detector id="d" lane="1i_0" pos="10" freq="60" file="out.xml"/>
</additional>"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("demand.rou.xml"),
        r#"<routes>
    <route id="west_east" edges="51o 1i 2o 52i"/>
    <flow id="stream" type="mix" begin="0" end="60" vehsPerHour="600" route="west_east"/>
</routes>"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("run.sumocfg"),
        format!(
            r#"<configuration>
    <input>
        <net-file value="{}"/>
        <route-files value="demand.rou.xml"/>
        <additional-files value="types.add.xml"/>
    </input>
    <time><begin value="0"/><end value="300"/></time>
</configuration>"#,
            net.display()
        ),
    )
    .unwrap();
    dir.join("run.sumocfg")
}

/// The cluster runs a SUMO scenario: every service loads it (the lights
/// service runs the additional file's program, red for 100 s where the
/// network's own turns green at 37 s) and the spawner its demand.
#[test]
fn a_sumocfg_drives_the_cluster() {
    let Some(net) = shared_map("cross.net.xml") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_cross_scenario(dir.path(), &net);
    let cluster = support::Cluster::start_on_with_admin("sumocfg", &cfg, "", false);
    let base = cluster.admin.clone().unwrap();
    let get = |path: &str| -> serde_json::Value {
        let mut r = ureq::get(format!("{base}{path}")).call().unwrap();
        r.body_mut().read_json().unwrap()
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(70);
    // The stepper's status comes once a second: wait for both to count ten.
    let counted = || {
        let s = get("/api/v1/status");
        let spawned = s["services"]["spawner"]["details"]["spawned"].as_u64();
        let inserted = s["services"]["stepper"]["details"]["inserted"].as_u64();
        spawned.unwrap_or(0).min(inserted.unwrap_or(0))
    };
    while counted() < 10 {
        assert!(
            std::time::Instant::now() < deadline,
            "the scenario's 10 vehicles did not all spawn and enter: {}",
            get("/api/v1/status")
        );
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
    let status = get("/api/v1/status");
    let stepper = &status["services"]["stepper"]["details"];
    assert!(stepper["time"].as_f64().unwrap() < 95.0, "{status}");
    assert_eq!(stepper["inserted"], 10, "{status}");
    let spawner = &status["services"]["spawner"]["details"];
    assert_eq!(
        spawner["max_vehicles"], 1_000_000,
        "a timetable has no vehicle cap unless one is given: {status}"
    );
    assert_eq!(spawner["insertion_backlog"], 0, "all ten are in: {status}");
    let lights = get("/api/v1/lights");
    let west_east = lights
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["group"] == "junction_3")
        .unwrap_or_else(|| panic!("no group junction_3: {lights}"));
    assert_eq!(west_east["color"], "red", "{west_east}");
    let next = west_east["next_change"].as_f64().unwrap();
    assert!(
        (next - 100.0).abs() < 0.5,
        "the replacement program turns green at 100 s, not {next}"
    );
}

/// `trafficmesh bench vs-sumo --json` with these arguments and the SUMO of
/// the virtualenv: its report; None (skipped) where SUMO is not installed.
fn vs_sumo(args: &[&std::ffi::OsStr]) -> Option<serde_json::Value> {
    let python = trafficmesh_testkit::python_with("sumo", "eclipse-sumo==1.28.0")?;
    let out = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
        .args(["bench", "vs-sumo", "--json", "--sumo"])
        .arg(Path::new(&python).with_file_name("sumo"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

/// netconvert's node lines: every node `(id, x, y)` of `node_type`.
fn nodes_xml(nodes: &[(&str, i32, i32)], node_type: &str) -> String {
    nodes
        .iter()
        .map(|(id, x, y)| {
            format!("  <node id=\"{id}\" x=\"{x}\" y=\"{y}\" type=\"{node_type}\"/>\n")
        })
        .collect()
}

/// netconvert's edge lines: each road `(a, b, priority)` one lane each way,
/// edges `ab` and `ba`, at 13.89 m/s.
fn two_way_edges_xml(roads: &[(&str, &str, u32)]) -> String {
    let mut edges = String::new();
    for &(a, b, priority) in roads {
        for (from, to) in [(a, b), (b, a)] {
            edges += &format!(
                "  <edge id=\"{from}{to}\" from=\"{from}\" to=\"{to}\" numLanes=\"1\" speed=\"13.89\" priority=\"{priority}\"/>\n"
            );
        }
    }
    edges
}

/// A four-arm junction made by SUMO's netconvert: node `C` of `node_type`
/// with 300 m arms `N`, `S`, `E`, `W`, one lane each way, edges `XC` in and
/// `CX` out; the W-E road has priority where the type uses it. None (skipped)
/// where SUMO is not installed.
fn netconvert_cross(dir: &Path, node_type: &str) -> Option<PathBuf> {
    let nodes = nodes_xml(
        &[
            ("C", 0, 0),
            ("N", 0, 300),
            ("S", 0, -300),
            ("E", 300, 0),
            ("W", -300, 0),
        ],
        node_type,
    );
    let edges = two_way_edges_xml(&[("N", "C", 1), ("S", "C", 1), ("E", "C", 2), ("W", "C", 2)]);
    netconvert(dir, node_type, &nodes, &edges, &[])
}

/// Flows (id, edges, vehicles an hour) on `netconvert_cross`'s junction:
/// from every arm straight on, left and right, `per_hour` each.
fn every_movement_of_the_cross(per_hour: u32) -> Vec<(String, String, u32)> {
    // (arm, straight, left, right) for traffic driving on the right.
    let arms = [
        ("W", "CE", "CN", "CS"),
        ("E", "CW", "CS", "CN"),
        ("N", "CS", "CE", "CW"),
        ("S", "CN", "CW", "CE"),
    ];
    let mut flows = Vec::new();
    for (arm, straight, left, right) in arms {
        for (movement, out) in [("s", straight), ("l", left), ("r", right)] {
            flows.push((
                format!("{arm}{movement}"),
                format!("{arm}C {out}"),
                per_hour,
            ));
        }
    }
    flows
}

/// Runs `flows` (id, edges, vehicles an hour, from 0 to 600 s) on `net` with
/// the realistic model until every vehicle has left, checking for overlaps
/// on the way: (inserted, arrived, the world at the end).
fn run_flows(net: &Path, flows: &[(String, String, u32)], what: &str) -> (u32, u32, World) {
    let run = run_flows_by_lane(net, flows, what);
    (run.0, run.1, run.2)
}

/// Writes `flows` (id, edges, vehicles an hour, from 0 to 600 s) as a SUMO
/// route file beside `net`; returns its path.
fn write_flows(net: &Path, flows: &[(String, String, u32)]) -> PathBuf {
    // Flows whose id begins with "truck" run the random simulator's trucks,
    // 3.1 m wide: on 3.2 m lanes their bodies cut the inside of turns. Those
    // beginning with "bus" run SUMO's buses.
    let mut routes = String::from(
        "<routes>\n  <vType id=\"car\" length=\"4.5\"/>\n  <vType id=\"truck\" length=\"9.2\" width=\"3.1\" vClass=\"truck\"/>\n  <vType id=\"bus\" vClass=\"bus\"/>\n",
    );
    for (id, edges, per_hour) in flows {
        let kind = ["truck", "bus"]
            .into_iter()
            .find(|kind| id.starts_with(kind))
            .unwrap_or("car");
        routes += &format!(
            "  <flow id=\"{id}\" type=\"{kind}\" begin=\"0\" end=\"600\" vehsPerHour=\"{per_hour}\"><route edges=\"{edges}\"/></flow>\n"
        );
    }
    routes += "</routes>\n";
    let rou = net.with_extension("rou.xml");
    std::fs::write(&rou, routes).unwrap();
    rou
}

/// As `run_flows`, with the number of vehicles inserted on each lane.
fn run_flows_by_lane(
    net: &Path,
    flows: &[(String, String, u32)],
    what: &str,
) -> (u32, u32, World, std::collections::BTreeMap<String, u32>) {
    let rou = write_flows(net, flows);
    let (net, _) = trafficmesh_service::load_network_with_routes(net, Some(&rou)).unwrap();
    let mut w = World::new(
        net,
        WorldConfig {
            max_vehicles: usize::MAX,
            vehicle: trafficmesh_model::NpcVehicleConfig {
                driver_model: trafficmesh_model::DriverModel::by_name("realistic").unwrap(),
                ..Default::default()
            },
            ..WorldConfig::default()
        },
    );
    let (mut inserted, mut arrived) = (0, 0);
    let mut by_lane = std::collections::BTreeMap::new();
    while w.time() < 3600.0 && !(w.time() > 1.0 && w.demand_done()) {
        w.step();
        let events: Vec<SimEvent> = w.drain_events().collect();
        for e in events {
            match e {
                SimEvent::Spawned { lane, .. } => {
                    inserted += 1;
                    *by_lane
                        .entry(w.network().lane(lane).name.clone())
                        .or_insert(0) += 1;
                }
                SimEvent::Despawned(t) => {
                    assert_eq!(t.reason, trafficmesh_sim::DespawnReason::RouteEnd, "{t:?}");
                    arrived += 1;
                }
                _ => {}
            }
        }
        if w.ticks().is_multiple_of(5) {
            assert_no_overlaps(&w, what);
        }
    }
    (inserted, arrived, w, by_lane)
}

/// A right-before-left junction with all four arms queued: 300 vehicles an
/// hour per arm, a third each straight, left and right, for ten minutes.
/// Every vehicle gets through, none overlaps another and none needs the jam
/// timeout.
#[test]
fn a_right_before_left_junction_with_every_arm_queued_lets_everybody_through() {
    let dir = tempfile::tempdir().unwrap();
    let Some(net) = netconvert_cross(dir.path(), "right_before_left") else {
        return;
    };
    let flows = every_movement_of_the_cross(100);
    let (inserted, arrived, w) = run_flows(&net, &flows, "right-before-left junction");
    // 12 flows of 100 an hour from 0 to 600 s: a departure every 36 s, 17 each.
    assert_eq!(inserted, 204, "the demand");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
    assert!(
        w.wait_stats().max_wait < 120.0,
        "someone stood {:.0} s",
        w.wait_stats().max_wait
    );
}

/// A left turn off the priority road facing a steady opposing stream (1,200
/// an hour, one every 3 s): the left-turners find their gaps, nobody
/// overlaps, nobody needs the jam timeout.
#[test]
fn a_left_turn_facing_a_steady_opposing_stream_gets_through() {
    let dir = tempfile::tempdir().unwrap();
    let Some(net) = netconvert_cross(dir.path(), "priority") else {
        return;
    };
    let flows = [
        ("opposing".to_string(), "EC CW".to_string(), 1200),
        ("left".to_string(), "WC CN".to_string(), 200),
    ];
    let (inserted, arrived, w) = run_flows(&net, &flows, "left turn against a stream");
    assert_eq!(inserted, 234, "the demand: 200 + 34");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

/// Junction 30 of Bologna's network: trucks (3.1 m wide on 3.2 m lanes)
/// turn left from road 218 into road 36, giving way inside the junction to
/// cars turning right into 36 from road 44, while cars on road 35 go
/// straight on and give way to the trucks. A truck's body cuts the inside of
/// its turn, across the end of road 35: a car there waits clear of the
/// ground the truck will sweep, not only of where it stands, so the two
/// never lock each other. Everybody gets through, nobody overlaps, nobody
/// needs the jam timeout.
#[test]
fn cars_giving_way_to_trucks_turning_through_a_junction_wait_clear_of_their_swing() {
    let Some((_dir, net)) = acosta_copy() else {
        return;
    };
    let flows = [
        ("truck_left".to_string(), "218 36".to_string(), 240),
        ("straight".to_string(), "35 38".to_string(), 500),
        ("right".to_string(), "44 36".to_string(), 300),
    ];
    let (inserted, arrived, w) = run_flows(&net, &flows, "trucks turning at junction 30");
    assert_eq!(inserted, 174, "the demand: 40 + 84 + 50");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0, "{:?}", w.wait_stats());
}

/// The two-lane roundabout of Bologna's network (its `roundabout` element:
/// eight junctions a few metres apart) with every entry queued and every
/// stream going most of the way round, buses among them: everybody gets
/// through, nobody overlaps, nobody needs the jam timeout or a gridlock
/// broken.
#[test]
fn a_roundabout_with_every_entry_queued_keeps_turning() {
    let Some((_dir, net)) = acosta_copy() else {
        return;
    };
    let ring = "77ab 77bc 77cd 53cd 53[0] 53[1][0] 53[1][1][0] 77[1][0]";
    let round = |from: &str, into: &str, out: &str| {
        let ring: Vec<&str> = ring.split(' ').collect();
        let start = ring.iter().position(|&e| e == into).unwrap();
        let way: Vec<&str> = (0..ring.len() - 1)
            .map(|k| ring[(start + k) % ring.len()])
            .collect();
        let last = way.iter().position(|&e| e == out).unwrap();
        format!("{from} {} {}", way[..=last].join(" "), exit_of(out))
    };
    fn exit_of(ring_edge: &str) -> &'static str {
        match ring_edge {
            "77[1][0]" => "77[1][1]",
            "77bc" => "21a",
            "53cd" => "82",
            "53[0]" => "78[1][1]",
            _ => unreachable!("no exit after {ring_edge}"),
        }
    }
    let flows = [
        (
            "from_56b".to_string(),
            round("56b", "77bc", "77[1][0]"),
            500,
        ),
        ("from_59".to_string(), round("59", "53cd", "77bc"), 500),
        (
            "from_127".to_string(),
            round("127", "77[1][0]", "53[0]"),
            500,
        ),
        // 77[0] is a bus lane.
        (
            "bus_from_77".to_string(),
            round("77[0]", "53[1][0]", "53cd"),
            120,
        ),
    ];
    let (inserted, arrived, w) = run_flows(&net, &flows, "the roundabout, every entry queued");
    assert_eq!(
        inserted,
        3 * 84 + 20,
        "the demand: 500 cars an hour for 600 s from each car entry, 120 buses"
    );
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0, "{:?}", w.wait_stats());
}

/// A two-lane road through a junction whose right lane is a bus lane (SUMO's
/// `allow="bus"`), made by netconvert. None (skipped) where SUMO is not
/// installed.
fn netconvert_bus_lane_road(dir: &Path) -> Option<PathBuf> {
    let edge = |id: &str, from: &str, to: &str| {
        format!(
            "  <edge id=\"{id}\" from=\"{from}\" to=\"{to}\" numLanes=\"2\" speed=\"13.89\">\n    <lane index=\"0\" allow=\"bus\"/>\n  </edge>\n"
        )
    };
    netconvert(
        dir,
        "bus_lane",
        r#"  <node id="W" x="-300" y="0"/><node id="C" x="0" y="0" type="priority"/><node id="E" x="300" y="0"/>
"#,
        &format!("{}{}", edge("WC", "W", "C"), edge("CE", "C", "E")),
        &[],
    )
}

/// Bus lanes are closed to cars and open to buses: imported with their
/// classes, cars of a route file and of random traffic keep off them, buses
/// (vClass bus) run on them as vehicles of their own kind, and so may SUMO's
/// class `ignoring` (the rightmost lane of a route with no lane change).
#[test]
fn bus_lanes_are_closed_to_cars_and_open_to_buses() {
    let dir = tempfile::tempdir().unwrap();
    let Some(net) = netconvert_bus_lane_road(dir.path()) else {
        return;
    };
    let map = trafficmesh_maps::import_map(&net).unwrap().map;
    let bus_lane = map.lanes.iter().find(|l| l.name == "WC_0").unwrap();
    assert_eq!(bus_lane.vehicle_classes, ["bus"], "{:?}", bus_lane.name);
    let car_lane = map.lanes.iter().find(|l| l.name == "WC_1").unwrap();
    assert!(car_lane.vehicle_classes.is_empty(), "open to all");

    std::fs::write(
        dir.path().join("mixed.rou.xml"),
        r#"<routes>
    <vType id="car" length="4.5"/>
    <vType id="city_bus" vClass="bus"/>
    <vType id="anything" vClass="ignoring"/>
    <flow id="anything" type="anything" begin="0" end="300" vehsPerHour="60"><route edges="WC CE"/></flow>
    <flow id="cars" type="car" begin="0" end="300" vehsPerHour="600"><route edges="WC CE"/></flow>
    <flow id="buses" type="city_bus" begin="0" end="300" vehsPerHour="60"><route edges="WC CE"/></flow>
</routes>"#,
    )
    .unwrap();
    let (network, _) = trafficmesh_service::load_network_with_routes(
        &net,
        Some(&dir.path().join("mixed.rou.xml")),
    )
    .unwrap();
    let mut routed = world_of(network, 0, usize::MAX);
    let (network, _) = trafficmesh_service::load_network_with_routes(&net, None).unwrap();
    let mut random = world_of(network, 0, 30);
    let mut arrived = std::collections::BTreeMap::<String, u32>::new();
    let mut on_bus_lanes = std::collections::BTreeSet::<String>::new();
    for _ in 0..(900.0 / 0.02) as usize {
        for w in [&mut routed, &mut random] {
            w.step();
            let net = w.network();
            for v in w.vehicles() {
                let kind = &net.kinds[v.kind];
                assert!(
                    net.allows(v.path[0], v.kind),
                    "a {} ({}) on {}",
                    kind.name,
                    kind.vehicle_class(),
                    net.lane(v.path[0]).name
                );
                if !net.lane(v.path[0]).vehicle_classes.is_empty() {
                    on_bus_lanes.insert(kind.name.clone());
                }
            }
        }
        for e in routed.drain_events() {
            if let SimEvent::Despawned(t) = e {
                *arrived.entry(t.kind).or_default() += 1;
            }
        }
        random.drain_events();
    }
    // 600 and 60 an hour for 300 s.
    assert_eq!(arrived.get("car"), Some(&50), "{arrived:?}");
    assert_eq!(arrived.get("city_bus"), Some(&5), "{arrived:?}");
    assert_eq!(arrived.get("anything"), Some(&5), "{arrived:?}");
    assert_eq!(
        on_bus_lanes.into_iter().collect::<Vec<_>>(),
        ["anything", "city_bus"],
        "only the buses and SUMO's class `ignoring` use the bus lanes"
    );
    assert!(random.ticks() > 0 && random.wait_stats().jam_resolutions == 0);
}

/// netconvert's network of `nodes` and `edges` (plain XML bodies) in `dir`,
/// with `options`. None (skipped) where SUMO is not installed.
fn netconvert(
    dir: &Path,
    name: &str,
    nodes: &str,
    edges: &str,
    options: &[&str],
) -> Option<PathBuf> {
    let python = trafficmesh_testkit::python_with("sumo", "eclipse-sumo==1.28.0")?;
    let (nod, edg) = (
        dir.join(format!("{name}.nod.xml")),
        dir.join(format!("{name}.edg.xml")),
    );
    std::fs::write(&nod, format!("<nodes>\n{nodes}</nodes>\n")).unwrap();
    std::fs::write(&edg, format!("<edges>\n{edges}</edges>\n")).unwrap();
    let net = dir.join(format!("{name}.net.xml"));
    let status = Command::new(Path::new(&python).with_file_name("netconvert"))
        .arg("-n")
        .arg(&nod)
        .arg("-e")
        .arg(&edg)
        .arg("-o")
        .arg(&net)
        .args(["--no-turnarounds", "--no-warnings"])
        .args(options)
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "netconvert failed on {name}");
    Some(net)
}

/// A four-way priority junction with all four approaches queued: 300
/// vehicles an hour per arm (a third each straight, left and right) for ten
/// minutes. Every vehicle gets through, none overlaps another and none
/// needs the jam timeout.
#[test]
fn a_priority_junction_with_every_approach_queued_lets_everybody_through() {
    let dir = tempfile::tempdir().unwrap();
    let Some(net) = netconvert_cross(dir.path(), "priority") else {
        return;
    };
    let flows = every_movement_of_the_cross(100);
    let (inserted, arrived, w) = run_flows(&net, &flows, "priority junction");
    assert_eq!(inserted, 204, "the demand");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

/// A flow on a three-lane road departs on every lane, as SUMO's
/// `departLane="best"` spreads it, not all in one queue: 3,000 vehicles an
/// hour, more than one lane takes. Every vehicle gets through, none overlaps
/// another and none needs the jam timeout.
#[test]
fn a_flow_on_a_three_lane_road_departs_on_every_lane() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = "  <node id=\"A\" x=\"0\" y=\"0\"/>\n  <node id=\"B\" x=\"300\" y=\"0\"/>\n  <node id=\"C\" x=\"600\" y=\"10\"/>\n";
    let edges = "  <edge id=\"AB\" from=\"A\" to=\"B\" numLanes=\"3\" speed=\"13.89\"/>\n  <edge id=\"BC\" from=\"B\" to=\"C\" numLanes=\"3\" speed=\"13.89\"/>\n";
    let Some(net) = netconvert(dir.path(), "three_lanes", nodes, edges, &[]) else {
        return;
    };
    let flows = vec![("f".to_string(), "AB BC".to_string(), 3000)];
    let (inserted, arrived, w, by_lane) = run_flows_by_lane(&net, &flows, "three lanes");
    assert_eq!(inserted, 500, "the demand");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
    for lane in ["AB_0", "AB_1", "AB_2"] {
        let n = by_lane.get(lane).copied().unwrap_or(0);
        assert!(
            n >= 100,
            "{n} of {inserted} departed on {lane}: {by_lane:?}"
        );
    }
}

/// A lane drop: two lanes narrow to one (a zipper merge), 1,200 vehicles an
/// hour on both lanes together. Every vehicle gets through, none overlaps
/// another and none needs the jam timeout.
#[test]
fn a_lane_drop_merges_both_lanes_without_a_jam() {
    let dir = tempfile::tempdir().unwrap();
    let Some(net) = netconvert(
        dir.path(),
        "lane_drop",
        r#"  <node id="A" x="-400" y="0"/><node id="M" x="0" y="0" type="zipper"/><node id="B" x="400" y="0"/>
"#,
        r#"  <edge id="AM" from="A" to="M" numLanes="2" speed="13.89"/>
  <edge id="MB" from="M" to="B" numLanes="1" speed="13.89"/>
"#,
        &[],
    ) else {
        return;
    };
    let flows = [("through".to_string(), "AM MB".to_string(), 1200)];
    let (inserted, arrived, w) = run_flows(&net, &flows, "lane drop");
    assert_eq!(inserted, 200, "the demand");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

/// A two-lane roundabout (radius 30 m) with four arms, every entry queued:
/// 300 vehicles an hour per arm, a third each to the next three exits.
/// Every vehicle gets through, none overlaps another and none needs the jam
/// timeout.
#[test]
fn a_two_lane_roundabout_with_every_entry_queued_lets_everybody_through() {
    let dir = tempfile::tempdir().unwrap();
    let ring = [("rN", 0, 30), ("rW", -30, 0), ("rS", 0, -30), ("rE", 30, 0)];
    let arms = [("N", 0, 300), ("W", -300, 0), ("S", 0, -300), ("E", 300, 0)];
    let mut nodes = String::new();
    for (id, x, y) in ring.iter().chain(arms.iter()) {
        nodes += &format!("  <node id=\"{id}\" x=\"{x}\" y=\"{y}\" type=\"priority\"/>\n");
    }
    let mut edges = String::new();
    // Counter-clockwise, as traffic driving on the right goes round.
    for k in 0..4 {
        let (from, to) = (ring[k].0, ring[(k + 1) % 4].0);
        edges += &format!(
            "  <edge id=\"{from}_{to}\" from=\"{from}\" to=\"{to}\" numLanes=\"2\" speed=\"8.33\" priority=\"3\"/>\n"
        );
    }
    for ((arm, ..), (node, ..)) in arms.iter().zip(ring.iter()) {
        edges += &format!(
            "  <edge id=\"{arm}in\" from=\"{arm}\" to=\"{node}\" numLanes=\"2\" speed=\"13.89\" priority=\"1\"/>\n  <edge id=\"{arm}out\" from=\"{node}\" to=\"{arm}\" numLanes=\"1\" speed=\"13.89\" priority=\"1\"/>\n"
        );
    }
    let Some(net) = netconvert(
        dir.path(),
        "roundabout",
        &nodes,
        &edges,
        &["--roundabouts.guess"],
    ) else {
        return;
    };
    let ring_edge = |k: usize| format!("{}_{}", ring[k % 4].0, ring[(k + 1) % 4].0);
    let mut flows = Vec::new();
    for (k, (arm, ..)) in arms.iter().enumerate() {
        for exits in 1..=3 {
            let mut route = vec![format!("{arm}in")];
            route.extend((0..exits).map(|j| ring_edge(k + j)));
            route.push(format!("{}out", arms[(k + exits) % 4].0));
            flows.push((format!("{arm}{exits}"), route.join(" "), 100));
        }
    }
    let (inserted, arrived, w) = run_flows(&net, &flows, "two-lane roundabout");
    assert_eq!(inserted, 204, "the demand");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
}

/// A road crossing another with no junction between them is a bridge over
/// it, as SUMO has it: a two-way street from south to north crosses one
/// from west to east and then passes straight through a junction of a third
/// street, touching neither. Trucks (3.1 m wide on 3.2 m lanes, whose
/// bodies are checked against every body near them) on all three arrive
/// together where the ways cross: none waits for another, none needs the
/// jam timeout.
#[test]
fn a_road_crossing_another_with_no_junction_passes_over_it() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = nodes_xml(
        &[
            ("S", 0, -300),
            ("N", 0, 400),
            ("W", -300, 0),
            ("E", 300, 0),
            ("A", -300, 100),
            ("B", 300, 100),
            ("D", -150, 250),
            ("T", 0, 100),
        ],
        "priority",
    );
    let edges = two_way_edges_xml(&[
        ("S", "N", 1),
        ("W", "E", 1),
        ("A", "T", 2),
        ("T", "B", 2),
        ("T", "D", 1),
    ]);
    let Some(net) = netconvert(dir.path(), "bridge", &nodes, &edges, &[]) else {
        return;
    };
    let summary = import_summary(&net, &dir.path().join("bridge.map.json"));
    assert!(
        summary.contains("cross with no junction between them"),
        "{summary}"
    );
    let flows: Vec<(String, String, u32)> = [
        ("truck_north", "SN"),
        ("truck_south", "NS"),
        ("truck_east", "WE"),
        ("truck_west", "EW"),
        ("truck_through_east", "AT TB"),
        ("truck_through_west", "BT TA"),
    ]
    .into_iter()
    .map(|(id, route)| (id.to_string(), route.to_string(), 360))
    .collect();
    let (inserted, arrived, w) = run_flows(&net, &flows, "bridge");
    assert_eq!(inserted, 6 * 60, "the demand");
    assert_eq!(arrived, inserted, "everybody through by {:.0} s", w.time());
    assert_eq!(w.wait_stats().jam_resolutions, 0);
    assert!(
        w.wait_stats().max_wait < 1.0,
        "a vehicle stood {:.1} s",
        w.wait_stats().max_wait
    );
}

/// Trucks (3.1 m wide on 3.2 m lanes) turn sharply left at a
/// right-before-left junction (as a netgenerate --rand network has it) out
/// onto the street other trucks come along, which give way to them. The
/// turning truck's rear, still in the junction, swings out over the end of
/// the oncoming lane: a truck coming up keeps clear of the ground the
/// turning body will sweep until its rear has left the junction, else the
/// two bodies stand in each other's way. Everybody gets through, nobody
/// overlaps, nobody needs the jam timeout.
#[test]
fn a_truck_swinging_out_of_its_turn_is_not_met_by_the_truck_coming_the_other_way() {
    let dir = tempfile::tempdir().unwrap();
    // Junction 3511 of a netgenerate --rand network, its arms as they lie.
    let nodes = nodes_xml(
        &[
            ("C", 0, 0),
            ("W", -261, 78),
            ("E", 172, 13),
            ("S", -77, -135),
            ("R", 132, -192),
        ],
        "right_before_left",
    );
    let mut edges = String::new();
    for arm in ["W", "E", "S", "R"] {
        for (from, to) in [(arm, "C"), ("C", arm)] {
            edges += &format!(
                "  <edge id=\"{from}{to}\" from=\"{from}\" to=\"{to}\" numLanes=\"1\" speed=\"13.89\"/>\n"
            );
        }
    }
    let Some(net) = netconvert(dir.path(), "sharp_left", &nodes, &edges, &[]) else {
        return;
    };
    let flows = [
        ("truck_left".to_string(), "SC CW".to_string(), 300),
        ("truck_right".to_string(), "WC CR".to_string(), 600),
    ];
    everybody_gets_through_unjammed(&net, &flows, 150);
}

/// Runs the flows through `sim --check` as a user does (realistic drivers
/// at their 0.1 s ticks), and at finer ticks: all `demand` vehicles
/// inserted and arrived, no jam resolution, no overlap.
fn everybody_gets_through_unjammed(net: &Path, flows: &[(String, String, u32)], demand: u32) {
    let rou = write_flows(net, flows);
    for dt in ["0.1", "0.05"] {
        let out = Command::new(env!("CARGO_BIN_EXE_trafficmesh"))
            .arg("sim")
            .arg("--map")
            .arg(net)
            .arg("--routes")
            .arg(&rou)
            .args(["--dt", dt, "--check", "--json"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(report["inserted"], demand, "dt {dt}: {report}");
        assert_eq!(report["arrived"], report["inserted"], "dt {dt}: {report}");
        assert_eq!(report["jam_resolutions"], 0, "dt {dt}: {report}");
        assert_eq!(report["check"]["overlaps"]["count"], 0, "dt {dt}: {report}");
    }
}

/// A street that bends back on itself at a node with no other arm (54
/// degrees between its two halves, as netgenerate's random networks have
/// them), trucks and cars both ways. A body leaving the bend swings its
/// rear over the end of the oncoming lane as its heading catches up with
/// the street; what comes up that lane keeps clear of the rest of that
/// swing (and a truck coming up, of a car's), else the two bodies stand in
/// each other's way.
#[test]
fn a_body_leaving_a_sharp_bend_is_not_met_by_what_comes_up_the_other_way() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = nodes_xml(
        &[("A", -150, 40), ("B", 0, 0), ("C", -117, -94)],
        "priority",
    );
    let edges = two_way_edges_xml(&[("A", "B", 1), ("B", "C", 1)]);
    let Some(net) = netconvert(dir.path(), "sharp_bend", &nodes, &edges, &[]) else {
        return;
    };
    let flows: Vec<(String, String, u32)> = [
        ("truck_down", "AB BC"),
        ("truck_up", "CB BA"),
        ("car_down", "AB BC"),
        ("car_up", "CB BA"),
    ]
    .into_iter()
    .map(|(id, edges)| (id.to_string(), edges.to_string(), 300))
    .collect();
    everybody_gets_through_unjammed(&net, &flows, 200);
}
