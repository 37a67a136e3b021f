//! A checked task declaration: a domain whose observations, drives, rules and teacher are written
//! in the language (`domain standoff { goal ... observe ... = ... success when ... }`).
//!
//! A [`TaskDef`] is data the checker builds (`check::task`) and the task runtime
//! (`task::declared`) only reads. Every named value of a task lives in one slot of an environment
//! of numbers: the robot's pose and speeds ([`BASE`]), the goal's parameters, the last action,
//! the `let`s and observations (in an order where each reads only slots before it), and the
//! `score` values. Expressions are [`Ir`] reading [`Ir::Slot`] (this step) and [`Ir::Prev`] (the
//! step before); they are total, loop-free and bounded in size, so a step costs a fixed, small
//! amount of work. This module does no IO and evaluates nothing itself.

use crate::domain::{Domain, Limits};

use super::ir::Ir;

/// The values every task can read, in slot order: name, unit, meaning.
pub const BASE: [(&str, &str, &str); 6] = [
    (
        "x",
        "m",
        "the robot's x position (odometry; the true pose when scoring in the simulator)",
    ),
    (
        "y",
        "m",
        "the robot's y position (odometry; the true pose when scoring in the simulator)",
    ),
    ("theta", "rad", "the robot's heading, in (-pi, pi]"),
    ("v", "m/s", "the measured translational speed"),
    ("w", "rad/s", "the measured rotational speed"),
    ("t", "s", "the time since the run started"),
];

/// Slot of `x`, `y`, `theta`, `v`, `w`, `t`.
pub const X: usize = 0;
pub const Y: usize = 1;
pub const THETA: usize = 2;
pub const V: usize = 3;
pub const W: usize = 4;
pub const T: usize = 5;

/// The most goal parameters a task may declare.
pub const MAX_GOAL_PARAMS: usize = 16;
/// The largest fixed test set.
pub const MAX_TEST_GOALS: usize = 10_000;
/// The largest magnitude of a goal range's bound, in the parameter's unit: every goal is drawn
/// from a range whose width is a finite number (a kilometre, a thousand radians; no task needs
/// more, and `[-1e308, 1e308]` would overflow the draw).
pub const MAX_GOAL_ABS: f64 = 1e6;
/// The longest time limit (`end after`) and the longest hold (`for`), s: ten minutes. At the
/// highest control rate the simulator allows (100 Hz) a run is then at most
/// [`crate::task::MAX_EPISODE_STEPS`] steps, a trace of a few megabytes.
pub const MAX_TIME_LIMIT_S: f64 = 600.0;

/// A goal parameter: drawn uniformly from `[lo, hi)` for each practice and test goal.
#[derive(Clone, Debug, PartialEq)]
pub struct GoalParam {
    pub name: String,
    pub unit: String,
    pub lo: f64,
    pub hi: f64,
}

/// Which speed of the base an action commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Translational speed, m/s.
    Speed,
    /// Rotational speed, rad/s.
    Turn,
}

impl Axis {
    pub fn word(self) -> &'static str {
        match self {
            Axis::Speed => "speed",
            Axis::Turn => "turn",
        }
    }
}

/// How an action drives one axis of the base.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    /// Index of the action in the domain.
    pub action: usize,
    /// `None`: the action is the command. `Some(limits)`: the action is added to the command each
    /// step and the sum kept in the limits.
    pub integrate: Option<Limits>,
}

/// When a run ends.
#[derive(Clone, Debug, PartialEq)]
pub enum EndRule {
    /// The condition held for `hold_s` seconds (0: at once).
    When { cond: Ir, hold_s: f64 },
    /// The time limit.
    After { limit_s: f64 },
}

/// Where a teacher statement writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TeacherTarget {
    /// A `let` of the teacher: a slot after the observations.
    Local(usize),
    /// An action of the domain.
    Action(usize),
}

/// A controller written in the language: its environment is the observations (slots
/// `0..obs_dim`) and then its `let`s.
#[derive(Clone, Debug, PartialEq)]
pub struct TeacherDef {
    pub slots: usize,
    pub stmts: Vec<(TeacherTarget, Ir)>,
}

/// A checked task.
#[derive(Clone, Debug, PartialEq)]
pub struct TaskDef {
    pub domain: Domain,
    /// The domain's doc comment.
    pub doc: String,
    pub goal: Vec<GoalParam>,
    pub test_count: usize,
    pub test_seed: u64,
    /// The name of each slot.
    pub slot_names: Vec<String>,
    /// `let`s and observations, in evaluation order: `(slot, value)`.
    pub computed: Vec<(usize, Ir)>,
    /// The slot of each observation, in the domain's order.
    pub observe: Vec<usize>,
    pub speed: Option<Drive>,
    pub turn: Option<Drive>,
    pub ends: Vec<EndRule>,
    /// `score` values in order: `(slot, value)`.
    pub score: Vec<(usize, Ir)>,
    /// Slots of the `error` and `heading_error` scores.
    pub error: usize,
    pub heading_error: Option<usize>,
    /// Slot of the `efficiency` score, when declared (else the path length is the measure).
    pub efficiency: Option<usize>,
    pub success: Ir,
    /// How each goal parameter is read from the pose a recording ends at.
    pub recorded: Option<Vec<Ir>>,
    pub teacher: Option<TeacherDef>,
}

impl TaskDef {
    pub fn name(&self) -> &str {
        &self.domain.name
    }

    /// Slot of the first goal parameter.
    pub fn goal_slot(&self) -> usize {
        BASE.len()
    }

    /// Slot of the first action.
    pub fn action_slot(&self) -> usize {
        BASE.len() + self.goal.len()
    }

    /// How many slots the environment has.
    pub fn slots(&self) -> usize {
        self.slot_names.len()
    }
}
