//! trafficmesh-admin: the REST admin of a cluster (axum on 127.0.0.1:8080 by
//! default). Talks to the other services only over Zenoh.

mod api;
mod live;
mod mapinfo;
mod metrics;
mod problem;
mod tls;
mod token;
mod view;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Role, runtime};
use trafficmesh_service::MapArgs;
use trafficmesh_service::settings::AdminSettings;

#[derive(Parser)]
#[command(
    name = "trafficmesh-admin",
    version,
    about = "REST admin of a trafficmesh cluster: spawn config, branch CSV, vehicles, lights, crosswalks, /metrics, and a live map at /",
    after_help = "Usually started by `trafficmesh up`. API documentation: /swagger-ui and /api/v1/openapi.json on the listening address.\n\
Mutating endpoints need `Authorization: Bearer <token>`: the token is --token or TRAFFICMESH_ADMIN_TOKEN, else the token file; \
when neither exists a token is generated, written to the token file (mode 0600) and printed once."
)]
struct Args {
    #[command(flatten)]
    bus: BusArgs,
    #[command(flatten)]
    map: MapArgs,
    #[command(flatten)]
    settings: AdminSettings,
    /// Services whose absence makes the cluster degraded.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = trafficmesh_bus::REQUIRED_SERVICES
    )]
    expect: Vec<String>,
}

fn main() -> ExitCode {
    runtime::main_with(|| run(Args::parse()))
}

fn default_token_file() -> PathBuf {
    let home = std::env::var_os("HOME")
        .map(PathBuf::from)
        .unwrap_or_else(|| ".".into());
    home.join(".config/trafficmesh/admin.token")
}

fn run(args: Args) -> Result<()> {
    let settings = &args.settings;
    trafficmesh_service::check_flags(settings)?;
    let request_timeout = Duration::from_secs_f64(settings.request_timeout);
    let bus_timeout = Duration::from_secs_f64(settings.bus_timeout);
    args.bus.keys()?;
    let net = args.map.load()?;
    let token_file = settings
        .token_file
        .clone()
        .unwrap_or_else(default_token_file);
    let (token, source) = token::resolve(settings.token.clone(), &token_file)?;
    // A certificate that cannot serve is a configuration error, found at once.
    let tls = match (&settings.tls_cert, &settings.tls_key) {
        (Some(cert), Some(key)) => Some(tls::acceptor(cert, key)?),
        _ => None,
    };
    if source == token::Source::Generated {
        // The one time the token is shown; it is never logged.
        println!(
            "admin token (generated, saved to {}; shown only now): {token}",
            token_file.display()
        );
    }
    runtime::tokio_runtime(2)?.block_on(async move {
        let metrics = metrics::install()?;
        let bus = Arc::new(Bus::open_service(&args.bus, Role::Member, "admin").await?);
        let map = net.fingerprint();
        trafficmesh_bus::check_map(&bus, map).await?;
        let view = Arc::new(view::ClusterView::default());
        view.follow(bus.clone(), net.light_groups.len(), net.crosswalks.len())
            .await?;
        let (status_view, bind) = (view.clone(), settings.listen.to_string());
        trafficmesh_bus::serve_status(
            bus.clone(),
            Some(map),
            Arc::new(move || {
                let time = status_view.read().clock.as_ref().map_or(0.0, |c| c.time);
                (time, serde_json::json!({ "http": bind }))
            }),
        );
        let refuse = bus.clone();
        let app = Arc::new(api::App {
            bus,
            view,
            map: mapinfo::MapInfo::new(net),
            token,
            metrics,
            expected: args.expect.clone(),
            bus_timeout,
        });
        let limits = api::Limits {
            max_body_bytes: settings.max_body_bytes,
            request_timeout,
            cors_origins: settings.cors_origins.clone(),
        };
        let router = api::router(app, &limits);
        // In place before the admin answers.
        let signal = runtime::shutdown_signal();
        let listener = tokio::net::TcpListener::bind(settings.listen)
            .await
            .with_context(|| format!("cannot listen on {}", settings.listen))?;
        let local = listener.local_addr()?;
        let scheme = if tls.is_some() { "https" } else { "http" };
        tracing::info!(
            "admin on {scheme}://{local}: live map at /, API docs at /swagger-ui, metrics at /metrics",
        );
        let serving = async move {
            match tls {
                Some(acceptor) => {
                    let listener = tls::TlsListener::new(listener, acceptor)?;
                    axum::serve(listener, router)
                        .with_graceful_shutdown(signal)
                        .await
                }
                None => axum::serve(listener, router).with_graceful_shutdown(signal).await,
            }
        };
        tokio::select! {
            r = serving => r?,
            e = trafficmesh_bus::another_map(&refuse, map) => return Err(e.into()),
        }
        Ok(())
    })
}
