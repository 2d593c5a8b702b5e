//! Intersection right of way: the yield-phase state machine of the reference
//! (section 3.6), evaluated on the previous tick's snapshot.
//!
//! Deliberate choices (docs/behaviour.md): traffic drives on the right, so
//! the "left-hand rule" phases yield to traffic on the right (the AWSIM reference: "yielding
//! to right-hand traffic"); the approach window is 18 m or 4 s of travel,
//! whichever is longer; a vehicle with no stop line yields at the junction
//! entrance rather than at its lane's first waypoint; headings are compared wrapped;
//! a vehicle waiting at its own red light does not evaluate the yield predicates.

use glam::DVec2;
use rayon::prelude::*;
use trafficmesh_model::{LightColor, YieldPhase};

use super::Snapshot;
use crate::buckets::Buckets;
use crate::geometry::{angle_between, cross};
use crate::network::{LaneId, LaneNetwork};
use crate::parallel::{chunk_count, chunk_len};
use crate::vehicle::{Vehicle, VehicleId};

const MIN_DISTANCE_TO_INTERSECTION: f64 = 18.0;
const APPROACH_TIME: f64 = 4.0;
const INTERACTION_RADIUS: f64 = 70.0;
const SAME_SIDE_RADIUS: f64 = 3.0;
const PARALLEL_BAND_DEG: f64 = 35.0;
const OVERRUN_TO_START: f64 = -0.5;
const OVERRUN_TO_CANCEL: f64 = -1.0;
const EGO_LATERAL: f64 = 2.0;
/// Below this a vehicle before the junction is standing, not crossing.
pub(crate) const CRAWL_SPEED: f64 = 0.5;
/// Held this long by a junction's rule, a vehicle is wholly impatient,
/// seconds: a minute, when a vehicle counts as stuck. (SUMO's
/// time-to-impatience is 180 s, against streams its drivers enter at smaller
/// gaps than the reference's.)
pub const IMPATIENCE_TIME: f64 = 60.0;
/// Room left between the other's stopping point and the junction, metres.
const CUT_IN_MARGIN: f64 = 3.0;
const EGO_ANGLE_DEG: f64 = 30.0;
/// Room a turn waiting inside the junction leaves before a crossing, metres.
const ZONE_STOP_MARGIN: f64 = 0.5;

/// What the predicates read about a vehicle, the own one and the others of its
/// junction: taken once per tick into two cache lines, so that looking over the
/// other vehicles of a junction does not pull in each one's whole state.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub struct RowInfo {
    // First line: what picks the junction's candidates, and its own approach.
    pub junction: Option<u32>,
    /// Within the approach window and not queued behind another vehicle.
    pub considered: bool,
    pub on_intersection: bool,
    /// yieldingPriorityAtTrafficLight: before the junction at a red light
    /// (or standing on its stop line, a little over it).
    pub waiting_at_red: bool,
    /// Moving at more than a crawl, or let through by deadlock breaking:
    /// before the junction, only such a vehicle is about to cross.
    pub crossing_soon: bool,
    pub yield_phase: YieldPhase,
    /// path[0] and path[1].
    pub lane: LaneId,
    pub next_lane: Option<LaneId>,
    /// In the padding before `first_int`: a wider field would take a third
    /// cache line.
    pub speed: f32,
    /// (index in path, lane) of the first intersection lane on the path.
    pub first_int: Option<(usize, LaneId)>,
    /// First point of the first junction lane (the approach it enters from).
    pub entry: DVec2,
    // Second line: where its body is.
    pub yaw: f64,
    pub front: DVec2,
    pub back: DVec2,
    /// Arc length of the rear bumper on `lane`.
    pub rear_s: f64,
    pub id: VehicleId,
}

// Two cache lines, no more.
const _: () = assert!(std::mem::size_of::<RowInfo>() == 128);

impl RowInfo {
    pub fn of(v: &Vehicle) -> Self {
        let seen = RowInfo {
            front: v.front,
            back: v.back,
            yaw: v.body_yaw,
            rear_s: v.rear_s(),
            speed: v.speed as f32,
            id: v.id,
            lane: v.path[0],
            yield_phase: v.yield_phase,
            next_lane: v.path.get(1).copied(),
            ..RowInfo::default()
        };
        let Some(first) = v.first_junction_lane else {
            return seen;
        };
        let on_intersection = first.k == 0;
        let offset = first.start - v.s;
        let window = MIN_DISTANCE_TO_INTERSECTION.max(v.speed * APPROACH_TIME);
        let obstructed = offset > v.distance_to_front;
        RowInfo {
            first_int: Some((first.k, first.lane)),
            considered: offset <= window && !obstructed,
            crossing_soon: v.speed >= CRAWL_SPEED || v.forced_through.is_some(),
            on_intersection,
            // On the junction lane, only one standing on its stop line (the
            // light's check holds it there, `light::PAST_LINE`).
            waiting_at_red: v.passability == LightColor::Red
                && (!on_intersection || (v.stops_at_light && v.distance_to_light <= 0.0)),
            entry: first.entry,
            junction: first.junction,
            ..seen
        }
    }
}

/// A considered vehicle of a junction: its id, which orders the members (so
/// that which one a predicate finds first does not depend on where the
/// vehicles lie in the world's list), and its index there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Member {
    pub id: VehicleId,
    pub index: u32,
}

/// Considered vehicles of each junction, in id order. Rebuilt in place each
/// tick.
#[derive(Clone, Debug, Default)]
pub struct JunctionBuckets {
    buckets: Buckets<Member>,
    /// (junction, member) per chunk ([`chunk_len`]) of vehicles,
    /// noted by the pass that takes each vehicle's [`RowInfo`], while it is at
    /// hand (kept for the allocations).
    chunks: Vec<Vec<(u32, Member)>>,
}

impl JunctionBuckets {
    /// One emptied member list per chunk of `vehicle_count` vehicles, for
    /// [`JunctionBuckets::note`]; then [`JunctionBuckets::group`].
    pub fn chunk_lists(&mut self, vehicle_count: usize) -> &mut [Vec<(u32, Member)>] {
        self.chunks
            .resize_with(chunk_count(vehicle_count), Vec::new);
        for list in &mut self.chunks {
            list.clear();
        }
        &mut self.chunks
    }

    /// The last chunk's member list, as it is (for vehicles added after a
    /// pass over the others filled the lists).
    pub fn last_list(&mut self) -> &mut Vec<(u32, Member)> {
        if self.chunks.is_empty() {
            self.chunks.push(Vec::new());
        }
        self.chunks.last_mut().expect("one list at least")
    }

    /// Notes vehicle `i` in its chunk's list if its junction considers it.
    pub fn note(list: &mut Vec<(u32, Member)>, i: usize, info: &RowInfo) {
        if info.considered
            && let Some(junction) = info.junction
        {
            let member = Member {
                id: info.id,
                index: i as u32,
            };
            list.push((junction, member));
        }
    }

    /// Groups the noted members by junction, in id order. (One thread: the
    /// tick groups the lane index beside it, the larger job.)
    pub fn group(&mut self, net: &LaneNetwork) {
        self.buckets
            .rebuild_from_parts(net.junction_count as usize, &self.chunks);
        self.buckets.sort_each_by(|a, b| a.id.cmp(&b.id));
    }

    /// Notes every vehicle again from `infos` and groups them: after lane
    /// changes have changed some.
    pub fn rebuild(&mut self, net: &LaneNetwork, infos: &[RowInfo]) {
        let chunk = chunk_len(infos.len());
        self.chunk_lists(infos.len())
            .par_iter_mut()
            .zip(infos.par_chunks(chunk))
            .enumerate()
            .for_each(|(k, (list, infos))| {
                for (j, info) in infos.iter().enumerate() {
                    Self::note(list, k * chunk + j, info);
                }
            });
        self.group(net);
    }

    pub(crate) fn of(&self, junction: Option<u32>) -> &[Member] {
        junction.map_or(&[], |j| self.buckets.get(j))
    }

    /// The index of the member `id` of `junction`, if it is one.
    pub(crate) fn index_of(&self, junction: Option<u32>, id: VehicleId) -> Option<u32> {
        let members = self.of(junction);
        let k = members.binary_search_by_key(&id, |m| m.id).ok()?;
        Some(members[k].index)
    }
}

/// The new phase and what goes with it.
pub struct RowDecision {
    pub phase: YieldPhase,
    pub point: DVec2,
    pub lane: Option<LaneId>,
    pub dominating: Option<VehicleId>,
}

struct Ctx<'a, 'b> {
    snap: &'a Snapshot<'b>,
    i: usize,
    v: &'a Vehicle,
    info: &'a RowInfo,
    candidates: &'a [Member],
    yield_lane: Option<LaneId>,
    /// On a junction lane, obeying the rules of the next one (see
    /// [`current_yield_lane`]): before the internal junction point.
    before_internal_junction: bool,
    /// Let through this junction by deadlock breaking: no rule makes it give
    /// way (lanes' rules, traffic on the right, holding for a vehicle that
    /// should yield to it) until it has left the junction, before it or on
    /// it; the one it waited for holds in FORCING_PRIORITY meanwhile, and
    /// giving way back would close the cycle again the next tick. A busy
    /// junction still holds it.
    released: bool,
}

/// Where a turn waiting at an internal junction point stands clear of the
/// lanes it waits for ([`Ctx::stop_before_zones`]).
enum ZoneStop {
    /// The junction lane it is on crosses none of them: at the point.
    Clear,
    /// The front stops here, before the crossing.
    At(DVec2),
    /// The front is in the crossing, or too near to stop before it.
    Reached,
}

/// A predicate's hit: the vehicle yielded to and where to stop.
type Hit = Option<(Option<VehicleId>, DVec2)>;

pub fn next_phase(snap: &Snapshot, i: usize) -> RowDecision {
    let v = &snap.vehicles[i];
    let info = &snap.row[i];
    // A reservation intersection's grants keep its ways apart, not its rules.
    if info
        .junction
        .is_some_and(|j| snap.net.reservation_junctions.contains(&j))
    {
        return RowDecision {
            phase: YieldPhase::None,
            point: v.yield_point,
            lane: None,
            dominating: None,
        };
    }
    let yield_lane = current_yield_lane(snap, v, info);
    let before_internal_junction =
        info.on_intersection && yield_lane.is_some() && v.path.get(1).copied() == yield_lane;
    // Before an internal junction point, the vehicles that matter are those
    // of the lane it waits to enter (a first junction lane that crosses no
    // other is a junction of its own).
    let junction = match yield_lane {
        Some(l) if before_internal_junction => snap.net.lane(l).junction.or(info.junction),
        _ => info.junction,
    };
    let candidates = snap.junctions.of(junction);
    let ctx = Ctx {
        snap,
        i,
        v,
        info,
        candidates,
        yield_lane,
        before_internal_junction,
        released: released_through(snap.net, v, info),
    };
    let keep = |phase, hit: Hit| match hit {
        Some((dominating, point)) => RowDecision {
            phase,
            point,
            lane: yield_lane,
            dominating,
        },
        None => RowDecision {
            phase: YieldPhase::None,
            point: v.yield_point,
            lane: yield_lane,
            dominating: None,
        },
    };
    let to = |phase, (dominating, point): (Option<VehicleId>, DVec2)| RowDecision {
        phase,
        point,
        lane: yield_lane,
        dominating,
    };
    let stay = |phase| RowDecision {
        phase,
        point: v.yield_point,
        lane: yield_lane,
        dominating: None,
    };
    let on = info.on_intersection;
    match v.yield_phase {
        YieldPhase::None => {
            // Read only for the vehicles near a junction: the lane's rule list
            // lies on a line of its own.
            let yield_lane = || {
                info.first_int
                    .map(|(_, l)| l)
                    .filter(|&l| !snap.net.lane(l).right_of_way.is_empty())
            };
            if info.considered && !on {
                let (_, lane) = info
                    .first_int
                    .expect("considered implies an intersection ahead");
                RowDecision {
                    phase: YieldPhase::EnteringIntersection,
                    point: snap.net.lane(lane).stop_point(0),
                    lane: yield_lane(),
                    dominating: None,
                }
            } else if on {
                RowDecision {
                    phase: YieldPhase::AtIntersection,
                    point: v.yield_point,
                    lane: yield_lane(),
                    dominating: None,
                }
            } else {
                RowDecision {
                    phase: YieldPhase::None,
                    point: v.yield_point,
                    lane: None,
                    dominating: None,
                }
            }
        }
        YieldPhase::EnteringIntersection => {
            if on {
                stay(YieldPhase::AtIntersection)
            } else if info.waiting_at_red {
                // Its own red light holds it already; re-evaluated the tick after green.
                stay(YieldPhase::EnteringIntersection)
            } else if let Some(hit) = ctx.should_yield_due_to_lanes(false) {
                to(YieldPhase::LanesRulesEnteringIntersection, hit)
            } else if let Some(hit) = ctx.intersection_busy() {
                to(YieldPhase::IntersectionBlocked, hit)
            } else if let Some(hit) = ctx.right_hand_rule_entering() {
                to(YieldPhase::LeftHandRuleEnteringIntersection, hit)
            } else {
                stay(YieldPhase::EnteringIntersection)
            }
        }
        YieldPhase::AtIntersection => {
            if !on {
                stay(YieldPhase::None)
            } else if let Some(hit) = ctx.should_yield_due_to_lanes(true) {
                to(YieldPhase::LanesRulesAtIntersection, hit)
            } else if let Some(hit) = ctx.some_vehicle_forcing_priority() {
                to(YieldPhase::ForcingPriority, hit)
            } else if let Some(hit) = ctx.right_hand_rule_on_intersection() {
                to(YieldPhase::LeftHandRuleAtIntersection, hit)
            } else {
                stay(YieldPhase::AtIntersection)
            }
        }
        YieldPhase::IntersectionBlocked => {
            keep(YieldPhase::IntersectionBlocked, ctx.intersection_busy())
        }
        YieldPhase::LanesRulesEnteringIntersection => {
            let hit = if on {
                None
            } else {
                ctx.should_yield_due_to_lanes(false)
            };
            keep(YieldPhase::LanesRulesEnteringIntersection, hit)
        }
        YieldPhase::LanesRulesAtIntersection => keep(
            YieldPhase::LanesRulesAtIntersection,
            ctx.should_yield_due_to_lanes(true),
        ),
        YieldPhase::LeftHandRuleEnteringIntersection => {
            let hit = if on {
                None
            } else {
                ctx.right_hand_rule_entering()
            };
            keep(YieldPhase::LeftHandRuleEnteringIntersection, hit)
        }
        YieldPhase::LeftHandRuleAtIntersection => keep(
            YieldPhase::LeftHandRuleAtIntersection,
            ctx.right_hand_rule_on_intersection(),
        ),
        YieldPhase::ForcingPriority => keep(
            YieldPhase::ForcingPriority,
            ctx.some_vehicle_forcing_priority(),
        ),
    }
}

/// Deadlock breaking let the vehicle through the junction it is at or before.
/// (Nearly every vehicle has no release: its lane is not read then.)
fn released_through(net: &LaneNetwork, v: &Vehicle, info: &RowInfo) -> bool {
    let Some(released) = v.forced_through else {
        return false;
    };
    info.first_int.is_some_and(|(_, l)| {
        net.lane(l)
            .junction
            .unwrap_or(super::deadlock::UNNUMBERED_JUNCTION)
            == released
    })
}

/// The lane whose rules the vehicle obeys. The reference sets it as the vehicle
/// approaches its junction. A junction path of several lanes (SUMO splits a
/// turn that waits inside the junction at an internal junction) brings its own
/// rules with its later lane: those apply from the junction lane before it
/// (which has none of its own) on, so that the turn waits at the internal
/// junction point, not finding its foes only once its front is past that
/// point (braking hard there, it stood in the lane of the traffic it waited
/// for).
fn current_yield_lane(snap: &Snapshot, v: &Vehicle, info: &RowInfo) -> Option<LaneId> {
    let net = snap.net;
    let has_rules = |l: LaneId| !net.lane(l).right_of_way.is_empty();
    match info.first_int {
        Some((0, lane)) => {
            let ruled = if has_rules(lane) {
                Some(lane)
            } else {
                v.path
                    .get(1)
                    .copied()
                    .filter(|&l| net.lane(l).intersection && has_rules(l))
            };
            ruled.or(v.yield_lane)
        }
        _ => v.yield_lane,
    }
}

impl Ctx<'_, '_> {
    fn net(&self) -> &LaneNetwork {
        self.snap.net
    }

    /// Other considered vehicles of this junction within the interaction radius.
    fn others(&self) -> impl Iterator<Item = &RowInfo> + '_ {
        self.candidates.iter().filter_map(move |m| {
            let o = &self.snap.row[m.index as usize];
            let near =
                o.front.distance_squared(self.v.front) < INTERACTION_RADIUS * INTERACTION_RADIUS;
            (m.index as usize != self.i && near).then_some(o)
        })
    }

    fn first_int_lane(info: &RowInfo) -> Option<LaneId> {
        info.first_int.map(|(_, l)| l)
    }

    fn same_side(&self, other: &RowInfo) -> bool {
        self.info.first_int.is_some()
            && other.first_int.is_some()
            && self.info.entry.distance_squared(other.entry) < SAME_SIDE_RADIUS * SAME_SIDE_RADIUS
    }

    /// Right-hand traffic: priority to the vehicle on the right.
    fn on_right(&self, o: &RowInfo) -> bool {
        let f = self.v.forward();
        cross(f, o.front - self.v.front) < 0.0 || cross(f, o.back - self.v.front) < 0.0
    }

    /// B must yield to A: B's first junction lane lists A's among its right-of-way lanes.
    fn has_priority(&self, a: &RowInfo, b: &RowInfo) -> bool {
        match (Self::first_int_lane(a), Self::first_int_lane(b)) {
            (Some(la), Some(lb)) => self.net().lane(lb).right_of_way.contains(&la),
            _ => false,
        }
    }

    fn parallelish(&self, o: &RowInfo) -> bool {
        let d = angle_between(self.v.body_yaw, o.yaw).to_degrees();
        !(PARALLEL_BAND_DEG..=180.0 - PARALLEL_BAND_DEG).contains(&d)
    }

    /// Do the two vehicles' paths through their first junction lanes still cross?
    fn intersect_overall(&self, o: &RowInfo) -> bool {
        self.crosses_from(self.info.first_int, o)
    }

    /// [`Self::intersect_overall`] from the junction lane whose rules the
    /// vehicle obeys: the turn's later lane, before the internal junction point.
    fn ruled_lane_crosses(&self, o: &RowInfo) -> bool {
        let own = if self.before_internal_junction {
            self.yield_lane.map(|l| (1, l))
        } else {
            self.info.first_int
        };
        self.crosses_from(own, o)
    }

    fn crosses_from(&self, own: Option<(usize, LaneId)>, o: &RowInfo) -> bool {
        let (Some((ka, a)), Some((kb, b))) = (own, o.first_int) else {
            return false;
        };
        if a == b {
            return true;
        }
        self.net().lane(a).conflicts.iter().any(|c| {
            c.other == b && (ka > 0 || self.v.rear_s() < c.a1) && (kb > 0 || o.rear_s < c.b1)
        })
    }

    /// Both on junction lanes and their remaining paths on them still cross.
    fn intersect_now_front(&self, o: &RowInfo) -> bool {
        if !self.info.on_intersection || !o.on_intersection {
            return false;
        }
        let (a, b) = (self.v.path[0], o.lane);
        a != b
            && self
                .net()
                .lane(a)
                .conflicts
                .iter()
                .any(|c| c.other == b && self.v.s < c.a1 && o.rear_s - self.v.width < c.b1)
    }

    /// Where to stop before the junction: our stop line, else the junction entrance.
    fn stop_before_junction(&self) -> DVec2 {
        let current = self.net().lane(self.v.path[0]);
        match (current.stop_center, self.info.first_int) {
            (Some(c), _) => c,
            (None, Some((_, lane))) => self.net().lane(lane).line.point(0),
            (None, None) => self.v.front,
        }
    }

    fn right_hand_rule_entering(&self) -> Hit {
        if self.released {
            return None;
        }
        self.others()
            .find(|o| {
                !o.yield_phase.is_yielding_before_intersection()
                    && !o.waiting_at_red
                    && !self.same_side(o)
                    && self.on_right(o)
                    && self.intersect_overall(o)
                    && !self.impatient_enough_to_cut_in_before(o)
            })
            .map(|o| (Some(o.id), self.stop_before_junction()))
    }

    fn right_hand_rule_on_intersection(&self) -> Hit {
        if self.released {
            return None;
        }
        self.others()
            .find(|o| {
                o.on_intersection
                    && !o.waiting_at_red
                    && !o.yield_phase.is_yielding_due_to_rules()
                    && !self.same_side(o)
                    && self.on_right(o)
                    && !self.has_priority(o, self.info)
                    && self.intersect_now_front(o)
            })
            .map(|o| (Some(o.id), self.v.front))
    }

    fn intersection_busy(&self) -> Hit {
        self.others()
            .find(|o| {
                o.on_intersection
                    // Over its stop line by a little, its red light holds it
                    // there: it crosses nobody's way now (nor on the right).
                    && !o.waiting_at_red
                    // Let through, or impatient, we go: one holding on the
                    // junction may hold for us (a body in our way still stops us).
                    && !(o.yield_phase == YieldPhase::ForcingPriority
                        && (self.released || self.impatience() > 0.0))
                    && !(o.yield_phase.is_yielding_due_to_rules() && self.parallelish(o))
                    && !self.same_side(o)
                    && self.intersect_overall(o)
            })
            .map(|o| (Some(o.id), self.stop_before_junction()))
    }

    /// A vehicle that should yield to us is crossing anyway (it was let through
    /// to break a deadlock, or it ignored us): hold here until it has passed.
    /// One still before the junction counts too (the reference looks only at
    /// vehicles on it) when it is about to cross (moving, or let through),
    /// not when its red light holds it (holding for that one would block the
    /// junction until its light turns green) nor when it stands: holding for a
    /// standing one that is about to yield to us leaves both creeping, each
    /// giving way to the other by turns.
    fn some_vehicle_forcing_priority(&self) -> Hit {
        if self.released {
            return None;
        }
        self.others()
            .find(|o| {
                !o.yield_phase.is_yielding_due_to_rules()
                    && !o.waiting_at_red
                    && (o.on_intersection || o.crossing_soon)
                    && self.has_priority(self.info, o)
                    && if self.info.on_intersection && o.on_intersection {
                        self.intersect_now_front(o)
                    } else {
                        self.intersect_overall(o)
                    }
            })
            .map(|o| (Some(o.id), self.v.front))
    }

    /// Lane rules: yield to vehicles (or the ego) on the lanes our junction lane yields to.
    fn should_yield_due_to_lanes(&self, on_intersection: bool) -> Hit {
        if self.released {
            return None;
        }
        let lane_id = self.yield_lane?;
        let lane = self.net().lane(lane_id);
        let ahead = self.before_internal_junction;
        let stop = if on_intersection && !ahead {
            lane.stop_center
                .unwrap_or_else(|| lane.line.point_at((lane.length() * 0.5).min(2.0)).0)
        } else {
            lane.stop_center.unwrap_or(lane.line.point(0))
        };
        if self.v.yield_phase.is_yielding_due_to_rules() {
            if self.v.signed_distance(self.v.yield_point) < OVERRUN_TO_CANCEL {
                return None;
            }
        } else if self.v.signed_distance(stop) < OVERRUN_TO_START {
            return None;
        }
        // Waiting at the internal junction point, the body stands clear of
        // the lanes it waits for: before the first zone where the junction
        // lane it is on crosses one of them, if there is one.
        let stop = if ahead {
            match self.stop_before_zones(&lane.right_of_way) {
                ZoneStop::Clear => stop,
                ZoneStop::At(point) => point,
                // Too late to stand clear of them here: the rules apply on
                // the later lane, once the vehicle is on it.
                ZoneStop::Reached => return None,
            }
        } else {
            stop
        };
        for &priority_lane in &lane.right_of_way {
            let npc = self.others().find(|o| {
                !o.waiting_at_red
                    && (!on_intersection
                        || (!o.yield_phase.is_yielding_due_to_rules()
                            && o.yield_phase != YieldPhase::IntersectionBlocked))
                    && self.dominates(o, priority_lane)
                    && self.ruled_lane_crosses(o)
                    && !self.impatient_enough_to_cut_in_before(o)
            });
            if let Some(o) = npc {
                return Some((Some(o.id), stop));
            }
            if let Some(ego) = self.snap.ego
                && ego_on_lane(self.net(), priority_lane, ego.position(), ego.forward())
            {
                return Some((None, stop));
            }
        }
        None
    }

    /// Where the front stops before the first zone in which the junction
    /// lane we are on crosses one of `others`.
    fn stop_before_zones(&self, others: &[LaneId]) -> ZoneStop {
        let lane = self.net().lane(self.v.path[0]);
        // Sorted by start: the first found is the first along the lane.
        let Some(zone) = lane.conflicts.iter().find(|c| others.contains(&c.other)) else {
            return ZoneStop::Clear;
        };
        let at = zone.a0 - ZONE_STOP_MARGIN;
        if at > self.v.s + OVERRUN_TO_START {
            ZoneStop::At(lane.line.point_at(at.max(0.0)).0)
        } else {
            ZoneStop::Reached
        }
    }

    /// 0 to 1: the time the junction's rules have held us, over [`IMPATIENCE_TIME`].
    fn impatience(&self) -> f64 {
        (self.v.trip.held_by_rule / IMPATIENCE_TIME).min(1.0)
    }

    /// Impatience, as SUMO's: the longer a vehicle has been held by a rule,
    /// the harder it lets a priority vehicle brake for it. It goes before one
    /// not yet in the junction that could still stop before the junction
    /// braking at our impatience (0 to 1, growing over [`IMPATIENCE_TIME`])
    /// times the sudden deceleration; wholly impatient, it also goes before
    /// one standing at the junction's entrance (held there by something
    /// else, maybe for good, like a full exit). Once we move, that one holds in
    /// FORCING_PRIORITY for us when it comes onto the junction, or waits
    /// before it while we are on it. Impatience lasts until we leave the
    /// junction, so that we do not stop again halfway.
    fn impatient_enough_to_cut_in_before(&self, o: &RowInfo) -> bool {
        let impatience = self.impatience();
        if o.on_intersection || impatience <= 0.0 {
            return false;
        }
        let speed = f64::from(o.speed);
        if impatience >= 1.0 && speed < CRAWL_SPEED {
            return true;
        }
        let braking = speed * speed / (2.0 * impatience * self.snap.config.sudden_deceleration);
        o.front.distance(o.entry) >= braking + CUT_IN_MARGIN
    }

    /// The other vehicle is on, or about to enter, `lane` as its first junction lane.
    fn dominates(&self, o: &RowInfo, lane: LaneId) -> bool {
        let next_is_junction = o.next_lane.is_some_and(|l| self.net().lane(l).intersection);
        (o.on_intersection || next_is_junction) && Self::first_int_lane(o) == Some(lane)
    }
}

/// The ego is on `lane`: within 2 m of one of its segments and within 30° of its direction.
fn ego_on_lane(net: &LaneNetwork, lane: LaneId, position: DVec2, forward: DVec2) -> bool {
    let line = &net.lane(lane).line;
    (0..line.point_count() - 1).any(|i| {
        let (a, b) = (line.point(i), line.point(i + 1));
        let ab = b - a;
        let len2 = ab.length_squared();
        if len2 < 1e-12 {
            return false;
        }
        let t = (position - a).dot(ab) / len2;
        let lateral = (position - (a + ab * t)).length();
        (0.0..=1.0).contains(&t)
            && lateral <= EGO_LATERAL
            && ab.normalize().angle_to(forward).abs() < EGO_ANGLE_DEG.to_radians()
    })
}
