//! The `secure` profile on one host: the certificates of
//! deploy/secure/make-certs.sh, the router and services from their units
//! with deploy/zenoh/secure and each identity's env file, over loopback
//! (names and certificates as on real hosts: the router is dialled as
//! `localhost`, one of the names its certificate carries). Strangers are
//! refused, identities may only publish and ask what they own, and the
//! admin answers HTTPS and wants its token. No root needed.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_rustls::TlsConnector;
use tokio_rustls::rustls::crypto::ring;
use tokio_rustls::rustls::pki_types::pem::PemObject;
use tokio_rustls::rustls::pki_types::{CertificateDer, ServerName};
use tokio_rustls::rustls::{ClientConfig, RootCertStore};

use super::{Env, cluster_env, deploy, exec_start, repo};

/// The services the secure cluster runs besides its router, each with an
/// identity of its own.
const SERVICES: [&str; 6] = [
    "stepper",
    "spawner",
    "lights",
    "crosswalks",
    "pedestrians",
    "admin",
];

/// The processes of the test, stopped on drop.
#[derive(Default)]
struct Processes(Vec<Child>);

impl Drop for Processes {
    fn drop(&mut self) {
        for child in &mut self.0 {
            unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        }
        for child in &mut self.0 {
            let deadline = Instant::now() + Duration::from_secs(5);
            while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// An identity's env file (make-certs.sh) as entries.
fn identity_env(tls: &Path, identity: &str) -> Env {
    std::fs::read_to_string(tls.join(format!("{identity}.env")))
        .unwrap()
        .lines()
        .filter_map(|l| l.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

/// How long a stranger's session tries before it counts as refused, and
/// how long one that is let in may take (a loaded machine's TLS handshakes).
const REFUSED_AFTER_MS: u32 = 5_000;
const LET_IN_WITHIN_MS: u32 = 30_000;

/// deploy/zenoh/secure/service.json5 as `identity` with `password`, its
/// certificate and key from `certs`, the CA it trusts from `tls`.
fn service_json5(tls: &Path, certs: &Path, identity: &str, password: &str) -> String {
    let text = std::fs::read_to_string(deploy().join("zenoh/secure/service.json5"))
        .unwrap()
        .replace(
            "${TRAFFICMESH_TLS_DIR}/ca.pem",
            &tls.join("ca.pem").display().to_string(),
        )
        .replace("${TRAFFICMESH_TLS_DIR}", &certs.display().to_string())
        .replace("${TRAFFICMESH_IDENTITY}", identity)
        .replace("${TRAFFICMESH_ZENOH_PASSWORD}", password);
    assert!(!text.contains("${"), "service.json5 uses another variable");
    text
}

/// A session config from `text`, dialling the router at `port` and giving
/// up after `timeout_ms`.
fn config_of(text: &str, port: u16, timeout_ms: u32) -> zenoh::Config {
    with_endpoint(zenoh::Config::from_json5(text).unwrap(), port, timeout_ms)
}

/// The profile's config for `identity` (its password, or another).
fn client_config(
    tls: &Path,
    identity: &str,
    password: &str,
    port: u16,
    timeout_ms: u32,
) -> zenoh::Config {
    config_of(
        &service_json5(tls, tls, identity, password),
        port,
        timeout_ms,
    )
}

fn with_endpoint(mut config: zenoh::Config, port: u16, timeout_ms: u32) -> zenoh::Config {
    let endpoint = format!("[\"tls/localhost:{port}\"]");
    config.insert_json5("connect/endpoints", &endpoint).unwrap();
    config
        .insert_json5("connect/timeout_ms", &timeout_ms.to_string())
        .unwrap();
    config
        .insert_json5("connect/exit_on_failure", "true")
        .unwrap();
    config
}

/// Opens a session, or says why not.
async fn open(config: zenoh::Config) -> Result<zenoh::Session, String> {
    zenoh::open(config).await.map_err(|e| e.to_string())
}

/// Payloads received on `key` so far.
async fn collect(session: &zenoh::Session, key: String) -> Arc<Mutex<Vec<Vec<u8>>>> {
    let got = Arc::new(Mutex::new(Vec::new()));
    let sink = got.clone();
    session
        .declare_subscriber(key)
        .callback(move |sample| {
            sink.lock()
                .unwrap()
                .push(sample.payload().to_bytes().to_vec())
        })
        .background()
        .await
        .unwrap();
    got
}

/// The status code of an HTTPS request to the admin, checked against the
/// deployment's CA under the name `localhost`.
async fn https(port: u16, ca: &Path, request: &str, token: Option<&str>) -> u16 {
    let mut roots = RootCertStore::empty();
    for cert in CertificateDer::pem_file_iter(ca).unwrap() {
        roots.add(cert.unwrap()).unwrap();
    }
    let config = ClientConfig::builder_with_provider(Arc::new(ring::default_provider()))
        .with_safe_default_protocol_versions()
        .unwrap()
        .with_root_certificates(roots)
        .with_no_client_auth();
    let tcp = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .unwrap();
    let name = ServerName::try_from("localhost").unwrap();
    let mut tls = TlsConnector::from(Arc::new(config))
        .connect(name, tcp)
        .await
        .expect("a TLS handshake with the admin, its certificate of the deployment's CA");
    let auth = token.map_or(String::new(), |t| format!("Authorization: Bearer {t}\r\n"));
    let head = format!(
        "{request} HTTP/1.1\r\nHost: localhost\r\n{auth}Content-Length: 0\r\nConnection: close\r\n\r\n"
    );
    tls.write_all(head.as_bytes()).await.unwrap();
    let mut response = Vec::new();
    // A server may close without a TLS close_notify: what came is enough.
    let _ = tls.read_to_end(&mut response).await;
    let text = String::from_utf8_lossy(&response);
    text.split_whitespace()
        .nth(1)
        .and_then(|code| code.parse().ok())
        .unwrap_or_else(|| panic!("no HTTP status from the admin: {text}"))
}

#[test]
fn the_secure_profile_refuses_strangers_and_keys_an_identity_does_not_own() {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_trafficmesh"))
        .parent()
        .unwrap()
        .to_path_buf();
    let dir = tempfile::tempdir().unwrap();
    let tls = dir.path().join("tls");
    trafficmesh_testkit::make_certs(&tls);
    let (port, http) = (free_port(), free_port());
    let cluster = format!("secure{}", std::process::id());
    let state = dir.path().join("state");
    std::fs::create_dir_all(&state).unwrap();
    // cluster.env with the secure profile's lines in force, on loopback.
    let mut env = cluster_env();
    let secure = std::fs::read_to_string(deploy().join("cluster.env")).unwrap();
    for line in secure.lines().filter_map(|l| l.strip_prefix('#')) {
        if let Some((k, v)) = line.split_once('=')
            && k.starts_with("TRAFFICMESH_")
        {
            env.insert(k.into(), v.into());
        }
    }
    let here = |installed: &str| {
        installed
            .replace(
                "/etc/trafficmesh/zenoh",
                &deploy().join("zenoh").display().to_string(),
            )
            .replace("/etc/trafficmesh/tls", &tls.display().to_string())
    };
    for value in env.values_mut() {
        *value = here(value);
    }
    for (k, v) in [
        ("TRAFFICMESH_CLUSTER", cluster.clone()),
        (
            "TRAFFICMESH_MAP",
            repo()
                .join("configs/maps/four_way.map.json")
                .display()
                .to_string(),
        ),
        ("TRAFFICMESH_STATE", state.display().to_string()),
        ("TRAFFICMESH_ADMIN_BIND", format!("127.0.0.1:{http}")),
        ("TRAFFICMESH_CONNECT", format!("tls/localhost:{port}")),
        ("PATH", std::env::var("PATH").unwrap_or_default()),
    ] {
        env.insert(k.into(), v);
    }
    assert!(env["TRAFFICMESH_ZENOH_CONFIG"].ends_with("secure/service.json5"));
    assert!(env["TRAFFICMESH_ADMIN_TLS_CERT"].ends_with("https.pem"));

    let mut processes = Processes::default();
    let logs = dir.path().to_path_buf();
    let mut start = |identity: &str, extra: &[String]| {
        let mut command = exec_start(identity, &env, &bin);
        command.extend(extra.iter().cloned());
        let log = std::fs::File::create(logs.join(format!("{identity}.log"))).unwrap();
        let child = Command::new(&command[0])
            .args(&command[1..])
            .env_clear()
            .envs(&env)
            .envs(identity_env(&tls, identity))
            .env("RUST_LOG", "info,zenoh=warn")
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap();
        processes.0.push(child);
    };
    start(
        "router",
        &["--listen".into(), format!("tls/127.0.0.1:{port}")],
    );
    for service in SERVICES {
        start(service, &[]);
    }
    let all_logs = || {
        let mut out = String::new();
        for entry in std::fs::read_dir(dir.path()).unwrap().flatten() {
            let p = entry.path();
            if p.extension().is_some_and(|e| e == "log") {
                out += &format!(
                    "---- {}\n{}\n",
                    p.display(),
                    std::fs::read_to_string(&p).unwrap_or_default()
                );
            }
        }
        out
    };
    let password =
        |identity: &str| identity_env(&tls, identity)["TRAFFICMESH_ZENOH_PASSWORD"].clone();
    let runtime = tokio::runtime::Runtime::new().unwrap();
    runtime.block_on(async {
        // An observer with its certificate and password sees the cluster work
        // under the access rules: vehicle batches and light states arrive.
        let observer = open(client_config(
            &tls,
            "observer",
            &password("observer"),
            port,
            LET_IN_WITHIN_MS,
        ))
        .await
        .unwrap_or_else(|e| panic!("the observer was refused: {e}\n{}", all_logs()));
        let vehicles = collect(&observer, format!("{cluster}/vehicles")).await;
        let lights = collect(&observer, format!("{cluster}/lights/**")).await;
        let deadline = Instant::now() + Duration::from_secs(40);
        while vehicles.lock().unwrap().len() < 10 || lights.lock().unwrap().is_empty() {
            assert!(
                Instant::now() < deadline,
                "no vehicle batches or light states reached the observer:\n{}",
                all_logs()
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }

        // The identities that act below, let in with their certificates.
        let pedestrians = open(client_config(
            &tls,
            "pedestrians",
            &password("pedestrians"),
            port,
            LET_IN_WITHIN_MS,
        ))
        .await
        .expect("the pedestrians identity is let in");
        let admin = open(client_config(
            &tls,
            "admin",
            &password("admin"),
            port,
            LET_IN_WITHIN_MS,
        ))
        .await
        .expect("the admin identity is let in");

        // Strangers: no certificate, a certificate of another CA, a wrong
        // password. Each is refused at the door.
        let observer_text = service_json5(&tls, &tls, "observer", &password("observer"));
        let no_cert: String = observer_text
            .replace("enable_mtls: true", "enable_mtls: false")
            .lines()
            .filter(|l| !l.contains("connect_private_key") && !l.contains("connect_certificate"))
            .collect::<Vec<_>>()
            .join("\n");
        assert!(
            open(config_of(&no_cert, port, REFUSED_AFTER_MS))
                .await
                .is_err(),
            "a process without a certificate got in"
        );
        let other = dir.path().join("other-ca");
        trafficmesh_testkit::make_certs(&other);
        let foreign = service_json5(&tls, &other, "observer", &password("observer"));
        assert!(
            open(config_of(&foreign, port, REFUSED_AFTER_MS))
                .await
                .is_err(),
            "a certificate of another CA got in"
        );
        let wrong = client_config(&tls, "observer", "not-the-password", port, REFUSED_AFTER_MS);
        assert!(open(wrong).await.is_err(), "a wrong password got in");

        // Keys not owned: the pedestrians service (let in) forges vehicle
        // states and a light state; none of it arrives, while the stepper's
        // and the lights' own keep coming.
        let (before_vehicles, before_lights) =
            (vehicles.lock().unwrap().len(), lights.lock().unwrap().len());
        let forged = b"forged by pedestrians".to_vec();
        for _ in 0..10 {
            pedestrians
                .put(format!("{cluster}/vehicles"), forged.clone())
                .await
                .unwrap();
            pedestrians
                .put(format!("{cluster}/lights/state/forged"), forged.clone())
                .await
                .unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        tokio::time::sleep(Duration::from_secs(4)).await;
        let (vehicles_now, lights_now) = (
            vehicles.lock().unwrap().clone(),
            lights.lock().unwrap().clone(),
        );
        assert!(
            vehicles_now.len() > before_vehicles + 10,
            "the stepper's batches stopped"
        );
        assert!(
            lights_now.len() > before_lights,
            "the lights' heartbeat of states stopped"
        );
        assert!(
            !vehicles_now.contains(&forged),
            "forged vehicle states arrived"
        );
        assert!(
            !lights_now.contains(&forged),
            "a forged light state arrived"
        );

        // Commands are the admin's: the admin identity's query for the branch
        // CSV gets an answer (asked again while the spawner, started with the
        // rest, may not have declared its queryable yet), and once it has, the
        // observer's same query gets none.
        let answers = |session: zenoh::Session| {
            let key = format!("{cluster}/spawner/branch_csv");
            async move {
                let replies = session
                    .get(key)
                    .timeout(Duration::from_secs(3))
                    .await
                    .unwrap();
                let mut n = 0;
                while let Ok(reply) = replies.recv_async().await {
                    n += usize::from(reply.result().is_ok());
                }
                n
            }
        };
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let n = answers(admin.clone()).await;
            if n == 1 {
                break;
            }
            assert!(
                n == 0 && Instant::now() < deadline,
                "the admin identity's command got {n} answers, one expected:\n{}",
                all_logs()
            );
        }
        assert_eq!(
            answers(observer.clone()).await,
            0,
            "the observer's command was answered"
        );

        // The REST admin over HTTPS: reads are open, changes want the token.
        let ca = tls.join("ca.pem");
        let token_file = state.join("admin.token");
        let deadline = Instant::now() + Duration::from_secs(20);
        while !token_file.exists() {
            assert!(
                Instant::now() < deadline,
                "the admin wrote no token:\n{}",
                all_logs()
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        let token = std::fs::read_to_string(&token_file).unwrap();
        let token = token.trim();
        assert_eq!(
            https(http, &ca, "GET /api/v1/spawn-config", None).await,
            200
        );
        assert_eq!(
            https(http, &ca, "POST /api/v1/spawn-config/save", None).await,
            401
        );
        assert_eq!(
            https(http, &ca, "POST /api/v1/spawn-config/save", Some("wrong")).await,
            401
        );
        assert_eq!(
            https(http, &ca, "POST /api/v1/spawn-config/save", Some(token)).await,
            200
        );
        // Plain HTTP to the HTTPS port gets no page.
        let plain = ureq::get(&format!("http://127.0.0.1:{http}/api/v1/spawn-config")).call();
        assert!(plain.is_err(), "plain HTTP was served");
    });

    // `trafficmesh status` as an observer, from the profile's config: every
    // service is up and the cluster healthy under the access rules.
    let out = Command::new(bin.join("trafficmesh"))
        .args([
            "status",
            "--json",
            "--expect",
            "stepper,spawner,lights,crosswalks,pedestrians,admin",
        ])
        .env_clear()
        .envs(&env)
        .envs(identity_env(&tls, "observer"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let health: serde_json::Value =
        serde_json::from_str(text.lines().find(|l| l.starts_with('{')).unwrap_or("{}"))
            .unwrap_or_else(|e| panic!("{e}: {text}"));
    assert_eq!(health["degraded"], false, "{health}\n{}", all_logs());
    let alive: BTreeSet<&str> = health["services"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(_, s)| s["alive"] == true)
        .map(|(name, _)| name.as_str())
        .collect();
    for service in SERVICES {
        assert!(alive.contains(service), "{service} not alive: {health}");
        // Its status answered the query (a reply on its own key), linked
        // to the router.
        let status = &health["services"][service];
        assert!(
            status["pid"].is_u64(),
            "{service}'s status did not answer: {health}"
        );
        assert!(
            status["peers"].to_string().contains("router "),
            "{service} is linked to no router: {health}"
        );
    }
    drop(processes);
}
