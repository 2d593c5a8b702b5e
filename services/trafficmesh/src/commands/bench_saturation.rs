//! `trafficmesh bench saturation`: how fast a queue discharges at a green
//! light. Twenty cars stand queued on a straight approach at a red light; it
//! turns green; the time each front bumper crosses the stop line gives the
//! discharge headway after the fourth car (the Highway Capacity Manual's
//! convention: the first cars are slower, reacting and accelerating) and the
//! saturation flow, vehicles per hour per lane.

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;
use serde_json::json;
use trafficmesh_model::{DriverModel, LightColor, MapFile, NpcVehicleConfig};
use trafficmesh_sim::lights::LightControl;
use trafficmesh_sim::{LaneNetwork, World, WorldConfig};

use crate::output::print_summary;

/// Cars in the queue.
const QUEUED: usize = 20;
/// Headways are measured from this car on (the fifth crosses after the fourth).
const FIRST_MEASURED: usize = 5;
/// Approach length; the stop line is at its end.
const APPROACH: f64 = 600.0;
/// Seconds of red for the placed cars to close up into a standing queue.
const SETTLE: f64 = 90.0;

#[derive(Args)]
pub struct SaturationArgs {
    /// The driver model of the queued cars: `awsim` or `realistic`.
    #[arg(long, default_value = "realistic")]
    model: DriverModel,
    /// Print one JSON object instead of `key: value` lines.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Report {
    model: &'static str,
    queued: usize,
    /// Mean seconds between stop-line crossings from the fifth car on.
    discharge_headway_s: f64,
    /// 3,600 / the discharge headway.
    saturation_flow_veh_per_hour_per_lane: f64,
    /// Seconds from green to the first car's crossing.
    first_crossing_s: f64,
}

/// A straight eastbound approach with a light at its end, a junction lane and
/// an exit: the map of the measurement.
fn approach_map() -> Result<MapFile> {
    let map = json!({
        "lanes": [
            { "name": "approach", "waypoints": [[0.0, 0.0], [APPROACH, 0.0]], "next": ["junction"],
              "stop_line": [[APPROACH, -1.75], [APPROACH, 1.75]], "traffic_light": "L" },
            { "name": "junction", "waypoints": [[APPROACH, 0.0], [APPROACH + 20.0, 0.0]], "next": ["exit"],
              "intersection": true },
            { "name": "exit", "waypoints": [[APPROACH + 20.0, 0.0], [APPROACH + 1500.0, 0.0]], "next": [] },
        ],
        "light_groups": [{ "name": "L", "program": { "green": 60, "yellow": 3, "red": 60 } }],
        "traffic_simulators": [{ "kind": "random", "lanes": ["approach"], "prefabs": ["Hatchback"], "enabled": false }],
    });
    Ok(serde_json::from_value(map)?)
}

pub fn run(a: SaturationArgs) -> Result<()> {
    let driver_model = a.model;
    let net = LaneNetwork::build(&approach_map()?)
        .map_err(|p| anyhow::anyhow!("the measurement's map is invalid: {p:?}"))?;
    let config = WorldConfig {
        vehicle: NpcVehicleConfig {
            driver_model,
            ..NpcVehicleConfig::default()
        },
        jam_timeout: 0.0,
        ..WorldConfig::default()
    };
    let mut world = World::new(net, config);
    world.set_light("L", LightControl::Forced(LightColor::Red))?;
    // Placed far apart; the red light lets them close up into a queue.
    let spacing = (APPROACH - 10.0) / QUEUED as f64;
    for k in 0..QUEUED {
        let s = APPROACH - 5.0 - k as f64 * spacing;
        world
            .place_vehicle("Hatchback", "approach", s, 0.0)
            .context("placing the queue")?;
    }
    let dt = world.config().dt;
    let ticks = |seconds: f64| (seconds / dt).round() as u64;
    for _ in 0..ticks(SETTLE) {
        world.step();
    }
    let approach = world.network().lane_id("approach").expect("the map's lane");
    world.set_light("L", LightControl::Forced(LightColor::Green))?;
    let green_at = world.time();
    let mut crossings: Vec<f64> = Vec::with_capacity(QUEUED);
    let mut crossed = std::collections::HashSet::new();
    for _ in 0..ticks(300.0) {
        world.step();
        for v in world.vehicles() {
            if v.path[0] != approach && crossed.insert(v.id) {
                crossings.push(world.time() - green_at);
            }
        }
        if crossings.len() == QUEUED {
            break;
        }
    }
    if crossings.len() < QUEUED {
        bail!(
            "only {} of {QUEUED} queued cars crossed the stop line in 300 s of green",
            crossings.len()
        );
    }
    crossings.sort_by(f64::total_cmp);
    let measured = &crossings[FIRST_MEASURED - 2..];
    let headway = (measured[measured.len() - 1] - measured[0]) / (measured.len() - 1) as f64;
    let report = Report {
        model: driver_model.name(),
        queued: QUEUED,
        discharge_headway_s: headway,
        saturation_flow_veh_per_hour_per_lane: 3600.0 / headway,
        first_crossing_s: crossings[0],
    };
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print_summary(&report)?;
    }
    Ok(())
}
