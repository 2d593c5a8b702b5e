//! The binary's own checks of flags and files (see tests/service_cli/checks.rs).

#[path = "../../../tests/service_cli/checks.rs"]
mod checks;

const BIN: &str = env!("CARGO_BIN_EXE_trafficmesh-admin");

#[test]
fn a_bad_flag_is_named_and_exits_2() {
    checks::exits_2_naming(
        BIN,
        &["--map", &checks::four_way(), "--request-timeout", "0"],
        "--request-timeout",
    );
}

#[test]
fn a_short_token_is_refused_and_exits_2() {
    checks::exits_2_naming(
        BIN,
        &["--map", &checks::four_way(), "--token", "short"],
        "shorter than 16 characters",
    );
}

#[test]
fn a_missing_map_is_named_and_exits_2() {
    checks::a_missing_map_is_named(BIN);
}
