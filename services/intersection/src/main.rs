//! trafficmesh-intersection: the intersection manager of the map's
//! reservation intersections (the product's document 004). Each tick the
//! stepper sends it one round (the ways given back and held, the heads of
//! the approaches asking) and drives by its answer; it publishes what it has
//! reserved for the live map. While it cannot be reached the stepper grants
//! nothing: vehicles wait at the stop lines, and the ways already granted
//! stay apart as they were planned. Started after them, it plans the ways
//! still held from where their vehicles are before it grants any other.

use std::process::ExitCode;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use serde::Serialize;
use trafficmesh_bus::{Bus, Served, runtime};
use trafficmesh_protocol::topics;
use trafficmesh_protocol::wire::{
    Answer, ApproachQueue, Clock, IntersectionView, LockstepTick, ReservedBox, Round, TickReport,
};
use trafficmesh_service::{Service, ServiceArgs};
use trafficmesh_sim::reservation::Intersections;

#[derive(Parser)]
#[command(
    name = "trafficmesh-intersection",
    version,
    about = "Grants ways through the map's reservation intersections to the stepper's vehicles",
    after_help = "Usually started by `trafficmesh up`. Keys: see docs/cluster.md."
)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
}

/// How often the live map's view goes out, wall time.
const VIEW_PERIOD: Duration = Duration::from_millis(200);
/// The view's rectangles: this far ahead, one slot in this many seconds.
const VIEW_AHEAD: f64 = 5.0;
const VIEW_EVERY: f64 = 0.5;

/// Counters for the status.
#[derive(Clone, Copy, Debug, Default, Serialize)]
struct Counters {
    intersections: usize,
    rounds: u64,
    granted: u64,
    planned_again: u64,
    revoked: u64,
    /// Heads waiting for a way after the last round.
    waiting: usize,
}

struct Manager {
    intersections: Intersections,
    time: f64,
    counters: Counters,
}

struct IntersectionService {
    manager: Mutex<Manager>,
    view_sent: Mutex<Option<Instant>>,
}

impl IntersectionService {
    fn manager(&self) -> MutexGuard<'_, Manager> {
        self.manager.lock().expect("manager lock")
    }

    /// The answer to `round`, counted.
    fn answer(&self, round: &Round) -> Answer {
        let mut m = self.manager();
        let answer = m.intersections.answer(round);
        m.time = round.time;
        let fresh = answer.granted.iter().filter(|g| !g.again).count();
        let c = &mut m.counters;
        c.rounds += 1;
        c.granted += fresh as u64;
        c.planned_again += (answer.granted.len() - fresh) as u64;
        c.revoked += answer.revoked.len() as u64;
        c.waiting = round.requests.len() - fresh;
        answer
    }

    /// The view of `m` at its time.
    fn view(m: &Manager) -> IntersectionView {
        let now = m.time;
        let mut view = IntersectionView {
            time: now,
            ..IntersectionView::default()
        };
        for (k, x) in m.intersections.list().iter().enumerate() {
            let k = k as u32;
            for (ahead, vehicle, body) in x.reserved_ahead(now) {
                let slot = (ahead / VIEW_EVERY).round() * VIEW_EVERY;
                if ahead > VIEW_AHEAD || (ahead - slot).abs() > 1e-6 {
                    continue;
                }
                view.reserved.push(ReservedBox {
                    intersection: k,
                    vehicle,
                    ahead_s: ahead,
                    x: body.centre.x,
                    y: body.centre.y,
                    yaw: body.axis.y.atan2(body.axis.x),
                    length: 2.0 * body.half_length,
                    width: 2.0 * body.half_width,
                });
            }
            for (lane, waited) in x.approaches(now) {
                view.approaches.push(ApproachQueue {
                    intersection: k,
                    lane,
                    head_waiting_s: waited,
                });
            }
        }
        view
    }

    /// The view, at most every [`VIEW_PERIOD`].
    async fn publish_view(&self, bus: &Bus) {
        {
            let mut sent = self.view_sent.lock().expect("view lock");
            if sent.is_some_and(|at| at.elapsed() < VIEW_PERIOD) {
                return;
            }
            *sent = Some(Instant::now());
        }
        let view = Self::view(&self.manager());
        if let Err(e) = bus.publish(&topics::INTERSECTION_VIEW, &view).await {
            tracing::warn!("cannot publish the intersection view: {e}");
        }
    }
}

fn main() -> ExitCode {
    runtime::main_with(|| {
        let args = Args::parse();
        let net = args.service.map.load()?;
        let map = net.fingerprint();
        let intersections = Intersections::of(&net);
        tracing::info!(
            "managing {} reservation intersection(s)",
            intersections.list().len()
        );
        let service = IntersectionService {
            manager: Mutex::new(Manager {
                counters: Counters {
                    intersections: intersections.list().len(),
                    ..Counters::default()
                },
                intersections,
                time: 0.0,
            }),
            view_sent: Mutex::new(None),
        };
        trafficmesh_service::run(&args.service, map, service)
    })
}

impl Service for IntersectionService {
    const NAME: &'static str = "intersection";
    type Answer = TickReport;

    fn status(&self) -> (f64, serde_json::Value) {
        let m = self.manager();
        (m.time, serde_json::to_value(m.counters).unwrap_or_default())
    }

    async fn start(self: &Arc<Self>, bus: &Arc<Bus>) -> Result<()> {
        // Declared before the service answers a lockstep question: a
        // stepper in lockstep sends its first round only after that.
        let rounds = bus.declare_call(&topics::INTERSECTION_ROUND).await?;
        tokio::spawn(answer_rounds(bus.clone(), rounds, self.clone()));
        Ok(())
    }

    async fn on_clock(&self, bus: &Arc<Bus>, _clock: Clock) -> Result<()> {
        self.publish_view(bus).await;
        Ok(())
    }

    async fn on_tick(&self, bus: &Arc<Bus>, _tick: LockstepTick) -> TickReport {
        self.publish_view(bus).await;
        TickReport::Ready
    }
}

/// `intersection/round`: one answer per round, in the order they come.
async fn answer_rounds(
    bus: Arc<Bus>,
    rounds: Served<Round, Answer>,
    service: Arc<IntersectionService>,
) {
    rounds
        .serve(&bus, |round: Round| {
            let answer = service.answer(&round);
            async move { Ok(answer) }
        })
        .await;
}
