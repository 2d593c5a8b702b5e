//! `trafficmesh`: the command line. Each subcommand lives in its own module;
//! this file is the list of them.

mod commands;
mod output;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "trafficmesh",
    version,
    about = "Deterministic NPC traffic simulation for autonomous-driving and traffic studies",
    after_help = "Examples:
  trafficmesh up                       # the whole cluster, configs/cluster.toml
  trafficmesh watch                    # one summary line per second from the bus
  trafficmesh ego --x 10 --y -3.5 --yaw 0
  trafficmesh sim --map configs/maps/four_way.map.json --duration 600 --out out
  trafficmesh gen-grid --size 5 --out grid5.map.json
  trafficmesh sim --map grid5.map.json --duration 1800 --max-vehicles 250 --seed 3 --json
  trafficmesh bench tick --size 40 --vehicles 10000"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the simulation headless in one process, as fast as it goes.
    Sim(commands::sim::SimArgs),
    /// Write an N x N signalised grid map (two lanes per direction).
    GenGrid(commands::gen_grid::GenGridArgs),
    /// Convert a SUMO network (.net.xml) or Lanelet2 map (.osm) to the native map format, with a summary.
    Import(commands::import::ImportArgs),
    /// Start the whole cluster on this machine (every service a child process).
    Up(commands::up::UpArgs),
    /// Print a live one-line summary per second from the bus.
    Watch(commands::watch::WatchArgs),
    /// Publish an ego vehicle pose on the bus.
    Ego(commands::ego::EgoArgs),
    /// The Zenoh router of a cluster spread over several hosts (see deploy/).
    Router(commands::router::RouterArgs),
    /// The cluster's health from any host: services, hosts, lag, errors.
    Status(commands::status::StatusArgs),
    /// Benchmarks that print their figures.
    #[cfg(feature = "bench")]
    #[command(subcommand)]
    Bench(commands::bench::BenchCommand),
}

fn main() -> ExitCode {
    trafficmesh_bus::runtime::init_logging();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Sim(args) => commands::sim::run(args),
        Command::GenGrid(args) => commands::gen_grid::run(args),
        Command::Import(args) => commands::import::run(args),
        #[cfg(feature = "bench")]
        Command::Bench(cmd) => commands::bench::run(cmd),
        Command::Up(args) => commands::up::run(args),
        Command::Watch(args) => commands::watch::run(args),
        Command::Ego(args) => commands::ego::run(args),
        Command::Router(args) => commands::router::run(args),
        Command::Status(args) => commands::status::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            // Bad arguments and bad files: the same exit code clap uses for usage errors.
            ExitCode::from(2)
        }
    }
}

/// The error and its causes, each cause once: file errors already quote the
/// error they wrap.
fn error_chain(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text = format!("{text}: {cause}");
        }
    }
    text
}
