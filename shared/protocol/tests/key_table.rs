//! docs/cluster.md's key table is the declarations' table: the same keys,
//! each of the declared kind, naming the declared payload and answer types.

use std::collections::BTreeMap;

use trafficmesh_protocol::topics::{self, Kind};

/// Types the table describes in words rather than by name.
const DESCRIBED: &[&str] = &["Empty", "Text", "Json", "TrafficSpawnConfig"];

/// (pattern, kind cell, payload cell) of each key in the table.
fn documented() -> Vec<(String, String, String)> {
    // The directory at run time: a binary built from another checkout that
    // shares the build directory reads this checkout's files.
    let path = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| env!("CARGO_MANIFEST_DIR").into())
        .join("../../docs/cluster.md");
    let doc = std::fs::read_to_string(path).expect("docs/cluster.md");
    let mut rows = Vec::new();
    let mut in_table = false;
    for line in doc.lines() {
        if line.starts_with("| key | kind |") {
            in_table = true;
            continue;
        }
        if !in_table || line.starts_with("|---") {
            continue;
        }
        if !line.starts_with('|') {
            break;
        }
        let cells: Vec<&str> = line.split(" | ").collect();
        let (keys, kind, payload) = (cells[0], cells[1], cells[cells.len() - 1]);
        for key in keys.split('`').filter(|k| k.starts_with("<c>/")) {
            let pattern = key
                .trim_start_matches("<c>/")
                .replace('<', "{")
                .replace('>', "}");
            rows.push((pattern, kind.to_string(), payload.to_string()));
        }
    }
    rows
}

fn kind_in_words(kind: &str) -> Kind {
    if kind.contains("liveliness") {
        Kind::Liveliness
    } else if kind.starts_with("put and query") {
        Kind::PutAndQuery
    } else if kind.starts_with("put") {
        Kind::Put
    } else {
        Kind::Query
    }
}

#[test]
fn the_docs_key_table_lists_every_declared_key_as_declared() {
    let declared: BTreeMap<&str, topics::Declared> =
        topics::all().into_iter().map(|d| (d.pattern, d)).collect();
    let rows = documented();
    let mut problems = Vec::new();
    for (pattern, kind, payload) in &rows {
        let Some(d) = declared.get(pattern.as_str()) else {
            problems.push(format!("{pattern}: in the docs, not declared"));
            continue;
        };
        if kind_in_words(kind) != d.kind {
            problems.push(format!(
                "{pattern}: docs say '{kind}', declared {:?}",
                d.kind
            ));
        }
        for name in std::iter::once(d.payload).chain(d.answer) {
            if !DESCRIBED.contains(&name) && !payload.contains(&format!("`{name}")) {
                problems.push(format!(
                    "{pattern}: the docs' payload does not name `{name}`"
                ));
            }
        }
    }
    for pattern in declared.keys() {
        if !rows.iter().any(|(p, _, _)| p == pattern) {
            problems.push(format!("{pattern}: declared, not in the docs"));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
