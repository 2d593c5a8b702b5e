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

pub mod branching;
pub mod buckets;
pub mod cognition;
pub mod conflicts;
pub mod control;
pub mod crosswalk;
pub mod crosswalk_agents;
pub mod decision;
pub mod ego;
pub mod events;
pub mod geometry;
pub mod idm;
pub mod lane_change;
pub mod lane_index;
pub mod lights;
pub mod network;
pub mod pedestrians;
pub mod populate;
pub mod prefetch;
pub mod rng;
pub mod spawn;
pub mod trajectory;
pub mod vehicle;
pub mod visualization;
pub mod world;

pub use ego::Ego;
pub use events::{DespawnReason, SimEvent, TripRecord};
pub use network::{LaneId, LaneNetwork};
pub use trajectory::TrajectoryHash;
pub use vehicle::{Vehicle, VehicleId};
pub use world::{WaitStats, World, WorldConfig, WorldError};
