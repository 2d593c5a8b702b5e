//! Front-obstacle distance: along-path metres from the front bumper to the
//! nearest body ahead: a leader on the own path, a vehicle standing in a
//! conflict zone of the path, the ego, or a full exit lane beyond a junction.

use glam::DVec2;
use trafficmesh_model::LightColor;

use super::Snapshot;
use super::path::{lanes_ahead, needed_lookahead};
use crate::conflicts::{Conflict, bodies_pass};
use crate::ego::Ego;
use crate::geometry::segments_intersect;
use crate::lane_change;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::{Vehicle, VehicleId};

/// A stopped vehicle this close to the start of a junction's exit lane leaves no
/// room to enter the junction behind it (metres beyond one's own length): the
/// gap at which a follower comes to rest (Decision's front-vehicle distance plus
/// its stop distance at standstill), so that one who enters clears the junction.
const EXIT_ROOM_MARGIN: f64 =
    crate::decision::MIN_FRONT_VEHICLE_DISTANCE + 3.0 * crate::decision::MIN_STOP_DISTANCE;

/// Zones closer than this along the path are one crossing, metres.
const CONTIGUOUS_ZONES: f64 = 1.0;
/// How far past a zone's start another's waiting point may lie (where it
/// waits for a neighbouring zone of the same lanes) for it to count as
/// waiting at that zone, metres.
const ZONE_WAIT_TOLERANCE: f64 = 1.0;

/// The nearest body ahead: along-path metres to it and, when it is another
/// vehicle, that vehicle's index (deadlock breaking follows these waits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontObstacle {
    pub distance: f64,
    pub vehicle: Option<u32>,
}

impl FrontObstacle {
    const NONE: FrontObstacle = FrontObstacle::clear_to(f64::INFINITY);

    /// Nothing nearer than `distance`: the starting point of a search.
    const fn clear_to(distance: f64) -> FrontObstacle {
        FrontObstacle {
            distance,
            vehicle: None,
        }
    }

    fn nearer(self, other: FrontObstacle) -> FrontObstacle {
        if other.distance < self.distance {
            other
        } else {
            self
        }
    }
}

pub fn front_obstacle(snap: &Snapshot, i: usize) -> FrontObstacle {
    let v = &snap.vehicles[i];
    let net = snap.net;
    let search = Search {
        snap,
        i,
        v,
        range: needed_lookahead(v.speed, snap.config),
        off_centreline: std::cell::OnceCell::new(),
        squeezing: v.is_squeezing(snap.time),
    };
    let mut best = FrontObstacle::NONE;
    let on_intersection = net.lane(v.path[0]).intersection;
    // Where the junction ahead begins: a movement through several junction
    // lanes whose exit is blocked waits before the first, not inside the box.
    let mut box_entry = f64::INFINITY;
    // Where a road zone just past the junction ahead is waited for (see
    // out_of_modelled_junction): its entry where the road lane before it
    // holds our body, else 0 (committed); and that of the junction just
    // before the lane at hand.
    let modelled_junctions = net.road_conflicts.between_roads_only();
    let (mut road_before, mut box_wait) = (f64::INFINITY, 0.0);
    let mut junction_behind = None;
    for (k, lane, offset) in lanes_ahead(net, v) {
        let l = net.lane(lane);
        if !l.intersection {
            junction_behind = box_entry.is_finite().then_some(box_wait);
            box_entry = f64::INFINITY;
            road_before = l.length();
        } else if box_entry.is_infinite() {
            box_entry = offset;
            box_wait = if road_before >= v.length { offset } else { 0.0 };
            junction_behind = None;
        }
        if offset > search.range || offset > best.distance {
            break;
        }
        let ahead = LaneAhead { lane, offset };
        best = best.nearer(search.leader_on(ahead));
        let mut crossing = search.conflicting_bodies(ahead, best.distance);
        if l.road_conflicts && !search.squeezing {
            crossing = crossing.nearer(search.nearer_claimant(ahead, crossing.distance));
        }
        if modelled_junctions && let Some(entry) = junction_behind {
            crossing = out_of_modelled_junction(crossing, entry);
        }
        best = best.nearer(crossing);
        if k >= 1
            && !on_intersection
            && l.intersection
            && let Some(exit) = exit_blocked_by(snap, v, k)
        {
            best = best.nearer(FrontObstacle {
                distance: box_entry.min(offset).max(0.0),
                vehicle: Some(exit),
            });
        }
    }
    if let Some((entry, by)) = super::passage::blocked_by_standing(snap, i) {
        best = best.nearer(FrontObstacle {
            distance: entry,
            vehicle: Some(by),
        });
    }
    if let Some(k) = best.vehicle
        && snap.vehicles[k as usize].speed < super::deadlock::STOPPED_SPEED
    {
        best.distance = search.clear_of_road_crossings(best.distance);
    }
    // A lane change under way: while its front still reaches into the lane
    // it left, it keeps behind the body ahead there too, closer than in a
    // queue, as it swings out past that body's corner.
    if let Some(left) = v.front_in_lane_left(net) {
        let ahead = search.leader_on(LaneAhead {
            lane: left,
            offset: -v.s,
        });
        best = best.nearer(FrontObstacle {
            distance: ahead.distance + lane_change::swing_out_allowance(net, v, snap.config),
            ..ahead
        });
    }
    // A lane change the route needs and has not found a gap for: wait before
    // the lane's end.
    if v.lane_change.is_some() {
        best = best.nearer(FrontObstacle::clear_to(
            (net.lane(v.path[0]).length() - v.s).max(0.0),
        ));
    }
    for body in snap.ego.into_iter().chain(snap.foreign) {
        best = best.nearer(FrontObstacle::clear_to(ego_distance(
            net,
            v,
            body,
            search.range,
        )));
    }
    best
}

/// A lane of the path and the along-path metres from our front bumper to its
/// start (negative for the lane we are on).
#[derive(Clone, Copy)]
struct LaneAhead {
    lane: LaneId,
    offset: f64,
}

/// The front-obstacle search of vehicle `i`, out to `range` metres.
struct Search<'a, 'b> {
    snap: &'a Snapshot<'b>,
    i: usize,
    v: &'a Vehicle,
    range: f64,
    /// What our body as drawn lies off our centreline, on each side: room
    /// we need beside our width to pass a body beside our way. Read only for
    /// road conflicts, once.
    off_centreline: std::cell::OnceCell<f64>,
    /// Let through a gridlock (see [`Vehicle::squeeze_until`]): road
    /// conflicts hold it nowhere.
    squeezing: bool,
}

impl Search<'_, '_> {
    fn id_of(&self, vehicle: u32) -> VehicleId {
        self.snap.vehicles[vehicle as usize].id
    }

    /// The nearest vehicle ahead on the lane whose body is ahead of ours.
    fn leader_on(&self, LaneAhead { lane, offset }: LaneAhead) -> FrontObstacle {
        let v = self.v;
        // Sorted by rear: skip every body whose rear is behind ours (one by
        // one: a lane holds a few bodies, fewer than a binary search's steps).
        // A ghost exactly abreast counts (two side by side that each want the
        // other's lane: see lane_change::stop_for_ghost).
        let occupants = self.snap.index.on_lane(lane).iter();
        for occ in occupants.skip_while(|o| offset + o.rear < -v.length) {
            if occ.vehicle as usize == self.i {
                continue;
            }
            let rear = offset + occ.rear;
            let front = offset + occ.front;
            // A vehicle waiting to change onto this lane: given room or not
            // (see lane_change::stop_for_ghost).
            let stop_at = if occ.ghost {
                let changer = &self.snap.vehicles[occ.vehicle as usize];
                match lane_change::stop_for_ghost(self.snap.net, self.snap.config, v, changer, rear)
                {
                    Some(at) => at,
                    None => continue,
                }
            } else {
                rear
            };
            let ahead = if occ.ghost {
                rear >= -v.length && front >= 0.0
            } else {
                rear > -v.length && front > 0.0
            };
            if ahead {
                return FrontObstacle {
                    distance: stop_at.max(0.0),
                    vehicle: Some(occ.vehicle),
                };
            }
        }
        FrontObstacle::NONE
    }

    /// Bodies standing in the conflict zones of the lane, nearer than `best`.
    fn conflicting_bodies(
        &self,
        LaneAhead { lane, offset }: LaneAhead,
        best: f64,
    ) -> FrontObstacle {
        let v = self.v;
        let mut nearest = FrontObstacle::clear_to(best);
        for z in self.snap.index.blocked_zones(lane) {
            let zone_start = offset + z.start;
            if offset + z.end <= 0.0 || zone_start > self.range {
                continue;
            }
            let d = match z.parallel_rear {
                // Merge or diverge: where the other's rear lies along our lane.
                Some(rear) => offset + rear,
                // Already inside a crossing: committed; the crossing vehicle waits for us.
                None if zone_start <= 0.0 => continue,
                None => zone_start,
            };
            // The nearest body, of level ones the lowest id: the same whatever
            // the zones' order in the list.
            let nearer = d < nearest.distance
                || (d == nearest.distance
                    && nearest
                        .vehicle
                        .is_some_and(|n| self.id_of(z.vehicle) < self.id_of(n)));
            if d <= 0.0
                || !nearer
                || z.vehicle as usize == self.i
                // A junction lane of our own path: its bodies are our leaders. A road
                // conflict with our own path is a tight loop: the body is in the way.
                || (!z.road && v.path.contains(&z.source))
                // Only road zones are passable; the offset is read for them alone.
                || (z.road && (self.squeezing || z.passable(v.body(self.off_centreline()))))
            {
                continue;
            }
            nearest = FrontObstacle {
                distance: d,
                vehicle: Some(z.vehicle),
            };
        }
        nearest
    }

    /// Road conflicts of the lane (no right of way covers them): the vehicle
    /// nearer the zone goes first, so we stop before a zone that another
    /// vehicle, nearer to it and held by nothing before it, is about to enter.
    fn nearer_claimant(&self, LaneAhead { lane, offset }: LaneAhead, best: f64) -> FrontObstacle {
        let mut nearest = FrontObstacle::clear_to(best);
        for c in self.snap.net.lane(lane).conflicts.iter().filter(|c| c.road) {
            let ours = offset + c.a0;
            if ours > self.range || ours >= nearest.distance {
                // Sorted by zone start: the rest lie further.
                break;
            }
            // Inside the zone already: committed, the other waits for our body.
            if ours <= 0.0 {
                continue;
            }
            if let Some(other) = self.claimant(c, ours)
                && let Some(distance) = self.where_crossing_begins(other, ours)
            {
                nearest = FrontObstacle {
                    distance,
                    vehicle: Some(other),
                };
            }
        }
        nearest
    }

    /// Where to wait for a claimant: a crossing of its path may begin on an
    /// earlier lane of ours than the road lane of the claim (a junction lane
    /// before it, with a zone of its own that runs up to the claim's), and
    /// one waiting inside that zone would block the claimant it waits for.
    /// None when our front is inside it already: committed, the claimant
    /// waits for our body.
    fn where_crossing_begins(&self, claimant: u32, ours: f64) -> Option<f64> {
        let theirs = &self.snap.vehicles[claimant as usize].path;
        let begins = crossing_begins(self.snap.net, self.v, theirs, ours);
        (begins > 0.0).then_some(begins)
    }

    /// A vehicle on the other lane of conflict `c`, or on a lane just before
    /// it, that will reach the zone before us: too wide to pass us there,
    /// first into the crossing of our ways (see [`goes_first`]), and neither
    /// an obstacle, a red light nor a junction's rule stops it before.
    fn claimant(&self, c: &Conflict, ours_to_zone: f64) -> Option<u32> {
        let (snap, i) = (self.snap, self.i);
        let (lane, zone) = (c.other, c.b0);
        snap.index
            .on_lane_or_before(snap.net, lane)
            .find_map(|(o, front)| {
                let to_zone = zone - front;
                if o.ghost || o.vehicle as usize == i || to_zone <= 0.0 {
                    return None;
                }
                let w = &snap.vehicles[o.vehicle as usize];
                let held = w.distance_to_front < to_zone
                    || (w.passability == LightColor::Red && w.distance_to_light < to_zone)
                    || self.waits_at_zone_for_lower_id(w, to_zone)
                    // Standing for a junction's rule (or holding for one let
                    // through), or yielding to one at a point short of the zone.
                    || (w.yield_phase.is_yielding()
                        && (w.speed < super::deadlock::STOPPED_SPEED
                            || w.signed_distance(w.yield_point) < to_zone));
                let heads_elsewhere = !w.path.iter().take(3).any(|&l| l == lane);
                if held || heads_elsewhere {
                    return None;
                }
                // As a body standing there would be passed (BlockedZone::passable).
                let ours = self.v.body(self.off_centreline());
                let theirs = w.body(w.drawn_off_centreline(snap.net));
                let first = !bodies_pass(c.gap, ours, theirs)
                    && goes_first(snap.net, w, self.v, (to_zone, ours_to_zone));
                first.then_some(o.vehicle)
            })
    }

    /// The obstacle distance to keep for a standing body `stop_at` metres
    /// ahead, so that the obstacle does not lie in a road crossing (or a
    /// stretch too narrow to pass a body like ours) that our front has not
    /// entered yet: no right of way covers it, and a body left standing
    /// there would block the other lane's traffic, which may be what the
    /// body we wait for waits for. Where a body of ours at the obstacle
    /// would reach into such a zone, the obstacle moves back to the zone's
    /// start; the zones are taken from the farthest ahead back (they are
    /// found in path order), so that an obstacle moved back into an earlier
    /// one moves again, before that one.
    fn clear_of_road_crossings(&self, stop_at: f64) -> f64 {
        if self.squeezing {
            return stop_at;
        }
        let (net, v) = (self.snap.net, self.v);
        let ours = v.body(0.0);
        let mut zones: Vec<(f64, f64)> = Vec::new();
        let modelled_junctions = net.road_conflicts.between_roads_only();
        let mut after_junction = false;
        for (_, lane, offset) in lanes_ahead(net, v) {
            if offset >= stop_at {
                break;
            }
            let l = net.lane(lane);
            if l.intersection {
                after_junction = true;
            }
            // Moved back into a junction the map models, the vehicle
            // would stand in its traffic's way (see out_of_modelled_junction).
            if !l.road_conflicts || (modelled_junctions && after_junction) {
                continue;
            }
            for c in l.conflicts.iter().filter(|c| c.road && !c.parallel) {
                let (z0, z1) = (offset + c.a0, offset + c.a1);
                if z0 >= stop_at {
                    break;
                }
                if z0 > 0.0 && z1 > stop_at - v.length && !bodies_pass(c.gap, ours, ours) {
                    zones.push((z0, z1));
                }
            }
        }
        let mut stop = stop_at;
        for &(z0, z1) in zones.iter().rev() {
            if z0 < stop && z1 > stop - v.length {
                stop = z0;
            }
        }
        stop
    }

    fn off_centreline(&self) -> f64 {
        *self
            .off_centreline
            .get_or_init(|| self.v.drawn_off_centreline(self.snap.net))
    }

    /// Two lanes that come close twice (where they merge side by side) give
    /// two zones, and each of two vehicles may be nearer to one of them: each
    /// then stands before its zone waiting for the other. A standing vehicle
    /// whose own obstacle lies at this zone is waiting there, maybe for us:
    /// of two such, the lower id goes.
    fn waits_at_zone_for_lower_id(&self, w: &Vehicle, to_zone: f64) -> bool {
        w.speed < super::deadlock::STOPPED_SPEED
            && w.distance_to_front <= to_zone + ZONE_WAIT_TOLERANCE
            && self.v.id < w.id
    }
}

/// Where a map models its junctions (`RoadConflicts::Opposing`), road zones
/// lie only between road lanes, and one just past a junction is waited for
/// before the junction (`entry` metres ahead, where the lane before holds
/// the body), never inside it, where the vehicle would block the junction's
/// own traffic. Once in, or where the lane before is too short to wait on
/// (between the junctions of a roundabout's ring, a few metres apart: the
/// vehicle would stand in the junction behind it, and a ring waiting at its
/// own entries stands still), the vehicle is committed and the clearance
/// check alone keeps the bodies apart.
fn out_of_modelled_junction(found: FrontObstacle, entry: f64) -> FrontObstacle {
    match found.vehicle {
        Some(_) if entry > 0.0 => FrontObstacle {
            distance: entry,
            ..found
        },
        Some(_) => FrontObstacle::NONE,
        None => found,
    }
}

/// How many lanes of each way are looked along for where the two ways meet.
const WAYS_MEET_LANES: usize = 4;

/// Of two vehicles whose ways cross, does `a` go before `b`? Ways may meet
/// at several zones (they cross and cross back, or run side by side too
/// narrow to pass), and each may be nearer to a different one: the one
/// nearer to where the ways first meet for it goes first (equally near, the
/// lower id), as both see it the same. Ways that do not meet within the
/// lanes looked at fall back to the zone at hand (`near`: metres from a's
/// and b's fronts to it).
fn goes_first(net: &LaneNetwork, a: &Vehicle, b: &Vehicle, near: (f64, f64)) -> bool {
    let (da, db) = match (
        first_meeting(net, a, &b.path),
        first_meeting(net, b, &a.path),
    ) {
        (Some(da), Some(db)) => (da, db),
        _ => near,
    };
    da < db || (da == db && a.id < b.id)
}

/// Metres from `runner`'s front to the first zone of its way that meets the
/// first lanes of `other_path` (negative when its front is in it already).
fn first_meeting(net: &LaneNetwork, runner: &Vehicle, other_path: &[LaneId]) -> Option<f64> {
    let theirs = &other_path[..other_path.len().min(WAYS_MEET_LANES)];
    lanes_ahead(net, runner)
        .take(WAYS_MEET_LANES)
        .find_map(|(_, lane, offset)| {
            net.lane(lane)
                .conflicts
                .iter()
                .find(|c| theirs.contains(&c.other) && offset + c.a1 > 0.0)
                .map(|c| offset + c.a0)
        })
}

/// Metres from `runner`'s front to where its crossing of `other_path` begins,
/// for the zone `zone` metres ahead: the zones with the first lanes of that
/// path before `zone`, in order along the runner's path (each lane's are
/// sorted by start); the last run of them with gaps under CONTIGUOUS_ZONES,
/// if it reaches `zone`, is the crossing. Not positive once its front is in.
fn crossing_begins(net: &LaneNetwork, runner: &Vehicle, other_path: &[LaneId], zone: f64) -> f64 {
    let theirs = &other_path[..other_path.len().min(3)];
    let mut run: Option<(f64, f64)> = None;
    for (_, lane, offset) in lanes_ahead(net, runner) {
        if offset >= zone {
            break;
        }
        let zones = net.lane(lane).conflicts.iter();
        for c in zones.filter(|c| theirs.contains(&c.other) && offset + c.a1 > 0.0) {
            let (a0, a1) = (offset + c.a0, offset + c.a1);
            if a0 >= zone {
                break;
            }
            run = match run {
                Some((start, end)) if a0 <= end + CONTIGUOUS_ZONES => Some((start, end.max(a1))),
                _ => Some((a0, a1)),
            };
        }
    }
    match run {
        Some((start, end)) if end >= zone - CONTIGUOUS_ZONES => start,
        _ => zone,
    }
}

/// "Don't block the box": the vehicle that leaves no room on the lane after
/// the junction lane path[k], if one does.
fn exit_blocked_by(snap: &Snapshot, v: &Vehicle, k: usize) -> Option<u32> {
    let exit = *v.path.get(k + 1)?;
    let occ = snap.index.on_lane(exit).first()?;
    // A realistic driver stands its own minimum gap behind the one ahead.
    let margin = match crate::control::driver_model(snap.net, v, snap.config) {
        trafficmesh_model::DriverModel::Awsim => EXIT_ROOM_MARGIN,
        trafficmesh_model::DriverModel::Realistic(idm) => idm.min_gap + 0.5,
    };
    // Where the last one on the exit comes to rest if it brakes hard now.
    let rests_at = occ.rear + occ.speed * occ.speed / (2.0 * snap.config.sudden_deceleration);
    let room = rests_at >= v.length + margin;
    (!room).then_some(occ.vehicle)
}

/// Along-path distance to the ego's box where it enters our corridor (our width).
fn ego_distance(net: &LaneNetwork, v: &Vehicle, ego: &Ego, range: f64) -> f64 {
    // Far bodies first, before the box's centre costs a sine and a cosine.
    let far = range + ego.reach() + v.width;
    if ego.position().distance_squared(v.front) > far * far {
        return f64::INFINITY;
    }
    if ego.center().distance(v.front) > range + ego.radius() + v.width {
        return f64::INFINITY;
    }
    let corners = ego.corners();
    let half_width = v.width * 0.5;
    let mut travelled = 0.0;
    let mut offset = -v.s;
    for &lane in &v.path {
        let line = &net.lane(lane).line;
        for seg in 0..line.point_count() - 1 {
            let (s0, s1) = (
                offset + line.vertices[seg].cum,
                offset + line.vertices[seg + 1].cum,
            );
            if s1 <= 0.0 {
                continue;
            }
            if s0.max(0.0) > range {
                return f64::INFINITY;
            }
            let a = if s0 < 0.0 { v.front } else { line.point(seg) };
            let b = line.point(seg + 1);
            if let Some(t) = first_hit(a, b, &corners, ego.center(), half_width) {
                return travelled + t;
            }
            travelled += a.distance(b);
        }
        offset += line.length();
    }
    f64::INFINITY
}

/// Distance along a->b to the first point where the box enters the corridor.
fn first_hit(
    a: DVec2,
    b: DVec2,
    corners: &[DVec2; 4],
    center: DVec2,
    half_width: f64,
) -> Option<f64> {
    let len = a.distance(b);
    if len < 1e-9 {
        return None;
    }
    let dir = (b - a) / len;
    let mut hit: Option<f64> = None;
    let mut take = |t: f64| hit = Some(hit.map_or(t, |h: f64| h.min(t)));
    for p in corners.iter().chain(std::iter::once(&center)) {
        let rel = *p - a;
        let t = rel.dot(dir);
        if (0.0..=len).contains(&t) && rel.perp_dot(dir).abs() <= half_width {
            take(t);
        }
    }
    for e in 0..4 {
        let (c, d) = (corners[e], corners[(e + 1) % 4]);
        if segments_intersect(a, b, c, d) {
            let n = (d - c).perp();
            let denom = dir.dot(n);
            if denom.abs() > 1e-12 {
                take(((c - a).dot(n) / denom).clamp(0.0, len));
            }
        }
    }
    hit
}
