//! Per-lane ordering of vehicles, rebuilt each tick: the leader, conflict and
//! spawn-clearance look-ups read it instead of scanning every vehicle.

use crate::network::LaneId;
use crate::vehicle::Vehicle;

/// One vehicle's body on one lane.
#[derive(Clone, Copy, Debug)]
pub struct Occupant {
    /// Arc lengths of the rear and front bumpers on this lane (may lie outside it).
    pub rear: f64,
    pub front: f64,
    /// Index of the vehicle in the world's vehicle list.
    pub vehicle: u32,
}

/// Vehicles of each lane sorted by rear position.
#[derive(Clone, Debug, Default)]
pub struct LaneIndex {
    starts: Vec<u32>,
    entries: Vec<Occupant>,
}

impl LaneIndex {
    pub fn build(
        lane_count: usize,
        vehicles: &[Vehicle],
        lane_length: impl Fn(LaneId) -> f64,
    ) -> Self {
        let mut counts = vec![0u32; lane_count + 1];
        for v in vehicles {
            counts[v.path[0] as usize] += 1;
            if v.rear_s() < 0.0
                && let Some(p) = v.prev_lane
            {
                counts[p as usize] += 1;
            }
        }
        let mut starts = vec![0u32; lane_count + 1];
        for i in 0..lane_count {
            starts[i + 1] = starts[i] + counts[i];
        }
        let mut fill = starts.clone();
        let mut entries = vec![
            Occupant {
                rear: 0.0,
                front: 0.0,
                vehicle: 0
            };
            starts[lane_count] as usize
        ];
        let mut put = |lane: LaneId, occ: Occupant| {
            let slot = &mut fill[lane as usize];
            entries[*slot as usize] = occ;
            *slot += 1;
        };
        for (i, v) in vehicles.iter().enumerate() {
            put(
                v.path[0],
                Occupant {
                    rear: v.rear_s(),
                    front: v.s,
                    vehicle: i as u32,
                },
            );
            if v.rear_s() < 0.0
                && let Some(p) = v.prev_lane
            {
                let len = lane_length(p);
                put(
                    p,
                    Occupant {
                        rear: len + v.rear_s(),
                        front: len + v.s,
                        vehicle: i as u32,
                    },
                );
            }
        }
        for lane in 0..lane_count {
            let slice = &mut entries[starts[lane] as usize..starts[lane + 1] as usize];
            if slice.len() > 1 {
                slice.sort_unstable_by(|a, b| {
                    a.rear.total_cmp(&b.rear).then(a.vehicle.cmp(&b.vehicle))
                });
            }
        }
        LaneIndex { starts, entries }
    }

    pub fn on_lane(&self, lane: LaneId) -> &[Occupant] {
        let (a, b) = (self.starts[lane as usize], self.starts[lane as usize + 1]);
        &self.entries[a as usize..b as usize]
    }
}
