//! Data types every trafficmesh process shares: the native map file format, the
//! NPC vehicle config, the spawn config (the AWSIM reference's `traffic_spawn.json`), the
//! vehicle catalogue and the enums of the NPC pipeline.
//!
//! This crate holds plain data and its validation. It does no I/O beyond
//! (de)serialising strings, reads no clock and knows nothing of Zenoh.

pub mod catalog;
pub mod driver_model;
pub mod enums;
pub mod geometry;
pub mod hash;
pub mod map;
pub mod reservation;
pub mod snapshot;
pub mod spawn_config;
pub mod vehicle_config;

pub use catalog::{VehicleKind, builtin_kind};
pub use driver_model::{DriverModel, IdmParams};
pub use enums::{LightColor, SpeedMode, TurnDirection, TurnSignal, YieldPhase};
pub use map::{
    CrosswalkArea, CrosswalkDef, DepartureDef, IntersectionController, IntersectionDef, LaneDef,
    LightGroupDef, LightProgram, MapFile, MapProblem, RoadConflicts, SimulatorDef, ZebraConfigDef,
};
pub use spawn_config::{
    BranchWeights, NextWeight, SpawnConfigError, SpawnRate, TrafficSpawnConfig,
};
pub use vehicle_config::{NpcVehicleConfig, SpeedLimitSource};
