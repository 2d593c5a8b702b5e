//! What the vehicles of reservation intersections and the intersection
//! manager say to each other each tick (the product's document 004): one
//! round from the vehicles' owner (the world in one process, the stepper in
//! a cluster), one answer from the manager (in the same process, or the
//! intersection service on the bus). Vehicles and lanes by their ids in the
//! simulation core; intersections by their index among the network's
//! reservation junctions.

use serde::{Deserialize, Serialize};

/// What a vehicle tells the intersection when it asks for a way through.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Approach {
    /// Metres from its front bumper to the path's start (0 at the line,
    /// negative once inside).
    pub to_entry: f64,
    pub speed: f64,
    /// The acceleration it drives the path with, m/s² (its comfortable one).
    pub accel: f64,
    /// The speed it keeps to on the path, m/s.
    pub max_speed: f64,
    pub length: f64,
    pub width: f64,
}

/// A request for a way through, from the vehicle at the head of its
/// approach lane.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Request {
    pub intersection: u32,
    pub vehicle: u64,
    /// The intersection lane it drives.
    pub lane: u32,
    /// The approach lane it waits on.
    pub from: u32,
    pub approach: Approach,
    /// It is an emergency vehicle, or one waits behind it in its lane.
    pub emergency: bool,
}

/// A vehicle of one intersection.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Member {
    pub intersection: u32,
    pub vehicle: u64,
}

/// A vehicle that keeps its way this tick.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Holding {
    pub intersection: u32,
    pub vehicle: u64,
    /// The intersection lane it was granted.
    pub lane: u32,
    /// Where it is now: its plan from here when it is planned again, or
    /// when the manager does not know its grant (it started after it).
    pub approach: Approach,
    /// Inside and behind its plan: plan it again from `approach`.
    pub replan: bool,
    /// Not in yet and still able to stop before its entry: a way planned
    /// again across its own takes its grant back.
    pub revocable: bool,
}

/// One tick's round, at simulated time `time`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Round {
    pub time: f64,
    /// Through: the grant goes, the rectangles stay until their time.
    pub finished: Vec<Member>,
    /// Gave their way back (off their way, late before the entry, gone).
    pub released: Vec<Member>,
    /// Every vehicle that keeps its grant; a grant of no vehicle here goes.
    pub holding: Vec<Holding>,
    /// The heads of the approaches without a way, asking.
    pub requests: Vec<Request>,
}

/// A way granted: the speeds to keep from the round's time on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Granted {
    pub intersection: u32,
    pub vehicle: u64,
    pub lane: u32,
    /// Speed at each step from the round's time, m/s.
    pub speeds: Vec<f64>,
    /// Seconds between two speeds.
    pub step: f64,
    /// A new plan of a vehicle that held a way (planned again, or taken
    /// over by a manager that had not granted it).
    pub again: bool,
}

/// The manager's answer to a round.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Answer {
    pub granted: Vec<Granted>,
    /// Grants taken back: their vehicles stop before their entry and ask again.
    pub revoked: Vec<Member>,
}
