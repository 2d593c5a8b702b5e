//! One tick at 1k, 10k and 100k vehicles on a generated signalised grid.
//! `cargo bench -p trafficmesh-sim --features bench --bench tick`

use std::time::Instant;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use trafficmesh_maps::{GridOptions, grid_map};
use trafficmesh_sim::World;
use trafficmesh_sim::populate::{empty_world, populate};

fn world_with(vehicles: usize) -> World {
    // 40 x 40 holds about 90,000 parked vehicles; 100k needs a larger grid.
    let size = if vehicles > 50_000 { 60 } else { 40 };
    let grid = grid_map(&GridOptions {
        size,
        ..GridOptions::default()
    });
    let mut world = empty_world(&grid, vehicles).expect("valid grid");
    assert_eq!(populate(&mut world, vehicles), vehicles, "grid too small");
    // One simulated minute first: the first seconds after placing parked cars
    // are cheaper than the steady state with queues at every junction.
    for _ in 0..3000 {
        world.step();
        world.drain_events().for_each(drop);
    }
    world
}

fn tick(c: &mut Criterion) {
    // Ticks run on a worker of the pool, as in `trafficmesh sim` and the
    // stepper: stepped from outside it, every parallel phase would be handed
    // over to the pool and waited for (about 0.1 ms here), which the product
    // never pays.
    let pool = rayon::ThreadPoolBuilder::new()
        .build()
        .expect("a thread pool");
    let mut group = c.benchmark_group("tick");
    group.sample_size(20);
    for vehicles in [1_000, 10_000, 100_000] {
        let mut world = pool.install(|| world_with(vehicles));
        group.throughput(Throughput::Elements(vehicles as u64));
        group.bench_with_input(BenchmarkId::from_parameter(vehicles), &vehicles, |b, _| {
            // Timed inside the pool, one hand-over per batch of ticks.
            b.iter_custom(|ticks| {
                pool.install(|| {
                    let start = Instant::now();
                    for _ in 0..ticks {
                        world.step();
                        world.drain_events().for_each(drop);
                    }
                    start.elapsed()
                })
            })
        });
    }
    group.finish();
}

criterion_group!(benches, tick);
criterion_main!(benches);
