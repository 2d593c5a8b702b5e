//! Crosswalk occupancy from agent footprints (pedestrians, cyclists) as other
//! processes publish them: which areas each agent overlaps, turned into the AWSIM
//! reference's enter/exit events per root. A root stays an occupant while any of
//! its agents (colliders) is in the area, so a character counts once.
//!
//! Cost per batch grows with the agents in it, not with the map: candidate
//! areas come from a uniform grid over their bounding boxes, and only the
//! (area, root) pairs the batch touches are re-counted.

use std::collections::{BTreeMap, BTreeSet};

use glam::DVec2;
use rustc_hash::FxHashMap;

use crate::crosswalk::{Occupancy, OccupancyChange, OccupantType};
use crate::geometry::polygons_overlap;
use crate::network::Crosswalk;

/// One agent as a source reports it.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentPose {
    pub id: String,
    pub root: String,
    pub kind: OccupantType,
    pub footprint: Vec<DVec2>,
}

/// What a source said about one agent: its root, its type, the areas it overlaps.
type Presence = (String, OccupantType, Vec<usize>);

/// Grid cell size for the area lookup, metres (about a crosswalk's length).
const CELL: f64 = 25.0;

#[derive(Clone, Debug)]
pub struct AgentOccupancy {
    /// Areas whose bounding box touches each grid cell.
    cells: FxHashMap<(i64, i64), Vec<usize>>,
    /// Each source's agents: id -> (root, kind, areas it overlaps).
    sources: BTreeMap<String, BTreeMap<String, Presence>>,
    /// How many agents hold each (area, root): the root is an occupant while > 0.
    holders: BTreeMap<(usize, String), (usize, OccupantType)>,
}

fn bounds(points: &[DVec2]) -> (DVec2, DVec2) {
    points.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

fn cells_of((lo, hi): (DVec2, DVec2)) -> impl Iterator<Item = (i64, i64)> {
    let cell = |v: f64| (v / CELL).floor() as i64;
    (cell(lo.x)..=cell(hi.x)).flat_map(move |x| (cell(lo.y)..=cell(hi.y)).map(move |y| (x, y)))
}

impl AgentOccupancy {
    pub fn new(areas: &[Crosswalk]) -> Self {
        let mut cells: FxHashMap<(i64, i64), Vec<usize>> = FxHashMap::default();
        for (i, area) in areas.iter().enumerate() {
            for c in cells_of(bounds(&area.polygon)) {
                cells.entry(c).or_default().push(i);
            }
        }
        AgentOccupancy {
            cells,
            sources: BTreeMap::new(),
            holders: BTreeMap::new(),
        }
    }

    /// The areas a footprint overlaps, ascending.
    fn areas_under(&self, areas: &[Crosswalk], footprint: &[DVec2]) -> Vec<usize> {
        let mut found: Vec<usize> = cells_of(bounds(footprint))
            .filter_map(|c| self.cells.get(&c))
            .flatten()
            .copied()
            .collect();
        found.sort_unstable();
        found.dedup();
        found.retain(|&i| polygons_overlap(&areas[i].polygon, footprint));
        found
    }

    /// Replaces everything `source` reported before with `agents`; applies the
    /// resulting enters and exits to `occupancy` and returns the areas whose
    /// occupant set changed.
    pub fn update_source(
        &mut self,
        areas: &[Crosswalk],
        occupancy: &mut Occupancy,
        source: &str,
        agents: &[AgentPose],
    ) -> BTreeSet<usize> {
        let next: BTreeMap<String, Presence> = agents
            .iter()
            .map(|a| {
                let inside = self.areas_under(areas, &a.footprint);
                (a.id.clone(), (a.root.clone(), a.kind, inside))
            })
            .collect();
        let old = self.sources.remove(source).unwrap_or_default();
        let mut touched = BTreeSet::new();
        for (root, _, inside) in old.values() {
            for &area in inside {
                let key = (area, root.clone());
                if let Some(h) = self.holders.get_mut(&key) {
                    h.0 -= 1;
                }
                touched.insert(key);
            }
        }
        for (root, kind, inside) in next.values() {
            for &area in inside {
                let key = (area, root.clone());
                self.holders.entry(key.clone()).or_insert((0, *kind)).0 += 1;
                touched.insert(key);
            }
        }
        if !next.is_empty() {
            self.sources.insert(source.to_string(), next);
        }
        let mut changed = BTreeSet::new();
        for key in touched {
            let (area, root) = &key;
            let held = self
                .holders
                .get(&key)
                .copied()
                .unwrap_or((0, OccupantType::Other));
            let change = if held.0 == 0 {
                self.holders.remove(&key);
                occupancy.exit(*area, root)
            } else {
                // A no-op (Ignored) when the root already counts here.
                occupancy.enter(areas, *area, root, held.1)
            };
            let verb = match change {
                OccupancyChange::Entered => "entered",
                OccupancyChange::Exited => "exited",
                OccupancyChange::Ignored => continue,
            };
            if areas[*area].debug_logs {
                tracing::info!("[Zebra] '{root}' {verb} '{}'", areas[*area].name);
            }
            changed.insert(*area);
        }
        changed
    }

    /// Forgets a source that went quiet.
    pub fn drop_source(
        &mut self,
        areas: &[Crosswalk],
        occupancy: &mut Occupancy,
        source: &str,
    ) -> BTreeSet<usize> {
        self.update_source(areas, occupancy, source, &[])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::crosswalk::Occupancy;
    use trafficmesh_model::ZebraConfigDef;

    fn area(name: &str, x: f64) -> Crosswalk {
        Crosswalk {
            walk_groups: Vec::new(),
            name: name.into(),
            polygon: vec![
                DVec2::new(x - 2.0, -8.0),
                DVec2::new(x + 2.0, -8.0),
                DVec2::new(x + 2.0, 8.0),
                DVec2::new(x - 2.0, 8.0),
            ],
            stops: vec![],
            max_detection_distance: 40.0,
            cos_tolerance: 0.17,
            stop_buffer: 1.5,
            debug_logs: false,
            whitelist: ZebraConfigDef::default(),
        }
    }

    fn agent(id: &str, root: &str, x: f64) -> AgentPose {
        AgentPose {
            id: id.into(),
            root: root.into(),
            kind: OccupantType::NpcPedestrian,
            footprint: vec![
                DVec2::new(x - 0.3, -0.3),
                DVec2::new(x + 0.3, -0.3),
                DVec2::new(x + 0.3, 0.3),
                DVec2::new(x - 0.3, 0.3),
            ],
        }
    }

    #[test]
    fn a_root_counts_once_and_leaves_with_its_last_collider() {
        let areas = vec![area("A", 0.0), area("B", 100.0)];
        let mut occ = Occupancy::new(2);
        let mut agents = AgentOccupancy::new(&areas);
        let two_colliders = [agent("1", "Human_1", 0.0), agent("2", "Human_1", 0.5)];
        assert_eq!(
            agents
                .update_source(&areas, &mut occ, "s", &two_colliders)
                .len(),
            1
        );
        assert_eq!(occ.occupants(0).len(), 1);
        assert!(!occ.is_occupied(1));
        // One collider leaves: still an occupant.
        assert!(
            agents
                .update_source(&areas, &mut occ, "s", &two_colliders[..1])
                .is_empty()
        );
        assert!(occ.is_occupied(0));
        // Walks over to B.
        let moved = agents.update_source(&areas, &mut occ, "s", &[agent("1", "Human_1", 100.0)]);
        assert_eq!(moved, BTreeSet::from([0, 1]));
        assert!(!occ.is_occupied(0) && occ.is_occupied(1));
        // The source goes quiet.
        agents.drop_source(&areas, &mut occ, "s");
        assert!(occ.occupied_areas().is_empty());
    }
}
