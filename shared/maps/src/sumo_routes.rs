//! SUMO route files (`.rou.xml`) as a demand: `vehicle` with `depart` and a
//! `route` (by id or inline), `flow` with `vehsPerHour`, `period`,
//! `probability` or `number` between `begin` and `end`. Each `vType` becomes a
//! vehicle kind of its own (length, width, and accel, decel, minGap, tau and
//! maxSpeed for the realistic driver model); a `vTypeDistribution` is drawn
//! from per vehicle with the run's seed. Edge routes become lane routes
//! through the imported network's connections.

use std::collections::HashMap;
use std::rc::Rc;

use rustc_hash::FxHashMap;

use roxmltree::Node;
use trafficmesh_model::hash::{Fnv1a, GOLDEN, splitmix};
use trafficmesh_model::map::{DepartureDef, MapFile, SimulatorDef};
use trafficmesh_model::{IdmParams, VehicleKind};

use crate::import::{ImportError, attr, attr_f64, parse_xml};

/// SUMO's default vehicle length, metres.
const DEFAULT_LENGTH: f64 = 5.0;
/// SUMO's default flow end when none is given: one day.
const DEFAULT_FLOW_END: f64 = 86_400.0;
/// More departures than this from one flow (or more seconds drawn for a
/// `probability` flow) is a mistake in the file, not demand: SUMO's largest
/// city scenarios have a few million vehicles in all.
const MAX_FLOW_DEPARTURES: f64 = 10_000_000.0;

/// The demand and what could not be carried over.
pub struct Demand {
    pub simulator: SimulatorDef,
    /// The vTypes the departures use, as vehicle kinds of the map's own.
    pub kinds: Vec<VehicleKind>,
    pub warnings: Vec<String>,
}

/// SUMO's defaults for a vType's size.
const DEFAULT_WIDTH: f64 = 1.8;

struct Network<'m> {
    /// Normal lanes of each edge, by lane index.
    edge_lanes: FxHashMap<&'m str, Vec<&'m str>>,
    next: FxHashMap<&'m str, &'m [String]>,
    length: FxHashMap<&'m str, f64>,
    /// The classes each lane allows; empty: all.
    classes: FxHashMap<&'m str, &'m [String]>,
}

/// The cheapest way on from a lane: its cost, the load on its lanes, and its
/// lanes (that lane first).
type Continuation<'a> = Option<(f64, f64, Rc<Steps<'a>>)>;

/// The lanes of a way on: some lanes, then the way on from a lane reached
/// (shared by every way that runs on from it, not copied), without its first
/// lane where the vehicle changes onto that lane from the last of these.
struct Steps<'a> {
    lanes: Vec<&'a str>,
    rest: Option<(Rc<Steps<'a>>, bool)>,
}

impl Steps<'_> {
    /// Every lane in order.
    fn to_vec(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut node = Some((self, false));
        while let Some((steps, skip_first)) = node {
            let skip = usize::from(skip_first);
            out.extend(steps.lanes.iter().skip(skip).map(|l| l.to_string()));
            node = steps.rest.as_ref().map(|(r, skip)| (r.as_ref(), *skip));
        }
        out
    }
}

/// Seconds over which a departure's weight on the lanes of its route fades
/// to 1/e: about the time a trip spends on the way.
const LOAD_MEMORY: f64 = 600.0;

/// The recent departures whose chosen lane routes run along each normal lane,
/// each weighted by how recently it departed. Drivers choose among lanes that
/// serve their way equally well by their queues; a lane that also carries a
/// turn has the longer queue, so those going on straight take the others.
#[derive(Default)]
struct LaneLoads(FxHashMap<String, (f64, f64)>);

impl LaneLoads {
    /// The load on `lane` at departure time `t` (junction lanes carry none).
    fn at(&self, lane: &str, t: f64) -> f64 {
        match self.0.get(lane) {
            Some(&(weight, since)) if t > since => weight * (-(t - since) / LOAD_MEMORY).exp(),
            Some(&(weight, _)) => weight,
            None => 0.0,
        }
    }

    /// One more departure at `t` along `lanes`.
    fn add(&mut self, lanes: &[String], t: f64) {
        for lane in lanes.iter().filter(|l| !l.starts_with(':')) {
            let weight = self.at(lane, t) + 1.0;
            let since = self.0.get(lane.as_str()).map_or(t, |&(_, s)| s.max(t));
            self.0.insert(lane.clone(), (weight, since));
        }
    }
}

/// Lanes shorter than this make a lane change on them dearer: there is little
/// or no room to wait for a gap (netconvert splits edges into pieces of 0.2 m).
const ROOMY_LANE: f64 = 50.0;

impl<'m> Network<'m> {
    fn new(map: &'m MapFile) -> Self {
        let mut edge_lanes: FxHashMap<&str, Vec<&str>> = FxHashMap::default();
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
            classes: map
                .lanes
                .iter()
                .map(|l| (l.name.as_str(), l.vehicle_classes.as_slice()))
                .collect(),
        }
    }

    /// May vehicles of `class` drive on `lane`?
    fn allows(&self, lane: &str, class: &str) -> bool {
        self.classes
            .get(lane)
            .is_none_or(|allowed| trafficmesh_model::catalog::class_allowed(allowed, class))
    }

    /// The cost of a lane change along `lane`: one, and far more where the
    /// lane is too short to wait on for a gap.
    fn shift_cost(&self, lane: &str) -> f64 {
        let length = self.length.get(lane).copied().unwrap_or(0.0);
        1.0 + 100.0 * (1.0 - (length / ROOMY_LANE).min(1.0))
    }

    /// Lanes from a lane of `edges[0]` through every edge in turn (internal
    /// lanes between them included), or None when the edges are not connected.
    /// Of all lane routes it takes those with the fewest lane changes, placed
    /// where there is room for them (SUMO's `departLane="best"` and its
    /// strategic lane choice), on lanes that allow `class`: one per start
    /// lane, the preferred first. Among equals the least loaded at departure
    /// time `t` wins, so that vehicles spread over the lanes that serve their
    /// way equally well, as drivers do, instead of all queueing in one of
    /// them; among equal loads `spread` picks. Also returns how many lane
    /// changes the preferred route needs.
    fn lane_routes(
        &self,
        edges: &[&str],
        class: &str,
        spread: u64,
        loads: &LaneLoads,
        t: f64,
    ) -> Option<(Vec<Vec<String>>, usize)> {
        let mut memo: FxHashMap<(&str, usize), Continuation> = FxHashMap::default();
        let ways = Ways {
            edges,
            class,
            spread,
            loads,
            t,
        };
        let mut starts: Vec<(Rank, Vec<String>)> = self
            .edge_lanes
            .get(edges.first()?)?
            .iter()
            .filter(|start| self.allows(start, class))
            .filter_map(|start| {
                let (cost, load, lanes) = self.extend(start, &ways, 1, &mut memo)?;
                let key = draw(spread, start);
                Some((Rank { cost, load, key }, lanes.to_vec()))
            })
            .collect();
        starts.sort_by(|a, b| cheaper(a.0, b.0));
        let best_cost = starts.first()?.0.cost;
        starts.retain(|s| (s.0.cost - best_cost).abs() < SAME_COST);
        // Where two listed lanes are not linked, the vehicle changes lanes.
        let changes = starts[0]
            .1
            .windows(2)
            .filter(|w| {
                !self
                    .next
                    .get(w[0].as_str())
                    .is_some_and(|n| n.contains(&w[1]))
            })
            .count();
        Some((starts.into_iter().map(|s| s.1).collect(), changes))
    }

    /// The cheapest continuation from `lane` (a lane of `edges[k - 1]`).
    fn extend<'a>(
        &'a self,
        lane: &'a str,
        ways: &Ways,
        k: usize,
        memo: &mut FxHashMap<(&'a str, usize), Continuation<'a>>,
    ) -> Continuation<'a> {
        let (edges, class) = (ways.edges, ways.class);
        if k == edges.len() {
            let end = Steps {
                lanes: vec![lane],
                rest: None,
            };
            return Some((0.0, ways.loads.at(lane, ways.t), Rc::new(end)));
        }
        if let Some(known) = memo.get(&(lane, k)) {
            return known.clone();
        }
        let mut best: Option<(Rank, Rc<Steps<'a>>)> = None;
        // Through up to three internal lanes to a lane of the next edge.
        let mut frontier: Vec<Vec<&str>> = vec![vec![lane]];
        for _ in 0..4 {
            let mut further = Vec::new();
            for path in frontier {
                let last = *path.last().expect("a path is never empty");
                for n in self.next.get(last).copied().unwrap_or(&[]) {
                    if !self.allows(n, class) {
                        continue;
                    }
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
                    let candidates = std::iter::once(n.as_str()).chain(
                        siblings
                            .iter()
                            .copied()
                            .filter(|s| *s != n.as_str() && self.allows(s, class)),
                    );
                    for (i, entry) in candidates.enumerate() {
                        let Some((cost, load, rest)) = self.extend(entry, ways, k + 1, memo) else {
                            continue;
                        };
                        let cost = cost + if i > 0 { self.shift_cost(n) } else { 0.0 };
                        // A change on the reached lane runs along it too.
                        let load = load + if i > 0 { ways.loads.at(n, ways.t) } else { 0.0 };
                        let candidate = Rank {
                            cost,
                            load,
                            key: draw(ways.spread, entry),
                        };
                        if best
                            .as_ref()
                            .is_none_or(|b| cheaper(candidate, b.0) == std::cmp::Ordering::Less)
                        {
                            // The lane reached is the first of the way on,
                            // or one the vehicle changes from onto it.
                            let out = Steps {
                                lanes: p.clone(),
                                rest: Some((rest, true)),
                            };
                            best = Some((candidate, Rc::new(out)));
                        }
                    }
                }
            }
            frontier = further;
        }
        let here = ways.loads.at(lane, ways.t);
        let best = best.map(|(r, lanes)| (r.cost, here + r.load, lanes));
        memo.insert((lane, k), best.clone());
        best
    }
}

/// Lane routes whose costs differ by less than this are equally good.
const SAME_COST: f64 = 1e-6;

/// One departure's lane-route search: its edges, class, tie draw, and the
/// lanes' loads at its departure time.
struct Ways<'w> {
    edges: &'w [&'w str],
    class: &'w str,
    spread: u64,
    loads: &'w LaneLoads,
    t: f64,
}

/// How good a lane route is: its cost, then its load, then its tie key.
#[derive(Clone, Copy)]
struct Rank {
    cost: f64,
    load: f64,
    key: TieKey,
}

/// Orders two lane routes by cost; equal costs by load, equal loads by their
/// tie keys.
fn cheaper(a: Rank, b: Rank) -> std::cmp::Ordering {
    if (a.cost - b.cost).abs() >= SAME_COST {
        a.cost.total_cmp(&b.cost)
    } else if (a.load - b.load).abs() >= SAME_COST {
        a.load.total_cmp(&b.load)
    } else {
        a.key.cmp(&b.key)
    }
}

/// Among equally good lanes the one with the smallest draw wins.
type TieKey = u64;

/// A draw of `lane`'s place among equally good lanes for one `spread` value.
fn draw(spread: u64, lane: &str) -> u64 {
    splitmix(mix(spread, lane, 0).wrapping_add(GOLDEN))
}

/// A small deterministic generator for `probability` flows (seeded by the flow id).
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(GOLDEN);
        (splitmix(self.0) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn optional(doc: &roxmltree::Document, n: Node, name: &str) -> Result<Option<f64>, ImportError> {
    n.attribute(name)
        .map(|_| attr_f64(doc, n, name))
        .transpose()
}

/// A vehicle type by id: a kind, or a distribution over kinds.
enum VehicleType {
    Kind(VehicleKind),
    /// (vType id, probability) of each member.
    Distribution(Vec<(String, f64)>),
}

/// Builds one demand from any number of route and additional files, in
/// order (a type must come before the vehicles that use it, as in SUMO).
pub struct DemandBuilder<'m> {
    net: Network<'m>,
    seed: u64,
    /// Departures before `begin` are left out; the rest start counting from it.
    begin: f64,
    end: f64,
    types: HashMap<String, VehicleType>,
    used: Vec<String>,
    departures: Vec<DepartureDef>,
    warnings: Vec<String>,
    /// Elements read but not simulated, by tag.
    not_simulated: std::collections::BTreeMap<String, usize>,
    unrouted: usize,
    unconnected: Vec<String>,
    /// Edge routes (per class) that need a lane change on the way.
    shifted_routes: usize,
    /// The departures so far along each lane, for the next ones' lane choice.
    loads: LaneLoads,
    /// Vehicles whose vType no file read defines, by type.
    undefined_types: std::collections::BTreeMap<String, usize>,
    /// Ids taken so far in every route file read, by namespace (as SUMO
    /// keeps them: vehicles and trips share one, flows have their own).
    ids: std::collections::HashSet<(&'static str, String)>,
}

impl<'m> DemandBuilder<'m> {
    /// `seed` draws vTypes from distributions; departures outside
    /// [`begin`, `end`) are left out.
    pub fn new(map: &'m MapFile, seed: u64, begin: f64, end: f64) -> Self {
        DemandBuilder {
            net: Network::new(map),
            seed,
            begin,
            end,
            types: HashMap::new(),
            used: Vec::new(),
            departures: Vec::new(),
            warnings: Vec::new(),
            not_simulated: Default::default(),
            unrouted: 0,
            unconnected: Vec::new(),
            shifted_routes: 0,
            loads: LaneLoads::default(),
            undefined_types: Default::default(),
            ids: Default::default(),
        }
    }

    /// The vTypes and vTypeDistributions of a route or additional file.
    pub fn add_types(&mut self, doc: &roxmltree::Document) -> Result<(), ImportError> {
        for n in doc.root_element().children().filter(|n| n.is_element()) {
            match n.tag_name().name() {
                "vType" => {
                    let (id, kind) = vehicle_type(doc, n)?;
                    self.types.insert(id, VehicleType::Kind(kind));
                }
                "vTypeDistribution" => {
                    let id = attr(doc, n, "id")?.to_string();
                    let mut members = Vec::new();
                    for t in n.children().filter(|c| c.has_tag_name("vType")) {
                        let (member, kind) = vehicle_type(doc, t)?;
                        let p = optional(doc, t, "probability")?.unwrap_or(1.0);
                        if p.is_nan() || p < 0.0 {
                            return Err(ImportError::at(
                                doc,
                                t,
                                &format!("attribute 'probability': {p} is negative"),
                            ));
                        }
                        members.push((member.clone(), p));
                        self.types.insert(member, VehicleType::Kind(kind));
                    }
                    if let Some(list) = n.attribute("vTypes") {
                        for member in list.split_whitespace() {
                            members.push((member.to_string(), 1.0));
                        }
                    }
                    if members.iter().map(|m| m.1).sum::<f64>() <= 0.0 {
                        return Err(ImportError::at(
                            doc,
                            n,
                            &format!("vTypeDistribution '{id}' has no member with a probability"),
                        ));
                    }
                    self.types.insert(id, VehicleType::Distribution(members));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Counts what an additional file holds that is not simulated (detectors,
    /// bus stops, ...); tlLogic programs and vTypes are read elsewhere.
    pub fn note_additionals(&mut self, doc: &roxmltree::Document) {
        for n in doc.root_element().children().filter(|n| n.is_element()) {
            let tag = n.tag_name().name();
            if !matches!(tag, "vType" | "vTypeDistribution" | "tlLogic" | "route") {
                *self.not_simulated.entry(tag.to_string()).or_default() += 1;
            }
        }
    }

    /// The vehicles, flows and routes of a route file.
    pub fn add_routes(&mut self, doc: &roxmltree::Document) -> Result<(), ImportError> {
        self.add_types(doc)?;
        let root = doc.root_element();
        let mut routes: HashMap<&str, Vec<&str>> = HashMap::new();
        let mut routed: std::collections::HashSet<(String, Vec<&str>)> = Default::default();
        for n in root.children().filter(|n| n.is_element()) {
            let tag = n.tag_name().name();
            match tag {
                "route" => {
                    let id = attr(doc, n, "id")?;
                    let edges = attr(doc, n, "edges")?.split_whitespace().collect();
                    if routes.insert(id, edges).is_some() {
                        return Err(ImportError::at(
                            doc,
                            n,
                            &format!("another route with the id '{id}' exists"),
                        ));
                    }
                    continue;
                }
                "vehicle" | "flow" | "trip" => {}
                "vType" | "vTypeDistribution" => continue,
                other => {
                    *self.not_simulated.entry(other.to_string()).or_default() += 1;
                    continue;
                }
            }
            // As SUMO: vehicles and trips share one namespace, flows have
            // their own (their vehicles are named after them).
            let id = attr(doc, n, "id")?;
            let namespace = if tag == "flow" { "flow" } else { "vehicle" };
            if !self.ids.insert((namespace, id.to_string())) {
                return Err(ImportError::at(
                    doc,
                    n,
                    &format!("another {namespace} with the id '{id}' exists"),
                ));
            }
            let stops = n.children().filter(|c| c.has_tag_name("stop")).count();
            if stops > 0 {
                *self.not_simulated.entry("stop".into()).or_default() += stops;
            }
            let inline = n.children().find(|c| c.has_tag_name("route"));
            let edges: Vec<&str> = match (n.attribute("route"), inline) {
                (Some(id), _) => routes.get(id).cloned().ok_or_else(|| {
                    ImportError::at(doc, n, &format!("route '{id}' is not defined before it"))
                })?,
                (None, Some(r)) => attr(doc, r, "edges")?.split_whitespace().collect(),
                (None, None) => {
                    self.unrouted += 1;
                    continue;
                }
            };
            let vehicle_type = match n.attribute("type") {
                Some(t) if self.types.contains_key(t) => Some(t.to_string()),
                Some(t) => {
                    *self.undefined_types.entry(t.to_string()).or_default() += 1;
                    None
                }
                None => None,
            };
            let Some(times) = departure_times(doc, n, tag)? else {
                self.warnings.push(format!(
                    "{tag} '{id}': depart '{}' is not a time; left out",
                    n.attribute("depart").unwrap_or("")
                ));
                continue;
            };
            let mut connected = true;
            for (k, time) in times.into_iter().enumerate() {
                if time < self.begin || time >= self.end {
                    continue;
                }
                let prefab = self.kind_for(vehicle_type.as_deref(), id, k);
                let class = self.class_of(&prefab);
                // Each departure's own lane routes: its id draws between
                // equally good lanes.
                let first = routed.insert((class.clone(), edges.clone()));
                let Some((routes, changes)) =
                    self.net
                        .lane_routes(&edges, &class, mix(self.seed, id, k), &self.loads, time)
                else {
                    connected = false;
                    continue;
                };
                self.loads.add(&routes[0], time);
                if first && changes > 0 {
                    self.shifted_routes += 1;
                }
                self.departures.push(DepartureDef {
                    time: time - self.begin,
                    route: routes[0].clone(),
                    prefab,
                    other_routes: routes[1..].to_vec(),
                });
            }
            if !connected {
                self.unconnected.push(id.to_string());
            }
        }
        Ok(())
    }

    /// The vehicle class of a kind this builder named.
    fn class_of(&self, kind: &str) -> String {
        match self.types.get(kind) {
            Some(VehicleType::Kind(k)) => k.vehicle_class().to_string(),
            _ => trafficmesh_model::catalog::DEFAULT_VEHICLE_CLASS.to_string(),
        }
    }

    /// The kind of one vehicle (the `k`-th of element `id`): its type, drawn
    /// from the distribution when the type is one; SUMO's default car without.
    fn kind_for(&mut self, vehicle_type: Option<&str>, id: &str, k: usize) -> String {
        let Some(mut name) = vehicle_type.map(str::to_string) else {
            return nearest_builtin(DEFAULT_LENGTH);
        };
        while let Some(VehicleType::Distribution(members)) = self.types.get(&name) {
            let total: f64 = members.iter().map(|m| m.1).sum();
            let mut draw = SplitMix(mix(self.seed, id, k)).next_f64() * total;
            let mut chosen = &members[members.len() - 1].0;
            for (member, p) in members {
                if draw < *p {
                    chosen = member;
                    break;
                }
                draw -= p;
            }
            name = chosen.clone();
        }
        if !self.used.contains(&name) {
            self.used.push(name.clone());
        }
        name
    }

    pub fn finish(mut self) -> Result<Demand, ImportError> {
        if self.shifted_routes > 0 {
            self.warnings.push(format!(
                "{} route(s) need a lane change on the way: those vehicles move across at the first gap and wait before the road's end for one",
                self.shifted_routes
            ));
        }
        if self.unrouted > 0 {
            self.warnings.push(format!("{} trip(s) without a route left out (routing from/to is not done here; use SUMO's duarouter)", self.unrouted));
        }
        if !self.unconnected.is_empty() {
            self.warnings.push(format!(
                "{} vehicle(s) or flow(s) whose edges are not connected lane to lane in the network, on lanes open to their vehicle class, left out (e.g. {})",
                self.unconnected.len(),
                self.unconnected.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
            ));
        }
        if !self.undefined_types.is_empty() {
            let list: Vec<String> = self
                .undefined_types
                .iter()
                .map(|(t, n)| format!("{n} of '{t}'"))
                .collect();
            self.warnings.push(format!(
                "vehicles of vTypes no file defines drive as SUMO's default car: {} (load the file that defines them: --sumocfg reads a scenario's additional files)",
                list.join(", ")
            ));
        }
        if !self.not_simulated.is_empty() {
            let list: Vec<String> = self
                .not_simulated
                .iter()
                .map(|(tag, n)| format!("{n} {tag}"))
                .collect();
            self.warnings
                .push(format!("read but not simulated: {}", list.join(", ")));
        }
        if self.departures.is_empty() {
            // The warnings say why.
            return Err(ImportError::plain(format!(
                "the route files have no vehicle or flow with a usable route{}",
                self.warnings
                    .iter()
                    .map(|w| format!("\n  {w}"))
                    .collect::<String>()
            )));
        }
        self.departures.sort_by(|a, b| a.time.total_cmp(&b.time));
        let kinds = self
            .used
            .iter()
            .filter_map(|name| match self.types.get(name) {
                Some(VehicleType::Kind(kind)) => Some(kind.clone()),
                _ => None,
            })
            .collect();
        Ok(Demand {
            simulator: SimulatorDef::Demand {
                departures: self.departures,
            },
            kinds,
            warnings: self.warnings,
        })
    }
}

/// One route file's demand on `map` (its own vTypes; seed 0, no time window).
pub fn import(text: &str, map: &MapFile) -> Result<Demand, ImportError> {
    let doc = parse_xml(text, "routes", "SUMO route file")?;
    let mut builder = DemandBuilder::new(map, 0, 0.0, f64::INFINITY);
    builder.add_routes(&doc)?;
    builder.finish()
}

/// A vType as a kind of its own size, with its car-following parameters.
fn vehicle_type(doc: &roxmltree::Document, n: Node) -> Result<(String, VehicleKind), ImportError> {
    let id = attr(doc, n, "id")?.to_string();
    let bus = n.attribute("vClass") == Some("bus");
    let length = optional(doc, n, "length")?.unwrap_or(if bus { 12.0 } else { DEFAULT_LENGTH });
    let width = optional(doc, n, "width")?.unwrap_or(if bus { 2.5 } else { DEFAULT_WIDTH });
    let defaults = if bus {
        // SUMO's defaults for its bus class.
        IdmParams {
            accel: 1.2,
            decel: 4.0,
            max_speed: 85.0 / 3.6,
            ..IdmParams::default()
        }
    } else {
        IdmParams::default()
    };
    let idm = IdmParams {
        accel: optional(doc, n, "accel")?.unwrap_or(defaults.accel),
        decel: optional(doc, n, "decel")?.unwrap_or(defaults.decel),
        min_gap: optional(doc, n, "minGap")?.unwrap_or(defaults.min_gap),
        headway: optional(doc, n, "tau")?.unwrap_or(defaults.headway),
        max_speed: optional(doc, n, "maxSpeed")?.unwrap_or(defaults.max_speed),
    };
    if !(length > 0.0 && width > 0.0) {
        return Err(ImportError::at(
            doc,
            n,
            &format!("vType '{id}': length and width must be positive"),
        ));
    }
    let mut kind = VehicleKind::sized(&id, length, width);
    kind.idm = Some(idm);
    if let Some(problem) = kind.problem() {
        return Err(ImportError::at(doc, n, &format!("vType '{id}': {problem}")));
    }
    kind.class = n.attribute("vClass").map(str::to_string);
    Ok((id, kind))
}

/// The departure times of a vehicle, trip or flow; None for a vehicle whose
/// `depart` is not a time (SUMO's `triggered` and the like).
fn departure_times(
    doc: &roxmltree::Document,
    n: Node,
    tag: &str,
) -> Result<Option<Vec<f64>>, ImportError> {
    let mut times = Vec::new();
    if tag != "flow" {
        let depart = attr(doc, n, "depart")?;
        return Ok(match depart.parse::<f64>() {
            Ok(t) if t.is_finite() && t >= 0.0 => Some(vec![t]),
            _ => None,
        });
    }
    let begin = optional(doc, n, "begin")?.unwrap_or(0.0);
    if begin < 0.0 {
        return Err(ImportError::at(
            doc,
            n,
            &format!(
                "attribute 'begin': {} is negative",
                n.attribute("begin").unwrap_or_default()
            ),
        ));
    }
    let end = optional(doc, n, "end")?.unwrap_or(DEFAULT_FLOW_END);
    let number = optional(doc, n, "number")?;
    let too_many = || {
        let (from, to) = (n.attribute("begin"), n.attribute("end"));
        ImportError::at(
            doc,
            n,
            &format!(
                "this flow would depart more than the {MAX_FLOW_DEPARTURES:.0} vehicles a flow \
                 may have (begin {}, end {})",
                from.unwrap_or("0"),
                to.unwrap_or("86400")
            ),
        )
    };
    let period = match (
        optional(doc, n, "vehsPerHour")?,
        optional(doc, n, "period")?,
        number,
    ) {
        (Some(vph), _, _) if vph > 0.0 => Some(3600.0 / vph),
        (_, Some(p), _) if p > 0.0 => Some(p),
        (_, _, Some(count)) if count >= 1.0 => Some((end - begin) / count),
        _ => None,
    };
    if let Some(period) = period {
        let count = ((end - begin) / period)
            .ceil()
            .min(number.unwrap_or(f64::MAX));
        if count > MAX_FLOW_DEPARTURES {
            return Err(too_many());
        }
        let limit = number.map_or(usize::MAX, |c| c as usize);
        let mut t = begin;
        let mut k = 0;
        while t < end && k < limit {
            times.push(t);
            k += 1;
            t = begin + k as f64 * period;
        }
    } else if let Some(p) = optional(doc, n, "probability")? {
        if (end - begin) * p > MAX_FLOW_DEPARTURES || end - begin > MAX_FLOW_DEPARTURES {
            return Err(too_many());
        }
        let id = attr(doc, n, "id")?;
        let mut rng = SplitMix(mix(0, id, 0));
        let mut t = begin;
        while t < end {
            if rng.next_f64() < p {
                times.push(t);
            }
            t += 1.0;
        }
    } else {
        return Err(ImportError::at(
            doc,
            n,
            "a flow needs vehsPerHour, period, probability or number",
        ));
    }
    Ok(Some(times))
}

/// A generator state from a seed, an element id and an index (FNV-1a).
fn mix(seed: u64, id: &str, k: usize) -> u64 {
    let mut h = Fnv1a::default();
    h.eat(id.as_bytes());
    h.0 ^ seed.rotate_left(17) ^ (k as u64).wrapping_mul(GOLDEN)
}

/// The built-in kind nearest in length (vehicles without a vType).
fn nearest_builtin(length: f64) -> String {
    trafficmesh_model::catalog::builtin_names()
        .filter_map(trafficmesh_model::catalog::builtin_kind)
        .min_by(|a, b| {
            (a.length - length)
                .abs()
                .total_cmp(&(b.length - length).abs())
        })
        .map(|k| k.name)
        .expect("the catalogue is not empty")
}
