//! deploy/container: compose.yaml and the Containerfile, read by a YAML
//! parser and held to the systemd units and cluster.env (no container
//! engine is needed; one that is present could build and run them as the
//! files' comments say).

use std::path::PathBuf;
use std::process::Command;

use super::repo;

#[test]
fn the_compose_file_runs_the_units_processes_from_the_containerfiles_image() {
    let Some(python) = trafficmesh_testkit::python_with("yaml", "pyyaml") else {
        return;
    };
    let bins = PathBuf::from(env!("CARGO_BIN_EXE_trafficmesh"))
        .parent()
        .unwrap()
        .to_path_buf();
    let out = Command::new(python)
        .arg(repo().join("tests/deploy/check_container.py"))
        .arg(repo())
        .arg(&bins)
        .output()
        .unwrap();
    assert!(
        out.status.success() && String::from_utf8_lossy(&out.stdout).contains("OK"),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
