//! Enums of the NPC pipeline, named as in the product documents.

use serde::{Deserialize, Serialize};

/// The speed modes of the AWSIM reference's Decision step, most to least restrictive last.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum SpeedMode {
    #[default]
    Normal,
    Slow,
    Stop,
    SuddenStop,
    AbsoluteStop,
}

impl SpeedMode {
    pub fn as_str(self) -> &'static str {
        match self {
            SpeedMode::Normal => "NORMAL",
            SpeedMode::Slow => "SLOW",
            SpeedMode::Stop => "STOP",
            SpeedMode::SuddenStop => "SUDDEN_STOP",
            SpeedMode::AbsoluteStop => "ABSOLUTE_STOP",
        }
    }
}

/// The intersection right-of-way phases (reference section 3.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum YieldPhase {
    #[default]
    None,
    EnteringIntersection,
    AtIntersection,
    IntersectionBlocked,
    LeftHandRuleEnteringIntersection,
    LeftHandRuleAtIntersection,
    LanesRulesEnteringIntersection,
    LanesRulesAtIntersection,
    ForcingPriority,
}

impl YieldPhase {
    /// Phases that produce a stop at the yield point (all but NONE, ENTERING and AT).
    pub fn is_yielding(self) -> bool {
        !matches!(
            self,
            YieldPhase::None | YieldPhase::EnteringIntersection | YieldPhase::AtIntersection
        )
    }

    /// "Yielding due to rules": the left-hand-rule and lane-rule phases.
    pub fn is_yielding_due_to_rules(self) -> bool {
        matches!(
            self,
            YieldPhase::LeftHandRuleEnteringIntersection
                | YieldPhase::LeftHandRuleAtIntersection
                | YieldPhase::LanesRulesEnteringIntersection
                | YieldPhase::LanesRulesAtIntersection
        )
    }

    /// "Yielding before the intersection".
    pub fn is_yielding_before_intersection(self) -> bool {
        matches!(
            self,
            YieldPhase::LeftHandRuleEnteringIntersection
                | YieldPhase::LanesRulesEnteringIntersection
        )
    }

    pub fn as_str(self) -> &'static str {
        match self {
            YieldPhase::None => "NONE",
            YieldPhase::EnteringIntersection => "ENTERING_INTERSECTION",
            YieldPhase::AtIntersection => "AT_INTERSECTION",
            YieldPhase::IntersectionBlocked => "INTERSECTION_BLOCKED",
            YieldPhase::LeftHandRuleEnteringIntersection => "LEFT_HAND_RULE_ENTERING_INTERSECTION",
            YieldPhase::LeftHandRuleAtIntersection => "LEFT_HAND_RULE_AT_INTERSECTION",
            YieldPhase::LanesRulesEnteringIntersection => "LANES_RULES_ENTERING_INTERSECTION",
            YieldPhase::LanesRulesAtIntersection => "LANES_RULES_AT_INTERSECTION",
            YieldPhase::ForcingPriority => "FORCING_PRIORITY",
        }
    }
}

/// Turn direction of a lane (lanelet `turn_direction`); missing means straight.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum TurnDirection {
    #[default]
    Straight,
    Left,
    Right,
}

/// Traffic-light colour as the NPCs read it (Vienna convention).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum LightColor {
    #[default]
    Green,
    Yellow,
    Red,
}

/// Turn-signal state shown by the Visualization step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum TurnSignal {
    #[default]
    Off,
    Left,
    Right,
}

// Every variant in code order: the binary vehicle batch sends the index.
impl SpeedMode {
    pub const ALL: [SpeedMode; 5] = [
        SpeedMode::Normal,
        SpeedMode::Slow,
        SpeedMode::Stop,
        SpeedMode::SuddenStop,
        SpeedMode::AbsoluteStop,
    ];
}

impl YieldPhase {
    pub const ALL: [YieldPhase; 9] = [
        YieldPhase::None,
        YieldPhase::EnteringIntersection,
        YieldPhase::AtIntersection,
        YieldPhase::IntersectionBlocked,
        YieldPhase::LeftHandRuleEnteringIntersection,
        YieldPhase::LeftHandRuleAtIntersection,
        YieldPhase::LanesRulesEnteringIntersection,
        YieldPhase::LanesRulesAtIntersection,
        YieldPhase::ForcingPriority,
    ];
}

impl TurnSignal {
    pub const ALL: [TurnSignal; 3] = [TurnSignal::Off, TurnSignal::Left, TurnSignal::Right];
}
