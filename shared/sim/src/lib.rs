//! The deterministic trafficmesh simulation core.
//!
//! Owns the lane network at run time, the NPC pipeline (Cognition, Decision,
//! Control, Visualization), spawning with its traffic simulators, traffic-light
//! programs, crosswalk occupancy and branch statistics. The stepper, the spawner,
//! the headless runner and later gateways all call into this crate.
//!
//! Invariants: no I/O, no clock, no Zenoh. Same network, config, seed and inputs
//! give bit-identical trajectories whatever the thread count: cognition reads an
//! immutable snapshot in parallel, randomness comes from per-entity seeded streams.

mod body_grid;
pub mod branching;
mod buckets;
mod cognition;
mod conflicts;
pub mod control;
pub mod crosswalk;
pub mod crosswalk_agents;
pub mod decision;
mod ego;
mod events;
pub mod geometry;
mod idm;
pub mod lane_change;
mod lane_choice;
mod lane_index;
pub mod lights;
mod lookahead;
mod loops;
pub mod motion_check;
pub mod network;
mod parallel;
pub mod pedestrians;
#[cfg(any(test, feature = "bench"))]
pub mod populate;
mod pose;
mod prefetch;
pub mod reservation;
mod rng;
pub mod session;
mod siblings;
pub mod spawn;
mod trajectory;
mod vehicle;
mod visualization;
pub mod walk_signal;
pub mod world;

pub use cognition::right_of_way::IMPATIENCE_TIME;
pub use ego::Ego;
pub use events::{DespawnReason, SimEvent, TripRecord};
pub use network::{LaneId, LaneNetwork};
pub use pose::Moved;
pub use trajectory::TrajectoryHash;
pub use vehicle::{Pose, Vehicle, VehicleId};
pub use world::{WaitStats, World, WorldConfig, WorldError};
