//! Roads that cross with no junction between them. SUMO builds a junction
//! wherever two roads meet at one level; where a road's lanes cross another
//! road, or pass through a junction, with no junction shared, the one passes
//! over the other (a bridge, a tunnel) and SUMO's vehicles on the two never
//! meet. The importer lists such pairs in `crosses_apart`, so that bodies
//! there are not taken for bodies in each other's way.

use std::collections::{BTreeSet, HashMap};

use glam::DVec2;
use roxmltree::Node;
use trafficmesh_model::geometry::{point_in_polygon, segments_intersect};
use trafficmesh_model::map::LaneDef;

/// Side of the grid cells that find the segments near each other, metres.
const CELL: f64 = 25.0;
const MAX_CELLS: i64 = 1_000;

/// A junction: its id and its outline (fewer than three points: none).
struct Junction<'a> {
    id: &'a str,
    outline: Vec<DVec2>,
}

/// Fills `crosses_apart` (on the first lane of each pair, in the lanes'
/// order) and returns how many pairs of lanes cross at different levels.
pub fn mark_crossings_apart(
    net: Node,
    index: &HashMap<String, usize>,
    lanes: &mut [LaneDef],
) -> usize {
    // The junctions each lane touches: a road's two ends, an internal lane's own.
    let mut touches: Vec<Vec<&str>> = vec![Vec::new(); lanes.len()];
    for edge in net.children().filter(|n| n.has_tag_name("edge")) {
        let (Some(from), Some(to)) = (edge.attribute("from"), edge.attribute("to")) else {
            continue;
        };
        for lane in edge.children().filter(|n| n.has_tag_name("lane")) {
            if let Some(&i) = lane.attribute("id").and_then(|id| index.get(id)) {
                touches[i] = vec![from, to];
            }
        }
    }
    let mut junctions: Vec<Junction> = Vec::new();
    for j in net.children().filter(|n| n.has_tag_name("junction")) {
        let Some(id) = j.attribute("id") else {
            continue;
        };
        if j.attribute("type") == Some("internal") {
            continue;
        }
        for lane in j.attribute("intLanes").unwrap_or("").split_whitespace() {
            if let Some(&i) = index.get(lane) {
                touches[i] = vec![id];
            }
        }
        junctions.push(Junction {
            id,
            outline: outline(j.attribute("shape").unwrap_or("")),
        });
    }
    let lines: Vec<Vec<DVec2>> = lanes
        .iter()
        .map(|l| {
            l.waypoints
                .iter()
                .map(|p| DVec2::new(p.0[0], p.0[1]))
                .collect()
        })
        .collect();
    let apart_ends = |a: usize, b: usize| {
        !touches[a].is_empty()
            && !touches[b].is_empty()
            && touches[a].iter().all(|j| !touches[b].contains(j))
    };

    let mut cells: HashMap<(i64, i64), Vec<(usize, usize)>> = HashMap::new();
    for (lane, line) in lines.iter().enumerate() {
        for (k, seg) in line.windows(2).enumerate() {
            for cell in cells_of(seg[0].min(seg[1]), seg[0].max(seg[1])) {
                cells.entry(cell).or_default().push((lane, k));
            }
        }
    }
    // Bodies on one lane of a street (both ways of it) reach over the
    // others: the street, or the junction, is what crosses apart.
    let mut groups: Vec<Vec<&str>> = Vec::new();
    let mut group_of: Vec<usize> = Vec::with_capacity(lanes.len());
    let mut group_index: HashMap<Vec<&str>, usize> = HashMap::new();
    for js in &touches {
        let mut key = js.clone();
        key.sort_unstable();
        let next = groups.len();
        let g = *group_index.entry(key.clone()).or_insert(next);
        if g == next {
            groups.push(key);
        }
        group_of.push(g);
    }
    let mut apart: BTreeSet<(usize, usize)> = BTreeSet::new();
    let mut through: BTreeSet<(usize, &str)> = BTreeSet::new();
    // Streets crossing streets, or a junction's internal lanes.
    for segments in cells.values() {
        for (n, &(a, i)) in segments.iter().enumerate() {
            for &(b, k) in &segments[n + 1..] {
                if (lanes[a].intersection && lanes[b].intersection) || !apart_ends(a, b) {
                    continue;
                }
                let (p, q) = (&lines[a], &lines[b]);
                if !segments_intersect(p[i], p[i + 1], q[k], q[k + 1]) {
                    continue;
                }
                match (lanes[a].intersection, lanes[b].intersection) {
                    (true, _) => through.insert((group_of[b], touches[a][0])),
                    (_, true) => through.insert((group_of[a], touches[b][0])),
                    _ => apart.insert(ordered(group_of[a], group_of[b])),
                };
            }
        }
    }
    // Streets through a junction they do not touch.
    for junction in junctions.iter().filter(|j| j.outline.len() >= 3) {
        let (lo, hi) = junction
            .outline
            .iter()
            .fold((DVec2::MAX, DVec2::MIN), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        for cell in cells_of(lo, hi) {
            for &(lane, k) in cells.get(&cell).map_or(&[][..], Vec::as_slice) {
                if lanes[lane].intersection
                    || touches[lane].is_empty()
                    || touches[lane].contains(&junction.id)
                {
                    continue;
                }
                let seg = [lines[lane][k], lines[lane][k + 1]];
                if crosses_outline(&junction.outline, seg) {
                    through.insert((group_of[lane], junction.id));
                }
            }
        }
    }
    // A street through a junction is apart from the junction and every street at it.
    for &(street, junction) in &through {
        for (g, key) in groups.iter().enumerate() {
            if key.contains(&junction) {
                apart.insert(ordered(street, g));
            }
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); groups.len()];
    for (lane, &g) in group_of.iter().enumerate() {
        members[g].push(lane);
    }
    let mut pairs: BTreeSet<(usize, usize)> = BTreeSet::new();
    for &(g, h) in &apart {
        for &a in &members[g] {
            for &b in &members[h] {
                pairs.insert(ordered(a, b));
            }
        }
    }
    for &(a, b) in &pairs {
        let other = lanes[b].name.clone();
        lanes[a].crosses_apart.push(other);
    }
    pairs.len()
}

fn ordered(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

/// `x,y[,z] ...` as points in the plane; unreadable text gives none.
fn outline(shape: &str) -> Vec<DVec2> {
    shape
        .split_whitespace()
        .map(|pair| {
            let mut coords = pair.split(',').map(str::parse::<f64>);
            match (coords.next(), coords.next()) {
                (Some(Ok(x)), Some(Ok(y))) if x.is_finite() && y.is_finite() => {
                    Some(DVec2::new(x, y))
                }
                _ => None,
            }
        })
        .collect::<Option<Vec<_>>>()
        .unwrap_or_default()
}

/// The segment has a point inside the outline or crosses its edge.
fn crosses_outline(outline: &[DVec2], [a, b]: [DVec2; 2]) -> bool {
    point_in_polygon(a, outline)
        || point_in_polygon(b, outline)
        || (0..outline.len())
            .any(|i| segments_intersect(a, b, outline[i], outline[(i + 1) % outline.len()]))
}

/// The grid cells the box from `lo` to `hi` covers; none for a box wider
/// than [`MAX_CELLS`] cells a side (no street's segment is 25 km long, but a
/// damaged file's may be).
fn cells_of(lo: DVec2, hi: DVec2) -> impl Iterator<Item = (i64, i64)> {
    let c = |v: f64| (v / CELL).floor() as i64;
    let (x0, mut x1, y0, y1) = (c(lo.x), c(hi.x), c(lo.y), c(hi.y));
    if x1.saturating_sub(x0) > MAX_CELLS || y1.saturating_sub(y0) > MAX_CELLS {
        x1 = x0 - 1;
    }
    (x0..=x1).flat_map(move |x| (y0..=y1).map(move |y| (x, y)))
}
