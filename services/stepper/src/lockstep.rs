//! Lockstep: before each tick the stepper asks every member (lights,
//! crosswalks, spawner, and any process that declared itself one) for its
//! inputs to that tick, and starts the tick only when the required members
//! have answered. With every input tied to a tick, the cluster runs the same
//! trajectories as `sim` on the same map, config and seed, at any speed.

use std::collections::BTreeMap;
use std::sync::Arc;
use trafficmesh_protocol::topics;

use trafficmesh_bus::Bus;
use trafficmesh_protocol::wire::{LockstepTick, SpawnVerdict, TickReport};
use trafficmesh_sim::World;

use crate::commands::InputState;

pub struct Lockstep {
    bus: Arc<Bus>,
    runtime: tokio::runtime::Handle,
    /// `<cluster>/lockstep/step/*`.
    key: String,
    /// Members without whose answer no tick starts.
    required: Vec<String>,
    /// The verdicts on the spawner's last orders, sent with the next round.
    pub verdicts: Vec<SpawnVerdict>,
    /// Who answered the last round.
    pub members: Vec<String>,
}

impl Lockstep {
    pub fn new(bus: Arc<Bus>, runtime: tokio::runtime::Handle, required: Vec<String>) -> Self {
        Lockstep {
            key: bus.keys().key_all(&topics::LOCKSTEP_STEP),
            bus,
            runtime,
            required,
            verdicts: Vec::new(),
            members: Vec::new(),
        }
    }

    /// The question for the tick `world` is about to run.
    pub fn question(&mut self, world: &World) -> LockstepTick {
        LockstepTick {
            tick: world.ticks(),
            time: world.time(),
            dt: world.config().dt,
            spawn_verdicts: std::mem::take(&mut self.verdicts),
        }
    }

    /// Every member's answer to `tick`, by member name; asks again until
    /// each required member has answered. `keep_going` runs between attempts
    /// (the tick thread's other inputs) and ends the wait with `None` when it
    /// returns false.
    pub fn round(
        &mut self,
        tick: &LockstepTick,
        keep_going: impl FnMut() -> bool,
    ) -> Option<BTreeMap<String, TickReport>> {
        let answers = self
            .runtime
            .block_on(self.bus.lockstep_round_of::<TickReport>(
                &self.key,
                tick,
                &self.required,
                keep_going,
            ))?;
        // Members come and go rarely: no copies while they stay the same.
        if !self.members.iter().eq(answers.keys()) {
            self.members = answers.keys().cloned().collect();
        }
        Some(answers)
    }
}

/// Applies the members' answers in name order; a state the world refuses
/// (unknown group or area) is counted as a bad payload of that member's key.
pub fn apply(
    bus: &Bus,
    world: &mut World,
    inputs: &mut InputState,
    answers: BTreeMap<String, TickReport>,
) {
    for (member, report) in answers {
        let reject = |reason: String| {
            bus.reject(&bus.keys().key_at(&topics::LOCKSTEP_STEP, &member), &reason)
        };
        match report {
            TickReport::Lights { changed, heartbeat } => {
                inputs.in_step.lights = true;
                for s in changed {
                    if let Err(e) =
                        world.set_remote_light(&s.group, s.color, s.valid_until, s.next_change)
                    {
                        reject(e.to_string());
                    }
                }
                if let Some(beat) = heartbeat {
                    world.extend_remote_lights(beat.valid_until);
                }
            }
            TickReport::Crosswalks { changed, heartbeat } => {
                inputs.in_step.crosswalks = true;
                for o in changed {
                    if let Err(e) =
                        world.set_crosswalk_occupants(&o.area, o.occupants.into_iter().collect())
                    {
                        reject(e.to_string());
                    }
                }
                if let Some(beat) = heartbeat {
                    inputs.crosswalks_valid_until = beat.valid_until;
                }
            }
            TickReport::Spawner { orders, config } => {
                inputs.in_step.spawner = true;
                if let Some(config) = config
                    && let Err(e) = world.set_spawn_config(config)
                {
                    reject(e.to_string());
                }
                inputs.queue_lockstep_spawns(world, orders);
            }
            TickReport::Ready => {}
        }
    }
}
