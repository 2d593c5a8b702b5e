//! Walkers at a signalised crosswalk wait for their walk signal: they step
//! onto it only while the through traffic that crosses it stands at red.

mod support;

use glam::DVec2;
use support::*;
use trafficmesh_model::LightColor;
use trafficmesh_sim::lights::Lights;
use trafficmesh_sim::network::LaneNetwork;
use trafficmesh_sim::pedestrians::{PedestrianConfig, Pedestrians};
use trafficmesh_sim::walk_signal::may_walk;

#[test]
fn walkers_start_only_while_the_traffic_crossing_them_has_red() {
    let map = trafficmesh_maps::grid_map(&trafficmesh_maps::GridOptions {
        size: 2,
        crosswalks: true,
        ..Default::default()
    });
    let net = LaneNetwork::build(&map).expect("grid map");
    assert!(!net.crosswalks.is_empty());
    for c in &net.crosswalks {
        // Each approach's crosswalk lies over that approach's own lanes.
        assert_eq!(c.walk_groups.len(), 1, "{}: {:?}", c.name, c.walk_groups);
    }
    let mut lights = Lights::new(net.light_groups.iter().map(|g| g.program));
    let config = PedestrianConfig {
        per_minute: 6.0,
        ..PedestrianConfig::default()
    };
    let mut people = Pedestrians::new(&net.crosswalks, config, 7);
    let mut seen = std::collections::HashSet::new();
    let mut started = vec![0; net.crosswalks.len()];
    let dt = 0.1;
    for tick in 1..=3000 {
        let t = tick as f64 * dt;
        lights.update(t);
        let color = |g: u32| lights.state(g as usize).color;
        people.step(t, dt, color);
        for agent in people.agents() {
            if !seen.insert(agent.id.clone()) {
                continue;
            }
            let at = agent.footprint.iter().copied().sum::<DVec2>() / 4.0;
            let (k, c) = net
                .crosswalks
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    let d = |c: &trafficmesh_sim::network::Crosswalk| {
                        c.polygon
                            .iter()
                            .map(|p| p.distance(at))
                            .fold(f64::MAX, f64::min)
                    };
                    d(a.1).total_cmp(&d(b.1))
                })
                .unwrap();
            let walk = may_walk(&c.walk_groups, color);
            assert!(
                walk,
                "walker {} started across {} at {t:.1} s against its signal",
                agent.id, c.name
            );
            assert!(
                c.walk_groups
                    .iter()
                    .all(|&g| lights.state(g as usize).color == LightColor::Red)
            );
            started[k] += 1;
        }
    }
    // Over five minutes every crosswalk had walks, and walkers used them.
    assert!(started.iter().all(|&n| n > 5), "{started:?}");
}

#[test]
fn only_a_crosswalk_past_a_stop_line_follows_its_light() {
    let mut map = signalised_road();
    let crosswalk = |name: &str, x: f64| {
        serde_json::json!({
            "name": name,
            "area": { "shape": "box", "center": [x, 0.0], "half_extents": [2.0, 6.0] }
        })
    };
    map.crosswalks = serde_json::from_value(serde_json::json!([
        crosswalk("MidBlock", 100.0),
        crosswalk("AtJunction", 210.0),
        crosswalk("BeforeTheLine", 195.0)
    ]))
    .unwrap();
    let net = LaneNetwork::build(&map).expect("map");
    let groups = |name: &str| {
        net.crosswalks[net.crosswalk(name).unwrap()]
            .walk_groups
            .clone()
    };
    // Mid-block the road's light is 90 m away: walkers go when they come.
    assert!(groups("MidBlock").is_empty());
    assert!(may_walk(&groups("MidBlock"), |_| LightColor::Green));
    // Over the junction and between the stop line and the junction, the
    // crossing traffic's red is the walk.
    assert_eq!(groups("AtJunction"), vec![0]);
    assert_eq!(groups("BeforeTheLine"), vec![0]);
    assert!(!may_walk(&groups("AtJunction"), |_| LightColor::Green));
    assert!(!may_walk(&groups("AtJunction"), |_| LightColor::Yellow));
    assert!(may_walk(&groups("AtJunction"), |_| LightColor::Red));
}
