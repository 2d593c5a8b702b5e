//! Lanelet2 `.osm` import: vehicle lanelets become lanes (centreline from the
//! left and right bounds, oriented as Lanelet2 orients them; a two-way lanelet
//! is a lane each way on its half), successors come from shared bound end points,
//! `speed_limit` and `turn_direction` tags carry over, traffic-light
//! regulatory elements become light groups with their stop lines,
//! `right_of_way` elements give who yields to whom, and crosswalk lanelets
//! become crosswalk areas with stop points where lanes enter them.
//!
//! Positions: `local_x`/`local_y` when every node has them (Autoware maps), else
//! lat/lon projected onto a plane tangent at the map's centre. Lanelet2 has no
//! signal timing: each intersection gets a synthesised two-phase program.

use std::collections::{BTreeMap, HashMap};

use roxmltree::{Document, Node};
use trafficmesh_model::enums::TurnDirection;
use trafficmesh_model::map::{
    CrosswalkArea, CrosswalkDef, LaneDef, LightGroupDef, LightProgram, Point, RoadConflicts,
};

use crate::import::{ImportError, Imported, assemble, attr, parse_xml};

const EARTH_RADIUS: f64 = 6_371_000.0;
/// Lanelet2's default for urban roads when a lanelet has no speed_limit, km/h.
const DEFAULT_SPEED_KMH: f64 = 50.0;
/// Stop lines of one intersection's lights lie within this of each other, metres.
const INTERSECTION_RADIUS: f64 = 60.0;
/// The synthesised program: green and yellow of each of the two phases, seconds.
const GREEN: f64 = 30.0;
const YELLOW: f64 = 3.0;

type Xy = [f64; 3];

struct Way<'a> {
    nodes: Vec<i64>,
    node: Node<'a, 'a>,
}

struct Relation<'a> {
    id: i64,
    node: Node<'a, 'a>,
    tags: HashMap<&'a str, &'a str>,
    members: Vec<(&'a str, &'a str, i64)>,
}

impl Relation<'_> {
    fn tag(&self, k: &str) -> Option<&str> {
        self.tags.get(k).copied()
    }
    fn ways(&self, role: &str) -> impl Iterator<Item = i64> + '_ {
        let role = role.to_string();
        self.members
            .iter()
            .filter(move |(t, r, _)| *t == "way" && *r == role)
            .map(|m| m.2)
    }
    fn relations(&self, role: &str) -> impl Iterator<Item = i64> + '_ {
        let role = role.to_string();
        self.members
            .iter()
            .filter(move |(t, r, _)| *t == "relation" && *r == role)
            .map(|m| m.2)
    }
}

/// One vehicle lanelet on its way to becoming a lane.
/// One direction of a lanelet: a lane.
struct Lanelet {
    id: i64,
    /// The lane's name: `ll_<id>`, and `ll_<id>_r` for the way against the
    /// bounds' direction of a two-way lanelet.
    name: String,
    centre: Vec<Xy>,
    width: f64,
    /// The bounds' first and last nodes (left, right) as driven: successors
    /// share them.
    start: (i64, i64),
    end: (i64, i64),
    /// The middle of the lanelet's start and end across its full width,
    /// where lanelets drawn with separate nodes meet.
    joins: (Xy, Xy),
    speed: f64,
    turn: Option<TurnDirection>,
    regulatory: Vec<i64>,
}

impl Lanelet {
    /// A lane opening from a point beside another: both bounds start at one node.
    fn opens(&self) -> bool {
        self.start.0 == self.start.1
    }

    /// A lane closing to a point: both bounds end at one node.
    fn closes(&self) -> bool {
        self.end.0 == self.end.1
    }
}

/// Does the pair of end nodes `ends` (left, right) include `node`?
fn has_node(ends: (i64, i64), node: i64) -> bool {
    ends.0 == node || ends.1 == node
}

fn id_of(doc: &Document, n: Node, name: &str) -> Result<i64, ImportError> {
    let text = attr(doc, n, name)?;
    text.parse().map_err(|_| {
        ImportError::at(
            doc,
            n,
            &format!("attribute '{name}': '{text}' is not an id"),
        )
    })
}

fn tags<'a>(n: Node<'a, 'a>) -> HashMap<&'a str, &'a str> {
    n.children()
        .filter(|c| c.has_tag_name("tag"))
        .filter_map(|t| Some((t.attribute("k")?, t.attribute("v")?)))
        .collect()
}

fn num(doc: &Document, n: Node, text: &str, what: &str) -> Result<f64, ImportError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| ImportError::at(doc, n, &format!("{what}: '{text}' is not a number")))
}

pub fn import(name: &str, text: &str) -> Result<Imported, ImportError> {
    let doc = parse_xml(text, "osm", "Lanelet2 map")?;
    let root = doc.root_element();
    let mut warnings = Vec::new();
    let points = node_positions(&doc, root, &mut warnings)?;
    let mut ways: HashMap<i64, Way> = HashMap::new();
    for w in root.children().filter(|n| n.has_tag_name("way")) {
        let nodes = w
            .children()
            .filter(|c| c.has_tag_name("nd"))
            .map(|nd| id_of(&doc, nd, "ref"))
            .collect::<Result<Vec<_>, _>>()?;
        ways.insert(id_of(&doc, w, "id")?, Way { nodes, node: w });
    }
    let mut relations: BTreeMap<i64, Relation> = BTreeMap::new();
    for r in root.children().filter(|n| n.has_tag_name("relation")) {
        let members = r
            .children()
            .filter(|c| c.has_tag_name("member"))
            .map(|m| {
                Ok((
                    attr(&doc, m, "type")?,
                    m.attribute("role").unwrap_or(""),
                    id_of(&doc, m, "ref")?,
                ))
            })
            .collect::<Result<Vec<_>, ImportError>>()?;
        let id = id_of(&doc, r, "id")?;
        relations.insert(
            id,
            Relation {
                id,
                node: r,
                tags: tags(r),
                members,
            },
        );
    }
    let geometry = |r: &Relation, role: &str| -> Result<(Vec<i64>, Vec<Xy>), ImportError> {
        let way_id = r.ways(role).next().ok_or_else(|| {
            ImportError::at(&doc, r.node, &format!("lanelet without a '{role}' way"))
        })?;
        let way = ways.get(&way_id).ok_or_else(|| {
            ImportError::at(
                &doc,
                r.node,
                &format!("'{role}' way {way_id} is not in the file"),
            )
        })?;
        let xy = way
            .nodes
            .iter()
            .map(|n| {
                points.get(n).copied().ok_or_else(|| {
                    ImportError::at(&doc, way.node, &format!("node {n} is not in the file"))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        if xy.len() < 2 {
            return Err(ImportError::at(
                &doc,
                way.node,
                "a bound needs at least two nodes",
            ));
        }
        Ok((way.nodes.clone(), xy))
    };

    let mut lanelets: Vec<Lanelet> = Vec::new();
    let mut crosswalks: Vec<(i64, Vec<Xy>)> = Vec::new();
    let mut skipped: BTreeMap<String, usize> = BTreeMap::new();
    for r in relations
        .values()
        .filter(|r| r.tag("type") == Some("lanelet"))
    {
        let subtype = r.tag("subtype").unwrap_or("road");
        let (mut left_ids, mut left) = geometry(r, "left")?;
        let (mut right_ids, mut right) = geometry(r, "right")?;
        // Bounds are drawn either way; as Lanelet2 does, the left bound is
        // turned to have the right one on its right, then the right bound to
        // have the left one on its left. Both then run in the driving direction.
        if side_of(&left, middle(&right)) >= 0.0 {
            left.reverse();
            left_ids.reverse();
        }
        if side_of(&right, middle(&left)) <= 0.0 {
            right.reverse();
            right_ids.reverse();
        }
        match subtype {
            "road" | "highway" | "play_street" | "emergency_lane" | "bus_lane" => {}
            "crosswalk" => {
                let mut polygon = left.clone();
                polygon.extend(right.iter().rev());
                crosswalks.push((r.id, polygon));
                continue;
            }
            other => {
                *skipped.entry(other.to_string()).or_default() += 1;
                continue;
            }
        }
        let speed = match r.tag("speed_limit") {
            Some(s) => num(
                &doc,
                r.node,
                s.split_whitespace().next().unwrap_or(s),
                "tag 'speed_limit'",
            )?,
            None => DEFAULT_SPEED_KMH,
        } / 3.6;
        let turn = r.tag("turn_direction").map(|t| match t {
            "left" => TurnDirection::Left,
            "right" => TurnDirection::Right,
            _ => TurnDirection::Straight,
        });
        let regulatory: Vec<i64> = r.relations("regulatory_element").collect();
        let (centre, width) = centreline(&left, &right);
        let joins = (centre[0], centre[centre.len() - 1]);
        let (l0, l1) = first_last(&left_ids);
        let (r0, r1) = first_last(&right_ids);
        let mut along = Lanelet {
            id: r.id,
            name: format!("ll_{}", r.id),
            centre,
            width,
            start: (l0, r0),
            end: (l1, r1),
            joins,
            speed,
            turn,
            regulatory,
        };
        if along.opens() || along.closes() {
            // As wide as its wide end: the narrow part is shared with the
            // lane beside.
            along.width =
                dist(left[0], right[0]).max(dist(left[left.len() - 1], right[right.len() - 1]));
        }
        let width = along.width;
        if r.tag("one_way") == Some("no") {
            // Both ways on one lanelet (Lanelet2's inverted lanelet for the
            // other): each keeps to its right half.
            let back_middle: Vec<Xy> = along.centre.iter().rev().copied().collect();
            let back_right: Vec<Xy> = left.iter().rev().copied().collect();
            let back = Lanelet {
                name: format!("ll_{}_r", r.id),
                centre: centreline(&back_middle, &back_right).0,
                width: width * 0.5,
                start: (r1, l1),
                end: (r0, l0),
                joins: (joins.1, joins.0),
                regulatory: along.regulatory.clone(),
                ..along
            };
            along.centre = centreline(&along.centre, &right).0;
            along.width = width * 0.5;
            lanelets.push(along);
            lanelets.push(back);
        } else {
            lanelets.push(along);
        }
    }
    for (subtype, n) in &skipped {
        warnings.push(format!(
            "{n} lanelet(s) of subtype '{subtype}' not imported (not for cars)"
        ));
    }

    // A lanelet's lanes: one, or two for a two-way lanelet.
    let mut index: HashMap<i64, Vec<usize>> = HashMap::new();
    for (i, l) in lanelets.iter().enumerate() {
        index.entry(l.id).or_default().push(i);
    }
    let successors = successors(&lanelets);
    let mut predecessors = vec![Vec::new(); lanelets.len()];
    for (i, next) in successors.iter().enumerate() {
        for &n in next {
            predecessors[n].push(i);
        }
    }
    keep_to_the_halves(&mut lanelets, &index, &successors, &predecessors);
    ease_tips(&mut lanelets, &successors, &predecessors);
    let mut lanes: Vec<LaneDef> = lanelets
        .iter()
        .enumerate()
        .map(|(i, l)| {
            // Junction lanelets: tagged with a turn direction (Autoware), or
            // where lanes diverge or merge.
            let diverges = predecessors[i].iter().any(|&p| successors[p].len() > 1);
            let merges = successors[i].iter().any(|&n| predecessors[n].len() > 1);
            let intersection = l.turn.is_some() || diverges || merges;
            LaneDef {
                name: l.name.clone(),
                waypoints: l.centre.iter().map(|p| Point(*p)).collect(),
                width: l.width,
                // A turn is driven no faster than its bend allows, as
                // netconvert limits SUMO's junction lanes.
                speed_limit: if intersection {
                    l.speed.min(turn_speed(&l.centre))
                } else {
                    l.speed
                },
                next: successors[i]
                    .iter()
                    .map(|&n| lanelets[n].name.clone())
                    .collect(),
                prev: Vec::new(),
                intersection,
                turn_direction: l.turn.unwrap_or_default(),
                stop_line: None,
                traffic_light: None,
                right_of_way: Vec::new(),
                vehicle_classes: Vec::new(),
                crosses_apart: Vec::new(),
            }
        })
        .collect();

    // Traffic lights: one group per regulatory element, on the lanelets that refer to it.
    let mut light_lanes: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    for (i, l) in lanelets.iter().enumerate() {
        for reg in &l.regulatory {
            let Some(r) = relations.get(reg) else {
                warnings.push(format!(
                    "lanelet {}: regulatory element {reg} is not in the file",
                    l.id
                ));
                continue;
            };
            match r.tag("subtype") {
                Some("traffic_light") => {
                    let stop = r
                        .ways("ref_line")
                        .next()
                        .and_then(|w| ways.get(&w))
                        .and_then(|w| {
                            Some([
                                Point(*points.get(w.nodes.first()?)?),
                                Point(*points.get(w.nodes.last()?)?),
                            ])
                        });
                    // On a two-way lanelet, the light is for the way that
                    // ends at its stop line.
                    if index[&l.id].len() > 1
                        && let Some([a, b]) = stop
                    {
                        let mid = [0, 1, 2].map(|k| (a.0[k] + b.0[k]) / 2.0);
                        if dist(mid, l.centre[0]) < dist(mid, l.centre[l.centre.len() - 1]) {
                            continue;
                        }
                    }
                    let lane = &mut lanes[i];
                    if lane.traffic_light.is_some() {
                        warnings.push(format!(
                            "lanelet {}: a second traffic light ({reg}) ignored",
                            l.id
                        ));
                        continue;
                    }
                    lane.traffic_light = Some(format!("tl_{reg}"));
                    lane.stop_line = Some(stop.unwrap_or_else(|| across_end(&l.centre, l.width)));
                    light_lanes.entry(*reg).or_default().push(i);
                }
                Some("right_of_way") => {}
                _ => {}
            }
        }
    }
    let light_groups = synthesise_programs(&lanelets, &lanes, &light_lanes, &mut warnings);

    let rings = give_rings_priority(&lanelets, &successors, &predecessors, &mut lanes);
    if rings > 0 {
        warnings.push(format!(
            "{rings} roundabout(s) found (rings of lanelets under {RING_LANE_MAX} m, at most \
             {RING_MAX} m round): lanes entering them yield to the ring"
        ));
    }

    // right_of_way elements: the yield lanelets yield to the right_of_way ones.
    for r in relations
        .values()
        .filter(|r| r.tag("subtype") == Some("right_of_way"))
    {
        let priority: Vec<String> = r
            .relations("right_of_way")
            .filter_map(|id| index.get(&id))
            .flatten()
            .map(|&i| lanelets[i].name.clone())
            .collect();
        for &y in r
            .relations("yield")
            .filter_map(|id| index.get(&id))
            .flatten()
        {
            for p in &priority {
                if !lanes[y].right_of_way.contains(p) {
                    lanes[y].right_of_way.push(p.clone());
                }
            }
        }
    }

    let permitted = crate::permitted_turns::turns_yield_to_oncoming(&mut lanes, &light_groups);
    if permitted > 0 {
        warnings.push(format!(
            "{permitted} turn(s) across an oncoming straight way of the same synthesised phase \
             yield to it (pairs no right_of_way element covers)"
        ));
    }

    let crosswalks = crosswalks
        .into_iter()
        .map(|(id, polygon)| {
            let stops =
                crate::crossing::stop_points(&polygon, lanelets.iter().map(|l| &l.centre[..]));
            if stops.is_empty() {
                warnings.push(format!(
                    "crosswalk lanelet {id}: no lane crosses it; it stops nobody"
                ));
            }
            CrosswalkDef {
                name: format!("cw_{id}"),
                area: CrosswalkArea::Polygon {
                    points: polygon.into_iter().map(Point).collect(),
                },
                stop_points: stops,
                max_detection_distance: 40.0,
                forward_angle_tolerance_deg: 80.0,
                stop_buffer: 1.5,
                enable_debug_logs: false,
                config: None,
            }
        })
        .collect();

    // Spawn lanes: the lanelets nothing leads into.
    Ok(assemble(
        format!("{name} (Lanelet2)"),
        lanes,
        light_groups,
        crosswalks,
        |i| predecessors[i].is_empty(),
        // Junctions are guessed (turn tags, splits, joins): lanelets also
        // cross and run close outside them.
        RoadConflicts::Everywhere,
        warnings,
    ))
}

fn node_positions(
    doc: &Document,
    root: Node,
    warnings: &mut Vec<String>,
) -> Result<HashMap<i64, Xy>, ImportError> {
    let mut local: HashMap<i64, Xy> = HashMap::new();
    // In document order: the centre is a floating-point sum, which must not
    // depend on a hash map's order (the import would differ run to run).
    let mut geo: Vec<(i64, (f64, f64, f64))> = Vec::new();
    let mut all_local = true;
    for n in root.children().filter(|n| n.has_tag_name("node")) {
        let id = id_of(doc, n, "id")?;
        let t = tags(n);
        let ele = t
            .get("ele")
            .map(|e| num(doc, n, e, "tag 'ele'"))
            .transpose()?
            .unwrap_or(0.0);
        match (t.get("local_x"), t.get("local_y")) {
            (Some(x), Some(y)) => {
                local.insert(
                    id,
                    [
                        num(doc, n, x, "tag 'local_x'")?,
                        num(doc, n, y, "tag 'local_y'")?,
                        ele,
                    ],
                );
            }
            _ => all_local = false,
        }
        let lat = num(doc, n, attr(doc, n, "lat")?, "attribute 'lat'")?;
        let lon = num(doc, n, attr(doc, n, "lon")?, "attribute 'lon'")?;
        geo.push((id, (lat, lon, ele)));
    }
    if all_local && !local.is_empty() {
        return Ok(local);
    }
    // A plane tangent at the centre: metres east and north of it.
    let count = geo.len().max(1) as f64;
    let lat0 = geo.iter().map(|(_, g)| g.0).sum::<f64>() / count;
    let lon0 = geo.iter().map(|(_, g)| g.1).sum::<f64>() / count;
    warnings.push(format!(
        "nodes have no local_x/local_y: lat/lon projected onto a plane tangent at {lat0:.6}, {lon0:.6}"
    ));
    let k = lat0.to_radians().cos();
    Ok(geo
        .into_iter()
        .map(|(id, (lat, lon, ele))| {
            (
                id,
                [
                    EARTH_RADIUS * k * (lon - lon0).to_radians(),
                    EARTH_RADIUS * (lat - lat0).to_radians(),
                    ele,
                ],
            )
        })
        .collect())
}

/// A roundabout's ring: lanes no longer than this, metres...
const RING_LANE_MAX: f64 = 25.0;
/// ... closing a loop no longer than this, metres (a roundabout 64 m
/// across), that turns once round.
const RING_MAX: f64 = 200.0;
/// The most lanes a ring is looked for with.
const RING_MAX_LANES: usize = 16;

/// Roundabouts that no `right_of_way` element marks (Lanelet2 has no
/// roundabout tag): a loop of short lanes that turns once round. As at a
/// roundabout's give-way line (and as netconvert makes them), a lane that
/// leads into the ring yields to the ring lane it merges beside. Returns how
/// many rings it found.
fn give_rings_priority(
    lanelets: &[Lanelet],
    successors: &[Vec<usize>],
    predecessors: &[Vec<usize>],
    lanes: &mut [LaneDef],
) -> usize {
    let lengths: Vec<f64> = lanelets.iter().map(|l| line_length(&l.centre)).collect();
    let short: Vec<bool> = lengths.iter().map(|&l| l <= RING_LANE_MAX).collect();
    let mut in_ring = vec![false; lanelets.len()];
    let mut rings = 0;
    for start in 0..lanelets.len() {
        if !short[start] || in_ring[start] {
            continue;
        }
        // Depth-first along short lanes with higher indices than the start, so
        // each loop is found once, from its lowest lane.
        let mut stack = vec![(start, 0usize)];
        let mut path = vec![start];
        let mut found = None;
        while let Some((at, k)) = stack.pop() {
            path.truncate(stack.len() + 1);
            let Some(&next) = successors[at].get(k) else {
                continue;
            };
            stack.push((at, k + 1));
            if next == start && path.len() >= 3 {
                let total: f64 = path.iter().map(|&i| lengths[i]).sum();
                if total <= RING_MAX && turns_once_round(lanelets, &path) {
                    found = Some(path.clone());
                    break;
                }
            } else if next > start
                && short[next]
                && !path.contains(&next)
                && path.len() < RING_MAX_LANES
            {
                path.push(next);
                stack.push((next, 0));
            }
        }
        let Some(ring) = found else { continue };
        rings += 1;
        for &r in &ring {
            in_ring[r] = true;
        }
        for (k, &r) in ring.iter().enumerate() {
            let before = ring[(k + ring.len() - 1) % ring.len()];
            for &entry in predecessors[r].iter().filter(|&&p| !ring.contains(&p)) {
                let name = lanelets[before].name.clone();
                if !lanes[entry].right_of_way.contains(&name) {
                    lanes[entry].right_of_way.push(name);
                }
            }
        }
    }
    rings
}

/// Does a loop of lanes turn once round (its headings adding up to ±360°)?
fn turns_once_round(lanelets: &[Lanelet], ring: &[usize]) -> bool {
    let points: Vec<Xy> = ring
        .iter()
        .flat_map(|&i| lanelets[i].centre.iter().copied())
        .collect();
    let heading = |a: Xy, b: Xy| (b[1] - a[1]).atan2(b[0] - a[0]);
    let steps: Vec<f64> = points
        .windows(2)
        .filter(|w| dist(w[0], w[1]) > 1e-6)
        .map(|w| heading(w[0], w[1]))
        .collect();
    let mut total = 0.0;
    for k in 0..steps.len() {
        let d = steps[(k + 1) % steps.len()] - steps[k];
        total +=
            (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    }
    (total.abs() - std::f64::consts::TAU).abs() < 0.5
}

/// Metres over which a one-way lanelet joining a two-way one eases from the
/// middle of the road to the half its way keeps to (at most half its length).
const HALF_TAPER: f64 = 10.0;

/// A one-way lanelet that continues or leads into a two-way one shares that
/// lanelet's full-width edge, so its centreline ends in the road's middle:
/// it is eased onto the half of its way there, as drivers keep right.
fn keep_to_the_halves(
    lanelets: &mut [Lanelet],
    index: &HashMap<i64, Vec<usize>>,
    successors: &[Vec<usize>],
    predecessors: &[Vec<usize>],
) {
    let two_way: Vec<bool> = lanelets.iter().map(|l| index[&l.id].len() > 1).collect();
    let two_way = |k: usize| two_way[k];
    for i in 0..lanelets.len() {
        if two_way(i) {
            continue;
        }
        let into = predecessors[i].iter().find(|&&p| two_way(p));
        let onto = successors[i].iter().find(|&&n| two_way(n));
        let start = into.map(|&p| {
            let c = &lanelets[p].centre;
            c[c.len() - 1]
        });
        let end = onto.map(|&n| lanelets[n].centre[0]);
        if start.is_none() && end.is_none() {
            continue;
        }
        lanelets[i].centre = eased_onto(&lanelets[i].centre, start, end, HALF_TAPER);
    }
}

/// A lanelet that opens from a point beside another (both bounds start at
/// one node: a lane added) leaves its centreline's start there, off the
/// middle of the lanelet it follows; one that closes to a point (a lane
/// dropped) ends off the middle of the lanelet it leads into. Each is eased
/// onto that middle over its whole length, as a driver steers into the new
/// lane or out of the ending one.
fn ease_tips(lanelets: &mut [Lanelet], successors: &[Vec<usize>], predecessors: &[Vec<usize>]) {
    for i in 0..lanelets.len() {
        let l = &lanelets[i];
        let start = l
            .opens()
            .then(|| predecessors[i].first())
            .flatten()
            .map(|&p| lanelets[p].centre[lanelets[p].centre.len() - 1]);
        let end = l
            .closes()
            .then(|| successors[i].first())
            .flatten()
            .map(|&n| lanelets[n].centre[0]);
        if start.is_some() || end.is_some() {
            lanelets[i].centre = eased_onto(&lanelets[i].centre, start, end, f64::INFINITY);
        }
    }
}

/// The centreline moved to start at `start` and end at `end` (where given),
/// the shift fading out over `taper` metres from each end (or the middle, for
/// both): eased in and out (smoothstep), so the lane leaves the joint in its
/// own heading.
fn eased_onto(centre: &[Xy], start: Option<Xy>, end: Option<Xy>, taper: f64) -> Vec<Xy> {
    let mut eased = densify(centre, 1.0);
    let mut along = vec![0.0];
    for w in eased.windows(2) {
        along.push(along[along.len() - 1] + dist(w[0], w[1]));
    }
    let length = along[along.len() - 1];
    let first = eased[0];
    let last = eased[eased.len() - 1];
    let start_shift = start.map_or([0.0; 2], |to| [to[0] - first[0], to[1] - first[1]]);
    let end_shift = end.map_or([0.0; 2], |to| [to[0] - last[0], to[1] - last[1]]);
    let taper = taper.min(length).max(1e-6);
    let weights = |s: f64| match (start.is_some(), end.is_some()) {
        (true, true) => {
            let u = smoothstep(s / length.max(1e-6));
            (1.0 - u, u)
        }
        (true, false) => (smoothstep(1.0 - s / taper), 0.0),
        _ => (0.0, smoothstep(1.0 - (length - s) / taper)),
    };
    for (p, &s) in eased.iter_mut().zip(&along) {
        let (ws, we) = weights(s);
        p[0] += start_shift[0] * ws + end_shift[0] * we;
        p[1] += start_shift[1] * ws + end_shift[1] * we;
    }
    eased
}

/// 0 below 0, 1 above 1, and a smooth S between.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The polyline with points added so that none lies further than `spacing`
/// from the next.
fn densify(line: &[Xy], spacing: f64) -> Vec<Xy> {
    let mut out = vec![line[0]];
    for w in line.windows(2) {
        let n = (dist(w[0], w[1]) / spacing).ceil().max(1.0) as usize;
        for k in 1..=n {
            let t = k as f64 / n as f64;
            out.push([0, 1, 2].map(|c| w[0][c] + (w[1][c] - w[0][c]) * t));
        }
    }
    out
}

fn first_last(ids: &[i64]) -> (i64, i64) {
    (ids[0], ids[ids.len() - 1])
}

/// The point that stands for a bound's middle: its middle node, or the
/// midpoint of a bound of two nodes.
fn middle(line: &[Xy]) -> Xy {
    if line.len() > 2 {
        line[line.len() / 2]
    } else {
        let (a, b) = (line[0], line[line.len() - 1]);
        [0, 1, 2].map(|k| (a[k] + b[k]) * 0.5)
    }
}

/// Which side of a polyline p lies on, by its nearest segment: positive to
/// the left, negative to the right.
fn side_of(line: &[Xy], p: Xy) -> f64 {
    let mut best = (f64::INFINITY, 0.0);
    for w in line.windows(2) {
        let (d, q) = (
            [w[1][0] - w[0][0], w[1][1] - w[0][1]],
            [p[0] - w[0][0], p[1] - w[0][1]],
        );
        let len2 = d[0] * d[0] + d[1] * d[1];
        let t = if len2 > 0.0 {
            ((q[0] * d[0] + q[1] * d[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let off = [q[0] - t * d[0], q[1] - t * d[1]];
        let distance = off[0] * off[0] + off[1] * off[1];
        if distance < best.0 {
            best = (distance, d[0] * q[1] - d[1] * q[0]);
        }
    }
    best.1
}

fn line_length(line: &[Xy]) -> f64 {
    line.windows(2).map(|w| dist(w[0], w[1])).sum()
}

fn dist(a: Xy, b: Xy) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The point at fraction t of a polyline's length.
fn at_fraction(line: &[Xy], t: f64) -> Xy {
    let total = line_length(line);
    let mut left = t * total;
    for w in line.windows(2) {
        let d = dist(w[0], w[1]);
        if left <= d && d > 0.0 {
            let f = left / d;
            return [0, 1, 2].map(|k| w[0][k] + (w[1][k] - w[0][k]) * f);
        }
        left -= d;
    }
    line[line.len() - 1]
}

/// Midpoints of the two bounds sampled at the same length fractions, and the mean width.
/// Lateral acceleration a turn is driven at, m/s² (netconvert's default for
/// `junctions.limit-turn-speed`).
const TURN_LATERAL_ACCEL: f64 = 5.5;

/// Points closer than this are merged before bends are measured, so that
/// digitising noise does not read as a tight bend.
const BEND_SPACING: f64 = 2.0;

/// The speed the tightest bend of `points` allows, sqrt(a · r); infinite
/// on a straight line.
fn turn_speed(points: &[Xy]) -> f64 {
    let mut spaced: Vec<Xy> = Vec::with_capacity(points.len());
    for p in points {
        if spaced.last().is_none_or(|q| dist(*q, *p) >= BEND_SPACING) {
            spaced.push(*p);
        }
    }
    let radius = spaced
        .windows(3)
        .map(|w| {
            let (a, b, c) = (dist(w[0], w[1]), dist(w[1], w[2]), dist(w[0], w[2]));
            let cross = (w[1][0] - w[0][0]) * (w[2][1] - w[0][1])
                - (w[1][1] - w[0][1]) * (w[2][0] - w[0][0]);
            // The circle through the three points: r = abc / (4 area).
            if cross.abs() < 1e-9 {
                f64::INFINITY
            } else {
                a * b * c / (2.0 * cross.abs())
            }
        })
        .fold(f64::INFINITY, f64::min);
    (TURN_LATERAL_ACCEL * radius).sqrt()
}

fn centreline(left: &[Xy], right: &[Xy]) -> (Vec<Xy>, f64) {
    let n = left.len().max(right.len()).clamp(2, 200);
    let mut centre: Vec<Xy> = Vec::with_capacity(n);
    let mut width = 0.0;
    for i in 0..n {
        let t = i as f64 / (n - 1) as f64;
        let (a, b) = (at_fraction(left, t), at_fraction(right, t));
        width += dist(a, b);
        let p = [0, 1, 2].map(|k| (a[k] + b[k]) / 2.0);
        if centre.last().is_none_or(|q| dist(*q, p) > 1e-6) {
            centre.push(p);
        }
    }
    if centre.len() < 2 {
        centre.push([centre[0][0] + 0.2, centre[0][1], centre[0][2]]);
    }
    (centre, (width / n as f64).max(1.0))
}

/// Successors share the end nodes of both bounds; lanelets whose bounds were
/// drawn with separate nodes are joined when their centrelines meet (0.5 m).
/// A lane that opens from or closes to a point shares one node with the
/// lanelet it branches off or merges into.
fn successors(lanelets: &[Lanelet]) -> Vec<Vec<usize>> {
    let mut by_start: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (i, l) in lanelets.iter().enumerate() {
        by_start.entry(l.start).or_default().push(i);
    }
    let mut successors: Vec<Vec<usize>> = lanelets
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let mut next: Vec<usize> = by_start.get(&l.end).cloned().unwrap_or_default();
            if next.is_empty() {
                next = lanelets
                    .iter()
                    .enumerate()
                    .filter(|(j, m)| {
                        // Not the same lanelet driven back.
                        m.id != l.id && *j != i && dist(m.joins.0, l.joins.1) < 0.5
                    })
                    .map(|(j, _)| j)
                    .collect();
            }
            if next.is_empty() && l.closes() {
                // A lane closing to a point leads into the lanelets that
                // start there: the one it merges into.
                next = lanelets
                    .iter()
                    .enumerate()
                    .filter(|(_, m)| m.id != l.id && has_node(m.start, l.end.0))
                    .map(|(j, _)| j)
                    .collect();
            }
            next.retain(|&j| j != i);
            next
        })
        .collect();
    // A lane opening from a point follows the lanelets that end there: the
    // one it branches off.
    let mut led_into = vec![false; lanelets.len()];
    successors
        .iter()
        .flatten()
        .for_each(|&j| led_into[j] = true);
    for (j, opening) in lanelets.iter().enumerate() {
        if !opening.opens() || led_into[j] {
            continue;
        }
        for (i, l) in lanelets.iter().enumerate() {
            if l.id != opening.id && has_node(l.end, opening.start.0) {
                successors[i].push(j);
            }
        }
    }
    successors
}

fn across_end(centre: &[Xy], width: f64) -> [Point; 2] {
    let (a, b) = (centre[centre.len() - 2], centre[centre.len() - 1]);
    let d = dist(a, b).max(1e-9);
    let (nx, ny) = (
        -(b[1] - a[1]) / d * width / 2.0,
        (b[0] - a[0]) / d * width / 2.0,
    );
    [
        Point([b[0] + nx, b[1] + ny, b[2]]),
        Point([b[0] - nx, b[1] - ny, b[2]]),
    ]
}

/// The direction of `centre` on its segment nearest to `p`. A light's axis is
/// the way its lanelet crosses the stop line: where the light sits on a
/// turning junction lanelet (stop line at its start), its end points where
/// the turn leaves, across the approach.
fn heading_at(centre: &[Xy], p: Xy) -> f64 {
    let nearest = centre
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = (ab[0] * ab[0] + ab[1] * ab[1]).max(1e-12);
            let t = (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0);
            let q = [a[0] + ab[0] * t, a[1] + ab[1] * t, a[2]];
            (dist(p, q), ab)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0));
    nearest.map_or(0.0, |(_, ab)| ab[1].atan2(ab[0]))
}

/// Two phases per intersection: lights whose approach runs along the first
/// light's axis (within 45°) get green first, the crossing axis after them.
fn synthesise_programs(
    lanelets: &[Lanelet],
    lanes: &[LaneDef],
    light_lanes: &BTreeMap<i64, Vec<usize>>,
    warnings: &mut Vec<String>,
) -> Vec<LightGroupDef> {
    if light_lanes.is_empty() {
        return Vec::new();
    }
    let info: Vec<(i64, Xy, f64)> = light_lanes
        .iter()
        .map(|(reg, ls)| {
            let l = &lanelets[ls[0]];
            let stop = lanes[ls[0]].stop_line.unwrap();
            let mid = [0, 1, 2].map(|k| (stop[0].0[k] + stop[1].0[k]) / 2.0);
            (*reg, mid, heading_at(&l.centre, mid))
        })
        .collect();
    // Intersections: lights whose stop lines are near each other, transitively.
    let mut cluster: Vec<usize> = (0..info.len()).collect();
    fn find(c: &mut [usize], i: usize) -> usize {
        if c[i] != i {
            c[i] = find(c, c[i]);
        }
        c[i]
    }
    for i in 0..info.len() {
        for j in i + 1..info.len() {
            if dist(info[i].1, info[j].1) < INTERSECTION_RADIUS {
                let (a, b) = (find(&mut cluster, i), find(&mut cluster, j));
                cluster[a] = b;
            }
        }
    }
    let mut axis: HashMap<usize, f64> = HashMap::new();
    let cycle = 2.0 * (GREEN + YELLOW);
    let groups = info
        .iter()
        .enumerate()
        .map(|(i, (reg, _, heading))| {
            let c = find(&mut cluster, i);
            let reference = *axis.entry(c).or_insert(*heading);
            let d = (heading - reference).rem_euclid(std::f64::consts::PI);
            let across =
                (std::f64::consts::FRAC_PI_4..=3.0 * std::f64::consts::FRAC_PI_4).contains(&d);
            LightGroupDef {
                name: format!("tl_{reg}"),
                program: LightProgram {
                    green: GREEN,
                    yellow: YELLOW,
                    red: cycle - GREEN - YELLOW,
                    offset: if across { GREEN + YELLOW } else { 0.0 },
                },
            }
        })
        .collect();
    let intersections = (0..info.len())
        .filter(|&i| find(&mut cluster, i) == i)
        .count();
    warnings.push(format!(
        "Lanelet2 has no signal timing: {} light(s) at {intersections} intersection(s) got a synthesised two-phase program ({GREEN} s green, {YELLOW} s yellow per approach axis)",
        info.len()
    ));
    groups
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lights_axis_is_the_way_its_lanelet_crosses_the_stop_line() {
        // A left turn from a southbound approach: stop line at its start,
        // leaving eastwards.
        let turn: Vec<Xy> = (0..=16)
            .map(|i| {
                let a = i as f64 / 16.0 * std::f64::consts::FRAC_PI_2;
                [10.0 - 10.0 * a.cos(), -10.0 * a.sin(), 0.0]
            })
            .collect();
        let south = -std::f64::consts::FRAC_PI_2;
        assert!((heading_at(&turn, turn[0]) - south).abs() < 0.1);
        // The approach lanelet itself, stop line at its end.
        let approach = [[0.0, 30.0, 0.0], [0.0, 15.0, 0.0], [0.0, 0.0, 0.0]];
        assert!((heading_at(&approach, approach[2]) - south).abs() < 1e-9);
        // At the turn's end it leaves eastwards.
        assert!(heading_at(&turn, turn[16]).abs() < 0.1);
    }

    /// An OSM file with local metric nodes (id, x, y), ways (id, nodes) and
    /// lanelets (id, left way, right way, one_way).
    fn osm(
        nodes: &[(i64, f64, f64)],
        ways: &[(i64, &[i64])],
        lanelets: &[(i64, i64, i64, &str)],
    ) -> String {
        let mut x = String::from("<?xml version='1.0'?><osm version='0.6'>");
        for (id, lx, ly) in nodes {
            x += &format!(
                "<node id='{id}' lat='0' lon='0'><tag k='local_x' v='{lx}'/><tag k='local_y' v='{ly}'/></node>"
            );
        }
        for (id, nds) in ways {
            x += &format!("<way id='{id}'>");
            for n in *nds {
                x += &format!("<nd ref='{n}'/>");
            }
            x += "</way>";
        }
        for (id, left, right, one_way) in lanelets {
            x += &format!(
                "<relation id='{id}'><member type='way' ref='{left}' role='left'/>\
                 <member type='way' ref='{right}' role='right'/><tag k='type' v='lanelet'/>\
                 <tag k='subtype' v='road'/><tag k='one_way' v='{one_way}'/></relation>"
            );
        }
        x + "</osm>"
    }

    fn lane<'a>(imported: &'a Imported, name: &str) -> &'a LaneDef {
        imported.map.lanes.iter().find(|l| l.name == name).unwrap()
    }

    #[test]
    fn bounds_drawn_against_the_lanelet_are_turned_as_lanelet2_turns_them() {
        // Two lanelets eastwards along y = 0 (left bound at y = 1.5, right at
        // y = -1.5); the second has both bounds drawn westwards.
        let nodes = [
            (1, 0.0, 1.5),
            (2, 10.0, 1.5),
            (3, 0.0, -1.5),
            (4, 10.0, -1.5),
            (5, 20.0, 1.5),
            (6, 20.0, -1.5),
        ];
        let ways: [(i64, &[i64]); 4] = [(10, &[1, 2]), (11, &[3, 4]), (12, &[5, 2]), (13, &[6, 4])];
        let text = osm(&nodes, &ways, &[(100, 10, 11, "yes"), (101, 12, 13, "yes")]);
        let imported = import("t", &text).unwrap();
        let second = lane(&imported, "ll_101");
        assert!(
            second.waypoints[0].0[0] < second.waypoints[1].0[0],
            "runs east"
        );
        assert_eq!(lane(&imported, "ll_100").next, vec!["ll_101".to_string()]);
    }

    #[test]
    fn a_lane_opening_beside_another_follows_the_lane_it_branches_off() {
        // One lane eastwards (y from -1.5 to 1.5) to x = 20, then two: the
        // first carries on, a second opens on its left from the point
        // (20, 1.5) to full width (y from 1.5 to 4.5) at x = 40.
        let nodes = [
            (1, 0.0, 1.5),
            (2, 20.0, 1.5),
            (3, 0.0, -1.5),
            (4, 20.0, -1.5),
            (5, 40.0, 1.5),
            (6, 40.0, -1.5),
            (7, 40.0, 4.5),
        ];
        let ways: [(i64, &[i64]); 5] = [
            (10, &[1, 2]),
            (11, &[3, 4]),
            (12, &[2, 5]),
            (13, &[4, 6]),
            (14, &[2, 7]),
        ];
        let text = osm(
            &nodes,
            &ways,
            &[
                (100, 10, 11, "yes"),
                (101, 12, 13, "yes"),
                (102, 14, 12, "yes"),
            ],
        );
        let imported = import("t", &text).unwrap();
        let mut next = lane(&imported, "ll_100").next.clone();
        next.sort();
        assert_eq!(next, ["ll_101", "ll_102"], "both lanes follow the first");
        let opening = lane(&imported, "ll_102");
        assert!(
            (opening.width - 3.0).abs() < 1e-9,
            "as wide as its wide end"
        );
        // Its centreline leaves from the middle of the lane it follows and
        // ends in its own middle.
        let (first, last) = (opening.waypoints[0].0, opening.waypoints.last().unwrap().0);
        assert!((first[0] - 20.0).abs() < 1e-9 && first[1].abs() < 1e-9);
        assert!((last[0] - 40.0).abs() < 1e-9 && (last[1] - 3.0).abs() < 1e-9);
        // Only the first lane is where vehicles enter the map.
        let Some(trafficmesh_model::map::SimulatorDef::Random { lanes, .. }) =
            imported.map.traffic_simulators.first()
        else {
            panic!("a random simulator");
        };
        assert_eq!(lanes, &["ll_100"]);
    }

    #[test]
    fn a_two_way_lanelet_is_a_lane_each_way_on_its_own_half() {
        // A 6 m wide two-way lanelet eastwards, then a one-way one carrying on east.
        let nodes = [
            (1, 0.0, 3.0),
            (2, 40.0, 3.0),
            (3, 0.0, -3.0),
            (4, 40.0, -3.0),
            (5, 80.0, 3.0),
            (6, 80.0, -3.0),
        ];
        let ways: [(i64, &[i64]); 4] = [(10, &[1, 2]), (11, &[3, 4]), (12, &[2, 5]), (13, &[4, 6])];
        let text = osm(&nodes, &ways, &[(100, 10, 11, "no"), (101, 12, 13, "yes")]);
        let imported = import("t", &text).unwrap();
        let (east, west) = (lane(&imported, "ll_100"), lane(&imported, "ll_100_r"));
        assert!((east.width - 3.0).abs() < 1e-9 && (west.width - 3.0).abs() < 1e-9);
        // Keeping right: eastwards south of the middle, westwards north of it.
        assert!(east.waypoints.iter().all(|p| (p.0[1] + 1.5).abs() < 1e-9));
        assert!(west.waypoints.iter().all(|p| (p.0[1] - 1.5).abs() < 1e-9));
        assert!(west.waypoints[0].0[0] > west.waypoints[1].0[0], "runs west");
        // Only the eastward way leads on into the one-way lanelet, which eases
        // from that half onto its own middle.
        assert_eq!(east.next, vec!["ll_101".to_string()]);
        assert!(west.next.is_empty());
        let on = lane(&imported, "ll_101");
        assert!(
            (on.waypoints[0].0[1] + 1.5).abs() < 1e-9,
            "starts on the half"
        );
        assert!(
            on.waypoints.last().unwrap().0[1].abs() < 1e-9,
            "ends in its middle"
        );
        let steps = on
            .waypoints
            .windows(2)
            .map(|w| (w[1].0[1] - w[0].0[1]).abs() / (w[1].0[0] - w[0].0[0]));
        assert!(steps.fold(0.0, f64::max) < 0.3, "eased, not kinked");
    }

    #[test]
    fn lanes_entering_a_roundabout_yield_to_the_ring() {
        // A small roundabout, and a large one (54 m across, as
        // mapping_example's, its ring's lanelets 21 m long).
        for radius in [8.0, 27.0] {
            lanes_entering_a_ring_yield_to_it(radius);
        }
    }

    fn lanes_entering_a_ring_yield_to_it(radius: f64) {
        // A ring of eight arcs anticlockwise round the origin (bounds 1.5 m
        // inside and outside `radius`; nodes 1.. inside, 101.. outside), and
        // an entry from the east that joins it at the top.
        let (inner, outer) = (radius - 1.5, radius + 1.5);
        let at = |r: f64, k: usize| {
            let a = k as f64 * std::f64::consts::FRAC_PI_8;
            (r * a.cos(), r * a.sin())
        };
        let mut nodes: Vec<(i64, f64, f64)> = Vec::new();
        for k in 0..16 {
            let ((ix, iy), (ox, oy)) = (at(inner, k), at(outer, k));
            nodes.push((1 + k as i64, ix, iy));
            nodes.push((101 + k as i64, ox, oy));
        }
        nodes.extend([(201, radius + 12.0, inner), (202, radius + 12.0, outer)]);
        let eighth = |q: usize, base: i64| -> Vec<i64> {
            (2 * q..=2 * q + 2)
                .map(|k| base + (k % 16) as i64)
                .collect()
        };
        let bounds: Vec<(i64, Vec<i64>)> = (0..8)
            .flat_map(|q| {
                [
                    (10 + q as i64, eighth(q, 1)),
                    (20 + q as i64, eighth(q, 101)),
                ]
            })
            .chain([(30, vec![201, 5]), (31, vec![202, 105])])
            .collect();
        let ways: Vec<(i64, &[i64])> = bounds.iter().map(|(id, n)| (*id, n.as_slice())).collect();
        let lanelets: Vec<(i64, i64, i64, &str)> = (0..8)
            .map(|q| (100 + q, 10 + q, 20 + q, "yes"))
            .chain([(200, 30, 31, "yes")])
            .collect();
        let imported = import("t", &osm(&nodes, &ways, &lanelets)).unwrap();
        assert!(
            imported
                .warnings
                .iter()
                .any(|w| w.starts_with("1 roundabout(s) found")),
            "radius {radius}: {:?}",
            imported.warnings
        );
        assert_eq!(lane(&imported, "ll_200").next, vec!["ll_102".to_string()]);
        assert_eq!(
            lane(&imported, "ll_200").right_of_way,
            vec!["ll_101".to_string()]
        );
        for q in 100..108 {
            assert!(lane(&imported, &format!("ll_{q}")).right_of_way.is_empty());
        }
    }

    #[test]
    fn a_turn_is_driven_as_fast_as_its_bend_allows() {
        // A quarter circle of 10 m radius, a point every metre of arc.
        let arc: Vec<Xy> = (0..=16)
            .map(|i| {
                let a = i as f64 / 16.0 * std::f64::consts::FRAC_PI_2;
                [10.0 * a.cos(), 10.0 * a.sin(), 0.0]
            })
            .collect();
        let v = turn_speed(&arc);
        assert!((v - (5.5f64 * 10.0).sqrt()).abs() < 0.2, "{v}");
        // A straight line, even with points a few centimetres apart, has none.
        let line: Vec<Xy> = (0..50).map(|i| [i as f64 * 0.05, 0.0, 0.0]).collect();
        assert!(turn_speed(&line).is_infinite());
    }
}
