//! The last check before a move: no body drives into another. The rules
//! (lanes, lights, right of way, the vehicle in front) keep bodies apart
//! where the map's lanes meet as they are drawn; where they do not (a bus
//! sweeping the inside of a tight turn, a merge whose approaches lie in two
//! junctions, a body left across a lane by a yield given too late), this
//! stops the vehicle short of the body in its way, as a driver would brake
//! for an obstacle no rule told them of.
//!
//! The way a vehicle will drive this tick is the ground its body sweeps from
//! where it is to where its furthest travel takes it along its path. A body
//! in that ground stops the vehicle where the sweep still keeps clear of it
//! (or, already nearer, comes no nearer), and stands in for the obstacle in
//! front when it is nearer. Of two vehicles moving into the same ground,
//! the one behind keeps [`MARGIN`] clear of the ground the one ahead can
//! cover this tick, so that the two never both stop for each other nor both
//! go. Vehicles on the open road, clear of junctions and lane changes and
//! narrow enough for their lane, are not checked (following keeps them
//! apart), but are bodies the others see.

use std::cell::OnceCell;

use glam::DVec2;

use super::Snapshot;
use super::path::point_on_path;
pub use crate::body_grid::is_wide;
use crate::body_grid::{BodyBox, MARGIN};
use crate::geometry::Obb;
use crate::vehicle::Vehicle;

/// A body in the vehicle's way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocked {
    /// How far the vehicle may drive before it comes nearer than the
    /// clearance kept, metres.
    pub travel: f64,
    /// The vehicle whose body is in the way (an index).
    pub by: u32,
}

/// Two headings whose sum is shorter than this (squared) point against each
/// other (more than about 150 degrees apart): no way both are going.
const HEADING_AGAINST: f64 = 0.25;
/// Two turns whose headings' sum is shorter than this (squared) head
/// against each other (more than 120 degrees apart).
const TURNS_AGAINST: f64 = 1.0;
/// Fronts this near along the shared way are level, metres (scaled by the
/// way's length, under 2).
const LEVEL: f64 = 0.05;
/// Within this of a junction, before or after it, a body is checked,
/// metres: room for a bus's swing and a body standing across an exit.
const JUNCTION_APPROACH: f64 = 10.0;
/// What a vehicle squeezing past bodies beside its way keeps from them at
/// the least, metres: room for its drawn pose settling on its chord.
const SQUEEZE_MARGIN: f64 = 0.1;
/// A body this far behind the rear is left behind, metres.
const BEHIND: f64 = 1.0;
/// Halvings of the tick's reach to find where the way first comes too near.
const BISECTIONS: usize = 5;
/// Rounding slack on the clearance, metres.
const SLACK: f64 = 1e-6;

/// The nearest body in the way of vehicle `i`.
pub fn blocked(snap: &Snapshot, i: usize) -> Option<Blocked> {
    let v = &snap.vehicles[i];
    let own = snap.bodies.body(i);
    let reach_out = own.swing + MARGIN;
    if on_open_road(snap, v, own) && !snap.bodies.squeezed_near(own, reach_out) {
        return None;
    }
    let (lo, hi) = own.obb.bounds();
    let out = DVec2::splat(reach_out);
    let rear = own.obb.centre.dot(own.obb.axis) - own.obb.half_length - BEHIND;
    let body = Shape::body(&own.obb);
    let squeezing = v.is_squeezing(snap.time);
    let mover = Mover {
        snap,
        v,
        own,
        body: &body,
        sweep: OnceCell::new(),
    };
    let mut nearest: Option<(Blocked, u64)> = None;
    snap.bodies.for_each_near(lo - out, hi + out, |j| {
        if j as usize == i {
            return;
        }
        let other = snap.bodies.body(j as usize);
        // The other goes first: we keep clear of the ground it can cover
        // this tick.
        let first = goes_first(other, own);
        let other_swing = if first { other.swing } else { 0.0 };
        // Out of reach, at another level, or wholly behind (driving on
        // only leaves it further behind).
        let behind =
            other.obb.centre.dot(own.obb.axis) + other.obb.half_shadow(own.obb.axis) + other_swing
                < rear;
        if behind
            || !own.may_meet(other, snap.net)
            || own.obb.separation(&other.obb) > reach_out + other_swing
        {
            return;
        }
        let obstacle = if first {
            Shape::swept(snap, &snap.vehicles[j as usize], other, other.reach)
        } else {
            Shape::body(&other.obb)
        };
        // The one behind keeps a margin (room for the other's way to swing
        // beyond what a tick's travel shows; none for a body standing
        // still), the one ahead only keeps off.
        let margin = if first {
            MARGIN.min(other.swing)
        } else if squeezing {
            SQUEEZE_MARGIN
        } else {
            0.0
        };
        let Some(travel) = mover.travel_clear_of(&obstacle, margin, first) else {
            return;
        };
        let better = nearest.is_none_or(|(b, id)| (travel, other.id) < (b.travel, id));
        if better {
            nearest = Some((Blocked { travel, by: j }, other.id));
        }
    });
    let yielded = way_of_wide_bodies(&mover, i);
    // A body as near as the way of the one given way to stands for it.
    [nearest.map(|(b, _)| b), yielded]
        .into_iter()
        .flatten()
        .min_by(|a, b| a.travel.total_cmp(&b.travel))
}

/// The vehicle whose way is checked: what every obstacle is held against.
struct Mover<'a, 'b> {
    snap: &'a Snapshot<'b>,
    v: &'a Vehicle,
    own: &'a BodyBox,
    /// Its body now.
    body: &'a Shape,
    /// The ground it sweeps this tick, made when first needed.
    sweep: OnceCell<Shape>,
}

impl Mover<'_, '_> {
    /// How far it may drive keeping `margin` from `obstacle` (or, nearer
    /// already, coming no deeper into it); None where that is out of reach
    /// or its sweep this tick keeps clear. Where the obstacle is the ground
    /// a vehicle that goes `first` can cover this tick, nearer already, it
    /// comes no nearer that ground on any side: sliding along its edge (no
    /// deeper into it) would close on the body that goes first, which keeps
    /// off this one only as it stands.
    fn travel_clear_of(&self, obstacle: &Shape, margin: f64, first: bool) -> Option<f64> {
        let now = self.body.gap(obstacle);
        if now > self.own.swing + MARGIN {
            return None;
        }
        if first && now < margin {
            return self.furthest(|sweep| sweep.no_nearer(obstacle, self.body));
        }
        // Rounding slack on the side of keeping apart: bodies that are apart
        // stay so by a hair, where a margin of nothing would let them touch.
        let keep = now.min(margin.max(2.0 * SLACK)) - SLACK;
        self.furthest(|sweep| sweep.keeps(obstacle, keep))
    }

    /// None where its whole sweep this tick is `clear`; else the furthest
    /// travel whose sweep is.
    fn furthest(&self, clear: impl Fn(&Shape) -> bool) -> Option<f64> {
        let Mover { snap, v, own, .. } = *self;
        let sweep = self
            .sweep
            .get_or_init(|| Shape::swept(snap, v, own, own.reach));
        if clear(sweep) {
            return None;
        }
        Some(clear_travel(own, |travel| {
            clear(&Shape::swept(snap, v, own, travel))
        }))
    }
}

/// The longest stretch of the way of the vehicle given way to whose ground
/// the one giving way keeps clear of, metres.
const YIELDED_WAY: f64 = 20.0;
/// How far before the junction a wide body driving through it may swing
/// out over the lane coming up to it, metres.
const SWING_OVER_APPROACH: f64 = 5.0;
/// The same for a body leaving a sharp turn, metres: its rear swings out as
/// its heading catches up, up to a body length back from the junction.
const LEAVING_SWING_OVER_APPROACH: f64 = 12.0;
/// The way is taken in steps this long, metres (the ground between two
/// places lies within their hull while the body turns little between them).
const YIELDED_STEP: f64 = 2.5;
/// The shortest step, metres, and the cosine of the most a body may turn
/// over one (about 8 degrees: a truck's corner then strays from the hull by
/// a centimetre).
const MIN_YIELDED_STEP: f64 = 0.3;
const COS_MOST_TURN_PER_STEP: f64 = 0.99;

/// The stretch of the way of `w`, metres from its front, over which its
/// body is in a junction: from where its front enters the one ahead to where
/// its rear leaves it (at most [`YIELDED_WAY`] long), or, with its front out
/// of one already, from here to where its rear leaves that one; in either
/// case on to where a heading lagging a sharp turn has caught up.
fn junction_stretch(
    net: &crate::network::LaneNetwork,
    w: &Vehicle,
    body: &BodyBox,
) -> Option<(f64, f64)> {
    if body.leaving_junction(net) {
        let line = &net.lane(w.path[0]).line;
        let along = line.direction(line.segment_at(w.s));
        let swing = heading_catches_up_in(w, along);
        return Some((0.0, (w.length - w.s).max(swing).min(YIELDED_WAY)));
    }
    let first = w.first_junction_lane?;
    let to_entry = first.start - w.s;
    let ahead = &w.path[first.k..];
    let in_junction = ahead
        .iter()
        .take_while(|&&l| net.lane(l).intersection)
        .count();
    let through: f64 = ahead[..in_junction]
        .iter()
        .map(|&l| net.lane(l).length())
        .sum();
    let from = to_entry.max(0.0);
    let mut to = to_entry + through + w.length;
    if let Some(&exit) = ahead.get(in_junction) {
        to = to.max(heading_catches_up_in(w, net.lane(exit).line.direction(0)));
    }
    Some((from, to.min(from + YIELDED_WAY)))
}

/// Metres `w` drives before its drawn heading has turned to `heading`,
/// turning no faster than a car can: where it lags its way (a turn sharper
/// than a body can follow), the body swings on over that stretch.
fn heading_catches_up_in(w: &Vehicle, heading: DVec2) -> f64 {
    crate::geometry::angle_between(w.pose.yaw, heading.y.atan2(heading.x))
        * crate::pose::TURN_RADIUS
}

/// A vehicle coming up to a junction keeps clear of the ground that a wide
/// body (a truck or bus with little room in its lane, whose body cuts the
/// inside of its turns) will sweep through the junction, not only of where
/// it is now: the one it gives way to, and any driving through the junction
/// now. Else it comes up to its stop line beside the truck, whose body,
/// swinging round the rest of its turn or out onto the street, then meets
/// its own, and neither can move. The same holds for a body that has just
/// left a sharp turn, its heading still swinging round, where it or the
/// mover is wide. Where it stands in that ground already, it comes no
/// nearer. (Narrower bodies keep to their lanes, which the junction's rules
/// keep apart.)
fn way_of_wide_bodies(mover: &Mover, i: usize) -> Option<Blocked> {
    let Mover { snap, v, own, .. } = *mover;
    if snap.net.lane(v.path[0]).intersection {
        return None;
    }
    let junction = snap.row[i].junction;
    let given_way = v
        .yield_phase
        .is_yielding()
        .then(|| snap.junctions.index_of(junction, v.dominating?))
        .flatten()
        .filter(|&j| is_wide(snap.net, &snap.vehicles[j as usize]));
    // A body swings out over no more than the last metres before the
    // junction: further back, nothing to look at.
    let to_entry = v.first_junction_lane.map(|f| f.start - v.s - own.swing);
    let sweeping = to_entry
        .filter(|&d| d <= LEAVING_SWING_OVER_APPROACH)
        .into_iter()
        .flat_map(|d| sweeping_through_junctions(mover, i, d <= SWING_OVER_APPROACH));
    given_way
        .into_iter()
        .chain(sweeping)
        .filter_map(|j| keep_clear_of_way(mover, j))
        .min_by(|a, b| a.travel.total_cmp(&b.travel).then(a.by.cmp(&b.by)))
}

/// Vehicles near the mover, as it comes up to its junction, whose bodies
/// still sweep through a junction: a wide one driving through it (not held
/// by a rule), or one whose turn there is sharper than its body can follow
/// (its drawn heading lags: the body swings out of the lane), where the
/// mover is `near_entry`; and one whose front has left a junction and whose
/// rear has not, its heading still lagging the turn, where it or the mover
/// is wide (the rest of that swing reaches over the end of the lane the
/// mover comes up: the oncoming lane of the street it turned into). Found
/// by where they are, not by the junction's rules: a wide body sweeps over
/// lanes those never set against its own. Indices, in id order.
fn sweeping_through_junctions<'a>(
    mover: &'a Mover,
    i: usize,
    near_entry: bool,
) -> impl Iterator<Item = u32> + 'a {
    let Mover { snap, v, own, .. } = *mover;
    let net = snap.net;
    let mover_wide = is_wide(net, v);
    let near = own.swing + own.obb.half_length + MARGIN;
    snap.bodies.sweeping().iter().copied().filter(move |&j| {
        let other = snap.bodies.body(j as usize);
        // No further than `keep_clear_of_way` looks: its stretch is at
        // most the longer of [`YIELDED_WAY`] and its length.
        let length = 2.0 * other.obb.half_length;
        let reach = near + YIELDED_WAY.max(length) + length;
        if j as usize == i || own.obb.centre.distance_squared(other.obb.centre) > reach * reach {
            return false;
        }
        // (The grid lists only wide or lagging bodies on junction lanes.)
        let w = &snap.vehicles[j as usize];
        if net.lane(other.lane).intersection {
            near_entry && !w.yield_phase.is_yielding()
        } else {
            // One leaving ahead of the mover on its own way is followed.
            (mover_wide || is_wide(net, w)) && !w.behind.iter().any(|l| l == v.path[0])
        }
    })
}

/// Where the mover stops short of the ground vehicle `j` sweeps through the
/// junction ahead of it, or through the rest of the one it is leaving.
fn keep_clear_of_way(mover: &Mover, j: u32) -> Option<Blocked> {
    let Mover { snap, v, own, .. } = *mover;
    let (w, other) = (&snap.vehicles[j as usize], snap.bodies.body(j as usize));
    // One whose way runs along our lane follows us (or leads): following
    // keeps the two apart, and its way through is where we are going.
    if !own.may_meet(other, snap.net) || w.path.contains(&v.path[0]) {
        return None;
    }
    let (mut from, way) = junction_stretch(snap.net, w, other)?;
    // Out of reach of the whole stretch: nothing to sweep near.
    let reach = way + 2.0 * other.obb.half_length + own.obb.half_length + own.swing + MARGIN;
    if own.obb.centre.distance_squared(other.obb.centre) > reach * reach {
        return None;
    }
    let mut nearest: Option<f64> = None;
    // In steps of [`YIELDED_STEP`], halved where the body turns fast: the
    // ground between two places lies within their hull only while the
    // body turns little between them (its corners sweep arcs).
    let mut here = placed(snap, w, other, from);
    while from < way {
        let mut step = YIELDED_STEP;
        let mut next = placed(snap, w, other, from + step);
        while step > MIN_YIELDED_STEP && here.1.dot(next.1) < COS_MOST_TURN_PER_STEP {
            step *= 0.5;
            next = placed(snap, w, other, from + step);
        }
        let ground = Shape::between(&here, &next);
        from += step;
        here = next;
        if let Some(travel) = mover.travel_clear_of(&ground, MARGIN, false) {
            nearest = Some(nearest.map_or(travel, |n| n.min(travel)));
        }
    }
    nearest.map(|travel| Blocked { travel, by: j })
}

/// Whether the whole body drives along one plain lane with room to spare,
/// clear of junctions and of a lane change: where following, lane changes
/// and spawning keep bodies apart by themselves (bodies meet where ways join, cross or run
/// close, which is in and by junctions and across lanes).
fn on_open_road(snap: &Snapshot, v: &Vehicle, own: &BodyBox) -> bool {
    let net = snap.net;
    let clear_ahead = v
        .first_junction_lane
        .is_none_or(|j| j.start - v.s > own.swing + JUNCTION_APPROACH);
    let clear_behind = v.s > v.length + JUNCTION_APPROACH
        || v.behind.latest().is_none_or(|l| !net.lane(l).intersection);
    let lane = net.lane(v.path[0]);
    // Having squeezed past bodies beside its way, it may stand where no
    // rule would put it.
    !lane.intersection
        && !v.has_squeezed()
        && !is_wide(net, v)
        && clear_ahead
        && clear_behind
        && v.sideways.offset == 0.0
        && v.shadow.is_none()
}

/// Of two bodies, `a` goes before `b`: its front is further along the way
/// both are heading (the one that reached the ground they share first),
/// except for two bodies heading against each other: of two turns in a
/// junction (a bus turning left sweeps across the exit of a car turning
/// right from the other way) the one nearer the end of its junction lane,
/// which leaves the ground first, goes first; of one in a junction, or
/// with its rear still in one (a truck swinging out of its turn over the
/// end of the oncoming lane), and one that has not entered, heading more
/// than 120 degrees apart, the one in the junction, which must clear it,
/// while the other can wait before it (a body leaving a sharp turn, its
/// drawn heading still lagging, may point well off the oncoming lane's
/// reverse: compared by their fronts, it would wait for the body waiting
/// for it); level, its id is lower.
/// Antisymmetric, so that of two bodies exactly one keeps clear of the
/// other's sweep.
fn goes_first(a: &BodyBox, b: &BodyBox) -> bool {
    let way = a.obb.axis + b.obb.axis;
    let turns_against = way.length_squared() <= TURNS_AGAINST
        && a.to_leave_junction.is_finite()
        && b.to_leave_junction.is_finite();
    if turns_against {
        if (a.to_leave_junction - b.to_leave_junction).abs() > LEVEL {
            return a.to_leave_junction < b.to_leave_junction;
        }
    } else if way.length_squared() <= TURNS_AGAINST
        && a.to_leave_junction.is_finite() != b.to_leave_junction.is_finite()
    {
        return a.to_leave_junction.is_finite();
    } else if way.length_squared() > HEADING_AGAINST {
        let front = |x: &BodyBox| (x.obb.centre + x.obb.axis * x.obb.half_length).dot(way);
        let (fa, fb) = (front(a), front(b));
        if (fa - fb).abs() > LEVEL {
            return fa > fb;
        }
    }
    a.id < b.id
}

/// The furthest travel within the tick's reach that is `clear`.
fn clear_travel(own: &BodyBox, clear_at: impl Fn(f64) -> bool) -> f64 {
    let (mut clear, mut blocked) = (0.0, own.reach);
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (clear + blocked);
        if clear_at(mid) {
            clear = mid;
        } else {
            blocked = mid;
        }
    }
    clear
}

/// A body, or the ground it sweeps driving along its path: the body now and
/// after the travel (the ground between lies within their hull), with the
/// axes its shadows are compared on: the boxes' own and across the way it
/// moves. An axis on which two shapes' shadows keep apart proves them apart
/// (the hull's own edges would be sharper by a hair on a bend, never
/// looser).
struct Shape {
    points: [DVec2; 8],
    corners: usize,
    axes: [DVec2; 3],
    axis_count: usize,
}

impl Shape {
    fn body(obb: &Obb) -> Self {
        let mut points = [DVec2::ZERO; 8];
        points[..4].copy_from_slice(&obb.corners());
        Shape {
            points,
            corners: 4,
            axes: [obb.axis; 3],
            axis_count: 1,
        }
    }

    /// The body now and `travel` metres on: moved as the chord between its
    /// bumpers moves.
    fn swept(snap: &Snapshot, v: &Vehicle, own: &BodyBox, travel: f64) -> Self {
        let mut points = [DVec2::ZERO; 8];
        points[..4].copy_from_slice(&own.obb.corners());
        let (then, axis, mid_then) = placed(snap, v, own, travel);
        points[4..].copy_from_slice(&then);
        let moved = mid_then - 0.5 * (v.front + v.back);
        Self::hull_of(points, own.obb.axis, axis, moved)
    }

    /// The body between two of its places (see [`placed`]).
    fn between((first, first_axis, mid_first): &Place, (then, axis, mid_then): &Place) -> Self {
        let mut points = [DVec2::ZERO; 8];
        points[..4].copy_from_slice(first);
        points[4..].copy_from_slice(then);
        Self::hull_of(points, *first_axis, *axis, *mid_then - *mid_first)
    }

    /// Two boxes' corners (the first four, the last four), their axes and
    /// how far the second lies from the first.
    fn hull_of(points: [DVec2; 8], first_axis: DVec2, axis: DVec2, moved: DVec2) -> Self {
        let moved = moved.try_normalize().unwrap_or(first_axis);
        Shape {
            points,
            corners: 8,
            axes: [first_axis, axis, moved],
            axis_count: 3,
        }
    }

    fn points(&self) -> &[DVec2] {
        &self.points[..self.corners]
    }

    /// Both shapes' axes and the normals to them.
    fn all_axes<'a>(&'a self, other: &'a Shape) -> impl Iterator<Item = DVec2> + 'a {
        self.axes[..self.axis_count]
            .iter()
            .chain(&other.axes[..other.axis_count])
            .flat_map(|&a| [a, a.perp()])
    }

    fn apart_on(&self, other: &Shape, axis: DVec2) -> f64 {
        let (a_lo, a_hi) = shadow(self.points(), axis);
        let (b_lo, b_hi) = shadow(other.points(), axis);
        (b_lo - a_hi).max(a_lo - b_hi)
    }

    /// The widest gap between the two on any of their axes: at least that
    /// far apart when positive, overlapping about that deep when not.
    fn gap(&self, other: &Shape) -> f64 {
        self.all_axes(other)
            .map(|axis| self.apart_on(other, axis))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Whether this shape (a sweep from `now`) comes no nearer `other`
    /// than `now` is on any of their axes.
    fn no_nearer(&self, other: &Shape, now: &Shape) -> bool {
        self.all_axes(other)
            .all(|axis| self.apart_on(other, axis) >= now.apart_on(other, axis) - SLACK)
    }

    /// Whether the two keep `keep` apart on some axis.
    fn keeps(&self, other: &Shape, keep: f64) -> bool {
        self.all_axes(other)
            .any(|axis| self.apart_on(other, axis) >= keep)
    }
}

/// A body's corners, its axis and the middle of its chord.
type Place = ([DVec2; 4], DVec2, DVec2);

/// The corners and axis of the body `travel` metres on along its path, and
/// the middle of its chord then: moved as the chord between its bumpers
/// moves, or, on its way across a lane change or where its drawn heading
/// lags the chord (just out of a sharp turn), as [`crate::pose::draw`] will
/// draw it.
fn placed(snap: &Snapshot, v: &Vehicle, own: &BodyBox, travel: f64) -> Place {
    let (front, _) = point_on_path(snap.net, v, travel);
    let (back, _) = point_on_path(snap.net, v, travel - v.length);
    let (mid_now, mid_then) = (0.5 * (v.front + v.back), 0.5 * (front + back));
    let turn = match (
        (v.front - v.back).try_normalize(),
        (front - back).try_normalize(),
    ) {
        (Some(now), Some(then)) => then.rotate(DVec2::new(now.x, -now.y)),
        _ => DVec2::X,
    };
    // A wide body on its way across a lane change moves across as it
    // drives on, toward the lane it heads for: beside the one it left, it
    // comes nearer the lane on its other side by centimetres a tick (others
    // have room to spare there). A heading that lags its chord, or will
    // (the chord turns faster than a car can), turns as it drives; one
    // drawn off its path eases back as the hold on its step lets it. Else
    // the body moves with its chord. (Nearly every call: no trigonometry.)
    let changing = v.sideways.offset != 0.0 || v.sideways.angle != 0.0;
    let lags = v.pose.yaw != v.body_yaw
        || crate::pose::drawn_off_path(v)
        || crate::pose::outturns(turn, travel);
    if (changing && is_wide(snap.net, v)) || (!changing && lags) {
        let (centre, axis) = crate::pose::drawn_after(v, travel, front, back);
        let obb = Obb {
            centre,
            axis,
            ..own.obb
        };
        return (obb.corners(), axis, mid_then);
    }
    // Where it is drawn off its path (see `Sideways::residual`), the body
    // eases back onto it as it drives.
    let eased = crate::pose::residual_after(v.sideways.residual, travel) - v.sideways.residual;
    let corners = own
        .obb
        .corners()
        .map(|c| mid_then + eased + turn.rotate(c - mid_now));
    (corners, turn.rotate(own.obb.axis), mid_then + eased)
}

/// The lowest and highest of the points' positions along `axis`.
fn shadow(points: &[DVec2], axis: DVec2) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in points {
        let x = p.dot(axis);
        lo = if x < lo { x } else { lo };
        hi = if x > hi { x } else { hi };
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body heading `degrees` from +x with its centre at (x, y), `to_leave`
    /// metres from the end of its junction lane.
    fn body(id: u64, (x, y): (f64, f64), degrees: f64, to_leave: f64) -> BodyBox {
        BodyBox {
            obb: Obb {
                centre: DVec2::new(x, y),
                axis: DVec2::from_angle(degrees.to_radians()),
                half_length: 2.5,
                half_width: 0.9,
            },
            to_leave_junction: to_leave,
            id,
            ..BodyBox::default()
        }
    }

    /// A bus that has just begun its left turn (12 m of it to go) and a car
    /// turning right the other way, 3 m from the end of its turn: the car
    /// leaves the ground they share first, so it goes first, whichever id
    /// is lower and whichever front lies further along their bisector.
    #[test]
    fn of_two_turns_heading_against_each_other_the_one_nearer_its_end_goes_first() {
        let bus = body(1, (1016.0, 134.6), -4.0, 12.5);
        let car = body(2, (1019.0, 137.5), -149.0, 3.0);
        assert!(goes_first(&car, &bus));
        assert!(!goes_first(&bus, &car));
    }

    /// A van just out of a corner too sharp to follow (its rear still in the
    /// junction, its drawn heading 38 degrees behind its lane) and a truck
    /// waiting at the end of the oncoming lane, 141 degrees apart: the van,
    /// which must clear the junction, goes first, though the truck's front
    /// lies further along the way both are heading.
    #[test]
    fn a_body_leaving_a_sharp_turn_goes_before_one_waiting_on_the_oncoming_lane() {
        let van = body(1, (771.2, 1585.5), -84.6, 0.0);
        let truck = body(2, (770.5, 1578.5), 56.5, f64::INFINITY);
        assert!(goes_first(&van, &truck));
        assert!(!goes_first(&truck, &van));
    }

    /// Off junction lanes the same two bodies go by where their fronts lie
    /// along the way both are heading: the rule for turns is the turns'.
    #[test]
    fn bodies_heading_against_each_other_off_junctions_go_by_their_fronts() {
        let a = body(1, (1016.0, 134.6), -4.0, f64::INFINITY);
        let b = body(2, (1019.0, 137.5), -149.0, f64::INFINITY);
        assert_eq!(goes_first(&a, &b), !goes_first(&b, &a));
        let way = a.obb.axis + b.obb.axis;
        let front = |x: &BodyBox| (x.obb.centre + x.obb.axis * x.obb.half_length).dot(way);
        assert_eq!(goes_first(&a, &b), front(&a) > front(&b));
    }

    /// With one of them in the junction (3 m to go on its junction lane)
    /// and the other not, the one in the junction, which must clear it,
    /// goes first, whichever front lies further along.
    #[test]
    fn of_bodies_heading_against_each_other_the_one_in_the_junction_goes_first() {
        let a = body(1, (1016.0, 134.6), -4.0, f64::INFINITY);
        for (x, y) in [(1019.0, 137.5), (1012.0, 137.5)] {
            let b = body(2, (x, y), -149.0, 3.0);
            assert!(goes_first(&b, &a), "b at ({x}, {y})");
            assert!(!goes_first(&a, &b), "b at ({x}, {y})");
        }
    }
}
