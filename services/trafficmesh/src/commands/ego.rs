//! `trafficmesh ego`: publishes the ego vehicle's pose on the bus.

use std::time::Duration;
use trafficmesh_protocol::topics;

use anyhow::{Result, bail};
use clap::Args;
use trafficmesh_bus::{Bus, BusArgs, Lane, Role};
use trafficmesh_protocol::wire::EgoPose;

#[derive(Args)]
pub struct EgoArgs {
    #[command(flatten)]
    bus: BusArgs,
    /// Rear-axle position, metres (map frame).
    #[arg(long, allow_negative_numbers = true)]
    x: f64,
    #[arg(long, allow_negative_numbers = true)]
    y: f64,
    /// Heading, radians counter-clockwise from +x.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    yaw: f64,
    /// Keep publishing at this rate (Hz) until Ctrl-C; default: once.
    #[arg(long)]
    rate: Option<f64>,
}

pub fn run(a: EgoArgs) -> Result<()> {
    let pose = EgoPose {
        x: a.x,
        y: a.y,
        z: 0.0,
        yaw: a.yaw,
        length: 4.9,
        width: 1.9,
        front_offset: 3.8,
    };
    if let Some(p) = pose.problem() {
        bail!("{p}");
    }
    if let Some(r) = a.rate
        && !(r.is_finite() && r > 0.0)
    {
        bail!("--rate must be a positive number of Hz, got {r}");
    }
    a.bus.keys()?;
    trafficmesh_bus::runtime::tokio_runtime(1)?.block_on(async move {
        let bus = Bus::open(&a.bus, Role::Member, "ego").await?;
        let publisher = bus
            .publisher(bus.keys().key(&topics::EGO), Lane::Reliable)
            .await?;
        // A put nobody hears is lost: wait for the subscribers first.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
        while !publisher.has_subscribers().await {
            if tokio::time::Instant::now() > deadline {
                bail!(
                    "nobody subscribes to {} (is the cluster running?)",
                    publisher.key()
                );
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        // The spawner and the stepper both subscribe; give the second a moment.
        tokio::time::sleep(Duration::from_millis(200)).await;
        match a.rate {
            None => {
                publisher.put(&pose).await?;
                tokio::time::sleep(Duration::from_millis(100)).await;
                println!("ego pose published on {}", publisher.key());
            }
            Some(hz) => {
                let mut every = tokio::time::interval(Duration::from_secs_f64(1.0 / hz));
                loop {
                    tokio::select! {
                        _ = every.tick() => publisher.put(&pose).await?,
                        _ = trafficmesh_bus::runtime::shutdown_signal() => break,
                    }
                }
            }
        }
        Ok(())
    })
}
