//! The tick thread: commands in, one world step, output out, then wait for the
//! next tick's wall-clock deadline (unless running as fast as possible).

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::{Duration, Instant};

use trafficmesh_protocol::wire::{Clock, Event};
use trafficmesh_sim::World;

use trafficmesh_bus::Bus;

use crate::commands::{self, Input, InputState};
use crate::inputs::Shared;
use crate::lockstep::{self, Lockstep};
use crate::telemetry::{Outputs, TickOutput, wire_events};

pub struct Pacing {
    /// Simulation seconds per wall second; 0 = as fast as possible.
    pub speed: f64,
    pub duration: Option<f64>,
    /// Each tick waits for the lockstep members' answers.
    pub lockstep: Option<Lockstep>,
    /// Saves the road every few simulated seconds.
    pub saver: Option<crate::snapshots::Saver>,
}

/// Applies what arrived since the last tick, in arrival order; false on Stop.
fn drain(
    world: &mut World,
    inputs: &mut InputState,
    inputs_rx: &Receiver<Input>,
    bus: &Bus,
) -> bool {
    loop {
        match inputs_rx.try_recv() {
            Ok(input) => match commands::apply(world, inputs, input.command) {
                Ok(true) => {}
                Ok(false) => return false,
                Err(reason) => bus.reject(&input.key, &reason),
            },
            Err(TryRecvError::Empty) => return true,
            Err(TryRecvError::Disconnected) => return false,
        }
    }
}

/// Runs the ticks until stopped (or the duration is over), then saves the
/// last road when snapshots are on: a stepper stopped on purpose loses none.
pub fn run(
    mut world: World,
    inputs_rx: Receiver<Input>,
    bus: Arc<Bus>,
    outputs: Outputs,
    mut pacing: Pacing,
    shared: Arc<Shared>,
) {
    ticks(&mut world, inputs_rx, bus, outputs, &mut pacing, shared);
    if let Some(saver) = pacing.saver.take() {
        saver.save_last(world.snapshot());
    }
}

fn ticks(
    world: &mut World,
    inputs_rx: Receiver<Input>,
    bus: Arc<Bus>,
    mut outputs: Outputs,
    pacing: &mut Pacing,
    shared: Arc<Shared>,
) {
    let dt = world.config().dt;
    let mut inputs = InputState::default();
    // Real time runs from where the road starts (a resumed one mid-run).
    let (started, start_time) = (Instant::now(), world.time());
    let mut rate_window = (Instant::now(), 0u64);
    let mut tick_rate = 0.0;
    let (mut spawned, mut despawned, mut arrived) = (0u64, 0u64, 0u64);
    let mut stuck = 0;
    loop {
        if !drain(world, &mut inputs, &inputs_rx, &bus) {
            return;
        }
        if let Some(lockstep) = &mut pacing.lockstep {
            let question = lockstep.question(world);
            let answers = lockstep.round(&question, || drain(world, &mut inputs, &inputs_rx, &bus));
            let Some(answers) = answers else { return };
            lockstep::apply(&bus, world, &mut inputs, answers);
        }
        let stale = world.time() > inputs.crosswalks_valid_until;
        if stale != world.occupancy().is_stale() {
            tracing::info!(
                "crosswalk states {} at t={:.2} (valid until {:.2})",
                if stale {
                    "went stale: every crosswalk counts as blocked"
                } else {
                    "are fresh again"
                },
                world.time(),
                inputs.crosswalks_valid_until
            );
        }
        world.set_crosswalks_stale(stale);
        let t0 = Instant::now();
        world.step();
        let tick_ms = t0.elapsed().as_secs_f64() * 1e3;
        let verdicts = inputs.finish_spawns(world);
        if let Some(lockstep) = &mut pacing.lockstep {
            lockstep.verdicts = verdicts;
        }

        let raw: Vec<_> = world.drain_events().collect();
        let events: Vec<Event> = wire_events(world, raw);
        for e in &events {
            match e {
                Event::Spawned { .. } => spawned += 1,
                Event::Despawned { reason, .. } => {
                    despawned += 1;
                    if matches!(reason.as_str(), "route_end" | "dead_end") {
                        arrived += 1;
                    }
                }
                Event::ZebraStop { .. }
                | Event::ZebraClear { .. }
                | Event::BranchDecision { .. } => {}
            }
        }
        rate_window.1 += 1;
        if rate_window.0.elapsed() >= Duration::from_secs(1) {
            tick_rate = rate_window.1 as f64 / rate_window.0.elapsed().as_secs_f64();
            rate_window = (Instant::now(), 0);
            // A scan of every vehicle: once a second, not every tick.
            stuck = world.stuck_vehicles();
        }
        let clock = Clock {
            tick: world.ticks(),
            time: world.time(),
            dt,
            vehicles: world.vehicles().len(),
            tick_ms,
            tick_rate,
        };
        {
            let mut s = shared.status.lock().expect("status lock");
            s.tick = clock.tick;
            s.time = clock.time;
            s.vehicles = clock.vehicles;
            s.tick_ms = tick_ms;
            s.tick_rate = tick_rate;
            s.spawned = spawned;
            s.despawned = despawned;
            s.inserted = spawned;
            s.arrived = arrived;
            let waits = world.wait_stats_so_far();
            s.max_wait_s = waits.max_wait;
            s.stuck_vehicles = stuck;
            s.stuck_vehicles_mean = waits.stuck_mean();
            s.jam_resolutions = waits.jam_resolutions;
            s.jam_removals = waits.jam_removals;
            s.gridlocks_broken = waits.gridlocks_broken;
            s.gridlocks_squeezed = waits.gridlocks_squeezed;
            s.red_light_crossings = world.red_light_crossings();
            s.batches_dropped = outputs.dropped.load(Ordering::Relaxed);
            s.crosswalks_stale = world.occupancy().is_stale();
            s.lights_stale = world.lights_stale();
            s.trajectory_hash = world.trajectory_hash();
            if let Some(lockstep) = &pacing.lockstep
                && s.lockstep_members != lockstep.members
            {
                s.lockstep_members.clone_from(&lockstep.members);
            }
        }
        if let Some(saver) = &mut pacing.saver
            && saver.due(world.time())
        {
            saver.save(world.snapshot());
        }
        let vehicles = outputs.vehicle_states(world);
        outputs.offer(TickOutput {
            clock,
            vehicles,
            events,
        });
        if pacing.duration.is_some_and(|d| world.time() >= d - 1e-9) {
            tracing::info!(
                "ran the duration: tick {}, t={:.2} s, {spawned} inserted, {arrived} arrived, trajectory hash {:016x}",
                world.ticks(),
                world.time(),
                world.trajectory_hash()
            );
            return;
        }
        if pacing.speed > 0.0 {
            let due = started + Duration::from_secs_f64((world.time() - start_time) / pacing.speed);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
    }
}
