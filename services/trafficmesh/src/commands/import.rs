//! `trafficmesh import FILE --out map.json`: a foreign map (SUMO `.net.xml`, Lanelet2 `.osm`)
//! in the native format, with a summary and the import's warnings.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use serde::Serialize;
use trafficmesh_maps::{import_map, write_atomic};

#[derive(Args)]
pub struct ImportArgs {
    /// The map to read: a SUMO `.net.xml` or Lanelet2 `.osm` (or a native `.map.json`, validated).
    file: PathBuf,
    /// Where to write the native map; only the summary when omitted.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Summary {
    file: String,
    lanes: usize,
    intersection_lanes: usize,
    /// Sum of the lanes' polyline lengths, metres.
    lane_length_m: f64,
    links: usize,
    light_groups: usize,
    crosswalks: usize,
    import_ms: f64,
    warnings: Vec<String>,
}

pub fn run(a: ImportArgs) -> Result<()> {
    let started = Instant::now();
    let imported = import_map(&a.file)?;
    let import_ms = started.elapsed().as_secs_f64() * 1e3;
    let map = &imported.map;
    let summary = Summary {
        file: a.file.display().to_string(),
        lanes: map.lanes.len(),
        intersection_lanes: map.lanes.iter().filter(|l| l.intersection).count(),
        lane_length_m: map.lanes.iter().map(|l| l.length()).sum(),
        links: map.lanes.iter().map(|l| l.next.len()).sum(),
        light_groups: map.light_groups.len(),
        crosswalks: map.crosswalks.len(),
        import_ms,
        warnings: imported.warnings.clone(),
    };
    if let Some(out) = &a.out {
        let text = serde_json::to_string_pretty(map)? + "\n";
        write_atomic(out, text.as_bytes())?;
    }
    if a.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!(
            "{}: {} lanes ({} in junctions, {:.0} m), {} links, {} light groups, {} crosswalks; read in {:.1} ms",
            summary.file,
            summary.lanes,
            summary.intersection_lanes,
            summary.lane_length_m,
            summary.links,
            summary.light_groups,
            summary.crosswalks,
            summary.import_ms
        );
        for w in &summary.warnings {
            println!("warning: {w}");
        }
        if let Some(out) = &a.out {
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}
