//! The vehicles' bodies as drawn (the published boxes, as the overlap check
//! reads them: shrunk by [`BODY_TOLERANCE`]), found by place: a
//! grid of square cells, each body noted in every cell its bounds touch
//! (with the ground it can cover this tick). Rebuilt every tick from the
//! snapshot, for the clearance check (`cognition::clearance`).

use glam::DVec2;
use rayon::prelude::*;

use crate::buckets::Buckets;
use crate::geometry::{Obb, angle_between};
use crate::network::{LaneId, LaneNetwork};
use crate::parallel::light_pass_len;
use crate::vehicle::{BODY_TOLERANCE, Vehicle, VehicleId};

/// One body: where it is, and how far it may go this tick.
#[derive(Clone, Copy, Debug, Default)]
pub struct BodyBox {
    pub obb: Obb,
    pub z: f64,
    /// The furthest it can drive this tick, metres.
    pub reach: f64,
    /// How far a corner of the body can move this tick: its travel and what
    /// its turn (no sharper than a car's) swings it, metres.
    pub swing: f64,
    /// Metres its front still drives on the junction lane it is on (0 just
    /// past it), infinite away from junction lanes. Of two turns heading
    /// against each other, the one nearer its end goes first.
    pub to_leave_junction: f64,
    pub id: VehicleId,
    /// The lane its front is on.
    pub lane: LaneId,
}

impl BodyBox {
    /// Whether its front has just left a junction while its rear has not.
    pub fn leaving_junction(&self, net: &LaneNetwork) -> bool {
        self.to_leave_junction == 0.0 && !net.lane(self.lane).intersection
    }

    /// Whether this body can meet `other` at all: not at another height,
    /// nor on a lane that crosses the other's at another level.
    pub fn may_meet(&self, other: &BodyBox, net: &LaneNetwork) -> bool {
        bodies_may_meet(net, (self.lane, self.z), (other.lane, other.z))
    }
}

/// Whether bodies on lanes `a` and `b`, at heights `za` and `zb`, can meet:
/// a bridge over a road keeps its bodies from the road's, whether the map
/// gives heights or only says which lanes cross apart.
pub fn bodies_may_meet(net: &LaneNetwork, (a, za): (LaneId, f64), (b, zb): (LaneId, f64)) -> bool {
    (za - zb).abs() <= LEVELS_APART && !net.lanes_apart(a, b)
}

/// A body noted in the cell of its bounds' lowest corner: its bounds (with
/// the ground its corners can cover this tick) beside its index, so that a
/// query reads the cell's list alone.
#[derive(Clone, Copy, Debug, Default)]
struct Noted {
    index: u32,
    lo: DVec2,
    hi: DVec2,
}

#[derive(Clone, Debug, Default)]
pub struct BodyGrid {
    boxes: Vec<BodyBox>,
    cells: Buckets<Noted>,
    /// (cell key, body), kept for the allocation.
    items: Vec<(u32, Noted)>,
    /// Cell keys are hashed into this many buckets (a power of two).
    key_count: usize,
    /// The widest bounds of any body, on each axis: a query looks this much
    /// further back for the cells where bodies reaching into it are noted.
    widest: DVec2,
    /// The bounds (with their swing) of the bodies that have squeezed past
    /// others (see [`Vehicle::squeeze_until`]): few, and where one stands
    /// no rule placed it, so every body near one is checked, wherever it
    /// drives.
    squeezed: Vec<(DVec2, DVec2)>,
    /// The bodies whose ground through a junction others coming up keep
    /// clear of: wide ones on a junction lane, and those whose front has
    /// left a junction while their rear, the drawn heading still lagging
    /// the turn, has not. Few: indices, in id order.
    sweeping: Vec<u32>,
}

/// A body with less room than this on each side of it in its lane is
/// checked on the open road too: on a bend the chord it is drawn as leaves
/// its lane (a truck beside another), metres.
const LANE_SPARE: f64 = 0.5;
/// A body leaving a junction whose drawn heading lags its chord by more than
/// this still swings, degrees.
const LAG_TO_SWING_DEG: f64 = 2.0;

/// A body with less than [`LANE_SPARE`] on each side in its lane: on a
/// bend the chord it is drawn as leaves its lane.
pub fn is_wide(net: &LaneNetwork, v: &Vehicle) -> bool {
    net.lane(v.path[0]).width - v.width < 2.0 * LANE_SPARE
}

/// Whether the drawn heading of `v` lags its chord (in or just out of a
/// turn sharper than a body can follow): its body still swings round.
fn heading_lags(v: &Vehicle) -> bool {
    angle_between(v.pose.yaw, v.body_yaw) > LAG_TO_SWING_DEG.to_radians()
}

/// Whether the body of `v` (its box `b`) still sweeps through a junction
/// (see [`BodyGrid::sweeping`]).
fn sweeps_through_junction(net: &LaneNetwork, v: &Vehicle, b: &BodyBox, turn_radius: f64) -> bool {
    let lane = net.lane(b.lane);
    if lane.intersection {
        is_wide(net, v) || too_sharp_to_follow(lane, turn_radius) || heading_lags(v)
    } else {
        b.leaving_junction(net) && heading_lags(v)
    }
}

/// Whether a junction lane turns on a tighter radius than a drawn heading
/// turning on `turn_radius` can follow.
fn too_sharp_to_follow(lane: &crate::network::Lane, turn_radius: f64) -> bool {
    lane.line.total_turn() * turn_radius > lane.length()
}

/// A cell's side, metres: about a bus's length.
const CELL: f64 = 12.0;

impl BodyGrid {
    /// Takes every vehicle's body; `reach` gives how far a vehicle can
    /// drive this tick, and its drawn heading turns by at most the distance
    /// driven over `turn_radius`.
    pub fn rebuild(
        &mut self,
        net: &LaneNetwork,
        vehicles: &[Vehicle],
        reach: impl Fn(&Vehicle) -> f64 + Sync,
        turn_radius: f64,
    ) {
        self.boxes.clear();
        self.boxes.par_extend(
            vehicles
                .par_iter()
                .with_min_len(light_pass_len(vehicles.len()))
                .map(|v| {
                    // The footprint the overlap check reads (`sim --check`).
                    let obb = v.drawn_box(BODY_TOLERANCE);
                    let reach = reach(v);
                    BodyBox {
                        obb,
                        z: v.pose.z,
                        reach,
                        swing: reach * (1.0 + obb.half_length.hypot(obb.half_width) / turn_radius),
                        to_leave_junction: to_leave_junction(net, v),
                        id: v.id,
                        lane: v.path[0],
                    }
                }),
        );
        self.key_count = (2 * self.boxes.len()).next_power_of_two().max(64);
        self.items.clear();
        self.squeezed.clear();
        self.sweeping.clear();
        self.widest = DVec2::ZERO;
        for (i, b) in self.boxes.iter().enumerate() {
            let (lo, hi) = b.obb.bounds();
            let (lo, hi) = (lo - DVec2::splat(b.swing), hi + DVec2::splat(b.swing));
            self.widest = self.widest.max(hi - lo);
            if vehicles[i].has_squeezed() {
                self.squeezed.push((lo, hi));
            }
            if sweeps_through_junction(net, &vehicles[i], b, turn_radius) {
                self.sweeping.push(i as u32);
            }
            let (cx, cy) = cell_of(lo);
            let noted = Noted {
                index: i as u32,
                lo,
                hi,
            };
            self.items.push((self.key(cx, cy), noted));
        }
        // In id order, as those who keep clear of them read them.
        self.sweeping
            .sort_unstable_by_key(|&i| vehicles[i as usize].id);
        self.cells.rebuild(self.key_count, &self.items);
    }

    /// Does a body that has squeezed past others come within `reach` of
    /// `body`'s bounds? (None has, nearly always: then no bounds are taken.)
    pub fn squeezed_near(&self, body: &BodyBox, reach: f64) -> bool {
        if self.squeezed.is_empty() {
            return false;
        }
        let (lo, hi) = body.obb.bounds();
        let (lo, hi) = (lo - DVec2::splat(reach), hi + DVec2::splat(reach));
        self.squeezed
            .iter()
            .any(|&(l, h)| l.cmple(hi).all() && lo.cmple(h).all())
    }

    /// The bodies that still sweep through a junction: wide ones on a
    /// junction lane, and those leaving one with their heading lagging.
    pub fn sweeping(&self) -> &[u32] {
        &self.sweeping
    }

    pub fn body(&self, i: usize) -> &BodyBox {
        &self.boxes[i]
    }

    /// Calls `f` once with each vehicle whose bounds (with its swing) meet
    /// the box from `lo` to `hi`.
    pub fn for_each_near(&self, lo: DVec2, hi: DVec2, mut f: impl FnMut(u32)) {
        // Not built yet (a world's first spawns): no body, and no keys.
        if self.key_count == 0 {
            return;
        }
        let ((x0, y0), (x1, y1)) = (cell_of(lo - self.widest), cell_of(hi));
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                for b in self.cells.get(self.key(cx, cy)) {
                    let meets =
                        b.lo.x <= hi.x && b.lo.y <= hi.y && b.hi.x >= lo.x && b.hi.y >= lo.y;
                    // A key another cell shares holds that cell's bodies too.
                    if meets && cell_of(b.lo) == (cx, cy) {
                        f(b.index);
                    }
                }
            }
        }
    }

    /// Whether a body placed at `obb` on `lane` (height `z`) keeps clear of
    /// every body as noted, each grown by what it can have covered in one
    /// tick: read between two rebuilds (by spawning, before the lane index
    /// of the tick), the bodies may have moved that far since.
    pub fn clear_of_moved(&self, net: &LaneNetwork, obb: &Obb, (lane, z): (LaneId, f64)) -> bool {
        let (lo, hi) = obb.bounds();
        let mut clear = true;
        self.for_each_near(lo, hi, |j| {
            let other = &self.boxes[j as usize];
            if clear
                && bodies_may_meet(net, (lane, z), (other.lane, other.z))
                && obb.separation(&other.obb) <= other.swing
            {
                clear = false;
            }
        });
        clear
    }

    fn key(&self, cx: i64, cy: i64) -> u32 {
        let h = (cx as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
            ^ (cy as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f);
        (h.rotate_left(23) & (self.key_count as u64 - 1)) as u32
    }
}

/// Metres the front still drives on the junction lane it is on; 0 with the
/// front just past one (the body still in it, or its drawn heading still
/// swinging round the turn), infinite elsewhere.
fn to_leave_junction(net: &LaneNetwork, v: &Vehicle) -> f64 {
    let lane = net.lane(v.path[0]);
    if lane.intersection {
        (lane.length() - v.s).max(0.0)
    } else if v.behind.latest().is_some_and(|l| net.lane(l).intersection)
        && (v.s < v.length || heading_lags(v))
    {
        0.0
    } else {
        f64::INFINITY
    }
}

fn cell_of(p: DVec2) -> (i64, i64) {
    (cell_coordinate(p.x), cell_coordinate(p.y))
}

/// `floor(x / CELL)`, without the library call `f64::floor` is on the
/// baseline x86-64 target (no SSE4.1 rounding instruction).
fn cell_coordinate(x: f64) -> i64 {
    let q = x * (1.0 / CELL);
    let t = q as i64;
    t - i64::from((t as f64) > q)
}

/// How near a body may come to another before the one moving stops: the
/// clearance kept, metres.
pub const MARGIN: f64 = 0.15;

/// Bodies at different heights (a bridge over a road) never meet, metres.
pub const LEVELS_APART: f64 = 3.0;
