//! Closed loops: lanes that, followed as they lead (no lane change), never
//! lead anywhere else, as the inner lane of a roundabout whose exits all
//! leave from the outer one. Found once when the network is built. A driver
//! without a route, offered a way off such a loop by a lane change, takes
//! it: else it would circle for ever, and a ring full of circling drivers
//! stands still (none of them ever leaves to make room).

use crate::network::Lane;

/// For each lane, whether it lies in a closed loop: a ring of lanes (two or
/// more, or one leading into itself) from which no lane leads out.
pub fn find(lanes: &[Lane]) -> Vec<bool> {
    let component = strongly_connected(lanes);
    let count = component.iter().copied().max().map_or(0, |c| c + 1);
    let mut size = vec![0usize; count];
    let mut leaks = vec![false; count];
    for (i, lane) in lanes.iter().enumerate() {
        let c = component[i];
        size[c] += 1;
        leaks[c] |= lane.next.iter().any(|&n| component[n as usize] != c);
    }
    lanes
        .iter()
        .enumerate()
        .map(|(i, lane)| {
            let c = component[i];
            let ring = size[c] > 1 || lane.next.iter().any(|&n| n as usize == i);
            ring && !leaks[c]
        })
        .collect()
}

/// Tarjan's strongly connected components over the lanes' `next` links,
/// without recursion (a town's lanes run to tens of thousands): each lane's
/// component number.
fn strongly_connected(lanes: &[Lane]) -> Vec<usize> {
    const UNSEEN: usize = usize::MAX;
    let n = lanes.len();
    let mut index = vec![UNSEEN; n];
    let mut low = vec![0usize; n];
    let mut on_stack = vec![false; n];
    let mut stack = Vec::new();
    let mut component = vec![UNSEEN; n];
    let (mut next_index, mut next_component) = (0, 0);
    // The depth-first walk: (lane, how many of its links were followed).
    let mut walk: Vec<(usize, usize)> = Vec::new();
    for root in 0..n {
        if index[root] != UNSEEN {
            continue;
        }
        walk.push((root, 0));
        index[root] = next_index;
        low[root] = next_index;
        next_index += 1;
        stack.push(root);
        on_stack[root] = true;
        while let Some(&mut (v, ref mut followed)) = walk.last_mut() {
            if let Some(&w) = lanes[v].next.get(*followed) {
                *followed += 1;
                let w = w as usize;
                if index[w] == UNSEEN {
                    index[w] = next_index;
                    low[w] = next_index;
                    next_index += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    walk.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            walk.pop();
            if let Some(&(parent, _)) = walk.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    component[w] = next_component;
                    if w == v {
                        break;
                    }
                }
                next_component += 1;
            }
        }
    }
    component
}
