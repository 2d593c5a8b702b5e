//! The road saved and put back: a world restored from a snapshot (through
//! its JSON, as the stepper keeps it) has the same time and vehicles, and
//! drives on without bodies meeting. A snapshot that does not fit is
//! refused and changes nothing.

mod support;

use support::*;
use trafficmesh_model::snapshot::RoadSnapshot;
use trafficmesh_sim::world::WorldError;
use trafficmesh_sim::{World, WorldConfig};

fn config() -> WorldConfig {
    WorldConfig {
        max_vehicles: 60,
        ..WorldConfig::default()
    }
}

fn busy_grid() -> World {
    let mut world = grid_world(3, config());
    run_for(&mut world, 90.0);
    assert!(
        world.vehicles().len() > 20,
        "{} vehicles",
        world.vehicles().len()
    );
    world
}

#[test]
fn a_restored_road_has_the_saved_time_and_vehicles_and_drives_on() {
    let world = busy_grid();
    let saved = world.snapshot();
    let text = serde_json::to_string(&saved).unwrap();
    let read: RoadSnapshot = serde_json::from_str(&text).unwrap();
    assert_eq!(read, saved);

    let mut restored = grid_world(3, config());
    restored.restore(&read).unwrap();
    assert_eq!(restored.time(), world.time());
    assert_eq!(restored.ticks(), world.ticks());
    assert_eq!(
        restored.snapshot(),
        saved,
        "the road put back is the road saved"
    );
    assert_eq!(
        restored.drain_events().count(),
        0,
        "restored vehicles are no new spawns"
    );
    for (a, b) in world.vehicles().iter().zip(restored.vehicles()) {
        assert_eq!(
            (a.id, a.kind, &a.path, a.s, a.speed),
            (b.id, b.kind, &b.path, b.s, b.speed)
        );
        // Drawn where it was (one changing lanes, mid-way across, is put
        // back on the lane it was leaving).
        if a.lane_change.is_none() {
            let d = (a.pose.x - b.pose.x).hypot(a.pose.y - b.pose.y);
            assert!(d < 1e-9, "#{} drawn {d:.3} m away", a.id);
        }
    }
    // It drives on: no bodies meet, and the vehicles move.
    let moved_from: Vec<_> = restored.vehicles().iter().map(|v| (v.id, v.pose)).collect();
    for _ in 0..(30.0 / restored.config().dt) as usize {
        restored.step();
        assert_no_overlap(&restored);
    }
    let moved = moved_from
        .iter()
        .filter(|(id, pose)| {
            restored
                .vehicle(*id)
                .is_none_or(|v| (v.pose.x - pose.x).hypot(v.pose.y - pose.y) > 1.0)
        })
        .count();
    assert!(
        moved * 2 > moved_from.len(),
        "{moved} of {} moved",
        moved_from.len()
    );
    // New vehicles get ids the saved ones never had.
    let highest = saved.vehicles.iter().map(|v| v.id).max().unwrap();
    assert!(
        restored
            .vehicles()
            .iter()
            .all(|v| v.id <= highest || v.id >= saved.next_id)
    );
}

#[test]
fn a_snapshot_that_does_not_fit_is_refused_and_changes_nothing() {
    let saved = busy_grid().snapshot();
    // Another map.
    let mut other = grid_world(2, config());
    assert!(matches!(
        other.restore(&saved),
        Err(WorldError::AnotherMap { .. })
    ));
    assert!(other.vehicles().is_empty() && other.time() == 0.0);
    // A lane the map does not have, in the last vehicle.
    let mut broken = saved.clone();
    broken.vehicles.last_mut().unwrap().path[0] = "no_such_lane".into();
    let mut world = grid_world(3, config());
    let err = world.restore(&broken).unwrap_err();
    assert!(err.to_string().contains("no_such_lane"), "{err}");
    assert!(world.vehicles().is_empty() && world.time() == 0.0);
    // A road already driven on.
    world.restore(&saved).unwrap();
    assert!(matches!(
        world.restore(&saved),
        Err(WorldError::NotEmpty(_))
    ));
}
