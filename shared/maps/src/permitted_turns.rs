//! Who yields within one phase of a synthesised signal program. A program
//! made per approach axis lets both ways of the axis go together, and a map
//! may say nothing of who yields between them (Lanelet2 `right_of_way`
//! elements are often drawn for some turns only). Then, as at a permitted
//! turn of a real signal (SUMO's `g` links), a turn that crosses the
//! oncoming straight way yields to it.

use std::collections::HashMap;

use glam::DVec2;

use trafficmesh_model::enums::TurnDirection;
use trafficmesh_model::geometry::segments_intersect;
use trafficmesh_model::map::{LaneDef, LightGroupDef, Point};

/// Junction lanes whose first (or last) points lie this near come from
/// (or go to) the same road: they diverge (or merge), they do not cross,
/// metres.
const SAME_ROAD: f64 = 3.0;

/// Let every signalised turn yield to the straight junction lanes it crosses
/// that go in the same phase (the same light program) from another road,
/// where neither lane lists the other already. Returns how many pairs were
/// added.
pub fn turns_yield_to_oncoming(lanes: &mut [LaneDef], groups: &[LightGroupDef]) -> usize {
    let programs: HashMap<&str, _> = groups
        .iter()
        .map(|g| (g.name.as_str(), g.program))
        .collect();
    let phase = |l: &LaneDef| {
        l.traffic_light
            .as_deref()
            .filter(|_| l.intersection)
            .and_then(|g| programs.get(g))
            .copied()
    };
    let mut added = Vec::new();
    for (t, turn) in lanes.iter().enumerate() {
        let Some(turn_phase) = phase(turn) else {
            continue;
        };
        if turn.turn_direction == TurnDirection::Straight {
            continue;
        }
        for (s, straight) in lanes.iter().enumerate() {
            let crosses = straight.turn_direction == TurnDirection::Straight
                && phase(straight) == Some(turn_phase)
                && !turn.right_of_way.contains(&straight.name)
                && !straight.right_of_way.contains(&turn.name)
                && apart(&turn.waypoints[0], &straight.waypoints[0])
                && apart(ends(turn), ends(straight))
                && polylines_cross(&turn.waypoints, &straight.waypoints);
            if crosses {
                added.push((t, s));
            }
        }
    }
    for &(t, s) in &added {
        let name = lanes[s].name.clone();
        lanes[t].right_of_way.push(name);
    }
    added.len()
}

fn ends(lane: &LaneDef) -> &Point {
    lane.waypoints.last().expect("a lane has two points")
}

fn apart(a: &Point, b: &Point) -> bool {
    a.ground_distance(*b) > SAME_ROAD
}

/// Do two polylines cross in the ground plane (two of their segments meet)?
fn polylines_cross(a: &[Point], b: &[Point]) -> bool {
    let ground = |p: &Point| DVec2::new(p.0[0], p.0[1]);
    a.windows(2).any(|p| {
        b.windows(2)
            .any(|q| segments_intersect(ground(&p[0]), ground(&p[1]), ground(&q[0]), ground(&q[1])))
    })
}

#[cfg(test)]
mod tests {
    use trafficmesh_model::map::LightProgram;

    use super::*;

    fn lane(name: &str, points: &[[f64; 2]], turn: TurnDirection, light: &str) -> LaneDef {
        LaneDef {
            name: name.into(),
            waypoints: points.iter().map(|p| Point([p[0], p[1], 0.0])).collect(),
            width: 3.0,
            speed_limit: 10.0,
            next: Vec::new(),
            prev: Vec::new(),
            intersection: true,
            turn_direction: turn,
            stop_line: None,
            traffic_light: Some(light.into()),
            right_of_way: Vec::new(),
            vehicle_classes: Vec::new(),
            crosses_apart: Vec::new(),
        }
    }

    fn group(name: &str, offset: f64) -> LightGroupDef {
        LightGroupDef {
            name: name.into(),
            program: LightProgram {
                green: 30.0,
                yellow: 3.0,
                red: 33.0,
                offset,
            },
        }
    }

    /// A north-south axis: a northbound turn east across the southbound
    /// straight lane, a southbound straight lane, and a westbound straight
    /// lane of the other phase.
    fn junction() -> Vec<LaneDef> {
        vec![
            lane(
                "turn",
                &[[-2.0, -10.0], [-2.0, 0.0], [4.0, 4.0], [10.0, 4.0]],
                TurnDirection::Right,
                "ns_turn",
            ),
            lane(
                "oncoming",
                &[[2.0, 10.0], [2.0, -10.0]],
                TurnDirection::Straight,
                "ns",
            ),
            lane(
                "across",
                &[[10.0, 2.0], [-10.0, 2.0]],
                TurnDirection::Straight,
                "ew",
            ),
            lane(
                "beside",
                &[[-2.0, -10.0], [-2.0, 10.0]],
                TurnDirection::Straight,
                "ns",
            ),
        ]
    }

    #[test]
    fn a_turn_across_the_oncoming_straight_way_of_its_phase_yields_to_it() {
        let mut lanes = junction();
        let groups = [group("ns", 0.0), group("ns_turn", 0.0), group("ew", 33.0)];
        assert_eq!(turns_yield_to_oncoming(&mut lanes, &groups), 1);
        assert_eq!(lanes[0].right_of_way, ["oncoming"]);
        // The straight ways yield to nobody; the crossing straight way of the
        // other phase and the straight way from the turn's own road are left
        // to the lights and to following.
        assert!(lanes[1..].iter().all(|l| l.right_of_way.is_empty()));
    }

    #[test]
    fn what_the_map_says_of_the_pair_stands() {
        let mut lanes = junction();
        lanes[1].right_of_way.push("turn".into());
        let groups = [group("ns", 0.0), group("ns_turn", 0.0), group("ew", 33.0)];
        assert_eq!(turns_yield_to_oncoming(&mut lanes, &groups), 0);
        assert!(lanes[0].right_of_way.is_empty());
    }

    #[test]
    fn a_turn_with_a_phase_of_its_own_yields_to_nobody() {
        let mut lanes = junction();
        let groups = [group("ns", 0.0), group("ns_turn", 20.0), group("ew", 33.0)];
        assert_eq!(turns_yield_to_oncoming(&mut lanes, &groups), 0);
    }
}
