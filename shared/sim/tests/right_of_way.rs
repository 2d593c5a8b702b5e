//! Intersection right of way: lane rules, and FORCING_PRIORITY breaking a four-way deadlock.

mod support;

use serde_json::json;
use support::*;
use trafficmesh_model::{MapFile, YieldPhase};
use trafficmesh_sim::{World, WorldConfig};

/// An unsignalised crossing at the origin. Each approach `X_in` (100 m) leads to
/// the junction lane `X_x` (20 m) and then `X_out`. `yields[k]` lists the junction
/// lanes approach k's junction lane must yield to.
fn crossing(yields: [&[&str]; 4]) -> MapFile {
    crossing_with_lead_in(yields, false)
}

/// The crossing with extra top-level map fields (crosswalks).
fn crossing_with(yields: [&[&str]; 4], extra: serde_json::Value) -> MapFile {
    map(crossing_lanes(yields, false), extra)
}

/// The crossing; with `lead_in`, each approach is 30 m long and comes out of
/// a junction lane of its own (`X_pre`, 10 m), as where junctions follow
/// closely.
fn crossing_with_lead_in(yields: [&[&str]; 4], lead_in: bool) -> MapFile {
    map(crossing_lanes(yields, lead_in), json!({}))
}

/// The crossing's lanes (see [`crossing_with_lead_in`]).
fn crossing_lanes(yields: [&[&str]; 4], lead_in: bool) -> Vec<serde_json::Value> {
    // (name, unit direction of travel)
    let approaches = [
        ("S", [0.0, 1.0]),
        ("W", [1.0, 0.0]),
        ("N", [0.0, -1.0]),
        ("E", [-1.0, 0.0]),
    ];
    let mut lanes = Vec::new();
    for (k, (name, d)) in approaches.iter().enumerate() {
        // Right-hand traffic: lanes sit 1.75 m right of the road's axis.
        let r = [d[1] * 1.75, -d[0] * 1.75];
        let at = |t: f64| [d[0] * t + r[0], d[1] * t + r[1]];
        let start = if lead_in { -40.0 } else { -110.0 };
        if lead_in {
            let mut pre = lane(
                &format!("{name}_pre"),
                &[at(-50.0), at(start)],
                &[&format!("{name}_in")],
            );
            pre["intersection"] = json!(true);
            lanes.push(pre);
        }
        lanes.push(lane(
            &format!("{name}_in"),
            &[at(start), at(-10.0)],
            &[&format!("{name}_x")],
        ));
        let mut x = lane(
            &format!("{name}_x"),
            &[at(-10.0), at(10.0)],
            &[&format!("{name}_out")],
        );
        x["intersection"] = json!(true);
        x["right_of_way"] = json!(yields[k]);
        lanes.push(x);
        lanes.push(lane(&format!("{name}_out"), &[at(10.0), at(200.0)], &[]));
    }
    lanes
}

fn assert_no_overlap(w: &World) {
    let pairs = overlapping_pairs(w.network(), w.vehicles(), 0.05);
    assert!(pairs.is_empty(), "overlap at t={:.2}: {pairs:?}", w.time());
}

#[test]
fn yields_at_intersection_to_vehicle_on_right_of_way_lane() {
    // Northbound S_x must yield to eastbound W_x.
    let mut w = world(&crossing([&["W_x"], &[], &[], &[]]), WorldConfig::default());
    let yielding = w.place_vehicle("Taxi", "S_in", 80.0, 10.0).unwrap();
    let priority = w.place_vehicle("Taxi", "W_in", 75.0, 10.0).unwrap();
    let mut saw_lane_rule = false;
    let mut priority_cleared_first = false;
    let went_on = run_until(&mut w, 30.0, |w| {
        assert_no_overlap(w);
        let (y, p) = (vehicle(w, yielding), vehicle(w, priority));
        saw_lane_rule |= y.yield_phase == YieldPhase::LanesRulesEnteringIntersection;
        if y.path[0] == w.network().lane_id("S_x").unwrap()
            && y.front.y > -3.0
            && !priority_cleared_first
        {
            // The yielding car reaches the crossing point only after the other has passed it.
            assert!(
                p.back.x > 1.75 + 1.0,
                "entered the crossing before the priority vehicle cleared it"
            );
            priority_cleared_first = true;
        }
        y.front.y > 20.0
    });
    assert!(
        saw_lane_rule,
        "never entered LANES_RULES_ENTERING_INTERSECTION"
    );
    assert!(
        priority_cleared_first && went_on,
        "the yielding vehicle did not cross after the other"
    );
}

#[test]
fn forcing_priority_resolves_a_four_way_deadlock() {
    // Each approach yields to the one on its right: a cycle nobody can win by rule.
    let mut w = world(
        &crossing([&["E_x"], &["S_x"], &["W_x"], &["N_x"]]),
        WorldConfig::default(),
    );
    let ids: Vec<u64> = ["S_in", "W_in", "N_in", "E_in"]
        .iter()
        .map(|l| w.place_vehicle("SmallCar", l, 70.0, 8.0).unwrap())
        .collect();
    let mut saw_forcing = false;
    let crossed = run_until(&mut w, 120.0, |w| {
        assert_no_overlap(w);
        saw_forcing |= w
            .vehicles()
            .iter()
            .any(|v| v.yield_phase == YieldPhase::ForcingPriority);
        ids.iter().all(|&id| {
            let v = vehicle(w, id);
            w.network().lane(v.path[0]).name.ends_with("_out") && v.s > 10.0
        })
    });
    assert!(saw_forcing, "no vehicle ever held in FORCING_PRIORITY");
    // As fast as without the junction before: about 21 s (creeping by turns
    // took 98 s).
    assert!(crossed, "the four vehicles did not all cross within 40 s");
}

/// A vehicle let through by deadlock breaking keeps its release until it has
/// left that junction, also when it waits on a lane that another junction
/// leads onto (the release used to lapse there the tick after it was given,
/// and the vehicles of the cycle crept by turns, none crossing).
#[test]
fn a_deadlock_right_after_another_junction_is_broken_too() {
    let mut w = world(
        &crossing_with_lead_in([&["E_x"], &["S_x"], &["W_x"], &["N_x"]], true),
        WorldConfig::default(),
    );
    let ids: Vec<u64> = ["S_pre", "W_pre", "N_pre", "E_pre"]
        .iter()
        .map(|l| w.place_vehicle("SmallCar", l, 6.0, 8.0).unwrap())
        .collect();
    let crossed = run_until(&mut w, 40.0, |w| {
        assert_no_overlap(w);
        ids.iter().all(|&id| {
            let v = vehicle(w, id);
            w.network().lane(v.path[0]).name.ends_with("_out") && v.s > 10.0
        })
    });
    // As fast as without the junction before: about 21 s (creeping by turns
    // took 98 s).
    assert!(crossed, "the four vehicles did not all cross within 40 s");
}

/// A vehicle let through by deadlock breaking goes, also when the one it
/// was waiting for would hold it again in FORCING_PRIORITY: here A, already
/// on a junction lane that yields to B's, waits for B's body, which stands
/// at its junction's entrance too close to A's way (roads that meet outside
/// any junction, as Lanelet2 maps draw them), while B holds for A, who should
/// have yielded to it. Released, B has to go, or the two wait for each other
/// until the jam timeout.
#[test]
fn a_vehicle_released_from_a_deadlock_is_not_held_again_by_the_one_it_waited_for() {
    let mut a_x = lane("A_x", &[[0.0, -20.0], [0.0, 20.0]], &["A_out"]);
    a_x["intersection"] = json!(true);
    a_x["right_of_way"] = json!(["B_x"]);
    let mut b_x = lane("B_x", &[[-1.5, 0.0], [20.0, 0.0]], &["B_out"]);
    b_x["intersection"] = json!(true);
    let m = map(
        vec![
            lane("A_in", &[[0.0, -100.0], [0.0, -20.0]], &["A_x"]),
            a_x,
            lane("A_out", &[[0.0, 20.0], [0.0, 200.0]], &[]),
            lane("B_in", &[[-100.0, 0.0], [-1.5, 0.0]], &["B_x"]),
            b_x,
            lane("B_out", &[[20.0, 0.0], [200.0, 0.0]], &[]),
        ],
        json!({ "road_conflicts": "everywhere" }),
    );
    let mut w = world(&m, WorldConfig::default());
    let b = w.place_vehicle("SmallCar", "B_in", 98.5, 0.0).unwrap();
    let a = w.place_vehicle("SmallCar", "A_x", 16.0, 0.0).unwrap();
    let mut held = false;
    let through = run_until(&mut w, 30.0, |w| {
        assert_no_overlap(w);
        held |= vehicle(w, b).yield_phase == YieldPhase::ForcingPriority;
        [(a, "A_out"), (b, "B_out")].iter().all(|&(id, out)| {
            w.vehicle(id)
                .is_none_or(|v| w.network().lane(v.path[0]).name == out)
        })
    });
    assert!(held, "B never held for A: no deadlock to break");
    assert!(through, "A and B still wait for each other after 30 s");
}

/// A minor road from the south meets a priority road from the west, whose
/// 600 m approach (5 m/s limit) carries a steady slow stream: a taxi every
/// 14 m, one always within reach of the junction, for two minutes.
fn minor_road_against_a_slow_stream() -> (World, u64, Vec<u64>) {
    let mut lanes = vec![
        lane("S_in", &[[1.75, -110.0], [1.75, -10.0]], &["S_x"]),
        lane("S_out", &[[1.75, 10.0], [1.75, 200.0]], &[]),
        lane("W_out", &[[10.0, -1.75], [200.0, -1.75]], &[]),
    ];
    let mut approach = lane("W_in", &[[-610.0, -1.75], [-10.0, -1.75]], &["W_x"]);
    approach["speed_limit"] = json!(5.0);
    lanes.push(approach);
    let mut s_x = lane("S_x", &[[1.75, -10.0], [1.75, 10.0]], &["S_out"]);
    s_x["intersection"] = json!(true);
    s_x["right_of_way"] = json!(["W_x"]);
    lanes.push(s_x);
    let mut w_x = lane("W_x", &[[-10.0, -1.75], [10.0, -1.75]], &["W_out"]);
    w_x["intersection"] = json!(true);
    lanes.push(w_x);
    let config = WorldConfig {
        vehicle: trafficmesh_model::NpcVehicleConfig {
            speed_limit_source: trafficmesh_model::SpeedLimitSource::LaneletSpeedLimit,
            ..Default::default()
        },
        ..WorldConfig::default()
    };
    let mut w = world(&map(lanes, json!({})), config);
    let stream = (0..40)
        .map(|k| {
            let front = 590.0 - 14.0 * k as f64;
            w.place_vehicle("Taxi", "W_in", front, 5.0).unwrap()
        })
        .collect();
    let minor = w.place_vehicle("Taxi", "S_in", 90.0, 0.0).unwrap();
    (w, minor, stream)
}

/// Impatience (SUMO's): a vehicle that has yielded for a while to a stream
/// that never leaves a gap goes before a priority vehicle that can still
/// stop for it comfortably, and that one stops. Before, it stood until the
/// stream ended.
#[test]
fn a_vehicle_yielding_to_a_stream_without_gaps_grows_impatient_and_goes() {
    let (mut w, minor, stream) = minor_road_against_a_slow_stream();
    let w_in = w.network().lane_id("W_in").unwrap();
    let mut yielded_to = std::collections::BTreeSet::new();
    let crossed = run_until(&mut w, 90.0, |w| {
        assert_no_overlap(w);
        let m = vehicle(w, minor);
        if m.yield_phase == YieldPhase::LanesRulesEnteringIntersection {
            yielded_to.extend(m.dominating);
        }
        m.front.y > 10.0
    });
    assert!(crossed, "still waiting after 90 s");
    assert!(
        yielded_to.len() >= 3,
        "it did not wait for the stream first: yielded to {yielded_to:?}"
    );
    let still_coming = stream
        .iter()
        .filter(|&&id| w.vehicle(id).is_some_and(|v| v.path[0] == w_in))
        .count();
    assert!(
        still_coming > 10,
        "the stream had ended: {still_coming} left"
    );
    assert!(
        w.time() < trafficmesh_sim::world::STUCK_AFTER + 5.0,
        "it went only after {:.0} s",
        w.time()
    );
    // The stream stops for it, and nobody touches anybody.
    run_until(&mut w, 30.0, |w| {
        assert_no_overlap(w);
        false
    });
}

/// A priority vehicle standing right at the junction's entrance (too near
/// to count on its stopping), held there for good (the lane after the
/// junction has no room: a walker who never leaves holds the car on it), is
/// no stream to wait for forever: a vehicle its rule holds grows wholly
/// impatient in a minute and crosses before it.
#[test]
fn a_vehicle_crosses_before_a_priority_vehicle_that_stands_for_good() {
    let zebra = json!({
        "crosswalks": [{
            "name": "Zebra",
            "area": { "shape": "box", "center": [30.0, -1.75], "half_extents": [2.0, 6.0] },
            "stop_points": [{ "position": [27.0, -1.75] }]
        }]
    });
    let mut w = world(
        &crossing_with([&["W_x"], &[], &[], &[]], zebra),
        WorldConfig::default(),
    );
    walker_on(&mut w, "Zebra");
    let held = w.place_vehicle("Taxi", "W_out", 12.0, 0.0).unwrap();
    let priority = w.place_vehicle("Taxi", "W_in", 99.0, 0.0).unwrap();
    let minor = w.place_vehicle("Taxi", "S_in", 95.0, 0.0).unwrap();
    let mut yielded = false;
    let crossed = run_until(&mut w, 120.0, |w| {
        assert_no_overlap(w);
        let m = vehicle(w, minor);
        yielded |= m.yield_phase == YieldPhase::LanesRulesEnteringIntersection
            && m.dominating == Some(priority);
        m.front.y > 10.0
    });
    assert!(yielded, "it never yielded to the standing priority vehicle");
    assert!(crossed, "still waiting after 120 s");
    let impatience = trafficmesh_sim::IMPATIENCE_TIME;
    assert!(
        w.time() >= impatience,
        "it went after {:.0} s, before it was wholly impatient",
        w.time()
    );
    let (p, h) = (vehicle(&w, priority), vehicle(&w, held));
    assert_eq!(
        w.network().lane(p.path[0]).name,
        "W_in",
        "the priority car waits"
    );
    assert!(h.speed < 0.1, "the walker still holds the exit");
    run_until(&mut w, 20.0, |w| {
        assert_no_overlap(w);
        false
    });
}

/// A left turn split in two junction lanes, as SUMO splits one that waits
/// inside the junction: `t1` (no rules of its own) up to the internal
/// junction point, then `t2`, which yields to the oncoming through lane `x`.
fn split_left_turn() -> MapFile {
    let mut t1 = lane("t1", &[[0.0, -10.0], [0.0, 0.0]], &["t2"]);
    t1["intersection"] = json!(true);
    let mut t2 = lane(
        "t2",
        &[[0.0, 0.0], [-3.0, 4.0], [-8.0, 6.0], [-12.0, 6.5]],
        &["out"],
    );
    t2["intersection"] = json!(true);
    t2["right_of_way"] = json!(["x"]);
    let mut x = lane("x", &[[-3.5, 12.0], [-3.5, -12.0]], &["b_out"]);
    x["intersection"] = json!(true);
    map(
        vec![
            lane("a", &[[0.0, -100.0], [0.0, -10.0]], &["t1"]),
            t1,
            t2,
            lane("out", &[[-12.0, 6.5], [-200.0, 6.5]], &[]),
            lane("b_in", &[[-3.5, 100.0], [-3.5, 12.0]], &["x"]),
            x,
            lane("b_out", &[[-3.5, -12.0], [-3.5, -200.0]], &[]),
        ],
        json!({}),
    )
}

/// The turn learns of the oncoming car on its first junction lane and waits
/// at the internal junction point, its front short of the lane it waits for,
/// instead of finding its rule only on the second lane and braking into it.
#[test]
fn a_split_turn_waits_at_the_internal_junction_point() {
    let mut w = world(&split_left_turn(), WorldConfig::default());
    let turner = w.place_vehicle("Taxi", "a", 60.0, 8.0).unwrap();
    let oncoming = w.place_vehicle("Taxi", "b_in", 5.0, 13.0).unwrap();
    let net = w.network();
    let (t1, t2) = (net.lane_id("t1").unwrap(), net.lane_id("t2").unwrap());
    let mut waited_on_t1 = false;
    let turned = run_until(&mut w, 40.0, |w| {
        assert_no_overlap(w);
        let (t, o) = (vehicle(w, turner), vehicle(w, oncoming));
        let oncoming_past = o.back.y < -2.0;
        if t.yield_phase == YieldPhase::LanesRulesAtIntersection && t.dominating == Some(oncoming) {
            waited_on_t1 |= t.path[0] == t1;
        }
        if !oncoming_past {
            // Short of the crossing: the front stays left of the lane it
            // waits for by more than a car's half width.
            assert!(
                t.path[0] != t2 || t.front.x > -3.5 + 1.8,
                "front at {:.2} in the oncoming lane at t={:.2}",
                t.front,
                w.time()
            );
        }
        w.network().lane(t.path[0]).name == "out"
    });
    assert!(waited_on_t1, "it did not wait on its first junction lane");
    assert!(turned, "the turn never went");
}

/// The crossing with a light at the start of each junction lane, as
/// Autoware's Lanelet2 maps draw them: west-east green for the first 30 s,
/// south-north red until 33 s.
fn signalised_crossing() -> MapFile {
    let mut lanes = crossing_lanes([&[], &[], &[], &[]], false);
    for l in &mut lanes {
        let name = l["name"].as_str().unwrap().to_string();
        if let Some(approach) = name.strip_suffix("_x") {
            let start = l["waypoints"][0].clone();
            l["stop_line"] = json!([start, start]);
            l["traffic_light"] = json!(if ["W", "E"].contains(&approach) {
                "WE"
            } else {
                "SN"
            });
        }
    }
    map(
        lanes,
        json!({ "light_groups": [
            { "name": "WE", "program": { "green": 30, "yellow": 3, "red": 33 } },
            { "name": "SN", "program": { "green": 30, "yellow": 3, "red": 33, "offset": 33 } },
        ] }),
    )
}

/// A car that stopped at its red light with its front a little over the
/// stop line, on the junction lane, waits at red like one before the line:
/// the crossing traffic, whose light is green, does not take the junction
/// for blocked by it (each would hold the other's green for ever).
#[test]
fn a_car_standing_at_red_just_over_its_stop_line_does_not_block_the_junction() {
    let mut w = world(&signalised_crossing(), WorldConfig::default());
    let at_red = w.place_vehicle("Taxi", "S_x", 0.3, 0.0).unwrap();
    let crossing = w.place_vehicle("Taxi", "W_in", 60.0, 10.0).unwrap();
    let s_x = w.network().lane_id("S_x").unwrap();
    let mut blocked = false;
    let crossed = run_until(&mut w, 25.0, |w| {
        assert_no_overlap(w);
        let (r, c) = (vehicle(w, at_red), vehicle(w, crossing));
        assert!(
            r.path[0] == s_x && r.s < 0.5,
            "the car at red moved: {:.2} m",
            r.s
        );
        blocked |= c.yield_phase == YieldPhase::IntersectionBlocked;
        w.network().lane(c.path[0]).name == "W_out"
    });
    let c = vehicle(&w, crossing);
    assert!(
        crossed && !blocked,
        "the crossing car waited for the one standing at red (blocked: {blocked}; {:?} {:?} on {} at {:.1} m, {:?})",
        c.yield_phase,
        c.speed_mode,
        w.network().lane(c.path[0]).name,
        c.s,
        c.dominating
    );
}
