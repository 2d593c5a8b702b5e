//! trafficmesh-pedestrians: walkers and cyclists crossing the map's crosswalks
//! on the stepper's clock, published as agent footprints on
//! `<cluster>/agents/pedestrians` ten times a simulated second.

use std::process::ExitCode;

use anyhow::{Result, bail};
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Lane, Role, runtime};
use trafficmesh_protocol::wire::{Agent, AgentBatch, Clock};
use trafficmesh_service::MapArgs;
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
    /// Step every tick on the crosswalks service's lockstep questions (answers
    /// on <cluster>/lockstep/agents/pedestrians) instead of following the clock.
    #[arg(long)]
    lockstep: bool,
}

/// The walkers and cyclists as agent footprints at `time`.
fn batch(people: &Pedestrians, time: f64) -> AgentBatch {
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
    AgentBatch { time, agents }
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
        let out = bus
            .publisher(keys.agents("pedestrians"), Lane::Reliable)
            .await?;
        let mut last: Option<f64> = None;
        let run = async {
            if args.lockstep {
                // Every tick, as a world that runs its own walkers steps them;
                // the agents also go out ten times a simulated second for others.
                let key = keys.lockstep_agents("pedestrians");
                bus.answer_ticks(&key, |tick| {
                    people.step(tick.time, tick.dt);
                    let agents = batch(&people, tick.time);
                    let due = last.is_none_or(|t| tick.time - t >= 0.1);
                    if due {
                        last = Some(tick.time);
                    }
                    let out = &out;
                    async move {
                        if due && let Err(e) = out.put(&agents).await {
                            tracing::warn!("cannot publish the agents: {e}");
                        }
                        agents
                    }
                })
                .await?;
                return anyhow::Ok(());
            }
            let clock = bus.subscribe(&keys.clock()).await?;
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
                out.put(&batch(&people, c.time)).await?;
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
