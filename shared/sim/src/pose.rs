//! The pose drawn: where a viewer, a recording or a perception stack sees the
//! body. Cognition reads the body as the chord between its bumpers on the path
//! (see [`crate::control::update_pose`]); the pose published is a car's:
//!
//! - the body is centred on that chord (on a sharp turn, where the chord is
//!   shorter than the body, it reaches as far past either bumper: drawn from
//!   the front bumper, a turning bus swung its tail into the lane beside, and
//!   followers keep clear of that reach: `Vehicle::drawn_lag`);
//! - the origin (rear axle) lies on that chord, but where it would move
//!   further than a car's (an imported lane that does not start where the one
//!   before it ends, a body spanning a drawn hairpin, a lane change on a
//!   bend), it keeps a car's step and catches up over the next metres, and
//!   those behind keep clear of where it is drawn (`Vehicle::drawn_lag`);
//! - the heading turns toward the body's chord no faster than a car at that
//!   speed can ([`TURN_RADIUS`]): drawn kinks and hairpins are driven round,
//!   the body turning about its centre on the chord, so that on a bend
//!   sharper than a car can take front and rear share the swing off the path
//!   (turned about its origin, the front of a car leaving a sharp right turn
//!   swung 1.3 m into the oncoming lane);
//! - a lane change moves the path at once, but the body eases across on an
//!   S-curve that a car could drive at that speed ([`Sideways`]), and while it
//!   still reaches into the lane it left it stays a body there for those
//!   coming up behind (the lane index's shadow).

use glam::DVec2;

use crate::network::LaneId;
use crate::vehicle::{Sideways, Vehicle};
use crate::visualization::STOPPED_SPEED;

/// The drawn heading turns by at most the distance driven over this, metres:
/// a little wider than the tightest turn a car makes (4 m at the rear axle).
pub(crate) const TURN_RADIUS: f64 = 4.5;
/// A lane change's tightest curve, metres (at low speed).
const LANE_CHANGE_RADIUS: f64 = 5.0;
/// A lane change's sideways acceleration at speed, m/s²: a comfortable one.
const LANE_CHANGE_SIDE_ACCEL: f64 = 2.0;
/// The steepest angle a lane change crosses at, radians.
const LANE_CHANGE_MAX_ANGLE: f64 = 0.5;
/// How far a bumper's centre may swing past a lane's centreline in a lane
/// change, metres.
const ENDS_PAST_CENTRE: f64 = 0.15;
/// A drawn position off the path (see [`Sideways::residual`]) is eased back
/// over this many times its distance...
const EASE_PER_METRE: f64 = 20.0;
/// ... and over this many metres at least.
const EASE_MIN: f64 = 2.0;
/// The drawn origin moves at most this share more than the distance driven...
const STEP_SPARE: f64 = 0.04;
/// ... plus this, metres (a body standing still stays put).
const STEP_SLACK: f64 = 0.002;

/// How far a body standing halfway across a lane change moves on across
/// each tick, metres: under what the motion check counts as a jump at rest.
const ACROSS_IN_PLACE: f64 = 0.02;

/// Standing (or creeping up to the lane's end, ever slower) with its body
/// still reaching into the lane it left and a further change pending (a
/// route that crosses two lanes before the road's end, the first change
/// made where the body stopped): it finishes the way across where it
/// stands, a little each tick. Else it would keep that lane's shadow, and
/// with it the next change, for ever: a change waits until the body is
/// wholly across.
pub fn finishing_across(v: &Vehicle) -> bool {
    v.shadow.is_some() && v.lane_change.is_some() && v.speed < STOPPED_SPEED
}

/// A tick's move along the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moved {
    /// Metres driven.
    pub distance: f64,
    /// The speed the tick began at: a lane change's curve is the one that
    /// speed drives. The clearance check forecast the body on it before
    /// the move, and the speed the tick ends at is lower where that check
    /// held the vehicle back (a tighter curve would swing the body further
    /// across than forecast).
    pub from_speed: f64,
}

impl Moved {
    /// Not moved: a vehicle just placed, or standing.
    pub const NOT: Moved = Moved {
        distance: 0.0,
        from_speed: 0.0,
    };
}

/// The pose after the body `moved` along its path (not at all for a
/// vehicle just placed: its heading is then the chord's at once).
pub fn draw(v: &mut Vehicle, moved: Moved, fresh: bool, z: f64) {
    let travelled = moved.distance;
    let (side, in_place) = sideways_after(v, moved.from_speed, travelled, v.heading);
    v.sideways = side;
    if v.shadow.is_some() {
        let (front, rear) = v.sideways.ends_across(v.front_offset, v.length);
        if front.max(rear) <= v.sideways.reach(v.width) || v.sideways.offset == 0.0 {
            v.shadow = None;
        }
    }
    let normal = v.heading.perp();
    let on_path = v.axle_on_path();
    let target = wrap(v.body_yaw + v.sideways.angle);
    let yaw = if fresh {
        target
    } else {
        turned_toward(v.pose.yaw, target, travelled)
    };
    let pivot = pivot(v, target, yaw);
    let side = &mut v.sideways;
    let mut axle = on_path + normal * side.offset + side.residual + pivot;
    if !fresh {
        // What the way's shape asks beyond a car's motion (a gap where an
        // imported lane does not start at the end of the one before, an
        // offset on a bend) is left over, and eased away as it drives on.
        let drawn = held_step(v.pose, axle, travelled, in_place);
        side.residual += drawn - axle;
        axle = drawn;
    }
    v.pose = crate::vehicle::Pose {
        x: axle.x,
        y: axle.y,
        z,
        yaw,
    };
}

/// Where the body lies across its path after `travelled` metres more along
/// it (`along`, the path's direction) from a tick begun at `speed`, and
/// how far a way across finished in place moved it.
fn sideways_after(v: &Vehicle, speed: f64, travelled: f64, along: DVec2) -> (Sideways, f64) {
    let mut side = v.sideways;
    if travelled < ACROSS_IN_PLACE && finishing_across(v) {
        let moved = across_in_place(&mut side);
        return (side, moved);
    }
    let ends = (v.front_offset, v.length - v.front_offset);
    ease_sideways(&mut side, speed, travelled, along, ends);
    (side, 0.0)
}

/// The centre and axis the body will be drawn with after driving
/// `travelled` metres on in this tick, its chord then running from `back`
/// to `front`: what [`draw`] makes of it. For the clearance check's forecast of a body
/// that does not move as its chord does: one whose heading lags the chord
/// (its corners then move otherwise, by up to the step the hold leaves
/// over), or one on its way across a lane change (it moves across as it
/// drives on).
pub(crate) fn drawn_after(
    v: &Vehicle,
    travelled: f64,
    front: DVec2,
    back: DVec2,
) -> (DVec2, DVec2) {
    let chord = front - back;
    let length = chord.length();
    let heading = if length > 1e-6 {
        chord / length
    } else {
        v.heading
    };
    let overhang = (0.5 * (v.length - length)).max(0.0);
    let (side, in_place) = sideways_after(v, v.speed, travelled, heading);
    let target = wrap(heading.y.atan2(heading.x) + side.angle);
    let yaw = turned_toward(v.pose.yaw, target, travelled);
    let on_path = front - heading * (v.front_offset - overhang);
    let wanted = on_path + heading.perp() * side.offset + side.residual + pivot(v, target, yaw);
    let axle = held_step(v.pose, wanted, travelled, in_place);
    let axis = DVec2::from_angle(yaw);
    (axle + axis * (v.front_offset - 0.5 * v.length), axis)
}

/// The heading `yaw` turned toward `target` after `travelled` metres, no
/// faster than a car turns.
fn turned_toward(yaw: f64, target: f64, travelled: f64) -> f64 {
    let most = travelled.max(0.0) / TURN_RADIUS;
    wrap(yaw + wrap(target - yaw).clamp(-most, most))
}

/// Whether a chord turning by `turn` (a unit rotation) over `travelled`
/// metres turns faster than the drawn heading may follow ([`turned_toward`]):
/// the heading then lags it. Without trigonometry: the cosine's Taylor
/// bound 1 - a²/2 + a⁴/24 is never below it, so no turn too fast is missed
/// (one within a hair of the most is counted too fast).
pub(crate) fn outturns(turn: DVec2, travelled: f64) -> bool {
    let most = travelled.max(0.0) / TURN_RADIUS;
    let most2 = most * most;
    most < std::f64::consts::PI && turn.x < 1.0 - most2 * (0.5 - most2 / 24.0)
}

/// Whether the body is drawn off its path by more than the hold on its
/// step leaves over ([`Sideways::residual`]): easing back, it may then be
/// held. (A residual decays toward nothing without reaching it.)
pub(crate) fn drawn_off_path(v: &Vehicle) -> bool {
    v.sideways.residual.length_squared() > STEP_SLACK * STEP_SLACK
}

/// Where a heading `yaw` lags its chord's `target`, the body turns about
/// its centre, not its origin: the front and the rear share the swing off
/// the path. The origin's shift for that. (Nearly every tick the heading
/// is the chord's: no sines then.)
fn pivot(v: &Vehicle, target: f64, yaw: f64) -> DVec2 {
    if yaw == target {
        DVec2::ZERO
    } else {
        (DVec2::from_angle(target) - DVec2::from_angle(yaw)) * (v.front_offset - 0.5 * v.length)
    }
}

/// The origin drawn on its way from the pose `was` to `wanted`, moved at
/// most a little more than the `travelled` metres (and `across` more, a
/// lane change finished in place).
fn held_step(was: crate::vehicle::Pose, wanted: DVec2, travelled: f64, across: f64) -> DVec2 {
    let was = DVec2::new(was.x, was.y);
    let step = wanted - was;
    let most = travelled.max(0.0) * (1.0 + STEP_SPARE) + STEP_SLACK + across;
    if step.length() > most {
        was + step * (most / step.length())
    } else {
        wanted
    }
}

/// The body has just been placed on the lane beside `from`: it starts the
/// way across from where it is drawn, and stays a body on `from` while it
/// reaches into it.
pub fn start_sideways(v: &mut Vehicle, from: LaneId) {
    // Across and along the body's chord on the new lane.
    let normal = v.heading.perp();
    let from_path = DVec2::new(v.pose.x, v.pose.y) - v.axle_on_path();
    let offset = from_path.dot(normal);
    // The lanes' distance: what the body had left to go across before the
    // change does not count.
    v.sideways.gap = (offset - v.sideways.offset).abs();
    v.sideways.offset = offset;
    v.sideways.residual = from_path - normal * offset;
    // An end of the body reaches a body of its width on `from` while it lies
    // further across than the two lanes' distance less a width.
    v.shadow = (offset.abs() > v.sideways.reach(v.width)).then_some(from);
}

/// One step of the way across: the heading relative to the path turns
/// toward the angle from which, turning back as tightly, the body ends on
/// the centreline, and the offset follows the heading. Turning about its
/// origin, a long body at a steep angle would reach into the lanes on either
/// side: neither end swings further than [`ENDS_PAST_CENTRE`] past the
/// centreline of the lane it heads for (the front) or of the lane it left
/// (the rear); `ends` are the front's and the rear's distances from the
/// origin. Driving at an angle to the path, the body falls behind its place
/// on it (`along` is the path's direction): that joins the residual.
fn ease_sideways(
    side: &mut Sideways,
    speed: f64,
    travelled: f64,
    along: DVec2,
    (front, rear): (f64, f64),
) {
    if travelled <= 0.0 {
        return;
    }
    side.residual = residual_after(side.residual, travelled);
    if side.offset == 0.0 && side.angle == 0.0 {
        return;
    }
    let radius = (speed * speed / LANE_CHANGE_SIDE_ACCEL).max(LANE_CHANGE_RADIUS);
    let turn = travelled / radius;
    // Turning back from angle a covers radius (1 - cos a) sideways.
    let steepest = (1.0 - side.offset.abs() / radius).max(-1.0).acos();
    // The sine of the angle at which an end `length` from the origin lies
    // `room` past its centreline.
    let swing = |room: f64, length: f64| ((room + ENDS_PAST_CENTRE) / length.max(1.0)).min(1.0);
    let across = side.offset.abs();
    let ends = swing(across, front)
        .min(swing((side.gap - across).max(0.0), rear))
        .asin();
    let wanted = -side.offset.signum() * steepest.min(ends).min(LANE_CHANGE_MAX_ANGLE);
    side.angle += (wanted - side.angle).clamp(-turn, turn);
    let before = side.offset;
    side.offset += travelled * side.angle.sin();
    side.residual -= along * (travelled * (1.0 - side.angle.cos()));
    if side.offset * before <= 0.0 {
        // On the centreline (or just past it): the change is done.
        side.offset = 0.0;
        side.angle = 0.0;
    }
}

/// One tick of the way across where the body stands (see
/// [`finishing_across`]): sideways, its angle kept until it is across.
/// Returns how far the body moved.
fn across_in_place(side: &mut Sideways) -> f64 {
    let step = side.offset.abs().min(ACROSS_IN_PLACE);
    side.offset -= side.offset.signum() * step;
    if side.offset == 0.0 {
        side.angle = 0.0;
    }
    step
}

/// What is left of a drawn position's `residual` off the path after
/// `travelled` metres more.
pub(crate) fn residual_after(residual: DVec2, travelled: f64) -> DVec2 {
    let distance = residual.length();
    if distance > 0.0 && travelled > 0.0 {
        residual * (1.0 - travelled / ease_length(distance)).max(0.0)
    } else {
        residual
    }
}

/// Metres over which a drawn position eases `distance` metres back onto the
/// path: a few centimetres per metre driven.
fn ease_length(distance: f64) -> f64 {
    (distance * EASE_PER_METRE).max(EASE_MIN)
}

/// An angle in (-π, π]. Those given here are sums and differences of two
/// such angles: one turn either way brings them back (no division).
fn wrap(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if a > PI {
        a - TAU
    } else if a <= -PI {
        a + TAU
    } else {
        a
    }
}
