//! The traffic service: the gRPC gateway a simulation runtime (NVIDIA's
//! alpasim and its forks) calls for its background actors. Each session
//! replays the logged actors until handover, then trafficmesh's NPC model
//! drives them, reacting to the ego.

mod catalogue;
mod service;

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use trafficmesh_sim::session::SessionConfig;

mod proto {
    pub mod common {
        tonic::include_proto!("common");
    }
    pub mod traffic {
        tonic::include_proto!("traffic");
    }
    pub const DESCRIPTORS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/descriptors.bin"));
}

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

    let (health, health_service) = tonic_health::server::health_reporter();
    health
        .set_serving::<proto::traffic::traffic_service_server::TrafficServiceServer<service::Gateway>>()
        .await;
    // Both reflection versions: grpcurl asks for v1, older tools for v1alpha.
    let reflection = || {
        tonic_reflection::server::Builder::configure()
            .register_encoded_file_descriptor_set(proto::DESCRIPTORS)
            .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
    };
    let reflection_v1 = reflection()
        .build_v1()
        .context("building the reflection service")?;
    let reflection_v1alpha = reflection()
        .build_v1alpha()
        .context("building the reflection service")?;

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
    tonic::transport::Server::builder()
        .add_service(health_service)
        .add_service(reflection_v1)
        .add_service(reflection_v1alpha)
        .add_service(proto::traffic::traffic_service_server::TrafficServiceServer::new(gateway))
        .serve_with_incoming_shutdown(incoming, signals)
        .await
        .context("serving gRPC")?;
    tracing::info!("traffic service stopped");
    Ok(())
}
