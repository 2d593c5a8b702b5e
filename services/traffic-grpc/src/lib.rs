//! The traffic service: `traffic.TrafficService` over gRPC, the gateway a
//! simulation runtime (NVIDIA's alpasim and its forks) calls for its
//! background actors, with the standard health service and server reflection.

pub mod bench;
pub mod catalogue;
pub mod codec;
pub mod service;
pub mod trajectory;

use anyhow::{Context, Result};

/// The generated messages and service of the project's .proto files.
pub mod proto {
    pub mod common {
        tonic::include_proto!("common");
        pub use crate::trajectory::Trajectory;
    }
    pub mod traffic {
        tonic::include_proto!("traffic");
    }
    /// Their descriptor set, for server reflection.
    pub const DESCRIPTORS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/descriptors.bin"));
}

/// HTTP/2 flow-control window per stream, bytes.
pub const WINDOW: u32 = 4 << 20;

/// TLS for the gRPC server: PEM files read at start.
pub struct Tls {
    pub cert: std::path::PathBuf,
    pub key: std::path::PathBuf,
    /// Clients must present a certificate of this CA (mutual TLS).
    pub client_ca: Option<std::path::PathBuf>,
}

impl Tls {
    fn config(&self) -> Result<tonic::transport::ServerTlsConfig> {
        let read = |p: &std::path::Path| {
            std::fs::read(p).with_context(|| format!("reading the TLS file {}", p.display()))
        };
        let mut config = tonic::transport::ServerTlsConfig::new().identity(
            tonic::transport::Identity::from_pem(read(&self.cert)?, read(&self.key)?),
        );
        if let Some(ca) = &self.client_ca {
            config = config.client_ca_root(tonic::transport::Certificate::from_pem(read(ca)?));
        }
        Ok(config)
    }
}

/// Serves `gateway` with health and reflection on `incoming` until `stop`,
/// over TLS when `tls` is given.
pub async fn serve(
    gateway: service::Gateway,
    incoming: tonic::transport::server::TcpIncoming,
    tls: Option<&Tls>,
    stop: impl std::future::Future<Output = ()>,
) -> Result<()> {
    use proto::traffic::traffic_service_server::TrafficServiceServer;
    let (health, health_service) = tonic_health::server::health_reporter();
    health
        .set_serving::<TrafficServiceServer<service::Gateway>>()
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
    let mut server = tonic::transport::Server::builder();
    if let Some(tls) = tls {
        server = server
            .tls_config(tls.config()?)
            .context("the TLS certificate or key")?;
    }
    server
        // An answer of 200 actors with their forecasts is ~200 kB: windows
        // that hold it whole save a flow-control round trip per call, and
        // frames that large (grpcio's clients take 4 MB frames) a pass
        // through the HTTP/2 layers per 16 kB.
        .initial_stream_window_size(WINDOW)
        .initial_connection_window_size(4 * WINDOW)
        .max_frame_size(WINDOW)
        .add_service(health_service)
        .add_service(reflection_v1)
        .add_service(reflection_v1alpha)
        .add_service(TrafficServiceServer::new(gateway))
        .serve_with_incoming_shutdown(incoming, stop)
        .await
        .context("serving gRPC")
}
