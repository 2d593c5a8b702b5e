//! Lanes that follow each other: one stream of vehicles, which conflicts with
//! itself only where a lane folds back on itself.

use crate::network::Lane;

/// Lanes one after the other (within this many metres of lanes between them)
/// carry one stream of vehicles: near their joint they do not conflict.
const LINKED_DISTANCE: f64 = 10.0;
/// Two points of linked lanes whose distance along the lanes exceeds their
/// distance across by more than this lie on a lane folding back on itself (a
/// hairpin): bodies there can touch although one follows the other. Closer to
/// a straight line, they are the joint itself, where only leaders matter.
pub(super) const JOINT_SLACK: f64 = 4.0;

/// How two lanes of a conflict pair follow each other, if they do.
#[derive(Clone, Copy)]
pub(super) enum Link {
    /// Vehicles go from the first lane to the second, with `gap` metres of lanes between.
    Forward {
        gap: f64,
    },
    Backward {
        gap: f64,
    },
}

impl Link {
    /// Along-lane metres between arc length `s` of the first lane and `t` of the second.
    pub(super) fn along(self, first_len: f64, second_len: f64, s: f64, t: f64) -> f64 {
        match self {
            Link::Forward { gap } => first_len - s + gap + t,
            Link::Backward { gap } => second_len - t + gap + s,
        }
    }

    pub(super) fn reversed(self) -> Link {
        match self {
            Link::Forward { gap } => Link::Backward { gap },
            Link::Backward { gap } => Link::Forward { gap },
        }
    }
}

/// The fewest metres of lanes between `from` and `to` through successors, if
/// `to` is reached with less than LINKED_DISTANCE in between.
fn link_gap(lanes: &[Lane], from: usize, to: usize) -> Option<f64> {
    let mut best: Option<f64> = None;
    let mut frontier = vec![(from, 0.0)];
    while let Some((lane, gap)) = frontier.pop() {
        for &n in &lanes[lane].next {
            let n = n as usize;
            if n == to {
                best = Some(best.map_or(gap, |b: f64| b.min(gap)));
                continue;
            }
            let through = gap + lanes[n].length();
            if through < LINKED_DISTANCE {
                frontier.push((n, through));
            }
        }
    }
    best
}

pub(super) fn link(lanes: &[Lane], a: usize, b: usize) -> Option<Link> {
    link_gap(lanes, a, b)
        .map(|gap| Link::Forward { gap })
        .or_else(|| link_gap(lanes, b, a).map(|gap| Link::Backward { gap }))
}
