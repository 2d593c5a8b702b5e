//! Gridlock's last resort and the figures a traffic engineer reads about
//! waiting. As SUMO does with `time-to-teleport`: a vehicle at the head of its
//! lane that has stood still for the jam timeout is moved to the start of the
//! next lane of its way where it fits, or, where none does, taken off the
//! road; either way it is counted. A ring of queues that wait on each other
//! (a gridlock, found in the waits: one that no release through a junction
//! has freed) cannot clear by itself: one head in it is moved on as soon as
//! the whole ring has stood for [`GRIDLOCK_PATIENCE`], without waiting out
//! the timeout.

use glam::DVec2;
use trafficmesh_model::LightColor;

use super::World;
use super::squeeze::{self, Squeeze};
use crate::body_grid::bodies_may_meet;
use crate::cognition::deadlock::{self, Wait};
use crate::cognition::path::first_junction_lane;
use crate::events::DespawnReason;
use crate::geometry::boxes_overlap;
use crate::lane_index::LaneIndex;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::{LanesBehind, Pose, Vehicle, VehicleId, WayPlace};

/// Ticks between looks for jammed vehicles: a timeout is minutes long, and
/// the look reads every vehicle.
const JAM_CHECK_INTERVAL: u64 = 50;
/// Standing this long (away from a red light) makes a vehicle stuck.
pub const STUCK_AFTER: f64 = 60.0;
/// Simulated seconds between two counts of the stuck vehicles for their mean.
const STUCK_SAMPLE_INTERVAL: f64 = 60.0;
/// Seconds every member of a gridlock must have stood before one is moved
/// on: well under [`STUCK_AFTER`], so that a ring is gone before its
/// vehicles count as stuck, and long enough that queues which are only slow
/// (all standing a moment at once) are left alone.
pub const GRIDLOCK_PATIENCE: f64 = 10.0;
/// A body whose front is this little ahead of ours is our own (the index is
/// a tick old; a jammed vehicle has stood still since).
const FRONT_TOLERANCE: f64 = 0.01;

/// What the world has seen of waiting, for `sim --json` and the stepper status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WaitStats {
    /// Jammed vehicles moved on or taken off the road by the jam timeout
    /// or to break a gridlock.
    pub jam_resolutions: u64,
    /// Of those, the ones taken off the road (no lane ahead had room).
    pub jam_removals: u64,
    /// Of those, the ones moved to break a gridlock before the timeout.
    pub gridlocks_broken: u64,
    /// Gridlocks whose members were let squeeze past bodies beside their
    /// way (see [`Squeeze`]), whether or not that freed them.
    pub gridlocks_squeezed: u64,
    /// The longest standstill any vehicle has had so far, seconds.
    pub max_wait: f64,
    /// The stuck vehicles counted at the start of each simulated minute so
    /// far (see [`World::stuck_vehicles`]), summed, and how many minutes:
    /// the mean over the run says more than the count at its end, one
    /// moment of it.
    pub stuck_sampled: u64,
    pub stuck_samples: u64,
}

impl WaitStats {
    /// Stuck vehicles on the road, averaged over the simulated minutes so far.
    pub fn stuck_mean(&self) -> f64 {
        if self.stuck_samples == 0 {
            0.0
        } else {
            self.stuck_sampled as f64 / self.stuck_samples as f64
        }
    }
}

impl World {
    /// Every JAM_CHECK_INTERVAL ticks, before spawning: notes the longest
    /// wait and resolves each jammed vehicle, in id order. Returns where it
    /// put vehicles (lane start, body length).
    pub(super) fn resolve_jams(&mut self) -> Vec<(DVec2, f64)> {
        let mut placed = Vec::new();
        self.relocated.clear();
        if !self.ticks.is_multiple_of(JAM_CHECK_INTERVAL) {
            return placed;
        }
        let timeout = self.config.jam_timeout;
        let gridlocked = std::mem::take(&mut self.gridlocked);
        let mut jammed: Vec<(u64, usize)> = Vec::new();
        // The first look of each simulated minute samples the stuck vehicles.
        let minute = (self.time / STUCK_SAMPLE_INTERVAL).floor() as u64;
        let sample = self.wait_stats.stuck_samples <= minute;
        let mut stuck = 0;
        for (i, v) in self.vehicles.iter().enumerate() {
            self.wait_stats.max_wait = self.wait_stats.max_wait.max(v.trip.wait);
            stuck += u64::from(sample && is_stuck(v));
            let timed_out = timeout > 0.0 && v.trip.wait >= timeout;
            let in_gridlock = gridlocked.contains(&v.id);
            let jammed_head = timed_out && is_jammed_head(&self.net, &self.index, v);
            if jammed_head || (in_gridlock && !v.should_despawn) {
                jammed.push((v.id, i));
                if timed_out {
                    tracing::debug!(
                        "jam timeout at {:.0} s: {} {:?} for {:?}, front {:.1} m",
                        self.time,
                        place(&self.net, v),
                        v.yield_phase,
                        v.dominating,
                        v.distance_to_front
                    );
                }
                self.wait_stats.gridlocks_broken += u64::from(in_gridlock && !timed_out);
            }
        }
        if sample {
            self.wait_stats.stuck_sampled += stuck;
            self.wait_stats.stuck_samples = minute + 1;
        }
        if jammed.is_empty() {
            return placed;
        }
        // A vehicle that moves or leaves is not where the lanes were followed.
        self.drop_prefollowed();
        jammed.sort_unstable();
        for (_, i) in jammed {
            self.wait_stats.jam_resolutions += 1;
            let kind = self.vehicles[i].kind;
            let target =
                lanes_ahead(&self.net, &self.vehicles[i])
                    .into_iter()
                    .find(|&(lane, place)| {
                        self.is_spawnable(kind, lane, &placed) && self.body_fits(i, lane, place)
                    });
            tracing::debug!(
                "jam resolved at {:.0} s: {} {}",
                self.time,
                place(&self.net, &self.vehicles[i]),
                target.map_or("taken off".into(), |(lane, _)| format!(
                    "moved to {}",
                    self.net.lane(lane).name
                ))
            );
            match target {
                Some((lane, place)) => {
                    let length = self.net.kinds[kind].length;
                    placed.push((self.net.lane(lane).line.point(0), length));
                    relocate(&self.net, &mut self.vehicles[i], lane, place);
                    self.relocated.push(self.vehicles[i].id);
                }
                None => {
                    let v = &mut self.vehicles[i];
                    v.should_despawn = true;
                    v.despawn_reason = Some(DespawnReason::Jammed);
                    self.wait_stats.jam_removals += 1;
                }
            }
        }
        placed
    }

    /// On the tick before a look for jammed vehicles: notes one head of each
    /// gridlock in this tick's waits (the lowest id), for the look to move
    /// on. Off with the jam timeout: a run that never teleports keeps its
    /// gridlocks.
    pub(super) fn note_gridlocks(&mut self, waits: &[Wait]) {
        let timeout = self.config.jam_timeout;
        if timeout <= 0.0 || !(self.ticks + 1).is_multiple_of(JAM_CHECK_INTERVAL) {
            return;
        }
        let patience = GRIDLOCK_PATIENCE.min(timeout);
        let cycles = deadlock::gridlocks(&self.vehicles, waits, patience);
        let mut gridlocked = Vec::new();
        for cycle in cycles {
            let (net, vehicles) = (&self.net, &self.vehicles);
            let squeeze = Squeeze::of(net, vehicles, waits, &cycle, self.time, patience);
            if tracing::enabled!(tracing::Level::DEBUG) {
                tracing::debug!(
                    "gridlock at {:.0} s ({squeeze:?}): {}",
                    self.time,
                    describe_cycle(net, vehicles, waits, &cycle)
                );
            }
            match squeeze {
                Squeeze::UnderWay => {}
                Squeeze::Begin => {
                    self.wait_stats.gridlocks_squeezed += 1;
                    for &i in &cycle {
                        self.vehicles[i].squeeze_until = self.time + squeeze::SQUEEZE_TIME;
                    }
                }
                Squeeze::Failed | Squeeze::Pointless => {
                    let members = cycle.iter().map(|&i| &vehicles[i]);
                    let is_head = |v: &Vehicle| is_jammed_head(net, &self.index, v);
                    gridlocked.extend(gridlock_head(members, is_head));
                }
            }
        }
        self.gridlocked = gridlocked;
    }

    /// Vehicle `i` moved to `lane` would touch no other body. The spawn check
    /// looks at the lane and at who is coming; a body longer than a short
    /// lane reaches back over the lanes before it, where another may be
    /// crossing right now.
    fn body_fits(&self, i: usize, lane: LaneId, place: WayPlace) -> bool {
        let mut moved = self.vehicles[i].clone();
        relocate(&self.net, &mut moved, lane, place);
        let body = moved.footprint(0.0);
        let reach = moved.length + moved.width;
        let centre = DVec2::new(moved.pose.x, moved.pose.y);
        self.vehicles.iter().enumerate().all(|(j, other)| {
            j == i
                || DVec2::new(other.pose.x, other.pose.y).distance(centre) > reach + other.length
                || !bodies_may_meet(
                    &self.net,
                    (lane, moved.pose.z),
                    (other.path[0], other.pose.z),
                )
                || !boxes_overlap(&body, &other.footprint(0.0))
        })
    }

    /// The figures as of the last look (once a simulated second), without
    /// reading every vehicle: cheap enough for every tick.
    pub fn wait_stats_so_far(&self) -> WaitStats {
        self.wait_stats
    }

    /// The figures with the longest wait of the vehicles on the road now.
    pub fn wait_stats(&self) -> WaitStats {
        let mut stats = self.wait_stats;
        for v in &self.vehicles {
            stats.max_wait = stats.max_wait.max(v.trip.wait);
        }
        stats
    }

    /// Vehicles that have stood still for [`STUCK_AFTER`] seconds or more,
    /// not counting those held by a red light.
    pub fn stuck_vehicles(&self) -> usize {
        self.vehicles.iter().filter(|v| is_stuck(v)).count()
    }

    /// Has the next tick log its stuck vehicles (debug level): where each
    /// stands, what its rules say and whom it waits for, to find what a
    /// queue waits for.
    pub fn log_stuck_vehicles_next_tick(&mut self) {
        self.log_stuck = tracing::enabled!(tracing::Level::DEBUG);
    }

    /// Logs the stuck vehicles with this tick's `waits` (see
    /// [`World::log_stuck_vehicles_next_tick`]).
    pub(super) fn log_stuck_vehicles(&self, waits: &[Wait]) {
        let waited_for = |i: usize| match waits.get(i) {
            Some(&(k, rule)) if (k as usize) < self.vehicles.len() => format!(
                "#{} ({})",
                self.vehicles[k as usize].id,
                if rule { "rule" } else { "body" }
            ),
            _ => "nobody".into(),
        };
        // Each stuck vehicle's chain of waits, to its root.
        let mut holders = Vec::new();
        for (i, v) in self
            .vehicles
            .iter()
            .enumerate()
            .filter(|(_, v)| is_stuck(v))
        {
            holders.extend(v.dominating);
            let mut k = i;
            while let Some(&(next, _)) = waits.get(k)
                && (next as usize) < self.vehicles.len()
                && !holders.contains(&self.vehicles[next as usize].id)
            {
                k = next as usize;
                holders.push(self.vehicles[k].id);
            }
        }
        let shown = |v: &Vehicle| is_stuck(v) || holders.contains(&v.id);
        for (i, v) in self.vehicles.iter().enumerate().filter(|(_, v)| shown(v)) {
            tracing::debug!(
                "stuck at {:.0} s: {} waited {:.0} s, {:?} {:?} for {:?}, front {:.1} m at {:.1} m/s, light {:?} {:.1} m, zebra {:?}, next {:?}, waits for {}",
                self.time,
                place(&self.net, v),
                v.trip.wait,
                v.speed_mode,
                v.yield_phase,
                v.dominating,
                v.distance_to_front,
                v.front_speed,
                v.passability,
                v.distance_to_light,
                v.zebra,
                v.path.get(1).map(|&l| &self.net.lane(l).name),
                waited_for(i),
            );
        }
    }

    /// No vehicle on the road and none left to come (a timetable run to its end).
    pub fn demand_done(&self) -> bool {
        self.vehicles.is_empty() && !self.spawner.any_enabled()
    }

    /// Vehicles due to depart that have not found room on the road yet.
    pub fn insertion_backlog(&self) -> usize {
        self.spawner.backlog()
    }
}

/// A gridlock's members for the debug log, in waiting order: each one's id,
/// lane, place on it and position, and whether a rule or a body holds it.
fn describe_cycle(
    net: &LaneNetwork,
    vehicles: &[Vehicle],
    waits: &[Wait],
    cycle: &[usize],
) -> String {
    cycle
        .iter()
        .map(|&i| {
            let held = if waits[i].1 { "rule" } else { "body" };
            format!("{} {held}", place(net, &vehicles[i]))
        })
        .collect::<Vec<_>>()
        .join(" -> ")
}

/// Where a vehicle is, for the debug log: id, kind, lane, place on it,
/// position.
fn place(net: &LaneNetwork, v: &Vehicle) -> String {
    format!(
        "#{} {} {} s={:.1} ({:.1}, {:.1})",
        v.id,
        net.kinds[v.kind].name,
        net.lane(v.path[0]).name,
        v.s,
        v.pose.x,
        v.pose.y
    )
}

fn at_red(v: &Vehicle) -> bool {
    v.light_lane.is_some() && v.passability == LightColor::Red
}

fn is_stuck(v: &Vehicle) -> bool {
    v.trip.wait >= STUCK_AFTER && !at_red(v)
}

/// The head of a queue (no body ahead on its own lane, as SUMO teleports
/// only a lane's first vehicle: what holds it lies beyond the lane's end, in
/// a junction, or is a body of another lane standing across its way), not
/// held by a red light (a light held red on purpose, or stale, is a wait, not
/// a jam), and not leaving anyway.
fn is_jammed_head(net: &LaneNetwork, index: &LaneIndex, v: &Vehicle) -> bool {
    let lane = net.lane(v.path[0]);
    let head = lane.intersection
        || v.distance_to_front >= lane.length() - v.s - 0.01
        || !index
            .on_lane(v.path[0])
            .iter()
            .any(|o| !o.ghost && o.front > v.s + FRONT_TOLERANCE);
    head && !at_red(v) && !v.should_despawn
}

/// The member of a gridlock to move on: of its queue heads the lowest id.
/// Where none is one (two bodies side by side short of a red light, each in
/// the other's way, or one whose lane another's body reaches into), the
/// lowest id of those a body holds nearer than any red light: their bodies
/// stand in each other's way whatever the light shows, for good unless one
/// of them moves. A ring every member of which a red light holds first
/// waits for the lights.
fn gridlock_head<'a>(
    members: impl Iterator<Item = &'a Vehicle> + Clone,
    is_head: impl Fn(&Vehicle) -> bool,
) -> Option<VehicleId> {
    let members = members.filter(|v| !v.should_despawn);
    let held_by_light = |v: &Vehicle| at_red(v) && v.distance_to_light <= v.distance_to_front;
    members
        .clone()
        .filter(|v| is_head(v))
        .map(|v| v.id)
        .min()
        .or_else(|| members.filter(|v| !held_by_light(v)).map(|v| v.id).min())
}

/// The lanes a jammed vehicle may be moved to, nearest first: the ordinary
/// (non-junction) lanes of its way ahead that hold its whole body (on a
/// shorter one it would reach back over lanes it is not known on), each with
/// where it is held.
fn lanes_ahead(net: &LaneNetwork, v: &Vehicle) -> Vec<(LaneId, WayPlace)> {
    v.way_ahead()
        .filter(|&(l, _)| {
            let lane = net.lane(l);
            !lane.intersection && lane.length() >= v.length
        })
        .collect()
}

/// Puts the vehicle at the start of `lane`, rear bumper at 0, standing, with
/// its path (what it held beyond `lane`, or the route from there on), route
/// progress and cached facts begun again from there.
fn relocate(net: &LaneNetwork, v: &mut Vehicle, lane: LaneId, place: WayPlace) {
    match place {
        WayPlace::Path(k) => {
            v.path.drain(..k);
        }
        WayPlace::Route(k) => {
            v.path.clear();
            v.path.push(lane);
            if let Some(route) = &mut v.route {
                route.index = k;
            }
        }
    }
    v.path_length = v.path.iter().map(|&l| net.lane(l).length()).sum();
    let lane_length = net.lane(lane).length();
    v.s = v.length.min(lane_length);
    v.speed = 0.0;
    v.acceleration = 0.0;
    v.behind = LanesBehind::default();
    v.forced_through = None;
    v.yield_phase = Default::default();
    v.dominating = None;
    v.first_junction_lane = first_junction_lane(net, &v.path);
    crate::lane_change::refresh_first_lanes(net, v);
    v.pose_at = (LaneId::MAX, f64::NAN);
    v.pose = Pose::default();
    v.sideways = Default::default();
    v.shadow = None;
    crate::control::update_pose(net, v, crate::pose::Moved::NOT);
    v.trip.wait = 0.0;
    v.trip.held_by_rule = 0.0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{WorldConfig, test_grid_world};

    /// Two vehicles of a grid world standing short of a red light, their
    /// bodies `to_body` metres ahead and the stop line `to_light`.
    fn short_of_red(to_body: f64, to_light: f64) -> Vec<Vehicle> {
        let mut world = test_grid_world(3, WorldConfig::default());
        while world.vehicles().len() < 2 {
            world.step();
        }
        let mut vehicles = world.vehicles()[..2].to_vec();
        for v in &mut vehicles {
            v.light_lane = Some(v.path[0]);
            v.passability = LightColor::Red;
            v.distance_to_front = to_body;
            v.distance_to_light = to_light;
        }
        vehicles
    }

    #[test]
    fn of_a_gridlock_the_lowest_queue_head_is_moved_on() {
        let vehicles = short_of_red(0.0, 3.0);
        let higher = vehicles.iter().map(|v| v.id).max();
        let chosen = gridlock_head(vehicles.iter(), |v| Some(v.id) == higher);
        assert_eq!(chosen, higher);
    }

    #[test]
    fn bodies_in_each_others_way_short_of_a_red_light_are_a_gridlock_all_the_same() {
        let vehicles = short_of_red(0.0, 3.0);
        let lowest = vehicles.iter().map(|v| v.id).min();
        assert_eq!(gridlock_head(vehicles.iter(), |_| false), lowest);
    }

    #[test]
    fn a_ring_held_first_by_red_lights_waits_for_them() {
        let vehicles = short_of_red(8.0, 3.0);
        assert_eq!(gridlock_head(vehicles.iter(), |_| false), None);
    }
}
