//! trafficmesh-lights: runs each light group's fixed-time program on the
//! stepper's clock. Publishes a group's state when it changes, a heartbeat that
//! keeps every state valid, answers the current states and takes overrides
//! (kept in a file with `--overrides`, taken up again at start).

mod overrides;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex, MutexGuard};

use anyhow::Result;
use clap::Parser;
use trafficmesh_bus::{Bus, Vouch, runtime};
use trafficmesh_model::{LightColor, LightProgram};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{Clock, LightOverride, LightState, LockstepTick, TickReport};
use trafficmesh_service::settings::LightsSettings;
use trafficmesh_service::{Service, ServiceArgs};
use trafficmesh_sim::LaneNetwork;
use trafficmesh_sim::lights::{LightControl, Lights};

#[derive(Parser)]
#[command(
    name = "trafficmesh-lights",
    version,
    about = "Traffic-light programs on the stepper's clock: states, heartbeat, overrides",
    after_help = "Usually started by `trafficmesh up`. Keys: see docs/cluster.md."
)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
    #[command(flatten)]
    settings: LightsSettings,
}

struct Groups {
    net: LaneNetwork,
    lights: Lights,
    time: f64,
    published: Vec<Option<LightColor>>,
    vouch: Vouch,
    /// Where the overrides in force are kept, when they are.
    overrides_file: Option<PathBuf>,
}

impl Groups {
    /// Runs the programs to `time`; returns the groups whose colour changed.
    fn advance(&mut self, time: f64) -> Vec<LightState> {
        self.time = time;
        self.lights.update(time);
        let mut changed = Vec::new();
        for i in 0..self.published.len() {
            let color = self.lights.state(i).color;
            if self.published[i] != Some(color) {
                self.published[i] = Some(color);
                changed.push(self.state(i));
            }
        }
        changed
    }

    fn state(&self, g: usize) -> LightState {
        let s = self.lights.state(g);
        let map_group = &self.net.light_groups[g];
        let (forced, program) = self.lights.control(g).as_override(map_group.program);
        LightState {
            group: map_group.name.clone(),
            color: s.color,
            next_change: s.next_change.is_finite().then_some(s.next_change),
            valid_until: self.vouch.valid_until(self.time),
            forced: forced.is_some(),
            program,
        }
    }
}

struct LightsService {
    groups: Mutex<Groups>,
}

impl LightsService {
    fn groups(&self) -> MutexGuard<'_, Groups> {
        self.groups.lock().expect("lights lock")
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| {
        let args = Args::parse();
        trafficmesh_service::check_flags(&args.settings)?;
        let net = args.service.map.load()?;
        runtime::check_key_names(
            "light group",
            net.light_groups.iter().map(|g| g.name.as_str()),
        )?;
        let map = net.fingerprint();
        let mut groups = Groups {
            lights: Lights::new(net.light_groups.iter().map(|g| g.program)),
            time: 0.0,
            published: vec![None; net.light_groups.len()],
            vouch: Vouch::new(args.settings.validity),
            net,
            overrides_file: args.settings.overrides.clone(),
        };
        if let Some(path) = &args.settings.overrides {
            resume_overrides(&mut groups, path)?;
        }
        let service = LightsService {
            groups: Mutex::new(groups),
        };
        trafficmesh_service::run(&args.service, map, service)
    })
}

impl Service for LightsService {
    const NAME: &'static str = "lights";
    type Answer = TickReport;

    fn status(&self) -> (f64, serde_json::Value) {
        let g = self.groups();
        (g.time, serde_json::json!({ "groups": g.published.len() }))
    }

    async fn start(self: &Arc<Self>, bus: &Arc<Bus>) -> Result<()> {
        tokio::spawn(answer_states(bus.clone(), self.clone()));
        tokio::spawn(take_overrides(bus.clone(), self.clone()));
        Ok(())
    }

    /// States that changed, and a heartbeat every validity/4.
    async fn on_clock(&self, bus: &Arc<Bus>, c: Clock) -> Result<()> {
        let (changed, beat) = {
            let mut g = self.groups();
            (g.advance(c.time), g.vouch.due(c.time))
        };
        publish(bus, &changed).await;
        if let Some(b) = beat {
            bus.publish(&topics::LIGHTS_HEARTBEAT, &b).await?;
        }
        Ok(())
    }

    /// Each tick's changes go to the stepper with the answer, and on the
    /// state keys for everyone else.
    async fn on_tick(&self, bus: &Arc<Bus>, tick: LockstepTick) -> TickReport {
        let (changed, heartbeat) = {
            let mut g = self.groups();
            (g.advance(tick.time), g.vouch.due(tick.time))
        };
        publish(bus, &changed).await;
        TickReport::Lights { changed, heartbeat }
    }
}

async fn publish(bus: &Bus, states: &[LightState]) {
    for s in states {
        if let Err(e) = bus.publish_at(&topics::LIGHT_STATE, &s.group, s).await {
            tracing::warn!("cannot publish a light state: {e}");
        }
    }
}

/// `lights/state/*` as a query: every group's current state (late joiners).
async fn answer_states(bus: Arc<Bus>, lights: Arc<LightsService>) {
    let keys = bus.keys().clone();
    let Ok(queryable) = bus.queryable(&keys.key_all(&topics::LIGHT_STATE)).await else {
        tracing::error!("cannot declare {}", keys.key_all(&topics::LIGHT_STATE));
        return;
    };
    while let Ok(query) = queryable.recv_async().await {
        let states: Vec<LightState> = {
            let g = lights.groups();
            (0..g.published.len()).map(|i| g.state(i)).collect()
        };
        for s in states {
            let key = keys.key_at(&topics::LIGHT_STATE, &s.group);
            if query
                .key_expr()
                .intersects(&zenoh::key_expr::KeyExpr::try_from(key.as_str()).expect("plain key"))
            {
                bus.reply_at(&query, &key, &s).await;
            }
        }
    }
}

/// `lights/override`: force a colour, set a program, or return to the map's.
async fn take_overrides(bus: Arc<Bus>, lights: Arc<LightsService>) {
    let served = bus
        .serve(&topics::LIGHTS_OVERRIDE, |o: LightOverride| {
            let (state, to_save) = {
                let mut g = lights.groups();
                let state = apply_override(&mut g, &o);
                let to_save = g
                    .overrides_file
                    .clone()
                    .map(|path| (path, overrides::in_force(&g.net, &g.lights)));
                (state, to_save)
            };
            let bus = &bus;
            async move {
                let state = state?;
                tracing::info!("light group '{}' overridden: {:?}", o.group, state.color);
                // Saved before the answer: an override acknowledged is one
                // a restart keeps.
                if let Some((path, in_force)) = to_save {
                    let shown = path.display().to_string();
                    let saved =
                        tokio::task::spawn_blocking(move || overrides::save(path, &in_force)).await;
                    if let Ok(Err(e)) = saved {
                        tracing::warn!("cannot save the light overrides to {shown}: {e:#}");
                    }
                }
                publish(bus, std::slice::from_ref(&state)).await;
                Ok(state)
            }
        })
        .await;
    if let Err(e) = served {
        tracing::error!("cannot serve the light overrides: {e}");
    }
}

/// Takes up the overrides saved in `path` by a lights service before this one.
fn resume_overrides(g: &mut Groups, path: &std::path::Path) -> Result<()> {
    let saved = overrides::load(path, &g.net)?;
    for o in &saved {
        apply_override(g, o).map_err(|e| {
            anyhow::anyhow!(
                "{}: group '{}': {e}; move the file away to start from the map's programs",
                path.display(),
                o.group
            )
        })?;
    }
    if !saved.is_empty() {
        let names: Vec<&str> = saved.iter().map(|o| o.group.as_str()).collect();
        tracing::info!(
            "resumed the overrides of light groups {} from {}",
            names.join(", "),
            path.display()
        );
    }
    Ok(())
}

fn apply_override(g: &mut Groups, o: &LightOverride) -> Result<LightState, String> {
    let i = g
        .net
        .light_group(&o.group)
        .ok_or_else(|| format!("unknown light group '{}'", o.group))?;
    if o.color.is_some() && o.program.is_some() {
        return Err("give either color or program, not both".into());
    }
    if let Some(p) = &o.program {
        check_program(p)?;
    }
    let control = LightControl::from_override(o.color, o.program, g.net.light_groups[i].program);
    let t = g.time;
    g.lights.set_control(i, control, t);
    g.published[i] = Some(g.lights.state(i).color);
    Ok(g.state(i))
}

fn check_program(p: &LightProgram) -> Result<(), String> {
    match p.problems().first() {
        Some((field, problem)) => Err(format!("{field}: {problem}")),
        None => Ok(()),
    }
}
