//! A compact per-lane table (compressed rows): all items of lane `l` are one slice.

use crate::network::LaneId;

#[derive(Clone, Debug, Default)]
pub struct PerLane<T> {
    starts: Vec<u32>,
    items: Vec<T>,
}

impl<T: Copy> PerLane<T> {
    /// Groups `items` by lane (a counting sort: stable, linear).
    pub fn build(lane_count: usize, items: &[(LaneId, T)]) -> Self {
        let mut starts = vec![0u32; lane_count + 1];
        for (lane, _) in items {
            starts[*lane as usize + 1] += 1;
        }
        for i in 0..lane_count {
            starts[i + 1] += starts[i];
        }
        let mut fill = starts.clone();
        // Every slot is overwritten below; the copies only give the vector its length.
        let mut out: Vec<T> = items.iter().map(|(_, item)| *item).collect();
        for (lane, item) in items {
            let slot = &mut fill[*lane as usize];
            out[*slot as usize] = *item;
            *slot += 1;
        }
        PerLane { starts, items: out }
    }

    pub fn on_lane(&self, lane: LaneId) -> &[T] {
        let (a, b) = (self.starts[lane as usize], self.starts[lane as usize + 1]);
        &self.items[a as usize..b as usize]
    }

    pub fn on_lane_mut(&mut self, lane: LaneId) -> &mut [T] {
        let (a, b) = (self.starts[lane as usize], self.starts[lane as usize + 1]);
        &mut self.items[a as usize..b as usize]
    }
}
