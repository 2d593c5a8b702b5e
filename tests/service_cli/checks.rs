//! Checks every service binary passes before it touches the bus: bad flags and
//! bad files end with a message naming the problem and exit code 2. Each
//! service's `tests/cli.rs` includes this file; building those tests is also
//! what makes Cargo build the binaries `trafficmesh up` and the cluster tests start.

use std::process::Command;

pub fn four_way() -> String {
    // At run time: a binary built from another checkout that shares the
    // build directory reads this checkout's files.
    let dir: std::path::PathBuf = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| env!("CARGO_MANIFEST_DIR").into());
    format!("{}/../../configs/maps/four_way.map.json", dir.display())
}

/// Runs `bin` with `args`; it must exit with 2 and name `needle` on stderr.
pub fn exits_2_naming(bin: &str, args: &[&str], needle: &str) {
    let out = Command::new(bin).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(needle), "stderr does not name {needle}: {err}");
}

pub fn a_missing_map_is_named(bin: &str) {
    exits_2_naming(
        bin,
        &["--map", "/nonexistent/x.map.json"],
        "/nonexistent/x.map.json",
    );
}
