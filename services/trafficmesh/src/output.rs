//! Files and text the CLI writes.

use std::path::Path;

use anyhow::Result;
use serde::Serialize;
use trafficmesh_sim::motion_check::{MotionCheck, Tally};
use trafficmesh_sim::{TripRecord, World};

/// trips.csv: one row per vehicle, finished trips first, then those still driving
/// (empty despawn_time, end_reason `running`).
pub fn write_trips(path: &Path, finished: &[TripRecord], world: &World) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "id",
        "kind",
        "spawn_time",
        "despawn_time",
        "distance_m",
        "stops",
        "time_stopped_s",
        "end_reason",
        "depart_delay_s",
        "time_loss_s",
    ])?;
    for t in finished {
        w.write_record([
            t.id.to_string(),
            t.kind.clone(),
            format!("{:.2}", t.spawn_time),
            format!("{:.2}", t.despawn_time),
            format!("{:.2}", t.distance),
            t.stops.to_string(),
            format!("{:.2}", t.time_stopped),
            t.reason.as_str().to_string(),
            format!("{:.2}", (t.spawn_time - t.depart).max(0.0)),
            format!("{:.2}", t.time_loss),
        ])?;
    }
    // The world keeps its vehicles grouped by lane; the file lists them by id.
    let mut running: Vec<_> = world.vehicles().iter().collect();
    running.sort_by_key(|v| v.id);
    for v in running {
        w.write_record([
            v.id.to_string(),
            world.network().kinds[v.kind].name.clone(),
            format!("{:.2}", v.trip.spawn_time),
            String::new(),
            format!("{:.2}", v.trip.distance),
            v.trip.stops.to_string(),
            format!("{:.2}", v.trip.time_stopped),
            "running".to_string(),
            format!("{:.2}", (v.trip.spawn_time - v.trip.depart).max(0.0)),
            format!("{:.2}", v.trip.time_loss),
        ])?;
    }
    trafficmesh_maps::write_atomic(path, &w.into_inner()?)?;
    Ok(())
}

/// Human-readable `key: value` lines of a summary; nested objects print one
/// `key.field` line per field.
pub fn print_summary<T: Serialize>(summary: &T) -> Result<()> {
    if let serde_json::Value::Object(fields) = serde_json::to_value(summary)? {
        for (k, v) in fields {
            match v {
                serde_json::Value::Object(inner) => {
                    for (field, value) in inner {
                        print_value(&format!("{k}.{field}"), value);
                    }
                }
                other => print_value(&k, other),
            }
        }
    }
    Ok(())
}

fn print_value(key: &str, value: serde_json::Value) {
    match value {
        serde_json::Value::Number(n) if n.is_f64() => {
            println!("{key:>22}: {:.3}", n.as_f64().unwrap_or_default())
        }
        serde_json::Value::String(s) => println!("{key:>22}: {s}"),
        other => println!("{key:>22}: {other}"),
    }
}

/// `sim --check`'s findings as JSON: per check the failing vehicle-ticks
/// (pair-ticks for overlaps), the distinct vehicles (pairs), the largest
/// excess over the bound and the first examples.
pub fn check_report(check: &MotionCheck) -> serde_json::Value {
    let tally = |t: &Tally| {
        serde_json::json!({
            "count": t.count,
            "distinct": t.distinct,
            "max_excess": t.max_excess,
            "first": t.first.iter().map(|f| serde_json::json!({
                "time": f.time,
                "vehicle": f.vehicle,
                "other": f.other,
                "lane": f.lane,
                "value": f.value,
                "bound": f.bound,
            })).collect::<Vec<_>>(),
        })
    };
    serde_json::json!({
        "ticks": check.ticks,
        "vehicle_steps": check.vehicle_steps,
        "jumps": tally(&check.jumps),
        "turns": tally(&check.turns),
        "overlaps": tally(&check.overlaps),
        "speeding": tally(&check.speeding),
        "red_lights": tally(&check.red_lights),
        "relocations": check.relocations,
    })
}
