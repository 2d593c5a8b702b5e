//! The skeleton every cluster service shares, written once: the bus, the map
//! check against the stepper's, the status, following the stepper's clock or
//! its lockstep questions, and stopping on a signal. A service is a
//! [`Service`] impl (its state, its own topics, what it does per tick) and a
//! `main` that builds it from its flags and hands it to [`run`].

use std::future::Future;
use std::sync::Arc;

use anyhow::Result;
use serde::Serialize;
use trafficmesh_bus::{Bus, BusArgs, Role, runtime};
use trafficmesh_protocol::wire::{Clock, LockstepTick};
use trafficmesh_protocol::{Keys, topics};

use crate::MapArgs;

/// The flags every cluster service takes besides its own.
#[derive(clap::Args, Clone, Debug)]
pub struct ServiceArgs {
    #[command(flatten)]
    pub bus: BusArgs,
    #[command(flatten)]
    pub map: MapArgs,
    /// Advance on the lockstep questions of the stepper (or of the crosswalks,
    /// for agent sources) instead of following the clock; `trafficmesh up`
    /// turns it on with `--speed 0`. Keys: docs/cluster.md, "Lockstep".
    #[arg(long)]
    pub lockstep: bool,
}

/// A cluster service: a state advanced on the stepper's clock, its own
/// topics, and a status. Methods take `&self`: the state keeps its mutable
/// parts behind a lock, held only between awaits.
pub trait Service: Send + Sync + Sized + 'static {
    /// Its name on the bus: the status key, the lockstep member, the logs.
    const NAME: &'static str;
    /// Async worker threads it needs.
    const WORKERS: usize = 1;
    /// What it answers a lockstep question with.
    type Answer: Serialize + Send;

    /// The simulation time reached and its own counters, for its status.
    fn status(&self) -> (f64, serde_json::Value);

    /// Declares its own subscriptions and queryables (each on a task of its
    /// own); runs once, before it follows the clock.
    fn start(self: &Arc<Self>, bus: &Arc<Bus>) -> impl Future<Output = Result<()>> + Send {
        let _ = bus;
        async { Ok(()) }
    }

    /// One tick of the stepper's clock, free-running (the latest one: ticks
    /// it was too slow for are skipped).
    fn on_clock(&self, bus: &Arc<Bus>, clock: Clock) -> impl Future<Output = Result<()>> + Send;

    /// One lockstep question: advance to its tick and answer it.
    fn on_tick(
        &self,
        bus: &Arc<Bus>,
        tick: LockstepTick,
    ) -> impl Future<Output = Self::Answer> + Send;

    /// Where its lockstep questions come.
    fn lockstep_key(keys: &Keys) -> String {
        keys.key_at(&topics::LOCKSTEP_STEP, Self::NAME)
    }

    /// After a stop signal or the end of the clock: last writes.
    fn stop(&self) -> Result<()> {
        Ok(())
    }
}

/// Runs `service`, built on the map with fingerprint `map` (see
/// `LaneNetwork::fingerprint`), until SIGINT or SIGTERM: joins the bus
/// (refusing a stepper on another map), serves its status, starts its topics
/// and follows the clock or the lockstep questions.
pub fn run<S: Service>(args: &ServiceArgs, map: u64, service: S) -> Result<()> {
    args.bus.keys()?;
    runtime::tokio_runtime(S::WORKERS)?.block_on(async move {
        // In place before the service shows up on the bus.
        let signal = runtime::shutdown_signal();
        let bus = Arc::new(Bus::open_service(&args.bus, Role::Member, S::NAME).await?);
        let service = Arc::new(service);
        trafficmesh_bus::check_map(&bus, map).await?;
        let status = service.clone();
        trafficmesh_bus::serve_status(bus.clone(), Some(map), Arc::new(move || status.status()));
        service.start(&bus).await?;
        tokio::select! {
            r = follow(&bus, &service, args.lockstep) => r?,
            _ = signal => {}
            e = trafficmesh_bus::another_map(&bus, map) => return Err(e.into()),
        }
        service.stop()
    })
}

/// The clock or the lockstep questions, until the bus closes.
async fn follow<S: Service>(bus: &Arc<Bus>, service: &Arc<S>, lockstep: bool) -> Result<()> {
    if lockstep {
        let key = S::lockstep_key(bus.keys());
        bus.answer_ticks(&key, |tick| service.on_tick(bus, tick))
            .await?;
        return Ok(());
    }
    let clock = bus.subscribe_to(&topics::CLOCK).await?;
    while let Some(c) = clock.latest(bus).await {
        service.on_clock(bus, c).await?;
    }
    Ok(())
}
