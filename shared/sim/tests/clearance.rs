//! Bodies never drive into each other, even where no rule of the map keeps
//! their ways apart: a vehicle stops short of a body in its way.

mod support;

use serde_json::{Value, json};
use support::*;
use trafficmesh_sim::WorldConfig;

/// Two roads crossing at (100, 0) with nothing marked: no conflict, no rule
/// for who goes first. Each road enters a junction 4 m past the crossing
/// (bodies are checked near junctions, where ways meet), with `extra` map
/// fields.
fn unmarked_crossing(extra: Value) -> trafficmesh_model::MapFile {
    let junction = |name: &str, points: &[[f64; 2]], next: &str| {
        let mut j = lane(name, points, &[next]);
        j["intersection"] = json!(true);
        j
    };
    map(
        vec![
            lane("east", &[[0.0, 0.0], [104.0, 0.0]], &["east_j"]),
            junction("east_j", &[[104.0, 0.0], [114.0, 0.0]], "east_x"),
            lane("east_x", &[[114.0, 0.0], [300.0, 0.0]], &[]),
            lane("north", &[[100.0, -100.0], [100.0, 4.0]], &["north_j"]),
            junction("north_j", &[[100.0, 4.0], [100.0, 14.0]], "north_x"),
            lane("north_x", &[[100.0, 14.0], [100.0, 200.0]], &[]),
        ],
        extra,
    )
}

/// Arriving together where nothing tells them who goes first, the two
/// bodies would meet: the later one (higher id) stops short of the ground
/// the earlier one covers, and both get through.
#[test]
fn where_no_rule_keeps_two_ways_apart_the_bodies_still_never_meet() {
    for dt in [0.02, 0.05, 0.1] {
        let mut w = world(
            &unmarked_crossing(json!({})),
            WorldConfig {
                dt,
                ..WorldConfig::default()
            },
        );
        // Fronts 40 m from the crossing, at the same speed: without a rule
        // they arrive together.
        let first = w.place_vehicle("Taxi", "east", 60.0, 10.0).unwrap();
        let second = w.place_vehicle("Taxi", "north", 60.0, 10.0).unwrap();
        let mut crossed = Vec::new();
        let done = run_until(&mut w, 120.0, |w| {
            assert_no_overlap(w);
            for id in [first, second] {
                // Its front 5 m past the crossing point (or gone).
                let past = w.vehicle(id).is_none_or(|v| {
                    (v.front.x - 100.0) * v.heading.x + v.front.y * v.heading.y > 5.0
                });
                if past && !crossed.contains(&id) {
                    crossed.push(id);
                }
            }
            w.vehicles().is_empty()
        });
        assert!(done, "both drive on (dt {dt})");
        assert_eq!(
            crossed,
            [first, second],
            "the earlier one goes first (dt {dt})"
        );
    }
}

/// A body standing across the way (held in the crossing by a walker on the
/// zebra just past it) stops the vehicle coming up to it, which goes on once
/// the crossing is clear.
#[test]
fn a_body_standing_across_the_way_stops_the_vehicle_short_of_it() {
    let mut w = world(
        &unmarked_crossing(json!({
            "crosswalks": [{
                "name": "Zebra",
                "area": { "shape": "box", "center": [100.0, 6.0], "half_extents": [6.0, 1.5] },
                "stop_points": [{ "position": [100.0, 3.0] }]
            }]
        })),
        WorldConfig::default(),
    );
    // The northbound body stands across the eastbound road.
    let (standing, coming) = held_across_the_way(&mut w, "Taxi", 50.0);
    let (s, c) = (vehicle(&w, standing), vehicle(&w, coming));
    assert!(s.speed < 0.01, "the walker holds the northbound car");
    assert!(c.speed < 0.01, "the eastbound car waits");
    assert!(
        c.s > 90.0,
        "it drove up to the body, not further back (s {:.1})",
        c.s
    );
    let crossed = goes_on_once_clear(&mut w, coming, 110.0, 30.0);
    assert!(crossed, "it never went on once the crossing was clear");
}

/// A walker on the zebra holds a `kind` northbound with its front at the
/// zebra's stop point, its body across the eastbound way; another `kind`
/// comes eastbound from `from` at 10 m/s. Runs 20 s, no two bodies
/// overlapping; returns (the one held, the one coming).
fn held_across_the_way(w: &mut trafficmesh_sim::World, kind: &str, from: f64) -> (u64, u64) {
    walker_on(w, "Zebra");
    let standing = w.place_vehicle(kind, "north", 102.5, 0.0).unwrap();
    let coming = w.place_vehicle(kind, "east", from, 10.0).unwrap();
    run_until(w, 20.0, |w| {
        assert_no_overlap(w);
        false
    });
    (standing, coming)
}

/// The walker leaves the zebra: does `coming` get past x = `past` (or off
/// the road) within `seconds`, no two bodies overlapping?
fn goes_on_once_clear(
    w: &mut trafficmesh_sim::World,
    coming: u64,
    past: f64,
    seconds: f64,
) -> bool {
    w.crosswalk_exit("Zebra", "Human_01").unwrap();
    run_until(w, seconds, |w| {
        assert_no_overlap(w);
        w.vehicle(coming).is_none_or(|v| v.front.x > past)
    })
}

/// Two lanes 3.2 m wide side by side, bending 20 degrees to the right at
/// x = 100 (the left one, outside the bend, at a crawl: 1 m/s), far from any
/// junction.
fn bend_of_two_lanes() -> trafficmesh_model::MapFile {
    let turn = (-20f64).to_radians();
    let (along, left) = (
        glam::DVec2::from_angle(turn),
        glam::DVec2::from_angle(turn).perp(),
    );
    // The outer lane's corner, where its two straight pieces meet.
    let t = 3.2 * (turn.cos() - 1.0) / -turn.sin();
    let corner = glam::DVec2::new(100.0, 0.0) + along * t + left * 3.2;
    let end = |offset: f64| glam::DVec2::new(100.0, 0.0) + along * 150.0 + left * offset;
    let [e0, e1] = [end(0.0), end(3.2)];
    let road = |name: &str, points: &[[f64; 2]], speed: f64, next: &str| {
        let mut l = lane(name, points, &[next]);
        l["width"] = json!(3.2);
        l["speed_limit"] = json!(speed);
        l
    };
    let junction = |name: &str, from: glam::DVec2, next: &str| {
        let to = from + along * 10.0;
        let mut j = lane(name, &[[from.x, from.y], [to.x, to.y]], &[next]);
        j["intersection"] = json!(true);
        j
    };
    let exit = |name: &str, junction_start: glam::DVec2| {
        let (from, to) = (
            junction_start + along * 10.0,
            junction_start + along * 110.0,
        );
        lane(name, &[[from.x, from.y], [to.x, to.y]], &[])
    };
    map(
        vec![
            road("a0", &[[0.0, 0.0], [100.0, 0.0], [e0.x, e0.y]], 13.89, "j0"),
            road(
                "a1",
                &[[0.0, 3.2], [corner.x, corner.y], [e1.x, e1.y]],
                1.0,
                "j1",
            ),
            junction("j0", e0, "x0"),
            junction("j1", e1, "x1"),
            exit("x0", e0),
            exit("x1", e1),
        ],
        json!({}),
    )
}

/// A truck passing another on the lane beside it where the two bend: the
/// rigid bodies cut the bend's inside, and two trucks on 3.2 m lanes do not
/// fit side by side there. The one coming up waits for the crawling one to
/// clear the bend instead of driving through its body, on the open road too.
#[test]
fn a_truck_does_not_pass_another_through_a_bend_too_tight_for_both() {
    let mut w = world(
        &bend_of_two_lanes(),
        WorldConfig {
            vehicle: trafficmesh_model::NpcVehicleConfig {
                speed_limit_source: trafficmesh_model::SpeedLimitSource::LaneletSpeedLimit,
                ..Default::default()
            },
            ..WorldConfig::default()
        },
    );
    // The crawling one in the bend, the other coming up at full speed.
    w.place_vehicle("Truck_2t", "a1", 100.0, 1.0).unwrap();
    w.place_vehicle("Truck_2t", "a0", 40.0, 13.89).unwrap();
    let through = run_until(&mut w, 300.0, |w| {
        assert_no_overlap(w);
        w.vehicles().is_empty()
    });
    assert!(through, "both drive on to the end");
}

/// A road heading east into a junction 6 m before it crosses a road
/// heading north, whose zebra just past the crossing holds a northbound
/// truck with its body across the eastbound way, inside the junction.
fn junction_with_a_body_across_it() -> trafficmesh_model::MapFile {
    let wide = |name: &str, points: &[[f64; 2]], next: &str| {
        let mut l = lane(name, points, &[next]);
        l["width"] = json!(3.2);
        l
    };
    let junction = |name: &str, points: &[[f64; 2]], next: &str| {
        let mut j = wide(name, points, next);
        j["intersection"] = json!(true);
        j
    };
    map(
        vec![
            wide("east", &[[0.0, 0.0], [94.0, 0.0]], "east_j"),
            junction("east_j", &[[94.0, 0.0], [114.0, 0.0]], "east_x"),
            lane("east_x", &[[114.0, 0.0], [300.0, 0.0]], &[]),
            wide("north", &[[100.0, -100.0], [100.0, 4.0]], "north_j"),
            junction("north_j", &[[100.0, 4.0], [100.0, 14.0]], "north_x"),
            lane("north_x", &[[100.0, 14.0], [100.0, 200.0]], &[]),
        ],
        json!({
            "crosswalks": [{
                "name": "Zebra",
                "area": { "shape": "box", "center": [100.0, 6.0], "half_extents": [6.0, 1.5] },
                "stop_points": [{ "position": [100.0, 3.0] }]
            }]
        }),
    )
}

/// A truck as wide as its lane does not drive into a junction whose way
/// through a standing body blocks: stopped short of that body inside the
/// junction, it would stand in the way of the one it stopped for. It waits
/// at the junction's entry, and goes once the body has gone.
#[test]
fn a_wide_body_waits_before_a_junction_whose_way_through_a_standing_body_blocks() {
    let mut w = world(&junction_with_a_body_across_it(), WorldConfig::default());
    // The northbound body stands across the eastbound way, 6 m into the
    // eastbound junction.
    let (standing, coming) = held_across_the_way(&mut w, "Truck_2t", 40.0);
    let (s, c) = (vehicle(&w, standing), vehicle(&w, coming));
    assert!(s.speed < 0.01, "the walker holds the northbound truck");
    assert!(c.speed < 0.01, "the eastbound truck waits");
    assert!(
        (80.0..=94.5).contains(&c.front.x),
        "it waits at the junction's entry (x = 94), not in the junction up to the body: front at x = {:.1}",
        c.front.x
    );
    let through = goes_on_once_clear(&mut w, coming, 120.0, 60.0);
    assert!(through, "it goes on once the body has gone");
}

/// A road east whose lane turns sharply (135 degrees, in a junction lane)
/// onto a road heading north-west, and a road running along that one the
/// other way, 3.5 m off on the side a body's front swings out to there.
fn sharp_corner_beside_a_road() -> trafficmesh_model::MapFile {
    let wide = |name: &str, points: &[[f64; 2]], next: &[&str]| {
        let mut l = lane(name, points, next);
        l["width"] = json!(3.2);
        l
    };
    let d = std::f64::consts::FRAC_1_SQRT_2;
    let off = 3.5;
    map(
        vec![
            wide("east", &[[0.0, 0.0], [96.0, 0.0]], &["corner"]),
            {
                let mut j = wide(
                    "corner",
                    &[[96.0, 0.0], [100.0, 0.0], [100.0 - 4.0 * d, 4.0 * d]],
                    &["nw"],
                );
                j["intersection"] = json!(true);
                j
            },
            wide(
                "nw",
                &[[100.0 - 4.0 * d, 4.0 * d], [100.0 - 80.0 * d, 80.0 * d]],
                &[],
            ),
            wide(
                "beside",
                &[
                    [100.0 - 80.0 * d + off * d, 80.0 * d + off * d],
                    [100.0 + off * d + 20.0 * d, off * d - 20.0 * d],
                ],
                &[],
            ),
        ],
        json!({}),
    )
}

/// A truck out of a sharp corner is drawn with its heading still catching
/// up with its way (by up to 42 degrees here), its body swinging across
/// the road beside: the clearance check forecasts the body where it will
/// be drawn, not where its chord lies, and whenever the truck coming the
/// other way arrives, no bodies meet.
#[test]
fn a_body_swinging_out_of_a_sharp_corner_is_seen_where_it_will_be_drawn() {
    for from in (0..50).map(|k| k as f64) {
        let mut w = world(&sharp_corner_beside_a_road(), WorldConfig::default());
        w.place_vehicle("Truck_2t", "east", 80.0, 8.0).unwrap();
        w.place_vehicle("Truck_2t", "beside", from, 12.0).unwrap();
        let through = run_until(&mut w, 40.0, |w| {
            assert_no_overlap(w);
            w.vehicles().is_empty()
        });
        assert!(through, "both drive on (from {from} m)");
    }
}

/// The same corner at ten ticks a second (as SUMO scenarios run), a car or
/// a truck turning it while a truck at the road's limit comes along the
/// road beside, from wherever it starts. The one that goes first keeps off
/// the other's body only as it stands; the other, already in the ground
/// the first can cover in the tick, must come no nearer it on any side:
/// sliding along that ground's edge (no deeper into it) still closed on
/// the body, by up to 29 cm. No bodies meet, and both drive on.
#[test]
fn a_body_in_the_ground_of_one_going_first_comes_no_nearer_it() {
    for (kind, speed) in [
        ("Taxi", 3.0),
        ("Taxi", 8.0),
        ("Truck_2t", 3.0),
        ("Truck_2t", 8.0),
    ] {
        for from in (0..100).map(|k| k as f64) {
            let mut w = world(
                &sharp_corner_beside_a_road(),
                WorldConfig {
                    dt: 0.1,
                    ..WorldConfig::default()
                },
            );
            w.place_vehicle(kind, "east", 80.0, speed).unwrap();
            w.place_vehicle("Truck_2t", "beside", from, 0.0).unwrap();
            let through = run_until(&mut w, 60.0, |w| {
                assert_no_overlap(w);
                w.vehicles().is_empty()
            });
            assert!(
                through,
                "both drive on ({kind} at {speed} m/s, from {from} m)"
            );
        }
    }
}

/// [`road_of_lanes`]`(3)` with lanes 3.2 m wide, as far apart as their
/// centrelines (`a0` the rightmost, at a queue's creep: 0.05 m/s; the
/// other approaches at 9.5 m/s).
fn three_narrow_lanes() -> trafficmesh_model::MapFile {
    let mut m = road_of_lanes(3);
    for l in &mut m.lanes {
        l.width = 3.2;
        if l.name.starts_with('a') {
            l.speed_limit = if l.name == "a0" { 0.05 } else { 9.5 };
        }
    }
    m
}

/// A truck changing from the left lane to the middle one at speed, its
/// body angled across the way, comes nearer the right lane with every
/// metre: beside a truck standing in a queue there (3.08 m wide bodies on
/// 3.2 m lanes), the clearance check forecasts it moving across as well as
/// on, and wherever the two meet, the bodies do not.
#[test]
fn a_truck_changing_lanes_beside_another_is_seen_moving_across() {
    for beside in (0..100).map(|k| 15.0 + 0.5 * k as f64) {
        let mut w = world(&three_narrow_lanes(), at_sumo_ticks_and_lane_limits());
        w.place_vehicle("Truck_2t", "a0", beside, 0.0).unwrap();
        let changing = w
            .place_vehicle_on_route("Truck_2t", &["a2", "j1", "x1"], 12.0, 8.0)
            .unwrap();
        let mut lanes = Vec::new();
        let through = run_until(&mut w, 400.0, |w| {
            assert_no_overlap(w);
            if let Some(v) = w.vehicle(changing) {
                let lane = w.network().lane(v.path[0]).name.clone();
                if lanes.last() != Some(&lane) {
                    lanes.push(lane);
                }
            }
            w.vehicles().is_empty()
        });
        assert!(through, "both drive on (beside at {beside} m)");
        // Placed on a2, it changes lanes within the first tick or later.
        assert!(
            lanes.ends_with(&["a1".to_string(), "j1".into(), "x1".into()]),
            "the truck changes lanes: {lanes:?}"
        );
    }
}

/// [`road_of_lanes`]`(2)` with lanes 3.2 m wide at 11 m/s, and beside the
/// left one a lane the other way, `w`, only 2.6 m off (two streets meeting
/// at a junction lie so in SUMO nets: Bologna's 11 and 67), its traffic at
/// a queue's creep (0.05 m/s).
fn a_road_beside_a_near_lane_the_other_way() -> trafficmesh_model::MapFile {
    let mut m = road_of_lanes(2);
    for l in &mut m.lanes {
        l.width = 3.2;
        l.speed_limit = 11.0;
    }
    let mut near = serde_json::to_value(&m).unwrap();
    let mut w = lane("w", &[[400.0, 5.8], [0.0, 5.8]], &[]);
    w["width"] = json!(3.2);
    w["speed_limit"] = json!(0.05);
    near["lanes"].as_array_mut().unwrap().push(w);
    serde_json::from_value(near).unwrap()
}

/// A truck changing lanes at speed toward a truck standing in the lane
/// beyond, its body angled across the way: the clearance check stops it
/// short, and the body is drawn where the check forecast it. Held back,
/// the truck ends the tick slower than it began; were its way across then
/// drawn on the tighter curve of the lower speed, its front corner would
/// swing further across than forecast, into the truck standing there.
#[test]
fn a_truck_held_back_mid_lane_change_is_drawn_where_it_was_forecast() {
    for standing_at in (0..39).map(|k| 46.0 + 0.5 * k as f64) {
        let mut w = world(
            &a_road_beside_a_near_lane_the_other_way(),
            at_sumo_ticks_and_lane_limits(),
        );
        w.place_vehicle("Truck_2t", "w", 400.0 - standing_at, 0.0)
            .unwrap();
        let changing = w
            .place_vehicle_on_route("Truck_2t", &["a0", "j1", "x1"], 40.0, 11.0)
            .unwrap();
        let mut held_mid_change = false;
        run_until(&mut w, 20.0, |w| {
            assert_no_overlap(w);
            let v = w.vehicle(changing).unwrap();
            held_mid_change |= v.speed == 0.0 && v.sideways.offset != 0.0;
            false
        });
        assert!(
            held_mid_change,
            "the truck is held back mid-change (standing at {standing_at} m)"
        );
    }
}

/// A corner of a generated network where two two-way streets meet at 60
/// degrees (netgenerate's random networks have many; the points are one of
/// them): the right turn round its inside turns on a 1.7 m radius, sharper
/// than a body can follow, so a car out of it is drawn with its heading 40
/// degrees behind its lane, its front over the end of the oncoming lane;
/// the left turn the other way loops round the outside.
fn sixty_degree_corner() -> trafficmesh_model::MapFile {
    let lane_of = |name: &str, points: &[[f64; 2]], next: &[&str], junction: bool| {
        let mut l = lane(name, points, next);
        l["width"] = json!(3.2);
        l["intersection"] = json!(junction);
        l
    };
    map(
        vec![
            lane_of("in", &[[-38.28, 95.72], [70.86, 89.24]], &["right"], false),
            lane_of(
                "right",
                &[
                    [70.86, 89.24],
                    [71.97, 89.03],
                    [72.55, 88.54],
                    [72.59, 87.78],
                    [72.1, 86.76],
                ],
                &["out"],
                true,
            ),
            lane_of("out", &[[72.1, 86.76], [-2.65, -26.02]], &[], false),
            lane_of(
                "back_in",
                &[[0.02, -27.79], [74.76, 84.99]],
                &["left"],
                false,
            ),
            lane_of(
                "left",
                &[
                    [74.76, 84.99],
                    [76.26, 88.06],
                    [76.14, 90.33],
                    [74.4, 91.79],
                    [71.05, 92.44],
                ],
                &["back_out"],
                true,
            ),
            lane_of("back_out", &[[71.05, 92.44], [-38.09, 98.92]], &[], false),
        ],
        json!({}),
    )
}

/// A van or a car turns the sharp corner while a truck comes up the
/// oncoming lane to turn it the other way, the truck from wherever it
/// still has room to stop before the van's swing begins (up to 72 m along
/// its lane; later, arriving as the van enters the corner, it stands in
/// the swing already). The truck keeps clear of the ground the van's body
/// swings over until its heading has caught up with the street it turns
/// into, and the van, which must clear the junction, goes before the truck
/// even where its lagging heading points 140 degrees from the truck's (not
/// head-on, where they went by their fronts): each had stood waiting for
/// the other until the gridlock valve took one off.
#[test]
fn a_body_swinging_out_of_a_corner_too_sharp_to_follow_is_kept_clear_of() {
    for kind in ["Van", "Taxi"] {
        for from in (0..=16).map(|k| 40.0 + 2.0 * k as f64) {
            let mut w = world(&sixty_degree_corner(), at_sumo_ticks_and_lane_limits());
            w.place_vehicle(kind, "in", 60.0, 13.0).unwrap();
            w.place_vehicle("Truck_2t", "back_in", from, 13.0).unwrap();
            let through = run_until(&mut w, 60.0, |w| {
                assert_no_overlap(w);
                w.vehicles().is_empty()
            });
            assert!(through, "both drive on ({kind}, truck from {from} m)");
            assert_eq!(
                w.wait_stats().jam_resolutions,
                0,
                "no jam resolution ({kind}, truck from {from} m)"
            );
        }
    }
}
