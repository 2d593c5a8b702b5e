//! SUMO `.net.xml` import: lanes (normal and internal) with their shapes,
//! widths and speeds; connections as next links (through their `via` internal
//! lanes) with turn directions; static `tlLogic` programs as one light group per
//! signal link; right of way from each junction's `request` response bits;
//! pedestrian crossings as crosswalk areas, stopping the lanes that enter them.
//!
//! Coordinates stay in the network's frame (SUMO has already applied
//! `netOffset`; the offset is kept in the map's name for the record).

use std::collections::{BTreeMap, HashMap};

use roxmltree::{Document, Node};
use trafficmesh_model::enums::TurnDirection;
use trafficmesh_model::map::{
    CrosswalkArea, CrosswalkDef, LaneDef, LightGroupDef, LightProgram, Point, RoadConflicts,
};

use crate::import::{ImportError, Imported, assemble, attr, attr_f64, parse_xml};

/// Lanes narrower than this are kept at it (SUMO's default lane width is 3.2 m).
const DEFAULT_WIDTH: f64 = 3.2;
/// Shorter lanes (SUMO's zero-length internal lanes) are stretched to it.
const MIN_LANE_LENGTH: f64 = 0.15;
/// SUMO's default crossing width.
const DEFAULT_CROSSING_WIDTH: f64 = 4.0;

struct Connection {
    from: String,
    to: String,
    via: Option<String>,
    tl: Option<String>,
    link_index: Option<usize>,
    dir: String,
}

pub struct Phase {
    duration: f64,
    state: Vec<char>,
}

pub fn import(name: &str, text: &str) -> Result<Imported, ImportError> {
    import_with_programs(name, text, Programs::new())
}

/// As [`import`], with `tlLogic` programs read from additional files that
/// replace the network's of the same id (as SUMO runs the last one loaded).
pub fn import_with_programs(
    name: &str,
    text: &str,
    replacements: Programs,
) -> Result<Imported, ImportError> {
    let doc = parse_xml(text, "net", "SUMO network")?;
    let net = doc.root_element();
    let mut warnings = Vec::new();
    let offset = net
        .children()
        .find(|n| n.has_tag_name("location"))
        .and_then(|l| l.attribute("netOffset"))
        .unwrap_or("0,0");

    // Lanes of vehicle edges; crossings and walking areas are the pedestrians' own.
    let mut lanes: Vec<LaneDef> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    let mut skipped_pedestrian = 0;
    let mut crossings: Vec<Node> = Vec::new();
    let mut walking_areas = 0;
    for edge in net.children().filter(|n| n.has_tag_name("edge")) {
        let function = edge.attribute("function").unwrap_or("normal");
        match function {
            "crossing" => {
                crossings.push(edge);
                continue;
            }
            "walkingarea" => {
                walking_areas += 1;
                continue;
            }
            _ => {}
        }
        for lane in edge.children().filter(|n| n.has_tag_name("lane")) {
            let Some(vehicle_classes) = motor_permissions(lane) else {
                skipped_pedestrian += 1;
                continue;
            };
            let id = attr(&doc, lane, "id")?.to_string();
            let waypoints = shape(&doc, lane)?;
            index.insert(id.clone(), lanes.len());
            lanes.push(LaneDef {
                name: id,
                waypoints,
                width: lane
                    .attribute("width")
                    .map(|_| attr_f64(&doc, lane, "width"))
                    .transpose()?
                    .unwrap_or(DEFAULT_WIDTH),
                speed_limit: attr_f64(&doc, lane, "speed")?,
                next: Vec::new(),
                prev: Vec::new(),
                intersection: function == "internal",
                turn_direction: TurnDirection::Straight,
                stop_line: None,
                traffic_light: None,
                right_of_way: Vec::new(),
                vehicle_classes,
                crosses_apart: Vec::new(),
            });
        }
    }
    if skipped_pedestrian > 0 {
        warnings.push(format!(
            "{skipped_pedestrian} lane(s) closed to motor vehicles (sidewalks, bike lanes, rails) not imported"
        ));
    }
    if walking_areas > 0 {
        warnings.push(format!(
            "{walking_areas} walking area(s) not imported (pedestrians only; crossings are)"
        ));
    }

    // U-turns (`dir="t"`, netconvert adds them at every dead end) are left out:
    // without them a vehicle leaves the map where its road ends, as a SUMO
    // vehicle does at the end of its route.
    let (connections, turnarounds): (Vec<Connection>, Vec<Connection>) = connections(&doc, net)?
        .into_iter()
        .partition(|c| c.dir != "t");
    if !turnarounds.is_empty() {
        warnings.push(format!(
            "{} U-turn connection(s) not imported",
            turnarounds.len()
        ));
    }
    let mut links: Vec<(String, String)> = Vec::new();
    // Lanes no other road leads into: where traffic comes in from outside.
    let mut entered: Vec<bool> = vec![false; lanes.len()];
    for c in &connections {
        let next = c.via.clone().unwrap_or_else(|| c.to.clone());
        links.push((c.from.clone(), next.clone()));
        if !c.from.starts_with(':') {
            for l in [Some(&next), Some(&c.to)].into_iter().flatten() {
                if let Some(&i) = index.get(l) {
                    entered[i] = true;
                }
            }
        }
        if let Some(via) = &c.via
            && let Some(&v) = index.get(via)
        {
            lanes[v].turn_direction = match c.dir.as_str() {
                "l" | "L" | "t" => TurnDirection::Left,
                "r" | "R" => TurnDirection::Right,
                _ => TurnDirection::Straight,
            };
        }
    }
    for (from, to) in &links {
        if let (Some(&f), true) = (index.get(from), index.contains_key(to))
            && !lanes[f].next.contains(to)
        {
            lanes[f].next.push(to.clone());
        }
    }
    stretch_degenerate(&mut lanes, &index, &links);
    let switchbacks = crate::joints::cut_switchbacks(&mut lanes, &index, &links);
    if switchbacks > 0 {
        warnings.push(format!(
            "{switchbacks} lane joint(s) where the next lane starts heading back moved back along both lanes, to a corner a car can drive"
        ));
    }

    let apart = crate::sumo_levels::mark_crossings_apart(net, &index, &mut lanes);
    if apart > 0 {
        warnings.push(format!(
            "{apart} pair(s) of lanes cross with no junction between them: taken as a bridge over the other (as SUMO does), vehicles on the two never meet"
        ));
    }

    let mut programs = tl_programs(&doc, net, &mut warnings)?;
    programs.extend(replacements);
    let light_groups = lights(&programs, &connections, &index, &mut lanes, &mut warnings)?;
    right_of_way(&doc, net, &index, &programs, &connections, &mut lanes)?;
    let crosswalks = crosswalks(&doc, &crossings, &lanes, &mut warnings)?;

    // Vehicles enter where no other road leads in (SUMO demand comes from route
    // files; without one, the map's random simulator spawns at these lanes).
    Ok(assemble(
        format!("{name} (SUMO network, netOffset {offset})"),
        lanes,
        light_groups,
        crosswalks,
        |i| !entered[i],
        // Internal lanes make up every junction, but the streets of a real
        // net may lie closer than two trucks need to pass each other.
        RoadConflicts::Opposing,
        warnings,
    ))
}

/// Each crossing's lane (its centreline across the road and its width) as a
/// rectangular crosswalk area, named after the crossing edge, with a stop point
/// on every vehicle lane that enters it.
fn crosswalks(
    doc: &Document,
    crossings: &[Node],
    lanes: &[LaneDef],
    warnings: &mut Vec<String>,
) -> Result<Vec<CrosswalkDef>, ImportError> {
    let centrelines: Vec<Vec<[f64; 3]>> = lanes
        .iter()
        .map(|l| l.waypoints.iter().map(|p| p.0).collect())
        .collect();
    let mut out = Vec::new();
    for edge in crossings {
        let id = attr(doc, *edge, "id")?;
        let Some(lane) = edge.children().find(|n| n.has_tag_name("lane")) else {
            return Err(ImportError::at(
                doc,
                *edge,
                &format!("crossing '{id}' has no lane"),
            ));
        };
        let line = shape(doc, lane)?;
        if line.len() < 2 {
            return Err(ImportError::at(
                doc,
                lane,
                &format!("crossing '{id}': its shape needs two points"),
            ));
        }
        let width = lane
            .attribute("width")
            .map(|_| attr_f64(doc, lane, "width"))
            .transpose()?
            .unwrap_or(DEFAULT_CROSSING_WIDTH);
        let polygon = band(&line, width);
        let stop_points = crate::crossing::stop_points(
            &polygon.iter().map(|p| p.0).collect::<Vec<_>>(),
            centrelines.iter().map(Vec::as_slice),
        );
        if stop_points.is_empty() {
            warnings.push(format!(
                "crossing '{id}': no vehicle lane enters it; it stops nobody"
            ));
        }
        out.push(CrosswalkDef {
            name: id.to_string(),
            area: CrosswalkArea::Polygon { points: polygon },
            stop_points,
            max_detection_distance: 40.0,
            forward_angle_tolerance_deg: 80.0,
            stop_buffer: 1.5,
            enable_debug_logs: false,
            config: None,
        });
    }
    Ok(out)
}

/// The band of `width` around a polyline (its two sides, one reversed).
fn band(line: &[Point], width: f64) -> Vec<Point> {
    let half = width / 2.0;
    let side = |sign: f64| -> Vec<Point> {
        line.iter()
            .enumerate()
            .map(|(i, p)| {
                let (a, b) = if i + 1 < line.len() {
                    (line[i], line[i + 1])
                } else {
                    (line[i - 1], line[i])
                };
                let (dx, dy) = (b.0[0] - a.0[0], b.0[1] - a.0[1]);
                let n = dx.hypot(dy).max(1e-9);
                Point([
                    p.0[0] - dy / n * half * sign,
                    p.0[1] + dx / n * half * sign,
                    p.0[2],
                ])
            })
            .collect()
    };
    let mut polygon = side(1.0);
    polygon.extend(side(-1.0).into_iter().rev());
    polygon
}

/// SUMO's vehicle classes of motor vehicles on roads: the ones simulated.
const MOTOR_CLASSES: [&str; 18] = [
    "private",
    "emergency",
    "authority",
    "army",
    "vip",
    "passenger",
    "hov",
    "taxi",
    "bus",
    "coach",
    "delivery",
    "truck",
    "trailer",
    "motorcycle",
    "moped",
    "evehicle",
    "custom1",
    "custom2",
];

/// The motor vehicle classes a lane allows, from SUMO's `allow` or
/// `disallow`: empty when it allows them all, None when it allows none of them
/// (a sidewalk, a bike lane, rails).
fn motor_permissions(lane: Node) -> Option<Vec<String>> {
    let listed = |name: &str| {
        lane.attribute(name)
            .map(|a| a.split_whitespace().collect::<Vec<_>>())
    };
    let allowed: Vec<&str> = match (listed("allow"), listed("disallow")) {
        (Some(allow), _) if allow.contains(&"all") => return Some(Vec::new()),
        (Some(allow), _) => MOTOR_CLASSES
            .into_iter()
            .filter(|c| allow.contains(c))
            .collect(),
        (None, Some(disallow)) if disallow.contains(&"all") => Vec::new(),
        (None, Some(disallow)) => MOTOR_CLASSES
            .into_iter()
            .filter(|c| !disallow.contains(c))
            .collect(),
        (None, None) => return Some(Vec::new()),
    };
    match allowed.len() {
        0 => None,
        n if n == MOTOR_CLASSES.len() => Some(Vec::new()),
        _ => Some(allowed.into_iter().map(str::to_string).collect()),
    }
}

/// `x,y[,z] x,y[,z] ...`, consecutive duplicates dropped.
fn shape(doc: &Document, lane: Node) -> Result<Vec<Point>, ImportError> {
    let text = attr(doc, lane, "shape")?;
    let mut points: Vec<Point> = Vec::new();
    for pair in text.split_whitespace() {
        let coords: Vec<f64> = pair
            .split(',')
            .map(|c| c.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| {
                ImportError::at(
                    doc,
                    lane,
                    &format!("attribute 'shape': '{pair}' is not x,y or x,y,z"),
                )
            })?;
        let p = match coords[..] {
            [x, y] => Point([x, y, 0.0]),
            [x, y, z] => Point([x, y, z]),
            _ => {
                return Err(ImportError::at(
                    doc,
                    lane,
                    &format!("attribute 'shape': '{pair}' is not x,y or x,y,z"),
                ));
            }
        };
        if points.last() != Some(&p) {
            points.push(p);
        }
    }
    if points.is_empty() {
        return Err(ImportError::at(
            doc,
            lane,
            "attribute 'shape' has no points",
        ));
    }
    Ok(points)
}

/// SUMO writes zero-length internal lanes (a shape of one repeated point): give
/// them a minimal length along the lane that leads into them.
fn stretch_degenerate(
    lanes: &mut [LaneDef],
    index: &HashMap<String, usize>,
    links: &[(String, String)],
) {
    for i in 0..lanes.len() {
        if lanes[i].length() >= MIN_LANE_LENGTH {
            continue;
        }
        let name = lanes[i].name.clone();
        let heading = links
            .iter()
            .find(|(_, to)| *to == name)
            .and_then(|(from, _)| index.get(from))
            .and_then(|&f| {
                let w = &lanes[f].waypoints;
                let (a, b) = (w[w.len().saturating_sub(2)], w[w.len() - 1]);
                let (dx, dy) = (b.0[0] - a.0[0], b.0[1] - a.0[1]);
                let n = (dx * dx + dy * dy).sqrt();
                (n > 1e-9).then(|| (dx / n, dy / n))
            })
            .unwrap_or((1.0, 0.0));
        let start = lanes[i].waypoints[0];
        lanes[i].waypoints = vec![
            start,
            Point([
                start.0[0] + heading.0 * MIN_LANE_LENGTH,
                start.0[1] + heading.1 * MIN_LANE_LENGTH,
                start.0[2],
            ]),
        ];
    }
}

fn connections(doc: &Document, net: Node) -> Result<Vec<Connection>, ImportError> {
    let mut out = Vec::new();
    for c in net.children().filter(|n| n.has_tag_name("connection")) {
        let from = format!("{}_{}", attr(doc, c, "from")?, attr(doc, c, "fromLane")?);
        let to = format!("{}_{}", attr(doc, c, "to")?, attr(doc, c, "toLane")?);
        let link_index = match c.attribute("linkIndex") {
            Some(i) => Some(i.parse::<usize>().map_err(|_| {
                ImportError::at(
                    doc,
                    c,
                    &format!("attribute 'linkIndex': '{i}' is not a link number"),
                )
            })?),
            None => None,
        };
        out.push(Connection {
            from,
            to,
            via: c.attribute("via").map(String::from),
            tl: c.attribute("tl").map(String::from),
            link_index,
            dir: c.attribute("dir").unwrap_or("s").to_string(),
        });
    }
    Ok(out)
}

/// One light group per signal link (`<tl>_<linkIndex>`), its program read from
/// the link's column of the phase states: its green, yellow and red times per
/// cycle and where its green starts.
pub type Programs = BTreeMap<String, (f64, Vec<Phase>)>;

/// Every `tlLogic` under `net` (a network or an additional file's root): its
/// offset and phases (the first program of an id).
pub fn tl_programs(
    doc: &Document,
    net: Node,
    warnings: &mut Vec<String>,
) -> Result<Programs, ImportError> {
    let mut programs: Programs = BTreeMap::new();
    for tl in net.children().filter(|n| n.has_tag_name("tlLogic")) {
        let id = attr(doc, tl, "id")?.to_string();
        if programs.contains_key(&id) {
            warnings.push(format!(
                "tlLogic '{id}': a second program is ignored (the first one runs)"
            ));
            continue;
        }
        if let Some(kind) = tl.attribute("type").filter(|t| *t != "static") {
            warnings.push(format!(
                "tlLogic '{id}': type '{kind}' run as a fixed-time program"
            ));
        }
        let offset = tl
            .attribute("offset")
            .map(|_| attr_f64(doc, tl, "offset"))
            .transpose()?
            .unwrap_or(0.0);
        let mut phases = Vec::new();
        for p in tl.children().filter(|n| n.has_tag_name("phase")) {
            phases.push(Phase {
                duration: attr_f64(doc, p, "duration")?,
                state: attr(doc, p, "state")?.chars().collect(),
            });
        }
        if phases.is_empty() || phases.iter().map(|p| p.duration).sum::<f64>() <= 0.0 {
            return Err(ImportError::at(
                doc,
                tl,
                &format!("tlLogic '{id}' has no phase with a duration"),
            ));
        }
        programs.insert(id, (offset, phases));
    }
    Ok(programs)
}

fn lights(
    programs: &Programs,
    connections: &[Connection],
    index: &HashMap<String, usize>,
    lanes: &mut [LaneDef],
    warnings: &mut Vec<String>,
) -> Result<Vec<LightGroupDef>, ImportError> {
    let mut groups: BTreeMap<String, LightGroupDef> = BTreeMap::new();
    for c in connections {
        let (Some(tl), Some(link)) = (&c.tl, c.link_index) else {
            continue;
        };
        let Some((offset, phases)) = programs.get(tl) else {
            warnings.push(format!(
                "connection {} -> {}: tlLogic '{tl}' not found; unsignalised",
                c.from, c.to
            ));
            continue;
        };
        let name = format!("{tl}_{link}");
        if !groups.contains_key(&name) {
            let program = link_program(tl, link, *offset, phases, warnings).ok_or_else(|| {
                ImportError::plain(format!(
                    "tlLogic '{tl}': link {link} is beyond its state strings"
                ))
            })?;
            groups.insert(
                name.clone(),
                LightGroupDef {
                    name: name.clone(),
                    program,
                },
            );
        }
        // The signal stops traffic before the junction: at the start of the
        // internal lane of this link, or at the end of the incoming lane.
        let (lane, at_start) = match &c.via {
            Some(via) if index.contains_key(via) => (index[via], true),
            _ => match index.get(&c.from) {
                Some(&f) => (f, false),
                None => continue,
            },
        };
        let l = &mut lanes[lane];
        if l.traffic_light.as_ref().is_some_and(|g| *g != name) {
            warnings.push(format!(
                "lane '{}': controlled by two signal links; keeps '{}'",
                l.name,
                l.traffic_light.as_ref().unwrap()
            ));
            continue;
        }
        l.traffic_light = Some(name);
        l.stop_line = Some(across(&l.waypoints, l.width, at_start));
    }
    Ok(groups.into_values().collect())
}

/// Two points across the lane at its start or end.
fn across(points: &[Point], width: f64, at_start: bool) -> [Point; 2] {
    let (a, b, p) = if at_start {
        (points[0], points[1], points[0])
    } else {
        (
            points[points.len() - 2],
            points[points.len() - 1],
            points[points.len() - 1],
        )
    };
    let (dx, dy) = (b.0[0] - a.0[0], b.0[1] - a.0[1]);
    let n = (dx * dx + dy * dy).sqrt().max(1e-9);
    let (nx, ny) = (-dy / n * width / 2.0, dx / n * width / 2.0);
    [
        Point([p.0[0] + nx, p.0[1] + ny, p.0[2]]),
        Point([p.0[0] - nx, p.0[1] - ny, p.0[2]]),
    ]
}

#[derive(Clone, Copy, PartialEq)]
enum Signal {
    Go,
    Amber,
    Stop,
}

/// The fixed-time program of one link: green, yellow, red totals and the time
/// its green starts. SUMO's `g` (green, must yield) counts as green: the
/// junction's response bits make it yield. Several green periods per cycle are
/// merged (warned).
fn link_program(
    tl: &str,
    link: usize,
    offset: f64,
    phases: &[Phase],
    warnings: &mut Vec<String>,
) -> Option<LightProgram> {
    let mut seq = Vec::new();
    for p in phases {
        let c = *p.state.get(link)?;
        let s = match c {
            'G' | 'g' | 'o' | 'O' => Signal::Go,
            'y' | 'Y' | 'u' => Signal::Amber,
            _ => Signal::Stop,
        };
        seq.push((s, p.duration));
    }
    let total = |s: Signal| {
        seq.iter()
            .filter(|(x, _)| *x == s)
            .map(|(_, d)| d)
            .sum::<f64>()
    };
    let (green, yellow, red) = (total(Signal::Go), total(Signal::Amber), total(Signal::Stop));
    let cycle = green + yellow + red;
    // Green starts at the first go phase that follows a non-go phase (cyclically).
    let n = seq.len();
    let starts: Vec<usize> = (0..n)
        .filter(|&i| seq[i].0 == Signal::Go && seq[(i + n - 1) % n].0 != Signal::Go)
        .collect();
    if starts.len() > 1 {
        warnings.push(format!(
            "tlLogic '{tl}' link {link}: {} green periods per cycle merged into one of {green} s",
            starts.len()
        ));
    }
    let start_phase = starts.first().copied().unwrap_or(0);
    let start: f64 = seq[..start_phase].iter().map(|(_, d)| d).sum();
    Some(LightProgram {
        green,
        yellow,
        red,
        offset: (start - offset).rem_euclid(cycle.max(1e-9)) + 0.0,
    })
}

/// `<junction intLanes=... ><request index response .../>`: bit j of link i's
/// response (counted from the right) set means link i yields to link j. At a
/// signalised junction that matters only where both links can be green at
/// once (SUMO's permissive `g` turns); elsewhere the lights keep them apart.
fn right_of_way(
    doc: &Document,
    net: Node,
    index: &HashMap<String, usize>,
    programs: &Programs,
    connections: &[Connection],
    lanes: &mut [LaneDef],
) -> Result<(), ImportError> {
    let signal_of: HashMap<&str, (&str, usize)> = connections
        .iter()
        .filter_map(|c| Some((c.via.as_deref()?, (c.tl.as_deref()?, c.link_index?))))
        .collect();
    let green_together = |a: &str, b: &str| -> bool {
        let (Some(&(ta, la)), Some(&(tb, lb))) = (signal_of.get(a), signal_of.get(b)) else {
            return true;
        };
        let Some((_, phases)) = programs.get(ta).filter(|_| ta == tb) else {
            return true;
        };
        let go = |c: Option<&char>| matches!(c, Some('G' | 'g'));
        phases
            .iter()
            .any(|p| go(p.state.get(la)) && go(p.state.get(lb)))
    };
    for j in net.children().filter(|n| n.has_tag_name("junction")) {
        if j.attribute("type") == Some("internal") {
            continue;
        }
        let internal: Vec<&str> = j
            .attribute("intLanes")
            .unwrap_or("")
            .split_whitespace()
            .collect();
        for r in j.children().filter(|n| n.has_tag_name("request")) {
            let i: usize = attr(doc, r, "index")?
                .parse()
                .map_err(|_| ImportError::at(doc, r, "attribute 'index' is not a number"))?;
            let response: Vec<char> = attr(doc, r, "response")?.chars().collect();
            let Some(&own) = internal.get(i).and_then(|l| index.get(*l)) else {
                continue;
            };
            for (k, bit) in response.iter().rev().enumerate() {
                if *bit != '1' {
                    continue;
                }
                let Some(other) = internal.get(k) else {
                    continue;
                };
                if index.contains_key(*other)
                    && green_together(internal[i], other)
                    && !lanes[own].right_of_way.iter().any(|x| x == other)
                {
                    lanes[own].right_of_way.push(other.to_string());
                }
            }
        }
    }
    Ok(())
}
