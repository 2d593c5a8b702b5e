//! Closed loops: lanes that, followed as they lead (no lane change), never
//! lead anywhere else, as the inner lane of a roundabout whose exits all
//! leave from the outer one. Found once when the network is built. A driver
//! without a route, offered a way off such a loop by a lane change, takes
//! it: else it would circle for ever, and a ring full of circling drivers
//! stands still (none of them ever leaves to make room).

use petgraph::algo::tarjan_scc;
use petgraph::graph::DiGraph;

use crate::network::Lane;

/// For each lane, whether it lies in a closed loop: a ring of lanes (two or
/// more, or one leading into itself) from which no lane leads out.
pub fn find(lanes: &[Lane]) -> Vec<bool> {
    let links = lanes
        .iter()
        .enumerate()
        .flat_map(|(i, lane)| lane.next.iter().map(move |&n| (i as u32, n)));
    let mut graph = DiGraph::<(), ()>::from_edges(links);
    // Lanes after the last one linked are nodes too.
    while graph.node_count() < lanes.len() {
        graph.add_node(());
    }
    let mut component = vec![0; lanes.len()];
    let components = tarjan_scc(&graph);
    for (c, lanes_of) in components.iter().enumerate() {
        for lane in lanes_of {
            component[lane.index()] = c;
        }
    }
    let mut leaks = vec![false; components.len()];
    for (i, lane) in lanes.iter().enumerate() {
        leaks[component[i]] |= lane
            .next
            .iter()
            .any(|&n| component[n as usize] != component[i]);
    }
    lanes
        .iter()
        .enumerate()
        .map(|(i, lane)| {
            let c = component[i];
            let ring = components[c].len() > 1 || lane.next.contains(&(i as u32));
            ring && !leaks[c]
        })
        .collect()
}
