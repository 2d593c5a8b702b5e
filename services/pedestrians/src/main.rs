//! trafficmesh-pedestrians: walkers and cyclists crossing the map's crosswalks
//! on the stepper's clock, published as agent footprints on
//! `<cluster>/agents/pedestrians` ten times a simulated second.

use std::process::ExitCode;

use anyhow::{Result, bail};
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Lane, Role, runtime};
use trafficmesh_maps::MapArgs;
use trafficmesh_model::wire::{Agent, AgentBatch, Clock};
use trafficmesh_sim::pedestrians::{PedestrianConfig, Pedestrians};

#[derive(Parser)]
#[command(
    name = "trafficmesh-pedestrians",
    version,
    about = "Pedestrians and cyclists crossing the map's crosswalks",
    after_help = "Usually started by `trafficmesh up`. Keys: see docs/cluster.md."
)]
struct Args {
    #[command(flatten)]
    bus: BusArgs,
    #[command(flatten)]
    map: MapArgs,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Crossings started per minute on each crosswalk (0 = nobody crosses).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    per_minute: f64,
    /// Share of crossings made by cyclists, 0 to 1.
    #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
    cyclist_share: f64,
}

fn main() -> ExitCode {
    runtime::main_with(|| run(Args::parse()))
}

fn run(args: Args) -> Result<()> {
    if !(args.per_minute.is_finite() && args.per_minute >= 0.0) {
        bail!(
            "--per-minute must be a number >= 0, got {}",
            args.per_minute
        );
    }
    if !(0.0..=1.0).contains(&args.cyclist_share) {
        bail!(
            "--cyclist-share must be between 0 and 1, got {}",
            args.cyclist_share
        );
    }
    args.bus.keys()?;
    let net = args.map.load()?;
    let config = PedestrianConfig {
        per_minute: args.per_minute,
        cyclist_share: args.cyclist_share,
        ..PedestrianConfig::default()
    };
    let mut people = Pedestrians::new(&net.crosswalks, config, args.seed);
    runtime::tokio_runtime(1)?.block_on(async move {
        let bus = Bus::open_service(&args.bus, Role::Member, "pedestrians").await?;
        let keys = bus.keys().clone();
        let clock = bus.subscribe(&keys.clock()).await?;
        let out = bus
            .publisher(keys.agents("pedestrians"), Lane::Reliable)
            .await?;
        let mut last: Option<f64> = None;
        let run = async {
            while let Some(c) = bus.next_latest::<Clock>(&clock).await {
                let Some(prev) = last else {
                    last = Some(c.time);
                    continue;
                };
                // Ten updates per simulated second are plenty for walkers.
                if !(c.time.is_finite() && c.time - prev >= 0.1) {
                    continue;
                }
                people.step(c.time, c.time - prev);
                last = Some(c.time);
                let agents = people
                    .agents()
                    .into_iter()
                    .map(|a| Agent {
                        id: a.id,
                        root: a.root,
                        kind: match a.kind {
                            trafficmesh_sim::crosswalk::OccupantType::SimpleCyclistMovement => {
                                "SimpleCyclistMovement".into()
                            }
                            _ => "NPCPedestrian".into(),
                        },
                        footprint: a.footprint.iter().map(|p| [p.x, p.y]).collect(),
                    })
                    .collect();
                out.put(&AgentBatch {
                    time: c.time,
                    agents,
                })
                .await?;
            }
            anyhow::Ok(())
        };
        tokio::select! {
            r = run => r?,
            _ = runtime::shutdown_signal() => {}
        }
        Ok(())
    })
}
