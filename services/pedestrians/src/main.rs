//! trafficmesh-pedestrians: walkers and cyclists crossing the map's crosswalks
//! on the stepper's clock, published as agent footprints on
//! `<cluster>/agents/pedestrians` ten times a simulated second.

use std::process::ExitCode;
use std::sync::{Arc, Mutex, MutexGuard};

use anyhow::Result;
use clap::Parser;
use trafficmesh_bus::{Bus, runtime};
use trafficmesh_protocol::wire::{Agent, AgentBatch, Clock, LightState, LockstepTick};
use trafficmesh_protocol::{Keys, topics};
use trafficmesh_service::settings::PedestriansSettings;
use trafficmesh_service::{Service, ServiceArgs};
use trafficmesh_sim::lights::{LightControl, Lights};
use trafficmesh_sim::network::LightGroup;
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
    service: ServiceArgs,
    /// Random seed of the crossings.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    settings: PedestriansSettings,
}

/// The walkers, the light groups their walk signals follow, and the last
/// time they were published.
struct Walkers {
    people: Pedestrians,
    /// Each group run as the lights service runs it: the map's program (so
    /// that walkers agree with it in lockstep too, tick for tick) until an
    /// override it publishes forces a colour or sets another program.
    lights: Lights,
    /// The map's groups, to read the lights' states by.
    groups: Vec<LightGroup>,
    last: Option<f64>,
}

impl Walkers {
    /// Walks on to `time`, each walk signal read from the groups' lights.
    fn step(&mut self, time: f64, dt: f64) {
        self.lights.update(time);
        let lights = &self.lights;
        self.people
            .step(time, dt, |g| lights.state(g as usize).color);
    }

    /// Takes up what the lights service says a group is doing: forced to a
    /// colour, on an admin's program, or back on the map's.
    fn follow(&mut self, state: &LightState) {
        let Some(g) = self.groups.iter().position(|g| g.name == state.group) else {
            return;
        };
        let forced = state.forced.then_some(state.color);
        let control = LightControl::from_override(forced, state.program, self.groups[g].program);
        if self.lights.control(g) != control {
            tracing::info!(
                "walk signals of light group '{}' follow {control:?}",
                state.group
            );
            // Programs run on absolute time and a forced colour on none: set
            // at the last step, the next step reads the group right.
            self.lights
                .set_control(g, control, self.last.unwrap_or(0.0));
        }
    }
}

struct PedestriansService {
    walkers: Mutex<Walkers>,
}

/// The walkers and cyclists as agent footprints at `time`.
fn batch(people: &Pedestrians, time: f64) -> AgentBatch {
    let agents = people
        .agents()
        .into_iter()
        .map(|a| Agent {
            id: a.id,
            root: a.root,
            kind: a.kind.name().into(),
            footprint: a.footprint.iter().map(|p| [p.x, p.y]).collect(),
        })
        .collect();
    AgentBatch { time, agents }
}

fn main() -> ExitCode {
    runtime::main_with(|| {
        let args = Args::parse();
        trafficmesh_service::check_flags(&args.settings)?;
        let net = args.service.map.load()?;
        let config = PedestrianConfig {
            per_minute: args.settings.per_minute,
            cyclist_share: args.settings.cyclist_share,
            ..PedestrianConfig::default()
        };
        let service = PedestriansService {
            walkers: Mutex::new(Walkers {
                people: Pedestrians::new(&net.crosswalks, config, args.seed),
                lights: Lights::new(net.light_groups.iter().map(|g| g.program)),
                groups: net.light_groups.clone(),
                last: None,
            }),
        };
        trafficmesh_service::run(&args.service, net.fingerprint(), service)
    })
}

impl PedestriansService {
    fn walkers(&self) -> MutexGuard<'_, Walkers> {
        self.walkers.lock().expect("walkers lock")
    }
}

impl Service for PedestriansService {
    const NAME: &'static str = "pedestrians";
    type Answer = AgentBatch;

    async fn start(self: &Arc<Self>, bus: &Arc<Bus>) -> Result<()> {
        let states = bus.subscribe_to(&topics::LIGHT_STATE).await?;
        let (bus, service) = (bus.clone(), self.clone());
        tokio::spawn(async move {
            // The overrides in force before this service started, then
            // every change.
            let all = bus.keys().key_all(&topics::LIGHT_STATE);
            let current = bus
                .get_each::<LightState>(&all, trafficmesh_service::LATE_STATES_WAIT)
                .await;
            for s in current.unwrap_or_default() {
                service.walkers().follow(&s);
            }
            while let Some((_, s)) = states.next(&bus).await {
                service.walkers().follow(&s);
            }
        });
        Ok(())
    }

    fn status(&self) -> (f64, serde_json::Value) {
        let w = self.walkers();
        let agents = w.people.agents().len();
        (
            w.last.unwrap_or(0.0),
            serde_json::json!({ "agents": agents }),
        )
    }

    /// Ten updates per simulated second are plenty for walkers.
    async fn on_clock(&self, bus: &Arc<Bus>, c: Clock) -> Result<()> {
        let agents = {
            let mut w = self.walkers();
            let Some(prev) = w.last else {
                w.last = Some(c.time);
                return Ok(());
            };
            if !(c.time.is_finite() && c.time - prev >= 0.1) {
                return Ok(());
            }
            w.step(c.time, c.time - prev);
            w.last = Some(c.time);
            batch(&w.people, c.time)
        };
        bus.publish_at(&topics::AGENTS, Self::NAME, &agents).await?;
        Ok(())
    }

    /// Every tick, as a world that runs its own walkers steps them; the
    /// agents also go out ten times a simulated second for others.
    async fn on_tick(&self, bus: &Arc<Bus>, tick: LockstepTick) -> AgentBatch {
        let (agents, due) = {
            let mut w = self.walkers();
            w.step(tick.time, tick.dt);
            let due = w.last.is_none_or(|t| tick.time - t >= 0.1);
            if due {
                w.last = Some(tick.time);
            }
            (batch(&w.people, tick.time), due)
        };
        if due && let Err(e) = bus.publish_at(&topics::AGENTS, Self::NAME, &agents).await {
            tracing::warn!("cannot publish the agents: {e}");
        }
        agents
    }

    fn lockstep_key(keys: &Keys) -> String {
        keys.key_at(&topics::LOCKSTEP_AGENTS, Self::NAME)
    }
}
