//! `trafficmesh bench intersection`: one four-way intersection, three lanes
//! per approach, run by fixed-time lights and by reservations (autonomous
//! intersection management) at the same demands. Per controller and demand:
//! vehicles served per hour per lane, mean and 95th-percentile delay (time
//! from arrival to the end of the exit less the free-flow time of the same
//! movement) and collisions (pairs of bodies that overlapped). The arrivals
//! are the map's own timetable (a demand simulator): the world inserts each
//! where there is room, as it does a SUMO demand.

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;
use trafficmesh_maps::four_way::{self, FourWayOptions, Movement};
use trafficmesh_model::map::{DepartureDef, SimulatorDef};
use trafficmesh_model::{DriverModel, IntersectionController, NpcVehicleConfig, SpeedLimitSource};
use trafficmesh_sim::motion_check::overlapping_pairs;
use trafficmesh_sim::{
    DespawnReason, LaneId, LaneNetwork, SimEvent, VehicleId, World, WorldConfig,
};
/// The footprints the overlap check compares, shrunk by this (as `sim --check`).
const OVERLAP_MARGIN: f64 = 0.1;
/// Tick, seconds (the `realistic` drivers' usual step).
const DT: f64 = 0.1;
const KIND: &str = "Hatchback";

#[derive(Args)]
pub struct IntersectionArgs {
    /// Demands to run, vehicles per hour per lane, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "100,300,500,700,900")]
    demand: Vec<f64>,
    /// Simulated seconds of arrivals per run (served vehicles are counted
    /// over this time; the run goes on until those inside have left).
    #[arg(long, default_value_t = 900.0)]
    duration: f64,
    /// Random seed of the arrivals and their movements.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Green seconds per phase of the fixed-time lights (two phases,
    /// east-west then north-south, 3 s of yellow each).
    #[arg(long, default_value_t = 30.0)]
    green: f64,
    /// Where to write the table as CSV.
    #[arg(long, default_value = "out/bench-intersection.csv")]
    csv: PathBuf,
    /// Where to draw mean and p95 delay against demand, per controller (PNG).
    #[arg(long, default_value = "out/bench-intersection.png")]
    plot: PathBuf,
    /// Print one JSON object `{"rows": [...]}` instead of the table.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Debug, Serialize)]
struct Row {
    controller: &'static str,
    demand_vphpl: f64,
    served_vphpl: f64,
    mean_delay_s: f64,
    p95_delay_s: f64,
    collisions: usize,
    /// Vehicles the jam timeout moved on or took off (after 300 s standing).
    jam_resolutions: u64,
}

/// A splitmix64 stream: arrivals and movements, the same for both controllers.
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One arrival: when, where, which way.
#[derive(Clone, Copy, Debug)]
struct Arrival {
    at: f64,
    approach: usize,
    lane: usize,
    movement: Movement,
}

/// Poisson arrivals on every approach lane at `demand` vehicles per hour;
/// a lane offering a turn sends half its vehicles that way.
fn arrivals(o: &FourWayOptions, demand: f64, duration: f64, seed: u64) -> Vec<Arrival> {
    let mut all = Vec::new();
    for d in 0..4 {
        for k in 0..o.lanes {
            let mut rng = Stream(seed ^ ((d * 16 + k) as u64).wrapping_mul(0xA24B_AED4_963E_E407));
            let moves = four_way::movements_of(k, o.lanes);
            let mut t = 0.0;
            loop {
                t += -(1.0 - rng.next()).ln() * 3600.0 / demand;
                if t >= duration {
                    break;
                }
                let movement = if moves.len() > 1 && rng.next() < 0.5 {
                    moves[1]
                } else {
                    Movement::Straight
                };
                all.push(Arrival {
                    at: t,
                    approach: d,
                    lane: k,
                    movement,
                });
            }
        }
    }
    all.sort_by(|a, b| a.at.total_cmp(&b.at));
    all
}

/// The intersection with `arrivals` as its timetable.
fn world_of(o: &FourWayOptions, arrivals: &[Arrival]) -> Result<World> {
    let mut map = four_way::four_way_map(o);
    let departures = arrivals
        .iter()
        .map(|a| DepartureDef {
            time: a.at,
            route: four_way::route(a.approach, a.lane, a.movement).to_vec(),
            prefab: KIND.to_string(),
            other_routes: Vec::new(),
        })
        .collect();
    map.traffic_simulators = vec![SimulatorDef::Demand { departures }];
    let net = LaneNetwork::build(&map)
        .map_err(|p| anyhow::anyhow!("the generated intersection is invalid: {p:?}"))?;
    let junctions: std::collections::HashSet<_> = net
        .lanes
        .iter()
        .filter(|l| l.intersection)
        .map(|l| l.junction)
        .collect();
    if junctions.len() != 1 {
        bail!(
            "the generated intersection's lanes form {} junctions, not one",
            junctions.len()
        );
    }
    let config = WorldConfig {
        dt: DT,
        max_vehicles: trafficmesh_sim::world::default_max_vehicles(true),
        vehicle: NpcVehicleConfig {
            driver_model: DriverModel::Realistic(Default::default()),
            speed_limit_source: SpeedLimitSource::LaneletSpeedLimit,
            ..NpcVehicleConfig::default()
        },
        ..WorldConfig::default()
    };
    Ok(World::new(net, config))
}

/// One vehicle that left at the end of its exit: the movement it took
/// through the intersection, when it was due and when it left.
#[derive(Clone, Copy, Debug)]
struct Served {
    movement: LaneId,
    depart: f64,
    left: f64,
}

/// What one run measured: the vehicles served, and the pairs that
/// overlapped.
struct Run {
    served: Vec<Served>,
    collisions: usize,
    jam_resolutions: u64,
}

fn run(o: &FourWayOptions, arrivals: &[Arrival], duration: f64) -> Result<Run> {
    let mut world = world_of(o, arrivals)?;
    // The intersection lane each vehicle was last seen on (a driver may
    // change lanes on its approach, and so its movement).
    let mut movement: HashMap<VehicleId, LaneId> = HashMap::new();
    let mut served = Vec::new();
    let mut pairs = std::collections::HashSet::new();
    let mut left = 0;
    // Arrivals end at `duration`; the run goes on until all have left.
    let limit = duration + 600.0;
    while world.time() < limit && left < arrivals.len() {
        world.step();
        for (i, j) in overlapping_pairs(world.network(), world.vehicles(), OVERLAP_MARGIN) {
            let (a, b) = (world.vehicles()[i].id, world.vehicles()[j].id);
            pairs.insert((a.min(b), a.max(b)));
        }
        for v in world.vehicles() {
            if world.network().lane(v.path[0]).intersection {
                movement.insert(v.id, v.path[0]);
            }
        }
        for event in world.drain_events() {
            let SimEvent::Despawned(trip) = event else {
                continue;
            };
            left += 1;
            if trip.reason == DespawnReason::RouteEnd
                && let Some(&m) = movement.get(&trip.id)
            {
                served.push(Served {
                    movement: m,
                    depart: trip.depart,
                    left: trip.despawn_time,
                });
            }
        }
    }
    Ok(Run {
        served,
        collisions: pairs.len(),
        jam_resolutions: world.wait_stats().jam_resolutions,
    })
}

/// Free-flow time of each movement: a vehicle alone, due at once.
fn free_flow(o: &FourWayOptions) -> Result<HashMap<LaneId, f64>> {
    let alone = FourWayOptions {
        controller: IntersectionController::Priority,
        ..o.clone()
    };
    let mut times = HashMap::new();
    for d in 0..4 {
        for k in 0..o.lanes {
            for m in four_way::movements_of(k, o.lanes) {
                let a = Arrival {
                    at: 0.0,
                    approach: d,
                    lane: k,
                    movement: m,
                };
                let r = run(&alone, &[a], 1.0)?;
                let s = r.served.first().context("a vehicle alone was not served")?;
                times.insert(s.movement, s.left - s.depart);
            }
        }
    }
    Ok(times)
}

fn row(
    controller: &'static str,
    o: &FourWayOptions,
    demand: f64,
    duration: f64,
    r: &Run,
    free: &HashMap<LaneId, f64>,
) -> Row {
    let mut delays: Vec<f64> = r
        .served
        .iter()
        .map(|s| (s.left - s.depart - free[&s.movement]).max(0.0))
        .collect();
    delays.sort_by(f64::total_cmp);
    let in_time = r.served.iter().filter(|s| s.left <= duration).count();
    let lanes = (4 * o.lanes) as f64;
    let p95 = delays
        .get(((delays.len() as f64 * 0.95).ceil() as usize).saturating_sub(1))
        .copied()
        .unwrap_or(0.0);
    Row {
        controller,
        demand_vphpl: demand,
        served_vphpl: in_time as f64 / lanes / (duration / 3600.0),
        mean_delay_s: if delays.is_empty() {
            0.0
        } else {
            delays.iter().sum::<f64>() / delays.len() as f64
        },
        p95_delay_s: p95,
        collisions: r.collisions,
        jam_resolutions: r.jam_resolutions,
    }
}

pub fn run_bench(a: IntersectionArgs) -> Result<()> {
    if a.demand.iter().any(|&d| !(d.is_finite() && d > 0.0)) {
        bail!("--demand: every demand must be a positive number of vehicles per hour per lane");
    }
    if !(a.duration.is_finite() && a.duration > 0.0) {
        bail!("--duration must be a positive number of seconds");
    }
    let base = FourWayOptions {
        green: a.green,
        ..FourWayOptions::default()
    };
    let free = free_flow(&base)?;
    let progress = indicatif::ProgressBar::new((2 * a.demand.len()) as u64);
    let mut rows = Vec::new();
    for &demand in &a.demand {
        let arrivals = arrivals(&base, demand, a.duration, a.seed);
        for (name, controller) in [
            ("lights", IntersectionController::Lights),
            ("reservation", IntersectionController::Reservation),
        ] {
            let o = FourWayOptions {
                controller,
                ..base.clone()
            };
            let r = run(&o, &arrivals, a.duration)?;
            rows.push(row(name, &o, demand, a.duration, &r, &free));
            progress.inc(1);
        }
    }
    progress.finish_and_clear();
    let decisions = decision_times(&base, a.seed)?;
    write_csv(&a.csv, &rows)?;
    let lines: Vec<super::delay_plot::Line> = ["lights", "reservation"]
        .into_iter()
        .map(|controller| super::delay_plot::Line {
            controller,
            points: rows
                .iter()
                .filter(|r| r.controller == controller)
                .map(|r| (r.demand_vphpl, r.mean_delay_s, r.p95_delay_s))
                .collect(),
        })
        .collect();
    super::delay_plot::write(&a.plot, &lines)?;
    if a.json {
        println!(
            "{}",
            serde_json::json!({ "rows": rows, "decision_us": decisions })
        );
    } else {
        println!(
            "{:<12} {:>8} {:>8} {:>10} {:>10} {:>10} {:>6}",
            "controller", "demand", "served", "mean_delay", "p95_delay", "collisions", "jams"
        );
        for r in &rows {
            println!(
                "{:<12} {:>8.0} {:>8.0} {:>10.1} {:>10.1} {:>10} {:>6}",
                r.controller,
                r.demand_vphpl,
                r.served_vphpl,
                r.mean_delay_s,
                r.p95_delay_s,
                r.collisions,
                r.jam_resolutions
            );
        }
        println!(
            "reservation decisions: a round of every approach asking p50 {:.1} us, p99 {:.1} us, max {:.1} us; one request p99 {:.1} us ({} rounds)",
            decisions.p50,
            decisions.p99,
            decisions.max,
            decisions.per_request_p99,
            decisions.rounds
        );
        println!(
            "(vehicles per hour per lane; delays in seconds; jams: jam-timeout resolutions; table in {}, plot in {})",
            a.csv.display(),
            a.plot.display()
        );
    }
    Ok(())
}

/// Wall time of the reservation decisions, microseconds: of a whole round
/// (every approach's head asking), and of one request (a round's time over
/// the requests in it).
#[derive(Debug, Serialize)]
struct DecisionTimes {
    p50: f64,
    p99: f64,
    max: f64,
    per_request_p99: f64,
    rounds: usize,
}

/// Rounds of decisions at the same intersection, in-process, as the
/// reservation intersection makes them every tick: the head of each of the
/// twelve approach lanes asks (from 0 to 60 m out, at 0 to 25 m/s, drawn
/// from the seed), and a granted head is replaced by a new vehicle; each
/// round timed alone.
fn decision_times(o: &FourWayOptions, seed: u64) -> Result<DecisionTimes> {
    use trafficmesh_sim::reservation::plan::{Approach, Margins};
    use trafficmesh_sim::reservation::{Intersection, Request};
    const ROUNDS: usize = 3000;
    let reserved = FourWayOptions {
        controller: IntersectionController::Reservation,
        ..o.clone()
    };
    let net = LaneNetwork::build(&four_way::four_way_map(&reserved))
        .map_err(|p| anyhow::anyhow!("the generated intersection is invalid: {p:?}"))?;
    let junction = net.reservation_junctions[0];
    let mut x = Intersection::of(&net, junction, 2.0, Margins::default());
    let mut rng = Stream(seed ^ 0x5EED);
    let mut heads: Vec<(VehicleId, usize, usize)> = (0..4)
        .flat_map(|d| (0..o.lanes).map(move |k| (d, k)))
        .enumerate()
        .map(|(i, (d, k))| (i as VehicleId, d, k))
        .collect();
    let mut next_id = heads.len() as VehicleId;
    let mut times = Vec::with_capacity(ROUNDS);
    let mut per_request = Vec::with_capacity(ROUNDS);
    for round in 0..ROUNDS {
        let now = round as f64 * DT;
        let requests: Vec<Request> = heads
            .iter()
            .map(|&(id, d, k)| {
                let moves = four_way::movements_of(k, o.lanes);
                let m = moves[id as usize % moves.len()];
                let lane = net
                    .lane_id(&four_way::movement_lane(d, k, m))
                    .expect("a movement");
                Request {
                    intersection: 0,
                    vehicle: id,
                    lane,
                    from: net.lane(lane).prev[0],
                    approach: Approach {
                        to_entry: 60.0 * rng.next(),
                        speed: 25.0 * rng.next(),
                        accel: 2.6,
                        max_speed: net.lane(lane).speed_limit,
                        length: 4.0,
                        width: 1.9,
                    },
                    emergency: false,
                }
            })
            .collect();
        let started = std::time::Instant::now();
        let granted = x.decide(now, &requests);
        times.push(started.elapsed().as_secs_f64() * 1e6);
        per_request.push(times[times.len() - 1] / requests.len() as f64);
        for id in granted {
            let head = heads.iter_mut().find(|h| h.0 == id).expect("a head");
            head.0 = next_id;
            next_id += 1;
        }
    }
    times.sort_by(f64::total_cmp);
    per_request.sort_by(f64::total_cmp);
    let at = |v: &[f64], q: f64| v[((v.len() as f64 * q).ceil() as usize).clamp(1, v.len()) - 1];
    Ok(DecisionTimes {
        p50: at(&times, 0.5),
        p99: at(&times, 0.99),
        max: times[times.len() - 1],
        per_request_p99: at(&per_request, 0.99),
        rounds: ROUNDS,
    })
}

/// Writes the table whole or not at all (a temporary file renamed over it).
fn write_csv(path: &std::path::Path, rows: &[Row]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let tmp = path.with_extension("csv.tmp");
    {
        let mut w =
            csv::Writer::from_path(&tmp).with_context(|| format!("writing {}", tmp.display()))?;
        for r in rows {
            w.serialize(r)?;
        }
        w.flush()?;
    }
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
