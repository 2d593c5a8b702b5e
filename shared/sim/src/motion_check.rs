//! Checks of a run's motion, tick by tick, as a perception stack or a viewer
//! reading the vehicle batch would make them: poses that jump further than
//! the speed allows, headings that turn faster than a car can, bodies that
//! overlap, speeds over the limit in force, stop lines crossed on red. Read-only: it looks at the world
//! after each tick and changes nothing.

use std::collections::HashMap;

use glam::DVec2;
use trafficmesh_model::SpeedLimitSource;

use crate::World;
use crate::body_grid::bodies_may_meet;
use crate::geometry::{angle_between, boxes_overlap};
use crate::network::LaneNetwork;
use crate::vehicle::{Vehicle, VehicleId};

/// Metres a pose may move beyond its speed times the tick: rounding, and the
/// centreline's few centimetres of approximation on curves.
pub const JUMP_SLACK: f64 = 0.05;
/// A car's smallest turning radius at its reference point, metres: the
/// heading turns at most speed / radius.
pub const MIN_TURN_RADIUS: f64 = 4.0;
/// Radians a heading may turn beyond what the radius allows in one tick.
pub const YAW_SLACK: f64 = 0.01;
/// Metres per second over the limit that count as speeding.
pub const SPEED_SLACK: f64 = 0.01;
/// Footprints are shrunk by this on every side before the overlap test.
pub const OVERLAP_MARGIN: f64 = crate::vehicle::BODY_TOLERANCE;
/// Examples kept of each kind of finding.
const EXAMPLES: usize = 5;

/// One finding: when, who, where, and the measure against its bound.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    pub time: f64,
    pub vehicle: VehicleId,
    /// The other body, for an overlap.
    pub other: Option<VehicleId>,
    pub lane: String,
    pub value: f64,
    pub bound: f64,
}

/// How often one check failed, and its first failures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tally {
    /// Vehicle-ticks (pairs-ticks for overlaps) that failed.
    pub count: u64,
    /// Distinct vehicles (pairs for overlaps) that failed at least once.
    pub distinct: u64,
    /// The largest excess over the bound.
    pub max_excess: f64,
    /// The first finding of each of the first vehicles (pairs) found.
    pub first: Vec<Finding>,
    seen: std::collections::HashSet<(VehicleId, VehicleId)>,
}

impl Tally {
    fn add(&mut self, f: Finding) {
        self.count += 1;
        self.max_excess = self.max_excess.max(f.value - f.bound);
        // The first finding of each vehicle (or pair): as many incidents as
        // examples, not one incident tick after tick.
        let other = f.other.unwrap_or(f.vehicle);
        if self
            .seen
            .insert((f.vehicle.min(other), f.vehicle.max(other)))
        {
            self.distinct += 1;
            if self.first.len() < EXAMPLES {
                self.first.push(f);
            }
        }
    }
}

/// The checks over a run so far.
#[derive(Default)]
pub struct MotionCheck {
    pub ticks: u64,
    pub vehicle_steps: u64,
    /// Poses that moved further than the speed allows.
    pub jumps: Tally,
    /// Headings that turned faster than a car can.
    pub turns: Tally,
    /// Pairs of bodies that overlap (value: how deep, metres).
    pub overlaps: Tally,
    /// Speeds over the lane's limit (or the fixed limit in force).
    pub speeding: Tally,
    /// Stop lines crossed on red (value: seconds into red; bound: the grace).
    pub red_lights: Tally,
    /// Vehicles the jam timeout moved ahead (SUMO's teleports): their jump
    /// is on purpose, counted here and not among the jumps.
    pub relocations: u64,
    last: HashMap<VehicleId, (DVec2, f64, f64)>,
}

impl MotionCheck {
    /// Looks at the world after a tick.
    pub fn observe(&mut self, world: &World) {
        let (net, dt, time) = (world.network(), world.config().dt, world.time());
        let vehicle = &world.config().vehicle;
        let lane_name = |v: &Vehicle| net.lane(v.path[0]).name.clone();
        let finding = |v: &Vehicle, other, value, bound| Finding {
            time,
            vehicle: v.id,
            other,
            lane: lane_name(v),
            value,
            bound,
        };
        self.ticks += 1;
        self.vehicle_steps += world.vehicles().len() as u64;
        let mut now = HashMap::with_capacity(world.vehicles().len());
        let relocated = world.relocated_last_tick();
        self.relocations += relocated.len() as u64;
        for v in world.vehicles() {
            let at = DVec2::new(v.pose.x, v.pose.y);
            let last = self.last.get(&v.id).filter(|_| !relocated.contains(&v.id));
            if let Some(&(was, yaw, speed)) = last {
                let fastest = speed.max(v.speed);
                let moved = at.distance(was);
                let may_move = fastest * dt + JUMP_SLACK;
                if moved > may_move {
                    self.jumps.add(finding(v, None, moved, may_move));
                }
                let turned = angle_between(yaw, v.pose.yaw);
                let may_turn = fastest * dt / MIN_TURN_RADIUS + YAW_SLACK;
                if turned > may_turn {
                    self.turns.add(finding(v, None, turned, may_turn));
                }
            }
            let limit = match vehicle.speed_limit_source {
                SpeedLimitSource::FixedSpeedLimit => vehicle.fixed_speed_limit,
                SpeedLimitSource::LaneletSpeedLimit => net.lane(v.path[0]).speed_limit,
            };
            if v.speed > limit + SPEED_SLACK {
                self.speeding.add(finding(v, None, v.speed, limit));
            }
            now.insert(v.id, (at, v.pose.yaw, v.speed));
        }
        self.last = now;
        for c in world.red_light_crossings_last_tick() {
            self.red_lights.add(Finding {
                time,
                vehicle: c.vehicle,
                other: None,
                lane: net.lane(c.lane).name.clone(),
                value: c.into_red,
                bound: crate::world::RED_GRACE,
            });
        }
        for (a, b) in overlapping_pairs(net, world.vehicles(), OVERLAP_MARGIN) {
            let (va, vb) = (&world.vehicles()[a], &world.vehicles()[b]);
            // How deep the shrunk footprints reach into each other.
            let depth = -va
                .drawn_box(OVERLAP_MARGIN)
                .separation(&vb.drawn_box(OVERLAP_MARGIN));
            if !self
                .overlaps
                .seen
                .contains(&(va.id.min(vb.id), va.id.max(vb.id)))
            {
                let show = |v: &Vehicle| {
                    format!(
                        "#{} {:?} {} s={:.1} ({:.1}, {:.1}) yaw {:.2} at {:.1} m/s, {:?} {:?}",
                        v.id,
                        v.kind,
                        lane_name(v),
                        v.s,
                        v.pose.x,
                        v.pose.y,
                        v.pose.yaw,
                        v.speed,
                        v.speed_mode,
                        v.yield_phase
                    )
                };
                tracing::debug!(
                    "overlap at {time:.1} s, {depth:.2} m deep: {} and {}",
                    show(va),
                    show(vb)
                );
            }
            self.overlaps
                .add(finding(va, Some(vb.id), depth.max(0.0), 0.0));
        }
    }
}

/// Pairs (indices into `vehicles`, the lower first) whose footprints shrunk
/// by `margin` overlap, at one level (see [`bodies_may_meet`]): neighbours
/// from a grid of cells, not all pairs.
pub fn overlapping_pairs(
    net: &LaneNetwork,
    vehicles: &[Vehicle],
    margin: f64,
) -> Vec<(usize, usize)> {
    const CELL: f64 = 10.0;
    let cell = |v: &Vehicle| {
        (
            (v.pose.x / CELL).floor() as i64,
            (v.pose.y / CELL).floor() as i64,
        )
    };
    let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (i, v) in vehicles.iter().enumerate() {
        cells.entry(cell(v)).or_default().push(i);
    }
    let mut pairs = Vec::new();
    for (i, v) in vehicles.iter().enumerate() {
        let (cx, cy) = cell(v);
        let a = v.footprint(margin);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for &j in cells
                    .get(&(cx + dx, cy + dy))
                    .map_or(&[][..], Vec::as_slice)
                {
                    let other = &vehicles[j];
                    if j > i
                        && boxes_overlap(&a, &other.footprint(margin))
                        && bodies_may_meet(
                            net,
                            (v.path[0], v.pose.z),
                            (other.path[0], other.pose.z),
                        )
                    {
                        pairs.push((i, j));
                    }
                }
            }
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::WorldConfig;
    use crate::world::test_grid_world;
    use trafficmesh_model::NpcVehicleConfig;

    fn world() -> World {
        let vehicle = NpcVehicleConfig {
            speed_limit_source: SpeedLimitSource::LaneletSpeedLimit,
            ..NpcVehicleConfig::default()
        };
        test_grid_world(
            2,
            WorldConfig {
                vehicle,
                ..WorldConfig::default()
            },
        )
    }

    fn first_road(w: &World) -> String {
        let lane = w.network().lanes.iter().find(|l| !l.intersection);
        lane.expect("a grid has roads").name.clone()
    }

    #[test]
    fn a_pose_that_moves_further_than_its_speed_allows_is_a_jump() {
        let mut check = MotionCheck::default();
        let mut before = world();
        let lane = first_road(&before);
        before.place_vehicle("Taxi", &lane, 20.0, 0.0).unwrap();
        check.observe(&before);
        // The same vehicle (id 0), standing, 30 m further on one tick later.
        let mut after = world();
        after.place_vehicle("Taxi", &lane, 50.0, 0.0).unwrap();
        check.observe(&after);
        assert_eq!(check.jumps.count, 1);
        assert!((check.jumps.first[0].value - 30.0).abs() < 0.5);
        assert_eq!(check.overlaps.count, 0);
    }

    #[test]
    fn bodies_on_top_of_each_other_and_speeds_over_the_lane_limit_are_found() {
        let mut check = MotionCheck::default();
        let mut w = world();
        let lane = first_road(&w);
        let limit = w.network().lanes[w.network().lane_id(&lane).unwrap() as usize].speed_limit;
        w.place_vehicle("Taxi", &lane, 30.0, 0.0).unwrap();
        w.place_vehicle("Taxi", &lane, 32.0, limit + 5.0).unwrap();
        check.observe(&w);
        assert_eq!((check.overlaps.count, check.overlaps.distinct), (1, 1));
        // Two metres apart on one lane: the shortest way out is sideways, a
        // whole shrunk width (1.94 - 2 x 0.1).
        assert!(
            (check.overlaps.max_excess - 1.74).abs() < 1e-9,
            "depth {}",
            check.overlaps.max_excess
        );
        assert_eq!(check.speeding.count, 1);
        assert!((check.speeding.max_excess - 5.0).abs() < 1e-9);
    }
}
