//! The traffic service as a runtime uses it: the binary on a free port, a
//! Python client generated with grpcio-tools from the project's .proto files.

use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn crate_dir() -> PathBuf {
    trafficmesh_testkit::repo_root().join("services/traffic-grpc")
}

/// A Python with the gRPC tools, health and reflection clients, and Zenoh.
fn python() -> Option<String> {
    trafficmesh_testkit::python_with(
        "grpc, grpc_tools, grpc_health, grpc_reflection, zenoh",
        "grpcio-tools grpcio-health-checking grpcio-reflection eclipse-zenoh (see .ci/run)",
    )
}

fn free_port() -> u16 {
    trafficmesh_bus::free_loopback_port().expect("a free loopback port")
}

/// Runs a client script; it must succeed and print OK.
fn assert_script_ok(script: &mut Command) {
    let out = script.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("OK"),
        "{script:?}:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Python stubs of the project's .proto files, generated with grpcio-tools.
fn generate_stubs(python: &str, dir: &Path) -> PathBuf {
    let stubs = dir.join("stubs");
    std::fs::create_dir(&stubs).unwrap();
    let proto = crate_dir().join("proto");
    let generated = Command::new(python)
        .args(["-m", "grpc_tools.protoc", "-I"])
        .arg(&proto)
        .arg(format!("--python_out={}", stubs.display()))
        .arg(format!("--grpc_python_out={}", stubs.display()))
        .arg(proto.join("common.proto"))
        .arg(proto.join("traffic.proto"))
        .output()
        .unwrap();
    assert!(
        generated.status.success(),
        "grpc_tools.protoc: {}",
        String::from_utf8_lossy(&generated.stderr)
    );
    stubs
}

/// The service on a free port with the four-way map as scene `four_way`,
/// on a Zenoh bus of its own (a cluster name and endpoint of this test's).
struct Service {
    child: Child,
    address: String,
    zenoh: String,
    cluster: String,
}

impl Service {
    fn start(dir: &Path) -> Service {
        Self::start_with(dir, &[])
    }

    fn start_with(dir: &Path, extra: &[String]) -> Service {
        let map = crate_dir().join("../../configs/maps/four_way.map.json");
        let scenes = dir.join("scenes.toml");
        std::fs::write(
            &scenes,
            format!(
                "[[scene]]\nid = \"four_way\"\nmap = \"{}\"\n",
                map.canonicalize().unwrap().display()
            ),
        )
        .unwrap();
        let address = format!("127.0.0.1:{}", free_port());
        let zenoh = format!("tcp/127.0.0.1:{}", free_port());
        let cluster = format!("grpc-test-{}", std::process::id());
        let child = Command::new(env!("CARGO_BIN_EXE_trafficmesh-traffic-grpc"))
            .args([
                "--bind",
                &address,
                "--listen",
                &zenoh,
                "--cluster",
                &cluster,
            ])
            .arg("--scenes")
            .arg(&scenes)
            .args(extra)
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let deadline = Instant::now() + Duration::from_secs(30);
        while TcpStream::connect(&address).is_err() {
            assert!(
                Instant::now() < deadline,
                "the service listens on {address}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        Service {
            child,
            address,
            zenoh,
            cluster,
        }
    }

    /// Waits up to 10 s for the process to end; its exit status.
    fn wait(&mut self) -> std::process::ExitStatus {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(Instant::now() < deadline, "the service stops");
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Document 003's usage example end to end, then the behaviour and error
/// checks of client.py: order and count of the answers, a pose at exactly
/// each time_query_us, logged poses unchanged before handover, an NPC that
/// stops behind an ego standing in its lane (and drives past without it),
/// the same answers for the same seed and inputs, sessions isolated, every
/// error its status code, each answer's actors on the bus for a Zenoh
/// subscriber; shut_down stops the service.
#[test]
fn a_generated_python_client_runs_the_usage_example_and_the_error_cases() {
    let Some(python) = python() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let stubs = generate_stubs(&python, dir.path());
    let mut service = Service::start(dir.path());
    assert_script_ok(
        Command::new(&python)
            .arg(crate_dir().join("tests/client.py"))
            .arg(&stubs)
            .arg(&service.address)
            .args([&service.zenoh, &service.cluster]),
    );
    assert!(
        service.wait().success(),
        "shut_down stops the service cleanly"
    );
}

#[test]
fn sigterm_stops_the_service_gracefully() {
    let dir = tempfile::tempdir().unwrap();
    let mut service = Service::start(dir.path());
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(service.child.id() as i32, libc::SIGTERM) };
    assert!(service.wait().success());
}

/// The certificates of a deployment, made by its script
/// (deploy/secure/make-certs.sh): the CA, the HTTPS certificate the admin
/// and the traffic service serve with (for localhost and 127.0.0.1) and the
/// `runtime` identity's client certificate.
fn certificates(dir: &Path) -> PathBuf {
    let certs = dir.join("certs");
    trafficmesh_testkit::make_certs(&certs);
    certs
}

/// With a certificate, key and client CA the service speaks only mutual
/// TLS: a client with the deployment's certificate is served; one without a
/// certificate, or without TLS, is refused.
#[test]
fn over_mutual_tls_only_clients_with_a_certificate_are_served() {
    let Some(python) = python() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let stubs = generate_stubs(&python, dir.path());
    let certs = certificates(dir.path());
    let file = |name: &str| certs.join(name).display().to_string();
    let service = Service::start_with(
        dir.path(),
        &[
            "--tls-cert".into(),
            file("https.pem"),
            "--tls-key".into(),
            file("https.key"),
            "--tls-client-ca".into(),
            file("ca.pem"),
        ],
    );
    assert_script_ok(
        Command::new(&python)
            .arg(crate_dir().join("tests/tls_client.py"))
            .arg(&stubs)
            .arg(&service.address)
            .arg(&certs),
    );
}
