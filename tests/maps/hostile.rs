//! Hostile input: real maps, a route file and a spawn config, mutated at
//! random (cut short, bytes changed, elements dropped or repeated, values
//! made hostile: NaN, infinities, huge, tiny and negative numbers, empty
//! strings), loaded the way `trafficmesh` loads a file: import, the map's
//! checks, the lane network, the spawn config applied, then a few seconds
//! driven. Each ends in a clear error or a running world, never a panic and
//! never a hang. proptest shrinks a failure to its fewest mutations.

use std::path::PathBuf;
use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use trafficmesh_sim::{LaneNetwork, World, WorldConfig};

use crate::support::{repo, shared_map};

/// One change to a file's text, at a point given as a fraction of its
/// length (in 65,536ths), so that it shrinks toward the file's start.
#[derive(Clone, Debug)]
enum Mutation {
    /// The text cut here.
    Truncate(u16),
    /// This printable byte put here.
    Byte(u16, u8),
    /// The item (a line of XML, an entry of JSON) from here dropped.
    Drop(u16),
    /// The item from here written twice.
    Repeat(u16),
    /// The next value from here (an XML attribute, a JSON scalar) replaced
    /// by the hostile value of this index.
    Value(u16, u8),
}

/// Values a broken or malicious file could hold where a number or a name is due.
const XML_VALUES: &[&str] = &[
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "-1",
    "0",
    "",
    "x",
    "99999999999999999999",
    "-0",
];
const JSON_VALUES: &[&str] = &[
    "null", "1e308", "-1e308", "1e-320", "-1", "0", "\"\"", "[]", "{}", "true", "\"x\"", "1e999",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<u16>().prop_map(Mutation::Truncate),
        (any::<u16>(), 0x20u8..0x7f).prop_map(|(at, b)| Mutation::Byte(at, b)),
        any::<u16>().prop_map(Mutation::Drop),
        any::<u16>().prop_map(Mutation::Repeat),
        (any::<u16>(), any::<u8>()).prop_map(|(at, v)| Mutation::Value(at, v)),
    ]
}

/// The byte offset `at` (65,536ths) of `text`, on a character boundary.
fn offset(text: &str, at: u16) -> usize {
    let mut i = text.len() * at as usize / 65_536;
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// The item that starts at the first separator at or after `from`, up to the
/// next one: a line of XML, an entry between commas of JSON.
fn item(text: &str, from: usize, json: bool) -> Option<(usize, usize)> {
    let sep = if json { ',' } else { '\n' };
    let start = from + text[from..].find(sep)?;
    let end = start + 1 + text[start + 1..].find(sep)?;
    Some((start, end))
}

fn mutate(text: &str, mutations: &[Mutation], json: bool) -> String {
    let mut text = text.to_string();
    for m in mutations {
        match *m {
            Mutation::Truncate(at) => {
                let i = offset(&text, at);
                text.truncate(i);
            }
            Mutation::Byte(at, b) => {
                let i = offset(&text, at);
                if text[i..].starts_with(|c: char| c.is_ascii()) {
                    text.replace_range(i..i + 1, &char::from(b).to_string());
                }
            }
            Mutation::Drop(at) => {
                if let Some((a, b)) = item(&text, offset(&text, at), json) {
                    text.replace_range(a..b, "");
                }
            }
            Mutation::Repeat(at) => {
                if let Some((a, b)) = item(&text, offset(&text, at), json) {
                    let copy = text[a..b].to_string();
                    text.insert_str(b, &copy);
                }
            }
            Mutation::Value(at, v) => {
                let from = offset(&text, at);
                let (opener, values) = if json {
                    (": ", JSON_VALUES)
                } else {
                    ("=\"", XML_VALUES)
                };
                let Some(start) = text[from..].find(opener).map(|i| from + i + opener.len()) else {
                    continue;
                };
                let end = if json {
                    start
                        + text[start..]
                            .find([',', '}', ']', '\n'])
                            .unwrap_or(text.len() - start)
                } else {
                    start + text[start..].find('"').unwrap_or(text.len() - start)
                };
                let value = values[v as usize % values.len()];
                text.replace_range(start..end, value);
            }
        }
    }
    text
}

/// Runs `load` on a thread of its own: its panic is the test's, and no
/// answer within a generous minute is a hang.
fn without_hang(what: &str, load: impl FnOnce() + Send + 'static) {
    let (done, finished) = mpsc::channel();
    let thread = std::thread::spawn(move || {
        load();
        let _ = done.send(());
    });
    match finished.recv_timeout(Duration::from_secs(60)) {
        Ok(()) => thread.join().unwrap(),
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            std::panic::resume_unwind(thread.join().unwrap_err())
        }
        Err(mpsc::RecvTimeoutError::Timeout) => {
            // The stuck load keeps its thread: end here, before it eats
            // the machine while the case is shrunk.
            eprintln!("{what}: no end after 60 s (a hang)");
            std::process::abort()
        }
    }
}

/// A few simulated seconds of the map's own traffic (and walkers) on `net`.
fn drive(net: LaneNetwork, spawn: Option<trafficmesh_model::TrafficSpawnConfig>) {
    let mut world = World::new(
        net,
        WorldConfig {
            max_vehicles: 20,
            ..WorldConfig::default()
        },
    );
    if let Some(config) = spawn {
        // Refused (lanes this map lacks, bad rates) is a clear error too.
        let _ = world.set_spawn_config(config);
    }
    for _ in 0..100 {
        world.step();
    }
}

/// Loads the mutated text of the map at `path` as `trafficmesh` would: an
/// error names the file; a map that passes its checks builds or says why.
fn load_map(path: PathBuf, mutations: &[Mutation], text: String) {
    let what = path.display().to_string();
    without_hang(&format!("{what} {mutations:?}"), move || {
        let imported = match trafficmesh_maps::import_text(&path, &text) {
            Ok(imported) => imported,
            Err(e) => {
                assert!(
                    e.to_string().starts_with(&what),
                    "an error without the file: {e}"
                );
                return;
            }
        };
        match LaneNetwork::build(&imported.map) {
            Ok(net) => drive(net, None),
            Err(problems) => assert!(!problems.is_empty(), "refused without a reason"),
        }
    });
}

/// `cases` runs, or `PROPTEST_CASES` when set (a longer hunt by hand).
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(cases),
        max_shrink_iters: 64,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Mutated copies of `path` (a third-party map, when present) loaded `cases` times.
fn hostile_copies_of(path: Option<PathBuf>, cases: u32, json: bool) {
    let Some(path) = path else { return };
    let text = std::fs::read_to_string(&path).unwrap();
    proptest!(config(cases), |(mutations in prop::collection::vec(mutation(), 1..6))| {
        load_map(path.clone(), &mutations, mutate(&text, &mutations, json));
    });
}

#[test]
fn mutated_sumo_networks_load_or_are_refused_without_panic_or_hang() {
    hostile_copies_of(shared_map("cross.net.xml"), 512, false);
    hostile_copies_of(
        shared_map("bologna_acosta/acosta_buslanes.net.xml"),
        128,
        false,
    );
}

#[test]
fn mutated_lanelet2_maps_load_or_are_refused_without_panic_or_hang() {
    hostile_copies_of(
        shared_map("autoware_intersection_lanelet2_map.osm"),
        128,
        false,
    );
    hostile_copies_of(shared_map("mapping_example.osm"), 128, false);
}

#[test]
fn mutated_native_maps_load_or_are_refused_without_panic_or_hang() {
    let map = repo().join("configs/maps/four_way.map.json");
    hostile_copies_of(Some(map), 512, true);
}

#[test]
fn mutated_route_files_and_spawn_configs_are_taken_or_refused_without_panic_or_hang() {
    let Some(cross) = shared_map("cross.net.xml") else {
        return;
    };
    let routes = std::fs::read_to_string(repo().join("tests/maps/cross.rou.xml")).unwrap();
    let map = trafficmesh_maps::import_map(&cross).unwrap().map;
    proptest!(config(512), |(mutations in prop::collection::vec(mutation(), 1..6))| {
        let text = mutate(&routes, &mutations, false);
        let mut map = map.clone();
        without_hang(&format!("cross.rou.xml {mutations:?}"), move || {
            let Ok(demand) = trafficmesh_maps::sumo_routes::import(&text, &map) else {
                return;
            };
            map.traffic_simulators = vec![demand.simulator];
            map.vehicle_kinds.extend(demand.kinds);
            if let Ok(net) = LaneNetwork::build(&map) {
                drive(net, None);
            }
        });
    });

    let four_way = repo().join("configs/maps/four_way.map.json");
    let spawn_path = repo().join("configs/traffic_spawn.json");
    let spawn = std::fs::read_to_string(&spawn_path).unwrap();
    let map = trafficmesh_maps::load_map(&four_way).unwrap();
    proptest!(config(512), |(mutations in prop::collection::vec(mutation(), 1..6))| {
        let text = mutate(&spawn, &mutations, true);
        let (map, path) = (map.clone(), spawn_path.clone());
        without_hang(&format!("traffic_spawn.json {mutations:?}"), move || {
            let Ok(config) = trafficmesh_maps::parse_spawn_config(&path, &text) else {
                return;
            };
            drive(LaneNetwork::build(&map).unwrap(), Some(config));
        });
    });
}
