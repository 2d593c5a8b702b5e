//! Hostile payloads: whatever bytes arrive on a key, its decoder gives the
//! value or an error, never a panic, and a vehicle batch announcing more than
//! it carries is refused before anything is allocated for it. proptest
//! shrinks a failure to the smallest payload.

use proptest::prelude::*;
use serde::de::DeserializeOwned;
use trafficmesh_model::{SpeedMode, TurnSignal, YieldPhase};
use trafficmesh_protocol::wire::vehicle_codec::{DecodeError, HEADER_BYTES};
use trafficmesh_protocol::wire::*;

fn vehicle() -> impl Strategy<Value = VehicleState> {
    let finite = || -1.0e6f32..1.0e6;
    (
        (any::<u64>(), any::<u16>(), any::<u32>(), any::<bool>()),
        (0..SpeedMode::ALL.len(), 0..YieldPhase::ALL.len()),
        0..TurnSignal::ALL.len(),
        prop::array::uniform11(finite()),
    )
        .prop_map(
            |((id, kind, lane, zebra), (mode, phase), signal, f)| VehicleState {
                id,
                kind,
                lane,
                s: f[0],
                x: f[1],
                y: f[2],
                z: f[3],
                yaw: f[4],
                speed: f[5],
                accel: f[6],
                length: f[7],
                width: f[8],
                check_distance: f[9],
                front_offset: f[10],
                mode: SpeedMode::ALL[mode],
                yield_phase: YieldPhase::ALL[phase],
                signal: TurnSignal::ALL[signal],
                zebra_blocked: zebra,
            },
        )
}

fn batch() -> impl Strategy<Value = VehicleBatch> {
    (
        any::<u64>(),
        0.0f64..1e6,
        any::<u64>(),
        prop::collection::vec(vehicle(), 0..20),
    )
        .prop_map(|(tick, time, sent_unix_us, vehicles)| VehicleBatch {
            tick,
            time,
            sent_unix_us,
            vehicles,
        })
}

/// Decodes `bytes` as JSON into `T` and runs its check where it has one:
/// no panic either way.
fn json<T: DeserializeOwned>(bytes: &[u8]) -> Option<T> {
    serde_json::from_slice::<T>(bytes).ok()
}

/// Every JSON payload type a service takes from the bus.
fn every_json_decoder(bytes: &[u8]) {
    if let Some(p) = json::<EgoPose>(bytes) {
        let _ = p.problem();
    }
    if let Some(b) = json::<AgentBatch>(bytes) {
        for a in &b.agents {
            let _ = a.problem();
        }
    }
    if let Some(t) = json::<RemoveTarget>(bytes) {
        let _ = t.problem();
    }
    json::<SpawnBatch>(bytes);
    json::<RestartRequest>(bytes);
    json::<LightOverride>(bytes);
    json::<LightState>(bytes);
    json::<CrosswalkOccupancy>(bytes);
    json::<Heartbeat>(bytes);
    json::<BlockedStopQuery>(bytes);
    json::<ProposalBatch>(bytes);
    json::<Clock>(bytes);
    json::<EventBatch>(bytes);
    json::<LockstepTick>(bytes);
    json::<TickReport>(bytes);
    json::<Round>(bytes);
    json::<Answer>(bytes);
    json::<ServiceStatus>(bytes);
    json::<trafficmesh_model::TrafficSpawnConfig>(bytes);
}

/// `PROPTEST_CASES`, when set, else `default`: a longer hunt by hand.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(512), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_bytes_decode_or_are_refused(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let _ = VehicleBatch::decode(&bytes);
        every_json_decoder(&bytes);
    }

    #[test]
    fn a_batch_decodes_to_what_was_encoded(b in batch()) {
        prop_assert_eq!(VehicleBatch::decode(&b.encode()), Ok(b));
    }

    /// Bytes changed, cut or added anywhere in a real batch.
    #[test]
    fn a_damaged_batch_decodes_or_is_refused(
        b in batch(),
        changes in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..8),
        cut in any::<prop::sample::Index>(),
        extra in prop::collection::vec(any::<u8>(), 0..70),
    ) {
        let mut bytes = b.encode();
        for (at, byte) in changes {
            let i = at.index(bytes.len());
            bytes[i] = byte;
        }
        let _ = VehicleBatch::decode(&bytes);
        let mut longer = bytes.clone();
        longer.extend_from_slice(&extra);
        let _ = VehicleBatch::decode(&longer);
        bytes.truncate(cut.index(bytes.len() + 1));
        let _ = VehicleBatch::decode(&bytes);
    }

    /// A header announcing any number of vehicles: refused unless the body
    /// holds exactly that many (nothing is sized from the announcement).
    #[test]
    fn an_announced_count_must_match_the_body(b in batch(), count in any::<u32>()) {
        let mut bytes = b.encode();
        bytes[HEADER_BYTES - 4..HEADER_BYTES].copy_from_slice(&count.to_le_bytes());
        match VehicleBatch::decode(&bytes) {
            Ok(decoded) => prop_assert_eq!(decoded.vehicles.len(), count as usize),
            Err(e) => {
                let is_length = matches!(e, DecodeError::Length { .. });
                prop_assert!(is_length, "{}", e);
            }
        }
    }

    /// Valid JSON of the right shape with its values made hostile.
    #[test]
    fn hostile_json_values_decode_or_are_refused(
        x in prop_oneof![Just(1e308), Just(-1e308), Just(0.0), Just(-1.0), any::<f64>()],
        text in prop::collection::vec(0x20u8..0x7f, 0..12)
            .prop_map(|b| String::from_utf8(b).expect("printable ASCII")),
        n in any::<u64>(),
    ) {
        let number = serde_json::to_string(&x).unwrap();
        let text = serde_json::to_string(&text).unwrap();
        for payload in [
            format!(r#"{{"x": {number}, "y": {number}, "yaw": {number}, "length": {number}, "width": {number}}}"#),
            format!(r#"{{"point": {{"x": {number}, "y": 0, "radius": {number}}}}}"#),
            format!(r#"{{"ego": {{"radius": {number}}}}}"#),
            format!(r#"{{"vehicle": {{"id": {n}}}}}"#),
            format!(r#"{{"time": {number}, "agents": [{{"id": {text}, "root": {text}, "type": {text}, "footprint": [[{number}, 0], [0, {number}], [{number}, {number}]]}}]}}"#),
            format!(r#"{{"group": {text}, "color": {text}}}"#),
            format!(r#"{{"group": {text}, "program": {{"green": {number}, "yellow": {number}, "red": {number}}}}}"#),
            format!(r#"{{"max_vehicles": {n}}}"#),
            format!(r#"{{"spawnRates": [{{"lane": {text}, "spawnsPerMinute": {number}}}]}}"#),
        ] {
            every_json_decoder(payload.as_bytes());
        }
    }
}
