//! Saving the road and putting it back: what a restarted stepper resumes
//! from. Vehicles come back with their ids, lanes (ahead and behind),
//! places, speeds and routes; what they had perceived is perceived again on
//! the next tick, and a lane change under way is not resumed.

use trafficmesh_model::snapshot::{RoadSnapshot, RouteSnapshot, VehicleSnapshot};

use super::{World, WorldError};
use crate::network::LaneId;
use crate::vehicle::{LanesBehind, Pose, RouteProgress};

impl World {
    /// The road now.
    pub fn snapshot(&self) -> RoadSnapshot {
        let name = |l: &LaneId| self.net.lane(*l).name.clone();
        RoadSnapshot {
            map: format!("{:016x}", self.net.fingerprint()),
            tick: self.ticks,
            time: self.time,
            next_id: self.next_id,
            vehicles: self
                .vehicles
                .iter()
                .filter(|v| !v.should_despawn)
                .map(|v| VehicleSnapshot {
                    id: v.id,
                    kind: self.net.kinds[v.kind].name.clone(),
                    path: v.path.iter().map(name).collect(),
                    behind: v.behind.iter().map(|l| name(&l)).collect(),
                    s: v.s,
                    speed: v.speed,
                    route: v.route.as_ref().map(|r| RouteSnapshot {
                        lanes: r.lanes.iter().map(name).collect(),
                        index: r.index,
                        leave_at_end: r.leave_at_end,
                    }),
                })
                .collect(),
        }
    }

    /// Puts the road of `snapshot` on this world, which must be empty and
    /// on the same map: its time, tick and vehicles. Nothing is changed when
    /// anything in it does not fit this map.
    pub fn restore(&mut self, snapshot: &RoadSnapshot) -> Result<(), WorldError> {
        let ours = format!("{:016x}", self.net.fingerprint());
        if snapshot.map != ours {
            return Err(WorldError::AnotherMap {
                theirs: snapshot.map.clone(),
                ours,
            });
        }
        if !self.vehicles.is_empty() {
            return Err(WorldError::NotEmpty(self.vehicles.len()));
        }
        let mut kinds = Vec::with_capacity(snapshot.vehicles.len());
        for v in &snapshot.vehicles {
            let kind = self
                .net
                .kind_index(&v.kind)
                .ok_or_else(|| WorldError::UnknownKind(v.kind.clone()))?;
            kinds.push(kind);
        }
        let lanes = |names: &[String]| -> Result<Vec<LaneId>, WorldError> {
            names
                .iter()
                .map(|n| {
                    self.net
                        .lane_id(n)
                        .ok_or_else(|| WorldError::UnknownLane(n.clone()))
                })
                .collect()
        };
        let mut placed = Vec::with_capacity(snapshot.vehicles.len());
        for (v, &kind) in snapshot.vehicles.iter().zip(&kinds) {
            let path = lanes(&v.path)?;
            let Some(&first) = path.first() else {
                return Err(WorldError::UnknownLane(format!(
                    "(vehicle {} on no lane)",
                    v.id
                )));
            };
            let length = self.net.lane(first).length();
            if !(0.0..=length).contains(&v.s) || !v.speed.is_finite() || v.speed < 0.0 {
                return Err(WorldError::OutsideLane {
                    lane: v.path[0].clone(),
                    s: v.s,
                    length,
                });
            }
            if v.behind.len() > 4 {
                return Err(WorldError::UnknownLane(format!(
                    "(vehicle {} covers {} lanes behind; 4 at most)",
                    v.id,
                    v.behind.len()
                )));
            }
            let behind = lanes(&v.behind)?;
            let route = match &v.route {
                Some(r) => Some((lanes(&r.lanes)?, r.index, r.leave_at_end)),
                None => None,
            };
            placed.push((v, kind, path, behind, route));
        }
        self.time = snapshot.time;
        self.ticks = snapshot.tick;
        for (saved, kind, path, behind, route) in placed {
            self.next_id = saved.id;
            self.register(kind, path[0], saved.s, saved.speed, None);
            let v = self.vehicles.last_mut().expect("just registered");
            v.path_length = path.iter().map(|&l| self.net.lane(l).length()).sum();
            v.path = path;
            v.route = route.map(|(lanes, index, leave_at_end)| RouteProgress {
                lanes: lanes.into(),
                index,
                leave_at_end,
            });
            v.behind = LanesBehind::default();
            // Pushed oldest first, so that the latest ends up first again.
            for &lane in behind.iter().rev() {
                v.behind.push(lane);
            }
            v.first_junction_lane = crate::cognition::path::first_junction_lane(&self.net, &v.path);
            crate::lane_change::refresh_first_lanes(&self.net, v);
            v.pose_at = (LaneId::MAX, f64::NAN);
            v.pose = Pose::default();
            crate::control::update_pose(&self.net, v, crate::pose::Moved::NOT);
        }
        let highest = snapshot
            .vehicles
            .iter()
            .map(|v| v.id + 1)
            .max()
            .unwrap_or(0);
        self.next_id = snapshot.next_id.max(highest);
        // They were on the road already: no spawn to announce.
        self.events.clear();
        self.drop_prefollowed();
        Ok(())
    }
}
