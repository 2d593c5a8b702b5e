//! Cognition: what each vehicle perceives this tick. Runs in parallel, every
//! vehicle reading the same immutable [`Snapshot`] of the previous tick, so the
//! result depends neither on thread count nor on the vehicles' order in the
//! world's list (where the order could decide, as between level bodies, ids do).

pub mod clearance;
pub mod curve;
pub mod deadlock;
pub mod light;
pub mod obstacles;
pub mod passage;
pub mod path;
pub mod right_of_way;

use glam::DVec2;
use trafficmesh_model::{LightColor, NpcVehicleConfig, YieldPhase};

use crate::body_grid::BodyGrid;
use crate::crosswalk::{Occupancy, try_get_blocked_stop};
use crate::ego::Ego;
use crate::lane_index::LaneIndex;
use crate::lights::Lights;
use crate::network::{LaneId, LaneNetwork};
use crate::vehicle::{Vehicle, VehicleId, ZebraState};
use right_of_way::{JunctionBuckets, RowInfo};

/// Everything cognition reads: the world as it was at the end of the last tick.
pub struct Snapshot<'a> {
    pub net: &'a LaneNetwork,
    pub vehicles: &'a [Vehicle],
    pub index: &'a LaneIndex,
    pub lights: &'a Lights,
    /// Simulation time of the tick.
    pub time: f64,
    pub occupancy: &'a Occupancy,
    pub ego: Option<&'a Ego>,
    /// Bodies the world does not drive (a runtime's actors): obstacles ahead like the ego.
    pub foreign: &'a [Ego],
    pub config: &'a NpcVehicleConfig,
    pub row: &'a [RowInfo],
    pub junctions: &'a JunctionBuckets,
    pub bodies: &'a BodyGrid,
}

/// Cognition's output for one vehicle; written back before the Decision step.
#[derive(Clone, Copy, Debug)]
pub struct Perception {
    pub distance_to_front: f64,
    /// Index of the vehicle that is the front obstacle, if one is.
    pub front_vehicle: Option<u32>,
    /// Its speed along the own path: a leader's speed; 0 for a vehicle
    /// crossing the path or any other obstacle.
    pub front_speed: f64,
    pub light_lane: Option<LaneId>,
    pub distance_to_light: f64,
    pub passability: LightColor,
    pub stops_at_light: bool,
    pub yield_phase: YieldPhase,
    pub yield_point: DVec2,
    pub yield_lane: Option<LaneId>,
    pub dominating: Option<VehicleId>,
    /// Deadlock breaking let the vehicle through this junction.
    pub forced_through: Option<u32>,
    pub zebra: ZebraState,
    /// The furthest the vehicle may drive this tick: short of a body in its
    /// way ([`clearance`]); infinite when none is.
    pub travel_cap: f64,
}

/// Cognition for vehicle `i`.
pub fn perceive(snap: &Snapshot, i: usize) -> Perception {
    let v = &snap.vehicles[i];
    let light = light::check(snap, v);
    let row = right_of_way::next_phase(snap, i);
    let zebra =
        match try_get_blocked_stop(&snap.net.crosswalks, snap.occupancy, v.front, v.forward()) {
            Some((distance, area)) => ZebraState {
                is_blocked: true,
                distance_to_stop: distance,
                area: Some(area),
                was_blocked: v.zebra.is_blocked,
            },
            None => ZebraState {
                was_blocked: v.zebra.is_blocked,
                ..ZebraState::default()
            },
        };
    let front = obstacles::front_obstacle(snap, i);
    let leader = front
        .vehicle
        .map(|k| &snap.vehicles[k as usize])
        .filter(|ahead| v.path.contains(&ahead.path[0]));
    let blocked = clearance::blocked(snap, i);
    // A body in the way nearer than the obstacle in front stands in for it;
    // following the leader on the path goes on (the travel stays capped).
    let (distance_to_front, front_vehicle, front_speed) = match blocked {
        Some(b)
            if b.travel < front.distance && (leader.is_none() || front.vehicle != Some(b.by)) =>
        {
            (b.travel, Some(b.by), 0.0)
        }
        _ => (
            front.distance,
            front.vehicle,
            leader.map_or(0.0, |ahead| ahead.speed),
        ),
    };
    Perception {
        distance_to_front,
        front_vehicle,
        front_speed,
        travel_cap: blocked.map_or(f64::INFINITY, |b| b.travel),
        light_lane: light.lane,
        distance_to_light: light.distance,
        passability: light.color,
        stops_at_light: light.stops,
        yield_phase: row.phase,
        yield_point: row.point,
        yield_lane: row.lane,
        dominating: row.dominating,
        forced_through: v.forced_through,
        zebra,
    }
}

impl Perception {
    pub fn apply(&self, v: &mut Vehicle) {
        v.distance_to_front = self.distance_to_front;
        v.front_speed = self.front_speed;
        v.light_lane = self.light_lane;
        v.distance_to_light = self.distance_to_light;
        v.passability = self.passability;
        v.stops_at_light = self.stops_at_light;
        v.yield_phase = self.yield_phase;
        v.yield_point = self.yield_point;
        v.yield_lane = self.yield_lane;
        v.dominating = self.dominating;
        v.forced_through = self.forced_through;
        v.zebra = self.zebra;
    }
}
