//! trafficmesh-lights: runs each light group's fixed-time program on the
//! stepper's clock. Publishes a group's state when it changes, a heartbeat that
//! keeps every state valid, answers the current states and takes overrides.

use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use anyhow::{Result, bail};
use clap::Parser;
use trafficmesh_bus::{Bus, BusArgs, Lane, Role, Vouch, runtime};
use trafficmesh_model::{LightColor, LightProgram};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{Clock, LightOverride, LightState, TickReport};
use trafficmesh_service::MapArgs;
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
    bus: BusArgs,
    #[command(flatten)]
    map: MapArgs,
    /// Simulation seconds a published state stays valid without a heartbeat;
    /// after that the stepper counts the group red.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    validity: f64,
    /// Advance on the stepper's lockstep questions instead of its clock
    /// (answers on <cluster>/lockstep/step/lights; see the stepper's --lockstep).
    #[arg(long)]
    lockstep: bool,
}

struct Groups {
    net: LaneNetwork,
    lights: Lights,
    time: f64,
    published: Vec<Option<LightColor>>,
}

impl Groups {
    /// Runs the programs to `time`; returns the groups whose colour changed.
    fn advance(&mut self, time: f64, validity: f64) -> Vec<LightState> {
        self.time = time;
        self.lights.update(time);
        let mut changed = Vec::new();
        for i in 0..self.published.len() {
            let color = self.lights.state(i).color;
            if self.published[i] != Some(color) {
                self.published[i] = Some(color);
                changed.push(self.state(i, validity));
            }
        }
        changed
    }

    fn state(&self, g: usize, validity: f64) -> LightState {
        let s = self.lights.state(g);
        LightState {
            group: self.net.light_groups[g].name.clone(),
            color: s.color,
            next_change: s.next_change.is_finite().then_some(s.next_change),
            valid_until: self.time + validity,
            forced: matches!(self.lights.control(g), LightControl::Forced(_)),
        }
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| run(Args::parse()))
}

fn run(args: Args) -> Result<()> {
    if !(args.validity.is_finite() && args.validity > 0.0) {
        bail!(
            "--validity must be a positive number of seconds, got {}",
            args.validity
        );
    }
    args.bus.keys()?;
    let net = args.map.load()?;
    runtime::check_key_names(
        "light group",
        net.light_groups.iter().map(|g| g.name.as_str()),
    )?;
    let lights = Lights::new(net.light_groups.iter().map(|g| g.program));
    let n = net.light_groups.len();
    let groups = Arc::new(Mutex::new(Groups {
        net,
        lights,
        time: 0.0,
        published: vec![None; n],
    }));
    let validity = args.validity;
    runtime::tokio_runtime(1)?.block_on(async move {
        let bus = Bus::open_service(&args.bus, Role::Member, "lights").await?;
        let bus = Arc::new(bus);
        let status = groups.clone();
        let map = groups.lock().expect("lights lock").net.fingerprint();
        trafficmesh_bus::check_map(&bus, map).await?;
        trafficmesh_bus::serve_status(
            bus.clone(),
            Some(map),
            Arc::new(move || {
                let g = status.lock().expect("lights lock");
                (g.time, serde_json::json!({ "groups": g.published.len() }))
            }),
        );
        tokio::spawn(answer_states(bus.clone(), groups.clone(), validity));
        tokio::spawn(take_overrides(bus.clone(), groups.clone(), validity));
        let advance = async {
            if args.lockstep {
                follow_lockstep(bus.clone(), groups.clone(), validity).await
            } else {
                follow_clock(bus.clone(), groups.clone(), validity).await
            }
        };
        tokio::select! {
            r = advance => r?,
            _ = runtime::shutdown_signal() => {}
            e = trafficmesh_bus::another_map(&bus, map) => return Err(e.into()),
        }
        Ok(())
    })
}

/// On every clock tick: states that changed, and a heartbeat every validity/4.
async fn follow_clock(bus: Arc<Bus>, groups: Arc<Mutex<Groups>>, validity: f64) -> Result<()> {
    let keys = bus.keys().clone();
    let clock = bus.subscribe(&keys.clock()).await?;
    let heartbeat = bus
        .publisher(keys.lights_heartbeat(), Lane::Reliable)
        .await?;
    let mut vouch = Vouch::new(validity);
    while let Some(c) = bus.next_latest::<Clock>(&clock).await {
        let (changed, beat) = {
            let mut g = groups.lock().expect("lights lock");
            (g.advance(c.time, validity), vouch.due(c.time))
        };
        for s in changed {
            bus.publish_at(&topics::LIGHT_STATE, &s.group, &s).await?;
        }
        if let Some(b) = beat {
            heartbeat.put(&b).await?;
        }
    }
    Ok(())
}

/// In lockstep: each tick's changes go to the stepper with the answer, and
/// on the state keys for everyone else.
async fn follow_lockstep(bus: Arc<Bus>, groups: Arc<Mutex<Groups>>, validity: f64) -> Result<()> {
    let key = bus.keys().lockstep_member("lights");
    let mut vouch = Vouch::new(validity);
    bus.answer_ticks(&key, |tick| {
        let changed = groups
            .lock()
            .expect("lights lock")
            .advance(tick.time, validity);
        let heartbeat = vouch.due(tick.time);
        let bus = bus.clone();
        async move {
            for s in &changed {
                if let Err(e) = bus.publish_at(&topics::LIGHT_STATE, &s.group, s).await {
                    tracing::warn!("cannot publish a light state: {e}");
                }
            }
            TickReport::Lights { changed, heartbeat }
        }
    })
    .await?;
    Ok(())
}

/// `lights/state/*` as a query: every group's current state (late joiners).
async fn answer_states(bus: Arc<Bus>, groups: Arc<Mutex<Groups>>, validity: f64) {
    let keys = bus.keys().clone();
    let Ok(queryable) = bus.queryable(&keys.light_states()).await else {
        tracing::error!("cannot declare {}", keys.light_states());
        return;
    };
    while let Ok(query) = queryable.recv_async().await {
        let states: Vec<LightState> = {
            let g = groups.lock().expect("lights lock");
            (0..g.published.len())
                .map(|i| g.state(i, validity))
                .collect()
        };
        for s in states {
            let key = keys.light_state(&s.group);
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
async fn take_overrides(bus: Arc<Bus>, groups: Arc<Mutex<Groups>>, validity: f64) {
    let keys = bus.keys().clone();
    let Ok(queryable) = bus.queryable(&keys.lights_override()).await else {
        tracing::error!("cannot declare {}", keys.lights_override());
        return;
    };
    while let Ok(query) = queryable.recv_async().await {
        let Some(o) = bus.query_payload::<LightOverride>(&query).await else {
            continue;
        };
        let result = {
            let mut g = groups.lock().expect("lights lock");
            apply_override(&mut g, &o, validity)
        };
        match result {
            Ok(state) => {
                tracing::info!("light group '{}' overridden: {:?}", o.group, state.color);
                let _ = bus
                    .publish_at(&topics::LIGHT_STATE, &state.group, &state)
                    .await;
                bus.reply(&query, &state).await;
            }
            Err(reason) => {
                bus.reject(query.key_expr().as_str(), &reason);
                bus.reply_error(&query, &reason).await;
            }
        }
    }
}

fn apply_override(g: &mut Groups, o: &LightOverride, validity: f64) -> Result<LightState, String> {
    let i = g
        .net
        .light_group(&o.group)
        .ok_or_else(|| format!("unknown light group '{}'", o.group))?;
    let control = match (o.color, o.program) {
        (Some(_), Some(_)) => return Err("give either color or program, not both".into()),
        (Some(color), None) => LightControl::Forced(color),
        (None, Some(p)) => {
            check_program(&p)?;
            LightControl::Program(p)
        }
        (None, None) => LightControl::Program(g.net.light_groups[i].program),
    };
    let t = g.time;
    g.lights.set_control(i, control, t);
    g.published[i] = Some(g.lights.state(i).color);
    Ok(g.state(i, validity))
}

fn check_program(p: &LightProgram) -> Result<(), String> {
    match p.problems().first() {
        Some((field, problem)) => Err(format!("{field}: {problem}")),
        None => Ok(()),
    }
}
