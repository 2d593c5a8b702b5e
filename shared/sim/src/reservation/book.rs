//! The rectangles granted so far, by time slot: a plan is granted only if
//! none of its rectangles overlaps one reserved for the same time (or
//! within the time margin of it).

use std::collections::BTreeMap;

use super::plan::Step;
use crate::geometry::Obb;
use crate::vehicle::VehicleId;

/// Reservations of one intersection.
#[derive(Clone, Debug, Default)]
pub struct Book {
    /// Slot (simulated time over the step, rounded down) to the rectangles
    /// reserved in it.
    slots: BTreeMap<i64, Vec<(VehicleId, Obb)>>,
    step: f64,
}

impl Book {
    pub fn new(step: f64) -> Self {
        Book {
            slots: BTreeMap::new(),
            step,
        }
    }

    fn slot(&self, t: f64) -> i64 {
        (t / self.step).floor() as i64
    }

    /// Does the plan, asked at time `now`, keep clear of every rectangle
    /// reserved within `time_margin` of each of its steps?
    pub fn is_clear(&self, now: f64, steps: &[Step], time_margin: f64) -> bool {
        let spread = (time_margin / self.step).ceil() as i64;
        steps.iter().all(|step| {
            let k = self.slot(now + step.t);
            self.slots
                .range(k - spread..=k + spread)
                .flat_map(|(_, held)| held)
                .all(|(_, body)| apart(body, &step.body))
        })
    }

    /// The vehicles holding a rectangle that the plan, asked at `now`,
    /// meets within `time_margin` of one of its steps.
    pub fn met_by(&self, now: f64, steps: &[Step], time_margin: f64) -> Vec<VehicleId> {
        let spread = (time_margin / self.step).ceil() as i64;
        let mut met: Vec<VehicleId> = steps
            .iter()
            .flat_map(|step| {
                let k = self.slot(now + step.t);
                self.slots
                    .range(k - spread..=k + spread)
                    .flat_map(|(_, held)| held)
                    .filter(|(_, body)| !apart(body, &step.body))
                    .map(|(v, _)| *v)
            })
            .collect();
        met.sort_unstable();
        met.dedup();
        met
    }

    /// Reserves the plan's rectangles for `vehicle`.
    pub fn reserve(&mut self, vehicle: VehicleId, now: f64, steps: &[Step]) {
        for step in steps {
            let k = self.slot(now + step.t);
            self.slots.entry(k).or_default().push((vehicle, step.body));
        }
    }

    /// Drops what `vehicle` holds (it left, or gave its way up).
    pub fn release(&mut self, vehicle: VehicleId) {
        self.slots.retain(|_, held| {
            held.retain(|(v, _)| *v != vehicle);
            !held.is_empty()
        });
    }

    /// Drops the slots that ended before `now` less `keep` seconds.
    pub fn expire(&mut self, now: f64, keep: f64) {
        let first = self.slot(now - keep);
        self.slots = self.slots.split_off(&first);
    }

    /// The rectangles reserved from `now` on, with their time ahead: what
    /// the live map draws, fading with time.
    pub fn ahead(&self, now: f64) -> impl Iterator<Item = (f64, VehicleId, &Obb)> {
        let step = self.step;
        self.slots
            .range(self.slot(now)..)
            .flat_map(move |(&k, held)| {
                held.iter()
                    .map(move |(v, body)| (k as f64 * step - now, *v, body))
            })
    }
}

/// Do two rectangles keep apart? Most pairs are far apart: their centres
/// further than their corners reach settle it without the overlap test.
fn apart(a: &Obb, b: &Obb) -> bool {
    let reach = a.half_length.hypot(a.half_width) + b.half_length.hypot(b.half_width);
    a.centre.distance_squared(b.centre) > reach * reach || a.separation(b) > 0.0
}
