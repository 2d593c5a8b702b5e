//! An actor the model drives off the lanes (or with no map): on at its
//! heading and speed, braking for the nearest body in its way.

use glam::DVec2;

use crate::ego::Ego;

use super::log::PoseAt;

/// Braking for a body in the way, m/s² (a firm stop, as the NPCs' sudden one).
const BRAKE: f64 = 4.0;
/// Gap kept to the body in front at standstill, metres.
const STANDSTILL_GAP: f64 = 2.0;
/// Lateral room beside the box that still counts as in the way, metres.
const SIDE_MARGIN: f64 = 0.3;

/// A body in the plane, for the free actors' look ahead.
#[derive(Clone, Copy, Debug)]
pub struct Obstacle {
    pub center: DVec2,
    pub length: f64,
    pub width: f64,
}

impl From<&Ego> for Obstacle {
    fn from(e: &Ego) -> Self {
        Obstacle {
            center: e.center(),
            length: e.length,
            width: e.width,
        }
    }
}

#[derive(Clone, Debug)]
pub struct FreeBody {
    /// Centre and rotation; the centre moves on at its heading.
    pose: PoseAt,
    speed: f64,
    length: f64,
    width: f64,
}

impl FreeBody {
    pub fn new(pose: PoseAt, speed: f64, length: f64, width: f64) -> Self {
        FreeBody {
            pose,
            speed,
            length,
            width,
        }
    }

    fn heading(&self) -> DVec2 {
        DVec2::from_angle(self.pose.yaw())
    }

    /// One tick: brake for the nearest body ahead in its lane of travel (of
    /// `others`, which may hold itself), then move on.
    pub fn advance(&mut self, dt: f64, others: &[Obstacle]) {
        let gap = self.gap_ahead(others);
        let stopping = self.speed * self.speed / (2.0 * BRAKE) + STANDSTILL_GAP;
        if gap < stopping {
            let room = (gap - STANDSTILL_GAP).max(0.0);
            let wanted = if room > 0.0 {
                self.speed * self.speed / (2.0 * room)
            } else {
                f64::INFINITY
            };
            self.speed = (self.speed - wanted.min(2.0 * BRAKE) * dt).max(0.0);
        }
        self.pose.position += (self.heading() * (self.speed * dt)).extend(0.0);
    }

    /// Metres from its front to the nearest body whose box reaches into its
    /// path ahead.
    fn gap_ahead(&self, others: &[Obstacle]) -> f64 {
        let forward = self.heading();
        let center = self.pose.position.truncate();
        let left = forward.perp();
        others
            .iter()
            .filter(|o| o.center.distance(center) > 0.01)
            .filter_map(|o| {
                let d = o.center - center;
                let along = d.dot(forward);
                let reach = 0.5 * (o.length.max(o.width));
                let side = d.dot(left).abs() - reach;
                (along > 0.0 && side < 0.5 * self.width + SIDE_MARGIN)
                    .then_some(along - 0.5 * self.length - reach)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Its present pose, stamped `t_us`.
    pub fn pose(&self, t_us: u64) -> PoseAt {
        PoseAt { t_us, ..self.pose }
    }

    /// Its pose `seconds` after now at its present speed, stamped `t_us`.
    pub fn pose_after(&self, t_us: u64, seconds: f64) -> PoseAt {
        PoseAt {
            t_us,
            position: self.pose.position + (self.heading() * (self.speed * seconds)).extend(0.0),
            rotation: self.pose.rotation,
        }
    }
}
