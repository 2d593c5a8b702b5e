//! The crate's modules in layers: each module uses only modules of its own
//! layer or below, so that a change to the agents never reaches into the
//! network, nor a pipeline stage into the world.

use std::collections::BTreeMap;
use std::path::Path;

/// Bottom to top. A module not listed fails the test: place it.
const LAYERS: &[(&str, &[&str])] = &[
    (
        "leaves",
        &["geometry", "buckets", "rng", "parallel", "prefetch"],
    ),
    (
        "network",
        &[
            "network",
            "siblings",
            "loops",
            "conflicts",
            "lights",
            "crosswalk",
            "walk_signal",
        ],
    ),
    (
        "agents",
        &[
            "vehicle",
            "lane_index",
            "body_grid",
            "lookahead",
            "branching",
            "ego",
            "idm",
            "trajectory",
            "events",
            "pedestrians",
            "crosswalk_agents",
            "reservation",
        ],
    ),
    (
        "pipeline stages",
        &[
            "cognition",
            "decision",
            "control",
            "visualization",
            "pose",
            "lane_change",
            "lane_choice",
            "spawn",
        ],
    ),
    ("world", &["world"]),
    ("front ends", &["session"]),
    ("tools", &["populate", "motion_check"]),
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS
        .iter()
        .position(|(_, modules)| modules.contains(&module))
}

/// The top-level module each source file belongs to, with its code (comments dropped).
fn sources(dir: &Path, module: Option<&str>, out: &mut Vec<(String, String)>) {
    for entry in std::fs::read_dir(dir).expect("src is readable") {
        let path = entry.expect("a directory entry").path();
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        if path.is_dir() {
            sources(&path, Some(module.unwrap_or(&stem)), out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let owner = module.unwrap_or(&stem).to_string();
            if owner == "lib" {
                continue;
            }
            let text = std::fs::read_to_string(&path).expect("a source file");
            // A module's unit tests (at its end) may use anything.
            let text = text.split("#[cfg(test)]").next().unwrap_or_default();
            let code: String = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect::<Vec<_>>()
                .join("\n");
            out.push((owner, code));
        }
    }
}

#[test]
fn no_module_uses_a_module_of_a_higher_layer() {
    let mut files = Vec::new();
    sources(
        // At run time: a binary built from another checkout that shares the
        // build directory reads this checkout's sources.
        &std::env::var_os("CARGO_MANIFEST_DIR")
            .map(std::path::PathBuf::from)
            .unwrap_or_else(|| env!("CARGO_MANIFEST_DIR").into())
            .join("src"),
        None,
        &mut files,
    );
    let mut upward: BTreeMap<(String, String), usize> = BTreeMap::new();
    for (owner, code) in &files {
        let own = layer_of(owner).unwrap_or_else(|| panic!("module '{owner}' is in no layer"));
        for (at, _) in code.match_indices("crate::") {
            let used: String = code[at + 7..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            let Some(theirs) = layer_of(&used) else {
                continue; // a re-export of the crate root (`crate::World`)
            };
            if theirs > own {
                *upward.entry((owner.clone(), used)).or_default() += 1;
            }
        }
    }
    assert!(
        upward.is_empty(),
        "modules using a higher layer (user, used): {upward:?}"
    );
}
