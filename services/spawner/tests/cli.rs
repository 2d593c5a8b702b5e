//! The binary's own checks of flags and files (see tests/service_cli/checks.rs).

#[path = "../../../tests/service_cli/checks.rs"]
mod checks;

const BIN: &str = env!("CARGO_BIN_EXE_trafficmesh-spawner");

#[test]
fn a_bad_spawn_config_is_named_with_its_lane_and_exits_2() {
    let path = std::env::temp_dir().join(format!("bad_spawn_{}.json", std::process::id()));
    std::fs::write(
        &path,
        r#"{"spawnRates": [{"lane": "no_such_lane", "spawnsPerMinute": 6}], "branchWeights": []}"#,
    )
    .unwrap();
    let config = path.display().to_string();
    checks::exits_2_naming(
        BIN,
        &["--map", &checks::four_way(), "--spawn-config", &config],
        "unknown lane 'no_such_lane'",
    );
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn a_missing_map_is_named_and_exits_2() {
    checks::a_missing_map_is_named(BIN);
}
