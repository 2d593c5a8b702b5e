//! Timed poses of one object (a log, or a client's updates): a body's centre
//! and orientation in the map frame, looked up at any time.

use glam::{DQuat, DVec2, DVec3};

/// A pose of a body's centre at a time, microseconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseAt {
    pub t_us: u64,
    pub position: DVec3,
    pub rotation: DQuat,
}

impl PoseAt {
    /// Heading about the vertical axis, radians.
    pub fn yaw(&self) -> f64 {
        yaw_of(self.rotation)
    }

    pub fn is_finite(&self) -> bool {
        self.position.is_finite() && self.rotation.is_finite()
    }
}

/// The heading of a rotation: where it turns the body's x axis, in the plane.
pub fn yaw_of(rotation: DQuat) -> f64 {
    let x = rotation * DVec3::X;
    x.y.atan2(x.x)
}

/// Poses sorted by time.
#[derive(Clone, Debug, Default)]
pub struct PoseLog {
    poses: Vec<PoseAt>,
}

impl PoseLog {
    /// Sorts the poses by time; of two at the same time the later given wins.
    pub fn new(mut poses: Vec<PoseAt>) -> Self {
        poses.sort_by_key(|p| p.t_us);
        poses.reverse();
        poses.dedup_by_key(|p| p.t_us);
        poses.reverse();
        PoseLog { poses }
    }

    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    pub fn first(&self) -> Option<&PoseAt> {
        self.poses.first()
    }

    pub fn last(&self) -> Option<&PoseAt> {
        self.poses.last()
    }

    /// Adds later poses (those not after the last are replaced from where they start).
    pub fn extend(&mut self, poses: Vec<PoseAt>) {
        let Some(from) = poses.iter().map(|p| p.t_us).min() else {
            return;
        };
        self.poses.retain(|p| p.t_us < from);
        self.poses.extend(PoseLog::new(poses).poses);
    }

    /// The pose at `t_us`: a logged one unchanged, between two interpolated
    /// (position linearly, rotation by slerp); None outside the log.
    pub fn at(&self, t_us: u64) -> Option<PoseAt> {
        let k = self.poses.partition_point(|p| p.t_us < t_us);
        let after = self.poses.get(k)?;
        if after.t_us == t_us {
            return Some(*after);
        }
        let before = self.poses.get(k.checked_sub(1)?)?;
        let f = (t_us - before.t_us) as f64 / (after.t_us - before.t_us) as f64;
        Some(PoseAt {
            t_us,
            position: before.position.lerp(after.position, f),
            rotation: before.rotation.slerp(after.rotation, f),
        })
    }

    /// The pose at `t_us`, or the nearest end's pose held.
    pub fn at_or_held(&self, t_us: u64) -> Option<PoseAt> {
        self.at(t_us).or_else(|| {
            let held = if t_us < self.first()?.t_us {
                self.first()?
            } else {
                self.last()?
            };
            Some(PoseAt { t_us, ..*held })
        })
    }

    /// Velocity in the plane at `t_us`, m/s, from the poses around it.
    pub fn velocity(&self, t_us: u64) -> DVec2 {
        let k = self.poses.partition_point(|p| p.t_us < t_us);
        let (a, b) = match (
            k.checked_sub(1).and_then(|i| self.poses.get(i)),
            self.poses.get(k),
        ) {
            (Some(a), Some(b)) if b.t_us > a.t_us => (a, b),
            (Some(a), _) if k >= 2 => (&self.poses[k - 2], a),
            (_, Some(b)) if k + 1 < self.poses.len() => (b, &self.poses[k + 1]),
            _ => return DVec2::ZERO,
        };
        let dt = (b.t_us - a.t_us) as f64 * 1e-6;
        if dt <= 0.0 {
            return DVec2::ZERO;
        }
        (b.position - a.position).truncate() / dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(t_us: u64, x: f64, yaw: f64) -> PoseAt {
        PoseAt {
            t_us,
            position: DVec3::new(x, 0.0, 1.0),
            rotation: DQuat::from_rotation_z(yaw),
        }
    }

    #[test]
    fn logged_poses_come_back_unchanged_and_between_them_interpolated() {
        let log = PoseLog::new(vec![pose(200_000, 2.0, 0.2), pose(0, 0.0, 0.0)]);
        assert_eq!(log.at(200_000), Some(pose(200_000, 2.0, 0.2)));
        let mid = log.at(100_000).unwrap();
        assert!((mid.position.x - 1.0).abs() < 1e-12);
        assert!((mid.yaw() - 0.1).abs() < 1e-9);
        assert_eq!(log.at(300_000), None);
        assert_eq!(log.at_or_held(300_000).unwrap().position.x, 2.0);
        assert!((log.velocity(100_000).x - 10.0).abs() < 1e-9);
    }

    #[test]
    fn yaw_comes_back_from_the_quaternion() {
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.0] {
            assert!((pose(0, 0.0, yaw).yaw() - yaw).abs() < 1e-12);
        }
    }

    #[test]
    fn a_heading_gives_the_rotation_of_its_angle() {
        // How forecasts turn a lane's heading into a rotation, without trigonometry.
        for yaw in [-3.1, -2.0, -0.3, 0.0, 0.7, 1.5, 3.0, std::f64::consts::PI] {
            let q = DQuat::from_rotation_arc_2d(DVec2::X, DVec2::from_angle(yaw));
            let want = DQuat::from_rotation_z(yaw);
            assert!(
                q.dot(want).abs() > 1.0 - 1e-12,
                "yaw {yaw}: {q} against {want}"
            );
        }
    }
}
