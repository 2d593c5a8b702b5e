use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use trafficmesh_maps::{GridOptions, grid_map, write_atomic};

#[derive(Args)]
pub struct GenGridArgs {
    /// Junctions per side (N for an N x N grid).
    #[arg(long)]
    size: usize,
    /// Distance between neighbouring junctions, metres.
    #[arg(long, default_value_t = 200.0)]
    block: f64,
    /// Add a zebra crossing on every approach.
    #[arg(long)]
    crosswalks: bool,
    /// Output file; standard output when omitted.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(a: GenGridArgs) -> Result<()> {
    if a.size == 0 || a.size > 200 {
        bail!("--size must be between 1 and 200, got {}", a.size);
    }
    if !(a.block.is_finite() && a.block >= 60.0) {
        bail!("--block must be at least 60 metres, got {}", a.block);
    }
    let map = grid_map(&GridOptions {
        size: a.size,
        block: a.block,
        crosswalks: a.crosswalks,
        ..GridOptions::default()
    });
    let text = serde_json::to_string_pretty(&map)? + "\n";
    match a.out {
        Some(path) => {
            write_atomic(&path, text.as_bytes())?;
            eprintln!(
                "wrote {} ({} lanes, {} light groups, {} crosswalks)",
                path.display(),
                map.lanes.len(),
                map.light_groups.len(),
                map.crosswalks.len()
            );
        }
        None => print!("{text}"),
    }
    Ok(())
}
