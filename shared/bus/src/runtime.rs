//! What every service process does the same way: logging and shutdown.

/// Logs to stderr, `RUST_LOG` overriding the default (info, zenoh's own warnings).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| "info,zenoh=warn,zenoh_transport=warn,zenoh_link_tcp=warn".into());
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}

/// Resolves on SIGINT or SIGTERM. The handlers are in place once this
/// returns, not only once the future is first polled: a service that says it
/// is ready and then takes a signal stops gracefully instead of being killed.
/// Call it within the runtime.
pub fn shutdown_signal() -> impl std::future::Future<Output = ()> + Send + 'static {
    use tokio::signal::unix::{SignalKind, signal};
    let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
    let mut int = signal(SignalKind::interrupt()).expect("SIGINT handler");
    async move {
        tokio::select! {
            _ = term.recv() => tracing::info!("SIGTERM received, stopping"),
            _ = int.recv() => tracing::info!("SIGINT received, stopping"),
        }
    }
}

/// A service's `main`: logging, then `run`; an error is printed with its
/// causes and ends the process with exit code 2 (bad flags, files, config).
pub fn main_with(run: impl FnOnce() -> anyhow::Result<()>) -> std::process::ExitCode {
    init_logging();
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

/// The async runtime of a service or client command, `workers` threads.
pub fn tokio_runtime(workers: usize) -> anyhow::Result<tokio::runtime::Runtime> {
    use anyhow::Context;
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(workers)
        .enable_all()
        .build()
        .context("cannot start the async runtime")
}

/// Wall clock in microseconds since the Unix epoch (batch timestamps, latency).
pub fn unix_micros() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0)
}

/// Names that become key chunks (light groups, crosswalks) must be plain.
pub fn check_key_names<'a>(
    what: &str,
    names: impl IntoIterator<Item = &'a str>,
) -> anyhow::Result<()> {
    match names
        .into_iter()
        .find(|n| !trafficmesh_protocol::is_plain_chunk(n))
    {
        Some(n) => anyhow::bail!(
            "{what} '{n}': a name used in a key must not contain '/', '*', '$', '?', '#' or spaces"
        ),
        None => Ok(()),
    }
}
