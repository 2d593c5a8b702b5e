//! Traffic-light programs and the state NPCs read from them.

use trafficmesh_model::{LightColor, LightProgram};

/// State of one light group at some time: colour and when it next changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightState {
    pub color: LightColor,
    /// Simulation time of the next change (infinite when forced).
    pub next_change: f64,
    /// Since when the group has shown this colour (simulation time).
    pub since: f64,
    /// When this colour is due to end: the program's next change, or the
    /// one the lights service announced; infinite when nobody knows.
    pub ends: f64,
}

/// Evaluates a fixed-time program: green from `offset`, then yellow, then red.
pub fn program_state(program: &LightProgram, t: f64) -> LightState {
    let cycle = program.cycle();
    let pos = (t - program.offset).rem_euclid(cycle);
    let start = t - pos;
    let (color, begin, end) = if pos < program.green {
        (LightColor::Green, 0.0, program.green)
    } else if pos < program.green + program.yellow {
        (
            LightColor::Yellow,
            program.green,
            program.green + program.yellow,
        )
    } else {
        (LightColor::Red, program.green + program.yellow, cycle)
    };
    LightState {
        color,
        next_change: start + end,
        since: start + begin,
        ends: start + end,
    }
}

/// What a light group is doing now: running its program or forced to a colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightControl {
    Program(LightProgram),
    Forced(LightColor),
    /// A colour received from the lights service, good until `valid_until`
    /// (simulation time); after that the group counts as red (fail-safe).
    /// `ends`: when the service said the colour changes (infinite when it
    /// did not say).
    Remote {
        color: LightColor,
        valid_until: f64,
        ends: f64,
    },
}

impl LightControl {
    /// What an override sets (as the lights service takes and publishes
    /// it): a forced colour, else a program; neither, the map's own
    /// program `map`.
    pub fn from_override(
        color: Option<LightColor>,
        program: Option<LightProgram>,
        map: LightProgram,
    ) -> LightControl {
        match color {
            Some(color) => LightControl::Forced(color),
            None => LightControl::Program(program.unwrap_or(map)),
        }
    }

    /// The inverse of [`Self::from_override`]: the colour forced, and the
    /// program run where it is not the map's own `map`. (A received colour
    /// is nobody's override: neither.)
    pub fn as_override(&self, map: LightProgram) -> (Option<LightColor>, Option<LightProgram>) {
        match *self {
            LightControl::Forced(color) => (Some(color), None),
            LightControl::Program(p) if p != map => (None, Some(p)),
            _ => (None, None),
        }
    }
}

/// The state `control` gives at `t`, after `before`: a colour that did not
/// change keeps its start (a program knows its own).
fn evaluate(control: &LightControl, t: f64, before: Option<LightState>) -> LightState {
    let state = |color, next_change, ends| LightState {
        color,
        next_change,
        since: match before {
            Some(b) if b.color == color => b.since,
            _ => t,
        },
        ends,
    };
    match control {
        LightControl::Program(p) => program_state(p, t),
        LightControl::Forced(color) => state(*color, f64::INFINITY, f64::INFINITY),
        LightControl::Remote {
            color,
            valid_until,
            ends,
        } if t <= *valid_until => state(*color, *valid_until, *ends),
        // Fail-safe: a state nobody vouches for any more is red.
        LightControl::Remote { .. } => state(LightColor::Red, f64::INFINITY, f64::INFINITY),
    }
}

/// The states of every light group, refreshed once per tick.
#[derive(Clone, Debug)]
pub struct Lights {
    controls: Vec<LightControl>,
    states: Vec<LightState>,
}

impl Lights {
    pub fn new(programs: impl IntoIterator<Item = LightProgram>) -> Self {
        let controls: Vec<LightControl> = programs.into_iter().map(LightControl::Program).collect();
        let states = controls.iter().map(|c| evaluate(c, 0.0, None)).collect();
        Lights { controls, states }
    }

    /// Refreshes the groups whose state has run out by `t` (time only moves
    /// forward; a changed control is evaluated when it is set).
    pub fn update(&mut self, t: f64) {
        for (state, control) in self.states.iter_mut().zip(&self.controls) {
            if t >= state.next_change {
                *state = evaluate(control, t, Some(*state));
            }
        }
    }

    /// Changes one group's control and refreshes its state at `t`.
    pub fn set_control(&mut self, group: usize, control: LightControl, t: f64) {
        self.controls[group] = control;
        self.states[group] = evaluate(&control, t, Some(self.states[group]));
    }

    pub fn control(&self, group: usize) -> LightControl {
        self.controls[group]
    }

    pub fn len(&self) -> usize {
        self.controls.len()
    }

    pub fn is_empty(&self) -> bool {
        self.controls.is_empty()
    }

    pub fn state(&self, group: usize) -> LightState {
        self.states[group]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_override_reads_back_as_it_was_given() {
        let map = LightProgram {
            green: 30.0,
            yellow: 3.0,
            red: 33.0,
            offset: 0.0,
        };
        let other = LightProgram { green: 7.0, ..map };
        for (color, program) in [
            (Some(LightColor::Red), None),
            (None, Some(other)),
            (None, None),
        ] {
            let control = LightControl::from_override(color, program, map);
            assert_eq!(control.as_override(map), (color, program));
        }
        // The map's own program, given as an override, is no override.
        let control = LightControl::from_override(None, Some(map), map);
        assert_eq!(control, LightControl::Program(map));
        assert_eq!(control.as_override(map), (None, None));
    }

    #[test]
    fn program_cycles_green_yellow_red_from_offset() {
        let p = LightProgram {
            green: 10.0,
            yellow: 3.0,
            red: 7.0,
            offset: 5.0,
        };
        assert_eq!(program_state(&p, 5.0).color, LightColor::Green);
        assert_eq!(program_state(&p, 14.9).color, LightColor::Green);
        assert_eq!(program_state(&p, 15.0).color, LightColor::Yellow);
        assert_eq!(program_state(&p, 18.0).color, LightColor::Red);
        assert_eq!(program_state(&p, 18.0).next_change, 25.0);
        assert_eq!(program_state(&p, 4.0).color, LightColor::Red);
        assert_eq!(program_state(&p, 25.0).color, LightColor::Green);
    }

    #[test]
    fn update_tick_by_tick_matches_the_program() {
        let p = LightProgram {
            green: 10.0,
            yellow: 3.0,
            red: 7.0,
            offset: 5.0,
        };
        let mut lights = Lights::new([p]);
        for tick in 0..5000 {
            let t = tick as f64 * 0.02;
            lights.update(t);
            assert_eq!(lights.state(0).color, program_state(&p, t).color, "t={t}");
        }
    }
}
