//! SUMO route files (`.rou.xml`) as a demand: `vehicle` with `depart` and a
//! `route` (by id or inline), `flow` with `vehsPerHour`, `period`,
//! `probability` or `number` between `begin` and `end`, and `vType` lengths
//! (each vehicle takes the catalogue kind nearest in length). Edge routes
//! become lane routes through the imported network's connections.

use std::collections::HashMap;

use roxmltree::Node;
use trafficmesh_model::map::{DepartureDef, MapFile, SimulatorDef};

use crate::import::{ImportError, attr, attr_f64, parse_xml};

/// SUMO's default vehicle length, metres.
const DEFAULT_LENGTH: f64 = 5.0;
/// SUMO's default flow end when none is given: one day.
const DEFAULT_FLOW_END: f64 = 86_400.0;

/// The demand and what could not be carried over.
pub struct Demand {
    pub simulator: SimulatorDef,
    pub warnings: Vec<String>,
}

struct Network<'m> {
    /// Normal lanes of each edge, by lane index.
    edge_lanes: HashMap<&'m str, Vec<&'m str>>,
    next: HashMap<&'m str, &'m [String]>,
    length: HashMap<&'m str, f64>,
    /// Lane changes the chosen lane routes need on the way.
    shifts: std::cell::Cell<usize>,
}

/// The cheapest way on from a lane: its cost and its lanes (that lane first).
type Continuation = Option<(f64, Vec<String>)>;

/// Lanes shorter than this make a lane change on them dearer: there is little
/// or no room to wait for a gap (netconvert splits edges into pieces of 0.2 m).
const ROOMY_LANE: f64 = 50.0;

impl<'m> Network<'m> {
    fn new(map: &'m MapFile) -> Self {
        let mut edge_lanes: HashMap<&str, Vec<&str>> = HashMap::new();
        for l in &map.lanes {
            if let Some((edge, _)) = l.name.rsplit_once('_')
                && !l.name.starts_with(':')
            {
                edge_lanes.entry(edge).or_default().push(&l.name);
            }
        }
        let length = map
            .lanes
            .iter()
            .map(|l| (l.name.as_str(), l.length()))
            .collect();
        Network {
            edge_lanes,
            next: map
                .lanes
                .iter()
                .map(|l| (l.name.as_str(), l.next.as_slice()))
                .collect(),
            length,
            shifts: std::cell::Cell::new(0),
        }
    }

    /// The cost of a lane change along `lane`: one, and far more where the
    /// lane is too short to wait on for a gap.
    fn shift_cost(&self, lane: &str) -> f64 {
        let length = self.length.get(lane).copied().unwrap_or(0.0);
        1.0 + 100.0 * (1.0 - (length / ROOMY_LANE).min(1.0))
    }

    /// Lanes from a lane of `edges[0]` through every edge in turn (internal
    /// lanes between them included), or None when the edges are not connected.
    /// Of all lane routes it takes one with the fewest lane changes, placed
    /// where there is room for them (SUMO's `departLane="best"` and its
    /// strategic lane choice), the rightmost among equals.
    fn lane_route(&self, edges: &[&str]) -> Option<Vec<String>> {
        let mut memo: HashMap<(&str, usize), Continuation> = HashMap::new();
        let best = self
            .edge_lanes
            .get(edges.first()?)?
            .iter()
            .filter_map(|start| self.extend(start, edges, 1, &mut memo))
            .min_by(|a, b| a.0.total_cmp(&b.0))?;
        // Where two listed lanes are not linked, the vehicle changes lanes.
        let changes = best
            .1
            .windows(2)
            .filter(|w| {
                !self
                    .next
                    .get(w[0].as_str())
                    .is_some_and(|n| n.contains(&w[1]))
            })
            .count();
        self.shifts.set(self.shifts.get() + changes);
        Some(best.1)
    }

    /// The cheapest continuation from `lane` (a lane of `edges[k - 1]`).
    fn extend<'a>(
        &'a self,
        lane: &'a str,
        edges: &[&str],
        k: usize,
        memo: &mut HashMap<(&'a str, usize), Continuation>,
    ) -> Continuation {
        if k == edges.len() {
            return Some((0.0, vec![lane.to_string()]));
        }
        if let Some(known) = memo.get(&(lane, k)) {
            return known.clone();
        }
        let mut best: Continuation = None;
        // Through up to three internal lanes to a lane of the next edge.
        let mut frontier: Vec<Vec<&str>> = vec![vec![lane]];
        for _ in 0..4 {
            let mut further = Vec::new();
            for path in frontier {
                let last = *path.last().expect("a path is never empty");
                for n in self.next.get(last).copied().unwrap_or(&[]) {
                    let mut p = path.clone();
                    p.push(n.as_str());
                    if n.starts_with(':') {
                        further.push(p);
                        continue;
                    }
                    if n.rsplit_once('_').map(|(e, _)| e) != Some(edges[k]) {
                        continue;
                    }
                    // Go on from the lane reached, or change on it to a
                    // sibling of the same edge and go on from there.
                    let siblings = self
                        .edge_lanes
                        .get(edges[k])
                        .map(Vec::as_slice)
                        .unwrap_or(&[]);
                    let candidates = std::iter::once(n.as_str())
                        .chain(siblings.iter().copied().filter(|s| *s != n.as_str()));
                    for (i, entry) in candidates.enumerate() {
                        let Some((cost, rest)) = self.extend(entry, edges, k + 1, memo) else {
                            continue;
                        };
                        let cost = cost + if i > 0 { self.shift_cost(n) } else { 0.0 };
                        if best.as_ref().is_none_or(|b| cost < b.0) {
                            let mut out: Vec<String> = p.iter().map(|s| s.to_string()).collect();
                            out.extend(rest.into_iter().skip(1));
                            best = Some((cost, out));
                        }
                    }
                }
            }
            frontier = further;
        }
        memo.insert((lane, k), best.clone());
        best
    }
}

/// A small deterministic generator for `probability` flows (seeded by the flow id).
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn optional(doc: &roxmltree::Document, n: Node, name: &str) -> Result<Option<f64>, ImportError> {
    n.attribute(name)
        .map(|_| attr_f64(doc, n, name))
        .transpose()
}

pub fn import(text: &str, map: &MapFile) -> Result<Demand, ImportError> {
    let doc = parse_xml(text, "routes", "SUMO route file")?;
    let root = doc.root_element();
    let net = Network::new(map);
    let mut warnings = Vec::new();
    let kinds: Vec<(String, f64)> = trafficmesh_model::catalog::builtin_names()
        .filter_map(trafficmesh_model::catalog::builtin_kind)
        .map(|k| (k.name, k.length))
        .collect();
    let nearest = |length: f64| {
        kinds
            .iter()
            .min_by(|a, b| (a.1 - length).abs().total_cmp(&(b.1 - length).abs()))
            .map(|k| k.0.clone())
            .expect("the catalogue is not empty")
    };
    let mut types: HashMap<&str, String> = HashMap::new();
    let mut routes: HashMap<&str, Vec<&str>> = HashMap::new();
    for n in root.children().filter(|n| n.is_element()) {
        match n.tag_name().name() {
            "vType" => {
                let length = optional(&doc, n, "length")?.unwrap_or(DEFAULT_LENGTH);
                types.insert(attr(&doc, n, "id")?, nearest(length));
            }
            "route" => {
                routes.insert(
                    attr(&doc, n, "id")?,
                    attr(&doc, n, "edges")?.split_whitespace().collect(),
                );
            }
            _ => {}
        }
    }
    let default_kind = nearest(DEFAULT_LENGTH);
    let mut lane_routes: HashMap<Vec<&str>, Option<Vec<String>>> = HashMap::new();
    let mut departures = Vec::new();
    let (mut unrouted, mut unconnected) = (0usize, Vec::new());
    for n in root.children().filter(|n| n.is_element()) {
        let tag = n.tag_name().name();
        if !matches!(tag, "vehicle" | "flow" | "trip") {
            continue;
        }
        let inline = n.children().find(|c| c.has_tag_name("route"));
        let edges: Vec<&str> = match (n.attribute("route"), inline) {
            (Some(id), _) => routes.get(id).cloned().ok_or_else(|| {
                ImportError::at(&doc, n, &format!("route '{id}' is not defined before it"))
            })?,
            (None, Some(r)) => attr(&doc, r, "edges")?.split_whitespace().collect(),
            (None, None) => {
                unrouted += 1;
                continue;
            }
        };
        let lanes = lane_routes
            .entry(edges.clone())
            .or_insert_with(|| net.lane_route(&edges))
            .clone();
        let Some(route) = lanes else {
            unconnected.push(n.attribute("id").unwrap_or("?").to_string());
            continue;
        };
        let prefab = n
            .attribute("type")
            .map(|t| {
                types
                    .get(t)
                    .cloned()
                    .unwrap_or_else(|| default_kind.clone())
            })
            .unwrap_or_else(|| default_kind.clone());
        let mut push = |time: f64| {
            departures.push(DepartureDef {
                time,
                route: route.clone(),
                prefab: prefab.clone(),
            })
        };
        if tag == "flow" {
            let begin = optional(&doc, n, "begin")?.unwrap_or(0.0);
            let end = optional(&doc, n, "end")?.unwrap_or(DEFAULT_FLOW_END);
            let number = optional(&doc, n, "number")?;
            let period = match (
                optional(&doc, n, "vehsPerHour")?,
                optional(&doc, n, "period")?,
                number,
            ) {
                (Some(vph), _, _) if vph > 0.0 => Some(3600.0 / vph),
                (_, Some(p), _) if p > 0.0 => Some(p),
                (_, _, Some(count)) if count >= 1.0 => Some((end - begin) / count),
                _ => None,
            };
            if let Some(period) = period {
                let limit = number.map_or(usize::MAX, |c| c as usize);
                let mut t = begin;
                let mut k = 0;
                while t < end && k < limit {
                    push(t);
                    k += 1;
                    t = begin + k as f64 * period;
                }
            } else if let Some(p) = optional(&doc, n, "probability")? {
                let id = attr(&doc, n, "id")?;
                let mut rng = SplitMix(id.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                    (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
                }));
                let mut t = begin;
                while t < end {
                    if rng.next_f64() < p {
                        push(t);
                    }
                    t += 1.0;
                }
            } else {
                return Err(ImportError::at(
                    &doc,
                    n,
                    "a flow needs vehsPerHour, period, probability or number",
                ));
            }
        } else {
            let depart = attr(&doc, n, "depart")?;
            match depart.parse::<f64>() {
                Ok(t) if t.is_finite() && t >= 0.0 => push(t),
                _ => warnings.push(format!(
                    "{tag} '{}': depart '{depart}' is not a time; left out",
                    n.attribute("id").unwrap_or("?")
                )),
            }
        }
    }
    if net.shifts.get() > 0 {
        warnings.push(format!(
            "{} route(s) need a lane change on the way: those vehicles move across at the first gap and wait before the road's end for one",
            net.shifts.get()
        ));
    }
    if unrouted > 0 {
        warnings.push(format!("{unrouted} trip(s) without a route left out (routing from/to is not done here; use SUMO's duarouter)"));
    }
    if !unconnected.is_empty() {
        warnings.push(format!(
            "{} vehicle(s) or flow(s) whose edges are not connected lane to lane in the network left out (e.g. {})",
            unconnected.len(),
            unconnected.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
        ));
    }
    if departures.is_empty() {
        return Err(ImportError::plain(
            "the route file has no vehicle or flow with a usable route".into(),
        ));
    }
    departures.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok(Demand {
        simulator: SimulatorDef::Demand { departures },
        warnings,
    })
}
