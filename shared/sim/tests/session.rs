//! Traffic-service sessions: log replay, when the model takes an actor over,
//! and how it then drives.

mod support;

use glam::{DQuat, DVec3};
use support::*;
use trafficmesh_sim::LaneNetwork;
use trafficmesh_sim::session::{Actor, PoseAt, SessionConfig, SessionError, TrafficSession};

const STEP: u64 = 100_000;

/// A session on the signalised road, seed 1, the default settings.
fn on_road(actors: Vec<Actor>, handover_us: u64) -> TrafficSession {
    let road = LaneNetwork::build(&signalised_road()).unwrap();
    TrafficSession::new(Some(road), actors, 1, handover_us, SessionConfig::default()).unwrap()
}

fn pose(t_us: u64, x: f64) -> PoseAt {
    PoseAt {
        t_us,
        position: DVec3::new(x, 0.0, 0.8),
        rotation: DQuat::IDENTITY,
    }
}

/// Eastbound on the approach at 10 m/s, logged from `from_us` for 1.5 s.
fn car(id: &str, from_us: u64, x0: f64) -> Actor {
    Actor {
        id: id.into(),
        size: DVec3::new(4.5, 1.9, 1.5),
        is_static: false,
        log: (0..=15)
            .map(|k| pose(from_us + k * STEP, x0 + k as f64))
            .collect(),
    }
}

fn drivers(s: &mut TrafficSession, until_us: u64, from_us: u64) -> Vec<(u64, Vec<&'static str>)> {
    (from_us..=until_us)
        .step_by(STEP as usize)
        .map(|t| {
            let answers = s.simulate(t, Vec::new()).unwrap();
            (t, answers.iter().map(|a| a.driver).collect())
        })
        .collect()
}

#[test]
fn the_model_takes_an_actor_over_at_handover_once_it_has_its_history() {
    // One actor logged from 0 (history enough at 1 s, handover at 2 s), one
    // that appears at 2.5 s (history enough at 3.5 s).
    let mut s = on_road(
        vec![car("early", 0, 20.0), car("late", 2_500_000, 60.0)],
        2_000_000,
    );
    for (t, d) in drivers(&mut s, 5_000_000, STEP) {
        // The answer at t is after the tick that starts at t - 20 ms at the latest.
        let early = if t > 2_000_000 { "model" } else { "log" };
        let late = if t > 3_500_000 { "model" } else { "log" };
        assert_eq!(d, vec![early, late], "at {t} us");
    }
}

#[test]
fn logged_poses_come_back_unchanged_until_handover_and_a_handed_over_car_keeps_its_lane() {
    let actor = car("a", 0, 20.0);
    let log = actor.log.clone();
    let mut s = on_road(vec![actor], 600_000);
    for t in (STEP..=1_000_000).step_by(STEP as usize) {
        let a = &s.simulate(t, Vec::new()).unwrap()[0];
        assert_eq!(a.poses[0], log[(t / STEP) as usize], "at {t} us");
        assert_eq!(a.poses.len(), 21, "the pose and a 2 s forecast at 10 Hz");
    }
    let mut last = 0.0;
    for t in (1_100_000..=6_000_000).step_by(STEP as usize) {
        let a = &s.simulate(t, Vec::new()).unwrap()[0];
        let p = a.poses[0];
        assert_eq!(p.t_us, t);
        assert!(p.position.y.abs() < 0.05, "on its lane at {t}: {p:?}");
        assert!(
            (p.position.z - 0.8).abs() < 1e-9,
            "its logged height: {p:?}"
        );
        assert!(p.position.x >= last, "it drives on: {last} -> {p:?}");
        last = p.position.x;
    }
    assert!(last > 50.0, "it drove on: {last}");
}

#[test]
fn a_car_handed_over_stops_behind_a_body_the_client_moves() {
    let mut s = on_road(vec![car("a", 0, 20.0)], 600_000);
    let mut x = 0.0;
    for t in (STEP..=12_000_000).step_by(STEP as usize) {
        let ego = vec![("ego".to_string(), vec![pose(t, 90.0)])];
        x = s.simulate(t, ego).unwrap()[0].poses[0].position.x;
    }
    // The ego is 4.9 m long, centred at 90 m: its rear at 87.55 m.
    assert!(x + 2.25 < 87.55 && x > 60.0, "stopped behind the ego: {x}");
}

#[test]
fn bad_requests_are_refused_and_leave_the_session_as_it_was() {
    let mut s = on_road(vec![car("a", 0, 20.0)], 600_000);
    s.simulate(500_000, Vec::new()).unwrap();
    assert_eq!(
        s.simulate(400_000, Vec::new()),
        Err(SessionError::TimeBackwards {
            now: 500_000,
            asked: 400_000
        })
    );
    let short = vec![("ego".to_string(), vec![pose(500_000, 90.0)])];
    assert!(matches!(
        s.simulate(600_000, short),
        Err(SessionError::MissingPoses { .. })
    ));
    let nan = vec![("ego".to_string(), vec![pose(600_000, f64::NAN)])];
    assert_eq!(
        s.simulate(600_000, nan),
        Err(SessionError::NotFinite("ego".into()))
    );
    assert_eq!(
        s.simulate(600_000, vec![("ego".into(), Vec::new())]),
        Err(SessionError::EmptyTrajectory("ego".into()))
    );
    assert!(s.simulate(600_000, Vec::new()).is_ok());
    assert_eq!(
        TrafficSession::new(
            None,
            vec![car("a", 0, 0.0), car("a", 0, 9.0)],
            1,
            0,
            SessionConfig::default()
        )
        .err(),
        Some(SessionError::DuplicateObject("a".into()))
    );
}
