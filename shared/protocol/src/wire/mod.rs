//! Messages on the Zenoh bus (serde_json payloads, but the per-tick vehicle
//! batch in the binary layout of `vehicle_codec`). docs/cluster.md's key-expression
//! table says which key carries which type; these structs are that contract.
//!
//! Poses are in the map frame (metres, yaw in radians counter-clockwise from +x).
//! Times are simulation seconds unless a field name says otherwise.

mod agents;
mod commands;
mod intersections;
mod lockstep;
mod sessions;
mod states;
mod telemetry;
pub mod vehicle_codec;

pub use agents::{Agent, AgentBatch, BlockedStopAnswer, BlockedStopQuery};
pub use commands::{
    ExternalProposal, ProposalBatch, ProposalResult, RemoveAnswer, RemoveTarget, RestartAnswer,
    RestartRequest, SpawnAnswer, SpawnBatch, SpawnOrder, SpawnVerdict,
};
pub use intersections::{Answer, ApproachQueue, IntersectionView, ReservedBox, Round};
pub use lockstep::{LockstepTick, TickReport};
pub use sessions::{SessionObject, SessionObjects};
pub use states::{
    CrosswalkOccupancy, EgoPose, Heartbeat, LightOverride, LightState, ServiceStatus,
};
pub use telemetry::{Clock, Event, EventBatch, VehicleBatch, VehicleState};

/// Checks that every listed number is finite; returns the first bad field's name.
pub fn first_non_finite(fields: &[(&'static str, f64)]) -> Option<&'static str> {
    fields.iter().find(|(_, v)| !v.is_finite()).map(|(n, _)| *n)
}
