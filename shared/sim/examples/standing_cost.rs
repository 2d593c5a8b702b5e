//! What a standing vehicle costs a tick against a moving one: fills a 40 x 40
//! grid with 10,000 vehicles, runs one simulated minute, then times 60 windows
//! of 50 ticks on one thread and fits the window's tick time to the number of
//! vehicles standing at its start (the grid's lights pulse, so that number
//! swings over each cycle).
//!
//! `cargo run --release -p trafficmesh-sim --features bench --example standing_cost` (pin it with
//! `taskset -c 1` on a busy host).

use std::time::Instant;

use trafficmesh_maps::{GridOptions, grid_map};
use trafficmesh_sim::populate::{empty_world, populate};

const VEHICLES: usize = 10_000;
const WARMUP_TICKS: usize = 3_000;
const WINDOWS: usize = 60;
const TICKS_PER_WINDOW: usize = 50;

fn main() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let grid = grid_map(&GridOptions {
        size: 40,
        ..GridOptions::default()
    });
    let mut world = empty_world(&grid, VEHICLES).expect("the generated grid is valid");
    populate(&mut world, VEHICLES);
    let samples: Vec<(f64, f64)> = pool.install(|| {
        for _ in 0..WARMUP_TICKS {
            world.step();
            world.drain_events().for_each(drop);
        }
        (0..WINDOWS)
            .map(|_| {
                let standing = world.vehicles().iter().filter(|v| v.speed == 0.0).count();
                let start = Instant::now();
                for _ in 0..TICKS_PER_WINDOW {
                    world.step();
                    world.drain_events().for_each(drop);
                }
                let ms = start.elapsed().as_secs_f64() * 1e3 / TICKS_PER_WINDOW as f64;
                println!("standing {standing:>5}  tick {ms:.3} ms");
                (standing as f64, ms)
            })
            .collect()
    });
    let (slope, intercept) = least_squares(&samples);
    let per_moving = intercept / VEHICLES as f64 * 1e3;
    let per_standing = per_moving + slope * 1e3;
    println!(
        "per vehicle and tick: moving {per_moving:.3} µs, standing {per_standing:.3} µs \
         (tick = {intercept:.3} ms {slope:+.6} ms per standing vehicle)"
    );
}

/// Slope and intercept of the least-squares line through `points`.
fn least_squares(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    let slope = sxy / sxx;
    (slope, my - slope * mx)
}
