//! The ego vehicle as NPCs see it: an oriented box somewhere in the map.

use glam::DVec2;

use crate::geometry::box_corners;
use crate::vehicle::Pose;

/// A real ego's pose and footprint. When no ego is given the world uses a dummy
/// ego that has no body and is nowhere: it blocks no spawn and no vehicle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ego {
    /// Rear-axle pose, as for NPCs.
    pub pose: Pose,
    pub length: f64,
    pub width: f64,
    /// Rear axle to front bumper.
    pub front_offset: f64,
}

impl Ego {
    /// An ego with a passenger car's footprint (AWSIM's Lexus: 4.9 x 1.9 m).
    pub fn car(x: f64, y: f64, yaw: f64) -> Self {
        Ego {
            pose: Pose { x, y, z: 0.0, yaw },
            length: 4.9,
            width: 1.9,
            front_offset: 3.8,
        }
    }

    pub fn position(&self) -> DVec2 {
        DVec2::new(self.pose.x, self.pose.y)
    }

    pub fn forward(&self) -> DVec2 {
        DVec2::from_angle(self.pose.yaw)
    }

    pub fn center(&self) -> DVec2 {
        self.position() + self.forward() * (self.front_offset - self.length * 0.5)
    }

    pub fn corners(&self) -> [DVec2; 4] {
        box_corners(
            self.center(),
            self.pose.yaw,
            self.length * 0.5,
            self.width * 0.5,
        )
    }

    /// How far any point of the box can be from `position()`: an upper
    /// bound without trigonometry, for skipping far bodies cheaply.
    pub fn reach(&self) -> f64 {
        (self.front_offset - self.length * 0.5).abs() + 0.5 * (self.length + self.width)
    }

    /// Radius of the circle around `center` that holds the box.
    pub fn radius(&self) -> f64 {
        (self.length * 0.5).hypot(self.width * 0.5)
    }
}
