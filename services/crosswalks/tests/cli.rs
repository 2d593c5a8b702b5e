//! The binary's own checks, before it touches the bus: bad flags and bad
//! files end with a message naming the problem and exit code 2.
//! (Building this test also makes Cargo build the binary that
//! `trafficmesh up` and the cluster tests start.)

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_trafficmesh-crosswalks");

fn map() -> String {
    format!(
        "{}/../../configs/maps/four_way.map.json",
        env!("CARGO_MANIFEST_DIR")
    )
}

#[test]
fn a_bad_flag_is_named_and_exits_2() {
    let out = Command::new(BIN)
        .args(["--map", &map(), "--validity", "nan"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--validity"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
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
