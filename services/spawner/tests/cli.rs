//! The binary's own checks, before it touches the bus: bad flags and bad
//! files end with a message naming the problem and exit code 2.
//! (Building this test also makes Cargo build the binary that
//! `trafficmesh up` and the cluster tests start.)

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_trafficmesh-spawner");

fn map() -> String {
    format!(
        "{}/../../configs/maps/four_way.map.json",
        env!("CARGO_MANIFEST_DIR")
    )
}

#[test]
fn a_bad_spawn_config_is_named_with_its_lane_and_exits_2() {
    let path = std::env::temp_dir().join(format!("bad_spawn_{}.json", std::process::id()));
    std::fs::write(
        &path,
        r#"{"spawnRates": [{"lane": "no_such_lane", "spawnsPerMinute": 6}], "branchWeights": []}"#,
    )
    .unwrap();
    let out = Command::new(BIN)
        .args(["--map", &map(), "--spawn-config"])
        .arg(&path)
        .output()
        .unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no_such_lane") && err.contains("lane"),
        "{err}"
    );
}

#[test]
fn a_missing_map_is_named_and_exits_2() {
    let out = Command::new(BIN)
        .args(["--map", "/nonexistent/x.map.json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/x.map.json"));
}
