//! The binary's own checks of flags and files (see tests/service_cli/checks.rs).

#[path = "../../../tests/service_cli/checks.rs"]
mod checks;

const BIN: &str = env!("CARGO_BIN_EXE_trafficmesh-intersection");

#[test]
fn a_bad_cluster_name_is_named_and_exits_2() {
    checks::exits_2_naming(
        BIN,
        &["--map", &checks::four_way(), "--cluster", "a/*"],
        "a/*",
    );
}

#[test]
fn a_missing_map_is_named_and_exits_2() {
    checks::a_missing_map_is_named(BIN);
}
