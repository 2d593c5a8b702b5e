//! `trafficmesh watch`: one summary line per second from the bus.

use std::collections::BTreeMap;
use std::time::Duration;
use trafficmesh_protocol::topics;

use anyhow::Result;
use clap::Args;
use trafficmesh_bus::{Bus, BusArgs, Role};
use trafficmesh_model::LightColor;
use trafficmesh_protocol::wire::{Clock, CrosswalkOccupancy, LightState};

#[derive(Args)]
pub struct WatchArgs {
    #[command(flatten)]
    bus: BusArgs,
    /// Stop after this many lines (default: until Ctrl-C).
    #[arg(long)]
    count: Option<u64>,
}

pub fn run(a: WatchArgs) -> Result<()> {
    a.bus.keys()?;
    trafficmesh_bus::runtime::tokio_runtime(1)?
        .block_on(async move {
            let bus = Bus::open(&a.bus, Role::Member, "watch").await?;
            let keys = bus.keys().clone();
            let clock = bus.subscribe(&keys.key(&topics::CLOCK)).await?;
            let lights = bus.subscribe(&keys.key_all(&topics::LIGHT_STATE)).await?;
            let crossings = bus.subscribe(&keys.key_all(&topics::OCCUPANCY)).await?;
            let mut light_colors: BTreeMap<String, LightColor> = BTreeMap::new();
            let mut occupied: BTreeMap<String, bool> = BTreeMap::new();
            bus.wait_for_peer(Duration::from_secs(2)).await;
            for s in current::<LightState>(&bus, &keys.key_all(&topics::LIGHT_STATE)).await? {
                light_colors.insert(s.group, s.color);
            }
            for o in current::<CrosswalkOccupancy>(&bus, &keys.key_all(&topics::OCCUPANCY)).await? {
                occupied.insert(o.area, o.occupied);
            }
            let mut last: Option<Clock> = None;
            let mut every = tokio::time::interval(Duration::from_secs(1));
            every.tick().await;
            let mut printed = 0;
            loop {
                tokio::select! {
                    Ok(s) = clock.recv_async() => last = bus.decode(&s).or(last),
                    Ok(s) = lights.recv_async() => if let Some(l) = bus.decode::<LightState>(&s) { light_colors.insert(l.group, l.color); },
                    Ok(s) = crossings.recv_async() => if let Some(o) = bus.decode::<CrosswalkOccupancy>(&s) { occupied.insert(o.area, o.occupied); },
                    _ = every.tick() => {
                        let alive: Vec<String> =
                            super::status::live_services(&bus, &keys).await.into_iter().collect();
                        println!("{}", line(last.as_ref(), &light_colors, &occupied, &alive));
                        printed += 1;
                        if a.count.is_some_and(|c| printed >= c) {
                            return Ok(());
                        }
                    }
                    _ = trafficmesh_bus::runtime::shutdown_signal() => return Ok(()),
                }
            }
        })
}

/// The current states under `key`, asked for until some answer: a session
/// just opened meets the other peers one by one, so the service that holds
/// them may not be reachable at the first query. Gives up after two seconds
/// (a map without lights or crosswalks has none).
async fn current<T: serde::de::DeserializeOwned>(bus: &Bus, key: &str) -> Result<Vec<T>> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    loop {
        let states = bus.get_each::<T>(key, Duration::from_millis(300)).await?;
        if !states.is_empty() || tokio::time::Instant::now() >= deadline {
            return Ok(states);
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

fn line(
    clock: Option<&Clock>,
    lights: &BTreeMap<String, LightColor>,
    occupied: &BTreeMap<String, bool>,
    alive: &[String],
) -> String {
    let count = |c: LightColor| lights.values().filter(|&&v| v == c).count();
    let sim = match clock {
        Some(c) => format!(
            "t={:.1}s vehicles={} ticks/s={:.1} tick={:.2}ms",
            c.time, c.vehicles, c.tick_rate, c.tick_ms
        ),
        None => "no clock (is the stepper running?)".to_string(),
    };
    let busy: Vec<&str> = occupied
        .iter()
        .filter(|(_, o)| **o)
        .map(|(a, _)| a.as_str())
        .collect();
    format!(
        "{sim} | lights green/yellow/red={}/{}/{} | crosswalks occupied={}/{} {:?} | up: {}",
        count(LightColor::Green),
        count(LightColor::Yellow),
        count(LightColor::Red),
        busy.len(),
        occupied.len(),
        busy,
        if alive.is_empty() {
            "-".to_string()
        } else {
            alive.join(",")
        }
    )
}
