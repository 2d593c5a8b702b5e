//! `trafficmesh router`: the Zenoh router of a cluster spread over several
//! hosts (deploy/). Every service and client connects to it in client mode,
//! so hosts only need to reach the router's address. It is a Zenoh session
//! in router mode, opened by the same zenoh build as the services: no other
//! binary to build or install. Logs each service of any cluster that comes
//! and goes (their liveliness tokens pass through it).

use anyhow::{Context, Result};
use clap::Args;
use trafficmesh_bus::BusArgs;
use trafficmesh_protocol::topics;
use zenoh::sample::SampleKind;

#[derive(Args)]
pub struct RouterArgs {
    /// Zenoh config of the router (deploy/zenoh/router.json5); without one
    /// it listens on tcp/0.0.0.0:7447. `--listen` overrides its endpoints.
    #[arg(long, env = "TRAFFICMESH_ZENOH_CONFIG")]
    zenoh_config: Option<std::path::PathBuf>,
    /// Endpoints to listen on (repeatable), e.g. tcp/0.0.0.0:7447.
    #[arg(long = "listen", value_delimiter = ',')]
    listen: Vec<String>,
}

/// Where a router listens without a config.
const DEFAULT_LISTEN: &str = "tcp/0.0.0.0:7447";

/// Zenoh's receiving threads in the router (its default is 2): a message for
/// a host whose link stops draining holds one until that host's session is
/// closed, and with every one held the close never runs
/// (eclipse-zenoh/zenoh#1876). `ZENOH_RUNTIME` in the environment wins.
const ROUTER_RUNTIME: &str = "(rx: (worker_threads: 6))";
/// The variable Zenoh reads its runtime's thread counts from.
const ZENOH_RUNTIME_ENV: &str = "ZENOH_RUNTIME";

pub fn run(a: RouterArgs) -> Result<()> {
    if std::env::var_os(ZENOH_RUNTIME_ENV).is_none() {
        // SAFETY: before the router starts any thread of its own (the async
        // runtime below, Zenoh's); nothing else reads the environment now.
        unsafe { std::env::set_var(ZENOH_RUNTIME_ENV, ROUTER_RUNTIME) };
    }
    let bus = BusArgs {
        cluster: "trafficmesh".into(),
        zenoh_config: a.zenoh_config.clone(),
        mode: Some("router".into()),
        connect: Vec::new(),
        listen: if a.listen.is_empty() && a.zenoh_config.is_none() {
            vec![DEFAULT_LISTEN.into()]
        } else {
            a.listen.clone()
        },
    };
    let config = bus.zenoh_config(trafficmesh_bus::Role::Hub)?;
    let listen = config
        .get_json("listen/endpoints")
        .unwrap_or_else(|_| "its config's endpoints".into());
    trafficmesh_bus::runtime::tokio_runtime(2)?.block_on(async move {
        let session = zenoh::open(config)
            .await
            .map_err(|e| anyhow::anyhow!("cannot open the router: {e}"))
            .context("is the address in use or not on this host?")?;
        tracing::info!("router {} listening on {listen}", session.zid());
        let stop = trafficmesh_bus::runtime::shutdown_signal();
        tokio::pin!(stop);
        let services = session
            .liveliness()
            // Every cluster's services: `*/alive/*`.
            .declare_subscriber(format!(
                "*/{}",
                topics::ALIVE.pattern.replace("{service}", "*")
            ))
            .history(true)
            .await
            .map_err(|e| anyhow::anyhow!("watching the services: {e}"))?;
        loop {
            tokio::select! {
                _ = &mut stop => break,
                Ok(sample) = services.recv_async() => {
                    let key = sample.key_expr().as_str();
                    match sample.kind() {
                        SampleKind::Put => tracing::info!("{key}: up"),
                        SampleKind::Delete => tracing::info!("{key}: gone"),
                    }
                }
            }
        }
        session
            .close()
            .await
            .map_err(|e| anyhow::anyhow!("closing the router: {e}"))?;
        Ok(())
    })
}
