//! Crosswalk occupancy from agent footprints (pedestrians, cyclists) as other
//! processes publish them: which areas each agent overlaps, turned into the
//! seed's enter/exit events per root. A root stays an occupant while any of
//! its agents (colliders) is in the area, so a character counts once.

use std::collections::{BTreeMap, BTreeSet};

use glam::DVec2;

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

#[derive(Clone, Debug, Default)]
pub struct AgentOccupancy {
    /// (source, agent id) -> (root, kind, areas it overlaps).
    agents: BTreeMap<(String, String), (String, OccupantType, BTreeSet<usize>)>,
}

impl AgentOccupancy {
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
        let mut next: BTreeMap<(String, String), (String, OccupantType, BTreeSet<usize>)> =
            BTreeMap::new();
        for a in agents {
            let inside: BTreeSet<usize> = areas
                .iter()
                .enumerate()
                .filter(|(_, area)| polygons_overlap(&area.polygon, &a.footprint))
                .map(|(i, _)| i)
                .collect();
            next.insert(
                (source.to_string(), a.id.clone()),
                (a.root.clone(), a.kind, inside),
            );
        }
        let old: Vec<_> = self
            .agents
            .range((source.to_string(), String::new())..)
            .take_while(|((s, _), _)| s == source)
            .map(|(k, _)| k.clone())
            .collect();
        let before = self.root_areas();
        for k in old {
            self.agents.remove(&k);
        }
        self.agents.extend(next);
        self.apply_diff(areas, occupancy, before)
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

    pub fn sources(&self) -> BTreeSet<String> {
        self.agents.keys().map(|(s, _)| s.clone()).collect()
    }

    /// (area, root) -> detected type, over every agent.
    fn root_areas(&self) -> BTreeMap<(usize, String), OccupantType> {
        let mut out = BTreeMap::new();
        for (root, kind, inside) in self.agents.values() {
            for &area in inside {
                out.insert((area, root.clone()), *kind);
            }
        }
        out
    }

    fn apply_diff(
        &self,
        areas: &[Crosswalk],
        occupancy: &mut Occupancy,
        before: BTreeMap<(usize, String), OccupantType>,
    ) -> BTreeSet<usize> {
        let after = self.root_areas();
        let mut changed = BTreeSet::new();
        for (area, root) in before.keys() {
            if !after.contains_key(&(*area, root.clone()))
                && occupancy.exit(*area, root) == OccupancyChange::Exited
            {
                if areas[*area].debug_logs {
                    tracing::info!("[Zebra] '{root}' exited '{}'", areas[*area].name);
                }
                changed.insert(*area);
            }
        }
        for ((area, root), kind) in &after {
            if !before.contains_key(&(*area, root.clone()))
                && occupancy.enter(areas, *area, root, *kind) == OccupancyChange::Entered
            {
                if areas[*area].debug_logs {
                    tracing::info!("[Zebra] '{root}' entered '{}'", areas[*area].name);
                }
                changed.insert(*area);
            }
        }
        changed
    }
}
