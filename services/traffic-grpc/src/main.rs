//! The traffic service: the gRPC gateway a simulation runtime (NVIDIA's
//! alpasim and its forks) calls for its background actors. Each session
//! replays the logged actors until handover, then trafficmesh's NPC model
//! drives them, reacting to the ego; each answer is also published on the
//! Zenoh bus for viewers.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Role, runtime};
use trafficmesh_service::check_flags;
use trafficmesh_service::settings::TrafficServiceSettings;
use trafficmesh_sim::session::SessionConfig;
use trafficmesh_traffic_grpc::{Tls, catalogue, serve, service};

/// Serves `traffic.TrafficService` (start_session, simulate, close_session,
/// get_metadata, get_available_scenes, shut_down), the standard gRPC health
/// service and server reflection, so `grpcurl` lists and calls it. Scenes for
/// map_id: `--map` (named by its file name up to its first dot) and the `--scenes` catalogue; an
/// unknown map_id runs map-less.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    #[command(flatten)]
    bus: BusArgs,
    /// A map that sessions may choose by its name (the file name up to its
    /// first dot; `trafficmesh up` passes the cluster's).
    #[arg(long)]
    map: Option<PathBuf>,
    /// A SUMO scenario whose network sessions may choose by its name.
    #[arg(long, conflicts_with = "map")]
    sumocfg: Option<PathBuf>,
    #[command(flatten)]
    settings: TrafficServiceSettings,
}

fn main() -> std::process::ExitCode {
    runtime::main_with(|| {
        let args = Args::parse();
        runtime::tokio_runtime(2)?.block_on(run(args))
    })
}

async fn run(args: Args) -> Result<()> {
    let s = &args.settings;
    check_flags(s)?;
    let mut scenes = match &s.scenes {
        Some(path) => catalogue::load(path)?,
        None => Default::default(),
    };
    if let Some(path) = args.map.as_ref().or(args.sumocfg.as_ref()) {
        catalogue::add(&mut scenes, path, glam::DVec3::ZERO)?;
    }
    tracing::info!(scenes = ?scenes.keys().collect::<Vec<_>>(), "scenes loaded");
    let bus = Bus::open_service(&args.bus, Role::Member, "traffic-grpc")
        .await
        .context("joining the Zenoh bus")?;
    let config = SessionConfig {
        min_history_us: s.min_history_us,
        forecast_horizon_us: s.forecast_horizon_us,
        forecast_step_us: s.forecast_step_us,
        ..SessionConfig::default()
    };
    let (stop, mut stopped) = tokio::sync::watch::channel(false);
    let gateway = service::Gateway::new(scenes, config, stop).with_bus(Arc::new(bus));
    let incoming = tonic::transport::server::TcpIncoming::bind(s.listen)
        .with_context(|| format!("binding {}", s.listen))?
        .with_nodelay(Some(true));
    // A signal or the shut_down call; the signal handlers are in place
    // before the service says it listens.
    let signal = runtime::shutdown_signal();
    tracing::info!(address = %s.listen, "traffic service listening");
    let signals = async move {
        tokio::select! {
            _ = signal => {}
            _ = stopped.wait_for(|s| *s) => {}
        }
    };
    let tls = s
        .tls_cert
        .clone()
        .zip(s.tls_key.clone())
        .map(|(cert, key)| Tls {
            cert,
            key,
            client_ca: s.tls_client_ca.clone(),
        });
    serve(gateway, incoming, tls.as_ref(), signals).await?;
    tracing::info!("traffic service stopped");
    Ok(())
}
