//! The Intelligent Driver Model (Treiber, Hennecke and Helbing, 2000), the
//! `realistic` driver model: one acceleration from the gap to what is ahead
//! and how fast it closes.

use trafficmesh_model::IdmParams;

/// The IDM's free-road exponent.
const DELTA: i32 = 4;
/// Metres before a stop line (light, yield point, zebra) where a vehicle comes
/// to rest.
pub const STOP_LINE_MARGIN: f64 = 0.5;

/// The acceleration toward `desired` speed behind an obstacle `gap` metres
/// ahead (bumper to bumper) moving at `lead_speed` along the path.
pub fn acceleration(p: &IdmParams, speed: f64, desired: f64, gap: f64, lead_speed: f64) -> f64 {
    let free = if desired > 0.0 {
        1.0 - (speed / desired).powi(DELTA)
    } else {
        // A lane closed to speed (0 m/s): only braking.
        -1.0
    };
    if !gap.is_finite() {
        return p.accel * free;
    }
    let closing = speed * (speed - lead_speed) / (2.0 * (p.accel * p.decel).sqrt());
    let wanted = p.min_gap + (speed * p.headway + closing).max(0.0);
    let gap = gap.max(0.01);
    p.accel * (free - (wanted / gap).powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_road_accelerates_to_the_desired_speed_and_no_further() {
        let p = IdmParams::default();
        assert!((acceleration(&p, 0.0, 13.89, f64::INFINITY, 0.0) - p.accel).abs() < 1e-9);
        assert!(acceleration(&p, 13.89, 13.89, f64::INFINITY, 0.0).abs() < 1e-9);
        assert!(acceleration(&p, 15.0, 13.89, f64::INFINITY, 0.0) < 0.0);
    }

    #[test]
    fn standing_at_the_minimum_gap_behind_a_stopped_leader_stays_put() {
        let p = IdmParams::default();
        assert!(acceleration(&p, 0.0, 13.89, p.min_gap, 0.0) <= 0.0);
        assert!(acceleration(&p, 0.0, 13.89, 3.0 * p.min_gap, 0.0) > 0.0);
    }

    #[test]
    fn closing_fast_on_a_stopped_obstacle_brakes_harder_than_comfort() {
        let p = IdmParams::default();
        assert!(acceleration(&p, 13.89, 13.89, 20.0, 0.0) < -p.decel);
    }
}
