//! The traffic service: the gRPC gateway a simulation runtime (NVIDIA's
//! alpasim and its forks) calls for its background actors. Each session
//! replays the logged actors until handover, then trafficmesh's NPC model
//! drives them, reacting to the ego.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use trafficmesh_sim::session::SessionConfig;
use trafficmesh_traffic_grpc::{catalogue, serve, service};

/// Serves `traffic.TrafficService` (start_session, simulate, close_session,
/// get_metadata, get_available_scenes, shut_down), the standard gRPC health
/// service and server reflection, so `grpcurl` lists and calls it.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Address to listen on.
    #[arg(
        long,
        default_value = "127.0.0.1:50054",
        env = "TRAFFICMESH_TRAFFIC_LISTEN"
    )]
    listen: SocketAddr,
    /// The scenes sessions may choose by map_id: a directory of maps (each
    /// named by its file stem) or a TOML list (`[[scene]] id, map, offset`).
    /// Without it every session runs map-less.
    #[arg(long)]
    scenes: Option<PathBuf>,
    /// History an actor needs before the model takes it over, microseconds.
    #[arg(long, default_value_t = 1_000_000)]
    min_history_us: u64,
    /// How far past time_query_us each answer forecasts, microseconds (0:
    /// the pose at time_query_us only).
    #[arg(long, default_value_t = 2_000_000)]
    forecast_horizon_us: u64,
    /// Time between forecast poses, microseconds.
    #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u64).range(1..))]
    forecast_step_us: u64,
}

#[tokio::main]
async fn main() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .init();
    let args = Args::parse();
    let scenes = match &args.scenes {
        Some(path) => catalogue::load(path)?,
        None => Default::default(),
    };
    tracing::info!(scenes = ?scenes.keys().collect::<Vec<_>>(), "scene catalogue loaded");
    let config = SessionConfig {
        min_history_us: args.min_history_us,
        forecast_horizon_us: args.forecast_horizon_us,
        forecast_step_us: args.forecast_step_us,
        ..SessionConfig::default()
    };
    let (stop, mut stopped) = tokio::sync::watch::channel(false);
    let gateway = service::Gateway::new(scenes, config, stop.clone());

    let incoming = tonic::transport::server::TcpIncoming::bind(args.listen)
        .with_context(|| format!("binding {}", args.listen))?
        .with_nodelay(Some(true));
    tracing::info!(address = %args.listen, "traffic service listening");
    let signals = async move {
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
            .expect("a SIGTERM handler");
        tokio::select! {
            _ = tokio::signal::ctrl_c() => tracing::info!("SIGINT: stopping"),
            _ = term.recv() => tracing::info!("SIGTERM: stopping"),
            _ = stopped.wait_for(|s| *s) => {}
        }
    };
    serve(gateway, incoming, signals).await?;
    tracing::info!("traffic service stopped");
    Ok(())
}
