//! The bus contract. `keys` builds every key expression of a cluster;
//! `wire` holds the messages they carry (serde_json payloads, and the binary
//! per-tick vehicle batch). docs/cluster.md's key table documents both.

pub mod keys;
pub mod topics;
pub mod wire;

pub use keys::{KeyError, Keys, is_plain_chunk};
