//! The validity protocol of published states: a service that vouches for its
//! states sends a heartbeat every validity/4 of simulation time, each good
//! until `time + validity`; a stepper that stops hearing it falls back to the
//! fail-safe (red lights, blocked crosswalks).

use trafficmesh_protocol::wire::Heartbeat;

#[derive(Clone, Copy, Debug)]
pub struct Vouch {
    validity: f64,
    last: f64,
}

impl Vouch {
    pub fn new(validity: f64) -> Self {
        Vouch {
            validity,
            last: f64::NEG_INFINITY,
        }
    }

    /// Until when a state published at `time` is good.
    pub fn valid_until(&self, time: f64) -> f64 {
        time + self.validity
    }

    /// The heartbeat to send at `time`, if one is due.
    pub fn due(&mut self, time: f64) -> Option<Heartbeat> {
        if time - self.last < self.validity / 4.0 {
            return None;
        }
        self.last = time;
        Some(Heartbeat {
            time,
            valid_until: self.valid_until(time),
        })
    }
}
