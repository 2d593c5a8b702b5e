//! NPC vehicle state (the reference's NPCVehicleInternalState).

use glam::DVec2;
use trafficmesh_model::{LightColor, SpeedMode, TurnSignal, YieldPhase};

use crate::geometry::Obb;
use crate::network::LaneId;
use crate::rng::SimRng;

pub type VehicleId = u64;

/// Pose in the map frame: x east, y north, z up, yaw radians counter-clockwise from +x.
/// (x, y) is the vehicle origin, the rear axle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub yaw: f64,
}

/// The lanes a vehicle came by, the latest first: where its body may still
/// be. Four reach back past the short road lane between two junction lanes
/// that a bus can straddle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LanesBehind([LaneId; 4]);

impl LanesBehind {
    /// Marks the places not yet filled (half the size of `Option`s: the
    /// vehicle list is moved about every tick).
    const NONE: LaneId = LaneId::MAX;

    /// The lane just before the current one.
    pub fn latest(&self) -> Option<LaneId> {
        self.iter().next()
    }

    /// The front has left `lane`.
    pub fn push(&mut self, lane: LaneId) {
        self.0.rotate_right(1);
        self.0[0] = lane;
    }

    /// Latest first.
    pub fn iter(&self) -> impl Iterator<Item = LaneId> + '_ {
        self.0.iter().copied().take_while(|&l| l != Self::NONE)
    }
}

impl Default for LanesBehind {
    fn default() -> Self {
        LanesBehind([Self::NONE; 4])
    }
}

/// A lane change under way as the body is drawn: the path moves to the new
/// lane at once, the body eases across to it as it drives on (see
/// [`crate::pose`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sideways {
    /// Metres left of the path's centreline (negative: right).
    pub offset: f64,
    /// Heading relative to the path, radians (positive: to the left).
    pub angle: f64,
    /// What is left of where it was drawn along the way (the lanes' shapes
    /// are not parallel everywhere), eased away as it drives on.
    pub residual: DVec2,
    /// Metres between the centrelines of the lane left and the new one,
    /// where the change began.
    pub gap: f64,
}

impl Sideways {
    /// How far across toward the lane left an end of a body `width` wide
    /// (the bumper's centre) may lie without reaching a body of its width
    /// there.
    pub fn reach(&self, width: f64) -> f64 {
        (self.gap - width).max(0.0)
    }

    /// How far across toward the lane left the front and the rear bumper's
    /// centres lie, metres: the front swings out first, the rear last.
    pub fn ends_across(&self, front_offset: f64, length: f64) -> (f64, f64) {
        let toward = self.offset.signum();
        let sin = self.angle.sin();
        (
            (self.offset + front_offset * sin) * toward,
            (self.offset - (length - front_offset) * sin) * toward,
        )
    }
}

/// The zebra-crossing fields of the crosswalk document.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZebraState {
    pub is_blocked: bool,
    /// Metres to the stop point minus the buffer; `f64::MAX` when not blocked.
    pub distance_to_stop: f64,
    /// Index of the matched crosswalk area.
    pub area: Option<usize>,
    pub was_blocked: bool,
}

impl Default for ZebraState {
    fn default() -> Self {
        ZebraState {
            is_blocked: false,
            distance_to_stop: f64::MAX,
            area: None,
            was_blocked: false,
        }
    }
}

/// A route being followed and how far along it the vehicle's lane list is.
#[derive(Clone, Debug)]
pub struct RouteProgress {
    pub lanes: std::sync::Arc<[LaneId]>,
    /// Index in `lanes` of the last lane appended to the path.
    pub index: usize,
    /// Leave the map after the last lane instead of choosing branches.
    pub leave_at_end: bool,
}

/// Where a lane of a vehicle's way ahead is held (see [`Vehicle::way_ahead`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WayPlace {
    /// Its index in the path.
    Path(usize),
    /// Its index in the route, beyond the lanes the path holds.
    Route(usize),
}

/// The first junction lane of a vehicle's path, kept up to date as lanes are
/// appended and dropped so that right of way need not walk the path each tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstJunctionLane {
    /// Index in `path`.
    pub k: usize,
    pub lane: LaneId,
    pub junction: Option<u32>,
    /// Its first point: where it enters the junction.
    pub entry: DVec2,
    /// Summed length of the path lanes before it.
    pub start: f64,
}

/// Trip accounting for the trip CSV.
#[derive(Clone, Copy, Debug, Default)]
pub struct TripStats {
    pub spawn_time: f64,
    /// When it was due to depart (a timetable's), else its spawn time.
    pub depart: f64,
    /// Seconds it has stood still without a break (SUMO's waiting time).
    pub wait: f64,
    /// Seconds it has been held by the rules of the junction it is at or
    /// before, at a crawl at most (creeping to its stop point does not end
    /// the wait), until it leaves that junction: its impatience grows with
    /// it.
    pub held_by_rule: f64,
    /// Seconds lost against driving at its lanes' speed limits throughout.
    pub time_loss: f64,
    pub distance: f64,
    pub stops: u32,
    pub time_stopped: f64,
    pub stopped: bool,
}

/// `repr(C)` with the fields every pass of a tick reads first: a tick touches
/// every vehicle several times, and at 10,000 vehicles the lines it touches,
/// not the instructions, set the pace.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Vehicle {
    // Read by every pass (lane following, lane index, cognition, motion).
    /// followingLanes: element 0 is the lane the front bumper is on.
    pub path: Vec<LaneId>,
    /// Arc length of the front bumper along path[0].
    pub s: f64,
    pub speed: f64,
    /// Origin (rear axle) to front bumper, length and width, metres.
    pub length: f64,
    pub width: f64,
    /// Summed length of the lanes in `path`.
    pub path_length: f64,
    /// The lanes before path[0], where the rear may still be.
    pub behind: LanesBehind,
    /// The lane beside path[0] that the route goes on from (a lane change it
    /// needs), kept up to date as the path changes.
    pub lane_change: Option<LaneId>,
    /// The lane it left in a lane change, while its body still reaches into
    /// it: a body on that lane for those coming up behind there (see
    /// [`Sideways`]).
    pub shadow: Option<LaneId>,
    /// Set by deadlock breaking: ignore lane rules while entering this junction.
    pub forced_through: Option<u32>,
    /// Set by gridlock breaking, until this simulated time: squeeze past
    /// bodies beside the way (road conflicts judged too narrow to pass),
    /// kept from touching them by the clearance check alone.
    pub squeeze_until: f64,
    pub should_despawn: bool,
    pub passability: LightColor,
    /// That light makes it stop: red, or a yellow it is not committed to.
    pub stops_at_light: bool,
    pub yield_phase: YieldPhase,
    pub speed_mode: SpeedMode,
    pub distance_to_front: f64,
    /// Speed of the vehicle ahead on the own path (0 for other obstacles).
    pub front_speed: f64,
    /// Along-path metres from the front bumper to the light lane's stop line.
    pub distance_to_light: f64,
    pub first_junction_lane: Option<FirstJunctionLane>,
    pub front: DVec2,
    /// Unit vector from the back to the front bumper (the body's chord on
    /// the path), and its angle: what cognition reads of the heading. The
    /// pose drawn may differ (see [`crate::pose`]).
    pub heading: DVec2,
    pub body_yaw: f64,
    pub back: DVec2,
    /// How far the body, drawn straight and centred on the chord between its
    /// bumpers, reaches past each bumper's place on the path: nothing on a
    /// straight lane, up to a metre or two on a sharp turn.
    pub overhang: f64,
    /// How far the rear corners of that body reach back past the rear
    /// bumper's place, along the lane there: a body turned off that lane
    /// swings a corner back over it (half its width times the sine of the
    /// angle), as a car just turned into a junction reaches back over its
    /// stop line.
    pub rear_reach: f64,
    pub front_offset: f64,
    /// (path[0], s) when the body was last placed; NaN before the first.
    pub pose_at: (LaneId, f64),

    // The rest of cognition's outputs.
    pub light_lane: Option<LaneId>,
    pub yield_lane: Option<LaneId>,
    pub yield_point: DVec2,
    pub dominating: Option<VehicleId>,
    pub zebra: ZebraState,

    // Control and Visualization outputs.
    pub acceleration: f64,
    pub pose: Pose,
    /// A lane change under way as the body is drawn.
    pub sideways: Sideways,
    pub turn_signal: TurnSignal,

    // Read on spawn, branch choices and despawn only.
    pub id: VehicleId,
    /// Index into the network's vehicle kinds.
    pub kind: usize,
    pub route: Option<RouteProgress>,
    pub despawn_reason: Option<crate::events::DespawnReason>,
    pub rng: SimRng,
    pub trip: TripStats,
    /// The way a reservation intersection granted it, until it is through.
    pub grant: Option<Box<crate::reservation::Driving>>,
}

/// Bodies overlap when their footprints shrunk by this on every side do,
/// metres: the centreline model approximates a rigid body on curves to a few
/// centimetres.
pub const BODY_TOLERANCE: f64 = 0.1;

impl Vehicle {
    /// The body as published (the pose's box), shrunk by `margin` on every
    /// side: the centreline model approximates a rigid body on curves to a
    /// few centimetres.
    pub fn footprint(&self, margin: f64) -> [DVec2; 4] {
        self.drawn_box(margin).corners()
    }

    /// [`Vehicle::footprint`] as an oriented box.
    pub fn drawn_box(&self, margin: f64) -> Obb {
        Obb {
            centre: self.drawn_centre(),
            axis: self.drawn_axis(),
            half_length: self.length * 0.5 - margin,
            half_width: self.width * 0.5 - margin,
        }
    }

    /// The unit heading of the body as published. Nearly always it is drawn
    /// along its chord: no sines then.
    pub fn drawn_axis(&self) -> DVec2 {
        if self.pose.yaw == self.body_yaw {
            self.heading
        } else {
            DVec2::from_angle(self.pose.yaw)
        }
    }

    /// The centre of the body as published (the pose is the rear axle's).
    pub fn drawn_centre(&self) -> DVec2 {
        DVec2::new(self.pose.x, self.pose.y)
            + self.drawn_axis() * (self.front_offset - self.length * 0.5)
    }

    /// Its body as a road conflict reads it, lying `off_centreline` off its
    /// centreline on each side.
    pub fn body(&self, off_centreline: f64) -> crate::conflicts::Body {
        crate::conflicts::Body {
            width: self.width,
            length: self.length,
            off_centreline,
        }
    }

    /// Gridlock breaking has let it squeeze past bodies beside its way.
    pub fn has_squeezed(&self) -> bool {
        self.squeeze_until.is_finite()
    }

    /// It squeezes past bodies beside its way at this simulated time.
    pub fn is_squeezing(&self, time: f64) -> bool {
        self.squeeze_until > time
    }

    /// Unit heading, kept in step with `pose.yaw` by the Control step.
    pub fn forward(&self) -> DVec2 {
        self.heading
    }

    /// Straight-line distance from the front bumper to p, negative when p is behind.
    pub fn signed_distance(&self, p: DVec2) -> f64 {
        let d = p - self.front;
        let dist = d.length();
        if self.forward().dot(d) < 0.0 {
            -dist
        } else {
            dist
        }
    }

    /// The lane it left in a lane change while its body still reaches into
    /// it, as long as it is on the lane it moved onto.
    pub fn shadow_lane(&self, net: &crate::network::LaneNetwork) -> Option<LaneId> {
        let lane = self.shadow?;
        net.lane(self.path[0])
            .siblings
            .contains(&lane)
            .then_some(lane)
    }

    /// The lane it left in a lane change while its front still reaches into
    /// it: it keeps behind the body ahead there.
    pub fn front_in_lane_left(&self, net: &crate::network::LaneNetwork) -> Option<LaneId> {
        let lane = self.shadow_lane(net)?;
        let (front, _) = self.sideways.ends_across(self.front_offset, self.length);
        (front > self.sideways.reach(self.width)).then_some(lane)
    }

    /// The lanes it will drive after its current one, each with where it is
    /// held: the rest of its path, then the rest of its route. (After a lane
    /// change the path's lanes need not be the route's, so the route is not
    /// searched for the lane it is on.)
    pub fn way_ahead(&self) -> impl Iterator<Item = (LaneId, WayPlace)> + '_ {
        let route = self.route.iter().flat_map(|r| {
            (r.index + 1..r.lanes.len()).map(move |k| (r.lanes[k], WayPlace::Route(k)))
        });
        let path = self.path.iter().enumerate().skip(1);
        path.map(|(k, &l)| (l, WayPlace::Path(k))).chain(route)
    }

    /// How far the body as drawn reaches sideways beyond where its place on
    /// the centreline would put it, metres: a body across the joint of two
    /// lanes at an angle, or on a bend, is the chord between its bumpers,
    /// and the drawn pose turns like a car's and catches up over metres
    /// where the lanes do not meet. The room beside it is that much less.
    pub fn drawn_off_centreline(&self, net: &crate::network::LaneNetwork) -> f64 {
        let heading = self.drawn_axis();
        let centre = self.drawn_centre();
        let mid = self.s - self.length * 0.5;
        let (lane, s) = if mid >= 0.0 {
            (self.path[0], mid)
        } else {
            match self.behind.latest() {
                Some(p) => (p, net.lane(p).length() + mid),
                None => return 0.0,
            }
        };
        let line = &net.lane(lane).line;
        let s = s.clamp(0.0, line.length());
        let (at, _) = line.point_at(s);
        let along = (line.point_at(s + 0.5).0 - line.point_at(s - 0.5).0).normalize_or_zero();
        (centre - at).perp_dot(along).abs() + self.length * 0.5 * heading.perp_dot(along).abs()
    }

    /// Metres the body is drawn behind its place on the path, at most: what
    /// the drawing has left over to catch up (see [`Sideways::residual`]),
    /// and how far its rear corners reach back past the rear bumper's place
    /// along the lane there (see [`Vehicle::rear_reach`]).
    pub fn drawn_lag(&self) -> f64 {
        let r = self.sideways.residual;
        let behind = if r == DVec2::ZERO { 0.0 } else { r.length() };
        behind + self.rear_reach
    }

    /// The part of [`Vehicle::rear_reach`] beyond the body's overhang: a rear
    /// corner swung back over the lane behind. Those following keep clear
    /// of it; lanes crossing a zone the body leaves do not wait for it.
    pub fn rear_corner_swing(&self) -> f64 {
        (self.rear_reach - self.overhang).max(0.0)
    }

    /// Where the origin (rear axle) lies on the chord between the bumpers,
    /// the body centred on the chord.
    pub fn axle_on_path(&self) -> DVec2 {
        self.front - self.heading * (self.front_offset - self.overhang)
    }

    /// Arc length of the rear bumper on path[0]; negative while it is still on the lane behind.
    pub fn rear_s(&self) -> f64 {
        self.s - self.length
    }
}
