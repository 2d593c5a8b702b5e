//! `trafficmesh bench bus [--tls-dir DIR]`: what the secure profile's TLS
//! costs on the bus. A router (`trafficmesh router`, a process of its own,
//! as deployed) and two clients on loopback, every message client → router
//! → client: a publisher
//! streams vehicle-batch-sized messages to a subscriber for a few seconds
//! (throughput), and a ping that the other client answers times the round
//! trip (latency). Over plain TCP, and over TLS with mutual authentication
//! (the certificates of deploy/secure/make-certs.sh) when `--tls-dir` is
//! given.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use clap::Args;
use serde::Serialize;
use zenoh::qos::CongestionControl;

#[derive(Args)]
pub struct BusArgs {
    /// The certificates of `deploy/secure/make-certs.sh DIR` (its default
    /// host names include localhost): adds the same runs over TLS.
    #[arg(long)]
    tls_dir: Option<PathBuf>,
    /// Message sizes streamed, bytes: by default a vehicle batch of 40
    /// vehicles and one of 10,000.
    #[arg(long, value_delimiter = ',', default_value = "2516,620036")]
    sizes: Vec<usize>,
    /// Seconds each size is streamed.
    #[arg(long, default_value_t = 3.0)]
    seconds: f64,
    /// Round trips timed (64-byte pings).
    #[arg(long, default_value_t = 2000)]
    pings: usize,
    /// Print one JSON object instead of `key: value` lines.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Stream {
    bytes: usize,
    /// Messages that arrived per second, from the first sent to the last in.
    messages_per_sec: f64,
    /// Sent but never arrived (none expected: the stream is reliable).
    lost: u64,
    megabytes_per_sec: f64,
}

#[derive(Serialize)]
struct Run {
    transport: &'static str,
    streams: Vec<Stream>,
    round_trip_p50_us: f64,
    round_trip_p99_us: f64,
}

pub fn run(a: BusArgs) -> Result<()> {
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        bail!("--seconds must be a positive number");
    }
    if a.sizes.is_empty() || a.sizes.contains(&0) {
        bail!("--sizes must list positive byte counts");
    }
    if a.pings == 0 {
        bail!("--pings must be at least 1");
    }
    if let Some(dir) = &a.tls_dir {
        for file in [
            "ca.pem",
            "router.pem",
            "router.key",
            "stepper.pem",
            "observer.pem",
        ] {
            if !dir.join(file).exists() {
                bail!(
                    "{}: no {file}; make the certificates with deploy/secure/make-certs.sh {}",
                    dir.display(),
                    dir.display()
                );
            }
        }
    }
    let runs = trafficmesh_bus::runtime::tokio_runtime(2)?.block_on(async {
        let mut runs = vec![measure(&a, None).await?];
        if let Some(dir) = &a.tls_dir {
            runs.push(measure(&a, Some(dir)).await?);
        }
        anyhow::Ok(runs)
    })?;
    if a.json {
        println!("{}", serde_json::json!({ "runs": runs }));
        return Ok(());
    }
    for r in &runs {
        for s in &r.streams {
            println!(
                "{} {} B: {:.0} messages/s, {:.1} MB/s, {} lost",
                r.transport, s.bytes, s.messages_per_sec, s.megabytes_per_sec, s.lost
            );
        }
        println!(
            "{} round trip (64 B, through the router): p50 {:.0} us, p99 {:.0} us",
            r.transport, r.round_trip_p50_us, r.round_trip_p99_us
        );
    }
    Ok(())
}

/// One transport's figures: TCP, or TLS with the certificates in `tls`.
async fn measure(a: &BusArgs, tls: Option<&Path>) -> Result<Run> {
    let port = trafficmesh_bus::free_loopback_port()?;
    // The router in a process of its own: in this one, Zenoh's receiving
    // threads would be the router's and the subscriber's at once, and the
    // router, blocked on the subscriber's full queue, would hold the very
    // threads that drain it.
    let router = Router::start(port, tls)?;
    let open = |config: zenoh::Config| async move {
        zenoh::open(config)
            .await
            .map_err(|e| anyhow!("cannot open a bench session: {e}"))
    };
    let publisher_session = open(client_config("stepper", port, tls)?).await?;
    let subscriber_session = open(client_config("observer", port, tls)?).await?;

    let mut streams = Vec::new();
    for &bytes in &a.sizes {
        streams.push(stream(&publisher_session, &subscriber_session, bytes, a.seconds).await?);
    }
    let mut rtts = ping(&publisher_session, &subscriber_session, a.pings).await?;
    rtts.sort_by(f64::total_cmp);
    let at = |q: f64| rtts[((rtts.len() - 1) as f64 * q).round() as usize];
    let run = Run {
        transport: if tls.is_some() { "tls" } else { "tcp" },
        streams,
        round_trip_p50_us: at(0.5),
        round_trip_p99_us: at(0.99),
    };
    for s in [subscriber_session, publisher_session] {
        let _ = s.close().await;
    }
    drop(router);
    Ok(run)
}

/// `trafficmesh router` on a loopback port, stopped on drop.
struct Router {
    child: std::process::Child,
    config: PathBuf,
}

impl Router {
    fn start(port: u16, tls: Option<&Path>) -> Result<Router> {
        let text = match tls {
            None => format!(
                r#"{{ mode: "router", listen: {{ endpoints: ["tcp/127.0.0.1:{port}"] }},
                   scouting: {{ multicast: {{ enabled: false }} }} }}"#
            ),
            Some(dir) => {
                let file = |name: &str| format!("{:?}", dir.join(name).display().to_string());
                format!(
                    r#"{{ mode: "router", listen: {{ endpoints: ["tls/localhost:{port}"] }},
                       scouting: {{ multicast: {{ enabled: false }} }},
                       transport: {{ link: {{ tls: {{ root_ca_certificate: {}, listen_private_key: {},
                       listen_certificate: {}, enable_mtls: true }} }} }} }}"#,
                    file("ca.pem"),
                    file("router.key"),
                    file("router.pem")
                )
            }
        };
        let config = std::env::temp_dir().join(format!(
            "trafficmesh-bench-bus-{}-{port}.json5",
            std::process::id()
        ));
        std::fs::write(&config, text)
            .with_context(|| format!("cannot write {}", config.display()))?;
        let child = std::process::Command::new(std::env::current_exe()?)
            .arg("router")
            .arg("--zenoh-config")
            .arg(&config)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .context("cannot start `trafficmesh router`")?;
        let router = Router { child, config };
        let deadline = Instant::now() + Duration::from_secs(10);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            if Instant::now() > deadline {
                bail!("the bench router did not listen on port {port} within 10 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        Ok(router)
    }
}

impl Drop for Router {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.config);
    }
}

/// A client of the bench router, over TLS showing `identity`'s certificate.
fn client_config(identity: &str, port: u16, tls: Option<&Path>) -> Result<zenoh::Config> {
    let mut c = zenoh::Config::default();
    let endpoint = match tls {
        Some(_) => format!("[\"tls/localhost:{port}\"]"),
        None => format!("[\"tcp/127.0.0.1:{port}\"]"),
    };
    let mut set = |key: &str, value: String| {
        c.insert_json5(key, &value)
            .map_err(|e| anyhow!("bench config {key}: {e}"))
    };
    set("scouting/multicast/enabled", "false".into())?;
    set("mode", "\"client\"".into())?;
    set("connect/endpoints", endpoint)?;
    set("listen/endpoints", "[]".into())?;
    if let Some(dir) = tls {
        let file = |name: &str| format!("{:?}", dir.join(name).display().to_string());
        set("transport/link/tls/root_ca_certificate", file("ca.pem"))?;
        set("transport/link/tls/enable_mtls", "true".into())?;
        set("transport/link/tls/verify_name_on_connect", "true".into())?;
        set(
            "transport/link/tls/connect_private_key",
            file(&format!("{identity}.key")),
        )?;
        set(
            "transport/link/tls/connect_certificate",
            file(&format!("{identity}.pem")),
        )?;
    }
    Ok(c)
}

/// Streams `bytes`-sized messages from one client to the other for
/// `seconds`: what arrived per second, once everything sent has arrived.
async fn stream(
    from: &zenoh::Session,
    to: &zenoh::Session,
    bytes: usize,
    seconds: f64,
) -> Result<Stream> {
    let key = format!("bench/stream/{bytes}");
    let received = Arc::new(AtomicU64::new(0));
    let counter = received.clone();
    let _subscriber = to
        .declare_subscriber(&key)
        .callback(move |_| {
            counter.fetch_add(1, Ordering::Relaxed);
        })
        .await
        .map_err(|e| anyhow!("{e}"))?;
    let publisher = from
        .declare_publisher(&key)
        .congestion_control(CongestionControl::Block)
        .await
        .map_err(|e| anyhow!("{e}"))?;
    wait_for_match(&publisher).await?;
    let payload = vec![0x5au8; bytes];
    let start = Instant::now();
    let mut sent = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        publisher
            .put(payload.clone())
            .await
            .map_err(|e| anyhow!("{e}"))?;
        sent += 1;
    }
    // Until all have arrived, or nothing more for two seconds (counted as lost).
    let (mut seen, mut last_progress) = (0, Instant::now());
    let mut end = start.elapsed();
    loop {
        let now = received.load(Ordering::Relaxed);
        if now > seen {
            (seen, last_progress, end) = (now, Instant::now(), start.elapsed());
        }
        if seen >= sent || last_progress.elapsed() > Duration::from_secs(2) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    let rate = seen as f64 / end.as_secs_f64();
    Ok(Stream {
        bytes,
        messages_per_sec: rate,
        lost: sent - seen.min(sent),
        megabytes_per_sec: rate * bytes as f64 / 1e6,
    })
}

/// `pings` round trips of 64 bytes, each answered by the other client's
/// subscriber: microseconds each.
async fn ping(a: &zenoh::Session, b: &zenoh::Session, pings: usize) -> Result<Vec<f64>> {
    let err = |e: zenoh::Error| anyhow!("{e}");
    let pong = b
        .declare_publisher("bench/pong")
        .congestion_control(CongestionControl::Block)
        .await
        .map_err(err)?;
    let answering = b.declare_subscriber("bench/ping").await.map_err(err)?;
    let answerer = tokio::spawn(async move {
        while let Ok(sample) = answering.recv_async().await {
            if pong.put(sample.payload().clone()).await.is_err() {
                break;
            }
        }
    });
    let pongs = a.declare_subscriber("bench/pong").await.map_err(err)?;
    let pinger = a
        .declare_publisher("bench/ping")
        .congestion_control(CongestionControl::Block)
        .await
        .map_err(err)?;
    wait_for_match(&pinger).await?;
    // The answerer's pong publisher must see our subscriber too: one ping
    // that comes back says the way round is open.
    tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            pinger.put(vec![0u8; 64]).await.map_err(err)?;
            if tokio::time::timeout(Duration::from_millis(100), pongs.recv_async())
                .await
                .is_ok()
            {
                return anyhow::Ok(());
            }
        }
    })
    .await
    .context("no pong within 10 s")??;
    let mut rtts = Vec::with_capacity(pings);
    for _ in 0..pings {
        let start = Instant::now();
        pinger.put(vec![0u8; 64]).await.map_err(err)?;
        tokio::time::timeout(Duration::from_secs(5), pongs.recv_async())
            .await
            .context("a ping not answered within 5 s")?
            .map_err(|e| anyhow!("{e}"))?;
        rtts.push(start.elapsed().as_secs_f64() * 1e6);
    }
    answerer.abort();
    Ok(rtts)
}

async fn wait_for_match(publisher: &zenoh::pubsub::Publisher<'_>) -> Result<()> {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let matching = publisher
            .matching_status()
            .await
            .map(|m| m.matching())
            .unwrap_or(false);
        if matching {
            return Ok(());
        }
        if Instant::now() > deadline {
            bail!("the bench subscriber was not matched within 10 s");
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}
