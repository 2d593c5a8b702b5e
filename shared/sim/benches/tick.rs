//! One tick at 1k, 10k and 100k vehicles on a generated signalised grid.
//! `cargo bench -p trafficmesh-sim --bench tick`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use trafficmesh_maps::{GridOptions, grid_map};
use trafficmesh_sim::populate::populate;
use trafficmesh_sim::{LaneNetwork, World, WorldConfig};

fn world_with(vehicles: usize) -> World {
    // 40 x 40 holds about 90,000 parked vehicles; 100k needs a larger grid.
    let size = if vehicles > 50_000 { 60 } else { 40 };
    let net = LaneNetwork::build(&grid_map(&GridOptions {
        size,
        ..GridOptions::default()
    }))
    .expect("valid grid");
    let mut world = World::new(
        net,
        WorldConfig {
            max_vehicles: vehicles,
            ..WorldConfig::default()
        },
    );
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
    let mut group = c.benchmark_group("tick");
    group.sample_size(20);
    for vehicles in [1_000, 10_000, 100_000] {
        let mut world = world_with(vehicles);
        group.throughput(Throughput::Elements(vehicles as u64));
        group.bench_with_input(BenchmarkId::from_parameter(vehicles), &vehicles, |b, _| {
            b.iter(|| {
                world.step();
                world.drain_events().for_each(drop);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, tick);
criterion_main!(benches);
