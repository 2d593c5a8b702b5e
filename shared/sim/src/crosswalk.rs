//! ZebraCrossingArea: occupancy of crosswalk areas and the blocked-stop query.

use std::collections::BTreeSet;

use glam::DVec2;

use crate::network::Crosswalk;

/// Component types the AWSIM reference's areas detect, by the names the AWSIM reference uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OccupantType {
    NpcPedestrian,
    SimpleCyclistMovement,
    BicycleMoveRotate,
    ClearWaypointFollower,
    WaypointFollower,
    /// Anything else (a vehicle's collider, a prop): never counted.
    Other,
}

impl OccupantType {
    /// Parses the AWSIM reference's type names (case-insensitive); unknown names are `Other`.
    pub fn parse(name: &str) -> Self {
        match name.to_ascii_lowercase().as_str() {
            "npcpedestrian" => Self::NpcPedestrian,
            "simplecyclistmovement" => Self::SimpleCyclistMovement,
            "bicyclemoverotate" => Self::BicycleMoveRotate,
            "clearwaypointfollower" => Self::ClearWaypointFollower,
            "waypointfollower" => Self::WaypointFollower,
            _ => Self::Other,
        }
    }
    /// The AWSIM reference's name of the type (what `parse` reads back).
    pub fn name(self) -> &'static str {
        match self {
            Self::NpcPedestrian => "NPCPedestrian",
            Self::SimpleCyclistMovement => "SimpleCyclistMovement",
            Self::BicycleMoveRotate => "BicycleMoveRotate",
            Self::ClearWaypointFollower => "ClearWaypointFollower",
            Self::WaypointFollower => "WaypointFollower",
            Self::Other => "Other",
        }
    }

    pub fn is_detected(self) -> bool {
        self != Self::Other
    }
}

/// Removes Unity's "(Clone)" suffix: the normalised prefab name.
pub fn normalized_prefab_name(name: &str) -> &str {
    name.trim_end().trim_end_matches("(Clone)").trim_end()
}

/// Whether an occupant with this root name passes the area's whitelist.
pub fn whitelisted(area: &Crosswalk, root_name: &str) -> bool {
    let w = &area.whitelist;
    if w.allowed_prefabs.is_empty() && w.allowed_root_name_substrings.is_empty() {
        return true;
    }
    let normalized = normalized_prefab_name(root_name);
    let lower = root_name.to_lowercase();
    w.allowed_prefabs
        .iter()
        .any(|p| normalized_prefab_name(p) == normalized)
        || w.allowed_root_name_substrings
            .iter()
            .any(|s| lower.contains(&s.to_lowercase()))
}

/// Occupant roots of every area.
#[derive(Clone, Debug, Default)]
pub struct Occupancy {
    roots: Vec<BTreeSet<String>>,
    /// Areas with at least one occupant, ascending: the per-vehicle query reads
    /// only these, so its cost does not grow with the number of crosswalks.
    occupied: Vec<usize>,
    /// Fail-safe: the occupancy source went quiet, so every area counts as
    /// occupied until it speaks again.
    stale: bool,
    all: Vec<usize>,
}

/// What an enter or exit did, for the debug log lines.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OccupancyChange {
    Entered,
    Exited,
    /// Not a detected type, not whitelisted, or no change.
    Ignored,
}

impl Occupancy {
    pub fn new(areas: usize) -> Self {
        Occupancy {
            roots: vec![BTreeSet::new(); areas],
            occupied: Vec::new(),
            stale: false,
            all: (0..areas).collect(),
        }
    }

    /// OnTriggerEnter: counts the root if its type is detected and it is whitelisted.
    pub fn enter(
        &mut self,
        areas: &[Crosswalk],
        area: usize,
        root: &str,
        kind: OccupantType,
    ) -> OccupancyChange {
        if !kind.is_detected() || !whitelisted(&areas[area], root) {
            return OccupancyChange::Ignored;
        }
        if self.roots[area].insert(root.to_string()) {
            self.refresh(area);
            OccupancyChange::Entered
        } else {
            OccupancyChange::Ignored
        }
    }

    /// OnTriggerExit.
    pub fn exit(&mut self, area: usize, root: &str) -> OccupancyChange {
        if self.roots[area].remove(root) {
            self.refresh(area);
            OccupancyChange::Exited
        } else {
            OccupancyChange::Ignored
        }
    }

    /// Replaces an area's occupants with a set already filtered elsewhere (the
    /// crosswalks service publishes them); returns whether anything changed.
    pub fn set_occupants(&mut self, area: usize, roots: BTreeSet<String>) -> bool {
        if self.roots[area] == roots {
            return false;
        }
        self.roots[area] = roots;
        self.refresh(area);
        true
    }

    pub fn set_stale(&mut self, stale: bool) {
        self.stale = stale;
    }

    pub fn is_stale(&self) -> bool {
        self.stale
    }

    pub fn is_occupied(&self, area: usize) -> bool {
        self.stale || !self.roots[area].is_empty()
    }

    pub fn occupants(&self, area: usize) -> &BTreeSet<String> {
        &self.roots[area]
    }

    pub fn occupied_areas(&self) -> &[usize] {
        if self.stale {
            &self.all
        } else {
            &self.occupied
        }
    }

    fn refresh(&mut self, area: usize) {
        let listed = self.occupied.binary_search(&area);
        match (self.roots[area].is_empty(), listed) {
            (false, Err(at)) => self.occupied.insert(at, area),
            (true, Ok(at)) => {
                self.occupied.remove(at);
            }
            _ => {}
        }
    }
}

/// TryGetBlockedStop: the closest occupied area whose stop point lies within the
/// detection distance and inside the forward cone; returns (distance minus the
/// buffer, floored at 0, and the area index).
pub fn try_get_blocked_stop(
    areas: &[Crosswalk],
    occupancy: &Occupancy,
    position: DVec2,
    forward: DVec2,
) -> Option<(f64, usize)> {
    let occupied = occupancy.occupied_areas();
    if occupied.is_empty() {
        return None;
    }
    let forward = forward.normalize_or_zero();
    let mut best: Option<(f64, usize)> = None;
    for &i in occupied {
        let area = &areas[i];
        for stop in &area.stops {
            let to_stop = stop.position - position;
            let dist = to_stop.length();
            if dist < 0.01 || dist > area.max_detection_distance {
                continue;
            }
            if forward.dot(to_stop / dist) < area.cos_tolerance {
                continue;
            }
            if let Some(h) = stop.heading
                && forward.dot(h) < 0.0
            {
                continue;
            }
            let candidate = (dist - area.stop_buffer).max(0.0);
            if best.is_none_or(|(d, _)| candidate < d) {
                best = Some((candidate, i));
            }
        }
    }
    best
}
