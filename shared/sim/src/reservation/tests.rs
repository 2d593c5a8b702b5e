use serde_json::json;

use super::*;

/// A four-way junction, one lane per approach, 20 m across: straight on
/// from each side ("we", "sn", "ew", "ns") and a right turn from the west
/// ("wr", into the southbound exit).
fn crossing() -> LaneNetwork {
    let lane = |name: &str, points: &[[f64; 2]], next: &[&str], inter: bool| {
        json!({ "name": name, "waypoints": points, "next": next, "intersection": inter,
                "speed_limit": 10.0 })
    };
    let lanes = vec![
        lane(
            "w_in",
            &[[-100.0, -1.6], [-10.0, -1.6]],
            &["we", "wr"],
            false,
        ),
        lane("s_in", &[[1.6, -100.0], [1.6, -10.0]], &["sn"], false),
        lane("e_in", &[[100.0, 1.6], [10.0, 1.6]], &["ew"], false),
        lane("n_in", &[[-1.6, 100.0], [-1.6, 10.0]], &["ns"], false),
        lane("we", &[[-10.0, -1.6], [10.0, -1.6]], &["e_out"], true),
        lane(
            "wr",
            &[[-10.0, -1.6], [-1.6, -1.6], [-1.6, -10.0]],
            &["s_out"],
            true,
        ),
        lane("sn", &[[1.6, -10.0], [1.6, 10.0]], &["n_out"], true),
        lane("ew", &[[10.0, 1.6], [-10.0, 1.6]], &["w_out"], true),
        lane("ns", &[[-1.6, 10.0], [-1.6, -10.0]], &["s_out"], true),
        lane("e_out", &[[10.0, -1.6], [100.0, -1.6]], &[], false),
        lane("n_out", &[[1.6, 10.0], [1.6, 100.0]], &[], false),
        lane("w_out", &[[-10.0, 1.6], [-100.0, 1.6]], &[], false),
        lane("s_out", &[[-1.6, -10.0], [-1.6, -100.0]], &[], false),
    ];
    let map = serde_json::from_value(json!({
        "lanes": lanes,
        "traffic_simulators": [{ "kind": "random", "lanes": ["w_in"], "prefabs": ["Taxi"], "enabled": false }],
    }))
    .expect("test map");
    LaneNetwork::build(&map).expect("test map builds")
}

fn junction(net: &LaneNetwork) -> Intersection {
    let j = net
        .lane(net.lane_id("we").unwrap())
        .junction
        .expect("a junction");
    Intersection::of(net, j, 2.0, Margins::default())
}

fn request(
    net: &LaneNetwork,
    vehicle: VehicleId,
    lane: &str,
    to_entry: f64,
    speed: f64,
) -> Request {
    let lane = net.lane_id(lane).unwrap();
    Request {
        intersection: 0,
        vehicle,
        lane,
        from: net.lane(lane).prev[0],
        approach: Approach {
            to_entry,
            speed,
            accel: 2.0,
            max_speed: 10.0,
            length: 4.5,
            width: 2.0,
        },
        emergency: false,
    }
}

#[test]
fn of_two_arriving_together_on_crossing_paths_one_is_refused_and_goes_after() {
    let net = crossing();
    let mut x = junction(&net);
    let asks = [
        request(&net, 1, "we", 10.0, 10.0),
        request(&net, 2, "sn", 10.0, 10.0),
    ];
    assert_eq!(x.decide(0.0, &asks), vec![1], "first come, first served");
    assert!(x.grant(2).is_none());
    // Vehicle 2 stops at its line and asks again, standing; once 1 has
    // crossed (its plan ends within 3 s) the way is free.
    let standing = [request(&net, 2, "sn", 0.0, 0.0)];
    let granted_at = (1..60)
        .map(|k| k as f64 * 0.1)
        .find(|&t| x.decide(t, &standing) == vec![2])
        .expect("granted once 1 has crossed");
    let last_of_1 = x.grant(1).unwrap().plan.steps.last().unwrap().t;
    assert!(
        granted_at > 0.5,
        "granted at {granted_at:.1} s, with 1 still crossing"
    );
    assert!(
        granted_at <= last_of_1 + 1.0,
        "granted at {granted_at:.1} s, 1 out at {last_of_1:.1} s"
    );
}

#[test]
fn ways_that_never_meet_are_granted_together() {
    let net = crossing();
    let mut x = junction(&net);
    let asks = [
        request(&net, 1, "we", 10.0, 10.0),
        request(&net, 2, "ew", 10.0, 10.0),
    ];
    assert_eq!(x.decide(0.0, &asks), vec![1, 2]);
}

#[test]
fn granted_rectangles_never_overlap_in_time() {
    let net = crossing();
    let mut x = junction(&net);
    let lanes = ["we", "wr", "sn", "ew", "ns"];
    // Every approach asks every 0.1 s for 30 s, a new vehicle as soon as
    // the last one was granted.
    let mut next_id = 1;
    let mut heads: Vec<(VehicleId, &str)> = lanes
        .iter()
        .map(|&l| {
            next_id += 1;
            (next_id, l)
        })
        .collect();
    let mut grants = Vec::new();
    for k in 0..300 {
        let now = k as f64 * 0.1;
        let asks: Vec<Request> = heads
            .iter()
            .map(|&(id, l)| request(&net, id, l, 5.0, 5.0))
            .collect();
        for id in x.decide(now, &asks) {
            grants.push(x.grant(id).unwrap().clone());
            let head = heads.iter_mut().find(|(v, _)| *v == id).unwrap();
            next_id += 1;
            head.0 = next_id;
        }
    }
    assert!(grants.len() > 20, "only {} grants in 30 s", grants.len());
    for (a, ga) in grants.iter().enumerate() {
        for gb in &grants[a + 1..] {
            for sa in &ga.plan.steps {
                for sb in &gb.plan.steps {
                    let (ta, tb) = (ga.at + sa.t, gb.at + sb.t);
                    if (ta - tb).abs() < 0.05 {
                        assert!(
                            sa.body.separation(&sb.body) > 0.0,
                            "two grants overlap at {ta:.1} s"
                        );
                    }
                }
            }
        }
    }
}

/// Vehicle 1 creeps across from the west (at most 1 m/s, its front
/// already 8 m in): for about 13 s its body holds the middle.
fn held_by_a_creeping_vehicle(net: &LaneNetwork) -> Intersection {
    let mut x = junction(net);
    let mut creeping = request(net, 1, "we", -8.0, 0.0);
    creeping.approach.accel = 0.3;
    creeping.approach.max_speed = 1.0;
    assert_eq!(x.decide(0.0, &[creeping]), vec![1]);
    x
}

#[test]
fn a_head_that_has_waited_ten_seconds_has_its_way_kept_clear_until_granted() {
    let net = crossing();
    let mut x = held_by_a_creeping_vehicle(&net);
    let south = request(&net, 2, "sn", 0.0, 0.0);
    assert!(x.decide(0.0, &[south]).is_empty(), "the middle is held");
    // Before 10 s a vehicle from the east, clear of 1's way, gets through
    // ahead of the south.
    let east = request(&net, 3, "ew", 5.0, 5.0);
    assert_eq!(x.decide(9.9, &[south, east]), vec![3]);
    x.release(3);
    // From 10 s the south's way is kept clear: the next from the east, whose
    // way crosses it, waits.
    let east = request(&net, 4, "ew", 5.0, 5.0);
    let mut granted = Vec::new();
    for k in 100..400 {
        granted.extend(x.decide(k as f64 * 0.1, &[south, east]));
    }
    assert_eq!(granted, vec![2, 4], "the south first, then the east");
}

#[test]
fn an_emergency_vehicles_lane_and_the_lanes_clear_of_it_are_served_first() {
    let net = crossing();
    let order = |emergency: bool| {
        let mut x = held_by_a_creeping_vehicle(&net);
        // The south waits for the middle; an emergency vehicle from the north
        // too; the east, whose way is free of 1's, asks last.
        let south = request(&net, 2, "sn", 0.0, 0.0);
        let mut north = request(&net, 3, "ns", 0.0, 0.0);
        north.emergency = emergency;
        let east = request(&net, 4, "ew", 5.0, 5.0);
        let mut order = Vec::new();
        for k in 1..400 {
            for id in x.decide(k as f64 * 0.1, &[south, north, east]) {
                order.push((id, k));
            }
        }
        order
    };
    let (without, with) = (order(false), order(true));
    let when = |order: &[(u64, i32)], id| order.iter().find(|(v, _)| *v == id).expect("granted").1;
    assert_eq!(
        without[0].0, 4,
        "without an emergency the free way goes first"
    );
    // The east's way crosses the north's: it waits until the emergency
    // vehicle has its way. The south's never comes near it: it is not held,
    // granted when its way clears, as without the emergency.
    assert!(when(&with, 3) < when(&with, 4), "{with:?}");
    assert_eq!(when(&with, 2), when(&without, 2), "{with:?} {without:?}");
}

#[test]
fn a_released_vehicle_frees_its_way_and_the_granted_speed_is_the_plans() {
    let net = crossing();
    let mut x = junction(&net);
    assert_eq!(x.decide(0.0, &[request(&net, 1, "we", 0.0, 0.0)]), vec![1]);
    let g = x.grant(1).unwrap();
    let mut driving = Driving::of(Granted {
        intersection: 0,
        vehicle: 1,
        lane: g.lane,
        speeds: g.plan.speeds.clone(),
        step: g.step,
        again: false,
    });
    assert_eq!(driving.speed(), 0.0);
    driving.elapsed = 2.0;
    assert!((driving.speed() - 4.0).abs() < 1e-9, "2 m/s² for 2 s");
    assert!(
        x.decide(0.1, &[request(&net, 2, "sn", 0.0, 0.0)])
            .is_empty()
    );
    x.release(1);
    assert_eq!(x.decide(0.2, &[request(&net, 2, "sn", 0.0, 0.0)]), vec![2]);
    assert!(x.reserved_ahead(0.2).all(|(_, v, _)| v == 2));
}
