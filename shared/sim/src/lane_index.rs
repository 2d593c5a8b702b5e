//! Per-lane ordering of vehicles, rebuilt each tick: the leader, conflict and
//! spawn-clearance look-ups read it instead of scanning every vehicle.

use rayon::prelude::*;

use crate::buckets::Buckets;
use crate::conflicts::{Body, Gap, bodies_pass};
use crate::network::{LaneId, LaneNetwork};
use crate::parallel::{chunk_count, chunk_len, join_if, light_pass_parallel};
use crate::vehicle::Vehicle;

/// One vehicle's body on one lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Occupant {
    /// Arc lengths of the rear and front bumpers on this lane (may lie outside it).
    pub rear: f64,
    pub front: f64,
    pub speed: f64,
    /// Index of the vehicle in the world's vehicle list when the index was
    /// built (vehicles spawned or removed since shift it: read `speed` here
    /// rather than the vehicle).
    pub vehicle: u32,
    /// Not a body: a vehicle beside this lane waiting to change onto it, at its
    /// place there, so that those coming up behind leave it room.
    pub ghost: bool,
}

/// A vehicle body standing in a conflict zone of a lane that is not its own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockedZone {
    /// The zone on the blocked lane, arc lengths.
    pub start: f64,
    pub end: f64,
    /// Merge or diverge: where the body's rear lies along the blocked lane.
    /// Crossings block from `start`.
    pub parallel_rear: Option<f64>,
    /// The lane the body is on.
    pub source: LaneId,
    pub vehicle: u32,
    /// A road conflict (see [`crate::conflicts::Conflict::road`]), and the
    /// body's width and length: a vehicle narrow enough passes the body.
    pub road: bool,
    pub width: f64,
    pub length: f64,
    /// The conflict's gap, seen from the blocked lane (see
    /// [`crate::conflicts::Conflict`]).
    pub gap: Gap,
    /// What the body as drawn lies off its centreline.
    pub off_centreline: f64,
}

impl BlockedZone {
    /// Does a vehicle pass the body beside it?
    pub fn passable(&self, vehicle: Body) -> bool {
        let body = Body {
            width: self.width,
            length: self.length,
            off_centreline: self.off_centreline,
        };
        self.road && bodies_pass(self.gap, vehicle, body)
    }
}

/// Vehicles of each lane sorted by rear position, and the conflict zones each
/// lane has blocked by bodies on other lanes. Rebuilt in place each tick.
#[derive(Clone, Debug, Default)]
pub struct LaneIndex {
    occupants: Buckets<Occupant>,
    blocked: Buckets<BlockedZone>,
    /// Items per chunk of vehicles, kept for their allocations.
    chunks: Vec<ChunkItems>,
    /// Vehicles waiting to change lanes (those with a ghost), in list order.
    lane_changers: Vec<u32>,
}

/// The index items of one chunk of vehicles (kept for their allocations).
#[derive(Clone, Debug, Default)]
struct ChunkItems {
    occupants: Vec<(LaneId, Occupant)>,
    blocked: Vec<(LaneId, BlockedZone)>,
    lane_changers: Vec<u32>,
}

impl ChunkItems {
    fn clear(&mut self) {
        self.occupants.clear();
        self.blocked.clear();
        self.lane_changers.clear();
    }

    /// Bodies of `some`, the vehicles from index `first` on (see [`ChunkItems::add`]).
    fn fill(&mut self, net: &LaneNetwork, some: &[Vehicle], first: u32) {
        self.clear();
        for (i, v) in (first..).zip(some) {
            self.add(net, v, i);
        }
    }

    /// The body (and ghost) of vehicle `i`, and the conflict zones its body blocks.
    fn add(&mut self, net: &LaneNetwork, v: &Vehicle, i: u32) {
        let items = &mut self.occupants;
        let first_item = items.len();
        // Where the body is drawn behind its place (see Vehicle::drawn_lag),
        // those behind keep clear of it there.
        let rear = v.rear_s() - v.drawn_lag();
        let swing = v.rear_corner_swing();
        let body = |ghost| Occupant {
            rear,
            front: v.s,
            speed: v.speed,
            vehicle: i,
            ghost,
        };
        items.push((v.path[0], body(false)));
        if let Some(left) = v.shadow_lane(net) {
            items.push((left, body(false)));
        }
        if let Some(target) = v.lane_change {
            self.lane_changers.push(i);
            items.push((target, body(true)));
        }
        if rear < 0.0
            && let Some(p) = v.behind.latest()
        {
            push_tail(net, items, p, rear, v.s, v.speed, i);
        }
        let blocked = &mut self.blocked;
        // Read only for bodies in road conflicts (maps without junctions
        // everywhere), once per body.
        let mut off_centreline = None;
        for &(lane, occ) in items[first_item..].iter().filter(|(_, o)| !o.ghost) {
            for c in &net.lane(lane).conflicts {
                // Sorted by zone start: the rest lie beyond the front.
                if c.a0 > occ.front {
                    break;
                }
                let rear = occ.rear + swing;
                if rear <= c.a1 {
                    blocked.push((
                        c.other,
                        BlockedZone {
                            start: c.b0,
                            end: c.b1,
                            parallel_rear: c.parallel.then(|| c.b0 + (rear - c.a0).max(0.0)),
                            source: lane,
                            vehicle: occ.vehicle,
                            road: c.road,
                            width: v.width,
                            length: v.length,
                            gap: c.gap.mirrored(),
                            off_centreline: if c.road {
                                *off_centreline.get_or_insert_with(|| v.drawn_off_centreline(net))
                            } else {
                                0.0
                            },
                        },
                    ));
                }
            }
        }
    }
}

/// The items of one chunk of vehicles, taken by the pass over them that
/// comes before the index is grouped (see [`LaneIndex::chunk_fillers`]).
pub struct ChunkFiller<'a> {
    items: &'a mut ChunkItems,
}

impl ChunkFiller<'_> {
    pub fn add(&mut self, net: &LaneNetwork, v: &Vehicle, i: usize) {
        self.items.add(net, v, i as u32);
    }
}

impl LaneIndex {
    pub fn empty(lane_count: usize) -> Self {
        LaneIndex {
            occupants: Buckets::build(lane_count, &[]),
            blocked: Buckets::build(lane_count, &[]),
            ..LaneIndex::default()
        }
    }

    /// Takes every vehicle's items and groups them. (A tick takes the items
    /// in its lane-following pass instead: [`LaneIndex::chunk_fillers`].)
    pub fn rebuild(&mut self, net: &LaneNetwork, vehicles: &[Vehicle]) {
        // Items per chunk of vehicles in parallel, then joined in list order,
        // so the result does not depend on the thread count.
        let chunk = chunk_len(vehicles.len());
        self.chunks
            .resize_with(chunk_count(vehicles.len()), Default::default);
        self.chunks
            .par_iter_mut()
            .zip(vehicles.par_chunks(chunk))
            .enumerate()
            .for_each(|(k, (items, some))| items.fill(net, some, (k * chunk) as u32));
        self.group(net, vehicles);
    }

    /// One emptied item list per chunk ([`chunk_len`]) of
    /// `vehicle_count` vehicles, for a pass over the vehicles to fill; then
    /// [`LaneIndex::group`].
    pub fn chunk_fillers(
        &mut self,
        vehicle_count: usize,
    ) -> impl IndexedParallelIterator<Item = ChunkFiller<'_>> {
        self.chunks
            .resize_with(chunk_count(vehicle_count), Default::default);
        self.chunks.par_iter_mut().map(|items| {
            items.clear();
            ChunkFiller { items }
        })
    }

    /// The last chunk's item list, as it is (for vehicles added after a pass
    /// over the others filled the lists: their items go after all others).
    pub fn last_filler(&mut self) -> ChunkFiller<'_> {
        if self.chunks.is_empty() {
            self.chunks.push(ChunkItems::default());
        }
        ChunkFiller {
            items: self.chunks.last_mut().expect("one list at least"),
        }
    }

    /// Groups the chunks' items by lane; `vehicles` are those the items
    /// index.
    pub fn group(&mut self, net: &LaneNetwork, vehicles: &[Vehicle]) {
        self.lane_changers.clear();
        for chunk in &self.chunks {
            self.lane_changers.extend_from_slice(&chunk.lane_changers);
        }
        let lanes = net.lanes.len();
        let (occupants, blocked) = (&mut self.occupants, &mut self.blocked);
        let chunks = &self.chunks;
        let occupant_parts: Vec<&[(LaneId, Occupant)]> =
            chunks.iter().map(|c| c.occupants.as_slice()).collect();
        let blocked_parts: Vec<&[(LaneId, BlockedZone)]> =
            chunks.iter().map(|c| c.blocked.as_slice()).collect();
        // Level rears (a lane-change ghost beside a twin) go by id, so that
        // the order does not depend on where the vehicles lie in the list.
        let id = |o: &Occupant| vehicles[o.vehicle as usize].id;
        let by_rear =
            |a: &Occupant, b: &Occupant| a.rear.total_cmp(&b.rear).then_with(|| id(a).cmp(&id(b)));
        let parallel = light_pass_parallel(vehicles.len());
        join_if(
            parallel,
            || {
                occupants.rebuild_from_parts(lanes, &occupant_parts);
                if parallel {
                    occupants.par_sort_each_by(by_rear);
                } else {
                    occupants.sort_each_by(by_rear);
                }
            },
            || blocked.rebuild_from_parts(lanes, &blocked_parts),
        );
    }

    /// Vehicles waiting to change lanes, in list order.
    pub fn lane_changers(&self) -> &[u32] {
        &self.lane_changers
    }

    pub fn on_lane(&self, lane: LaneId) -> &[Occupant] {
        self.occupants.get(lane)
    }

    /// Occupants of `lane` and of the lanes just before it, each with its
    /// front's arc length measured along `lane` (negative before its start).
    pub fn on_lane_or_before<'a>(
        &'a self,
        net: &'a LaneNetwork,
        lane: LaneId,
    ) -> impl Iterator<Item = (&'a Occupant, f64)> + 'a {
        let here = self.on_lane(lane).iter().map(|o| (o, o.front));
        let before = net.lane(lane).prev.iter().flat_map(move |&p| {
            let len = net.lane(p).length();
            self.on_lane(p).iter().map(move |o| (o, o.front - len))
        });
        here.chain(before)
    }

    /// Conflict zones of `lane` with a body of another lane in them.
    pub fn blocked_zones(&self, lane: LaneId) -> &[BlockedZone] {
        self.blocked.get(lane)
    }

    /// Asks for the cache lines where the look-ups of `lane` start.
    pub fn prefetch_lane(&self, lane: LaneId) {
        self.occupants.prefetch_key(lane);
        self.blocked.prefetch_key(lane);
    }
}

/// The part of a body behind its lane: on `lane` (the one before, at `rear`
/// and `front` relative to its end), and, where it reaches further back than
/// that lane is long, on every lane before that: the vehicle does not remember
/// which it came from, and a body across a merge blocks both anyway.
fn push_tail(
    net: &LaneNetwork,
    items: &mut Vec<(LaneId, Occupant)>,
    lane: LaneId,
    rear: f64,
    front: f64,
    speed: f64,
    vehicle: u32,
) {
    let len = net.lane(lane).length();
    items.push((
        lane,
        Occupant {
            rear: len + rear,
            front: len + front,
            speed,
            vehicle,
            ghost: false,
        },
    ));
    if len + rear < 0.0 {
        for &p in &net.lane(lane).prev {
            push_tail(net, items, p, len + rear, len + front, speed, vehicle);
        }
    }
}
