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
    /// The condition held for `hold_s` seconds (0: at once). `text` is the rule as written
    /// (`end when range < 0.3`, spaces collapsed): what an ending it causes is named by.
    When { cond: Ir, hold_s: f64, text: String },
    /// The time limit.
    After { limit_s: f64 },
}

/// A look back over a stretch of a run, in a flaw's condition: `total(EXPR, SECONDS)` or
/// `change(EXPR, SECONDS)`. Its value at a point is kept in a slot after the task's own
/// ([`TaskDef::window_slot`]), filled by `interp::flaws` from the points before it.
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    pub kind: WindowKind,
    /// What is summed or compared, evaluated at each point like a `let` (it may read `prev`).
    pub value: Ir,
    /// How far back it looks, s (positive, at most [`MAX_TIME_LIMIT_S`]).
    pub seconds: f64,
}

/// How a [`Window`] looks back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowKind {
    /// `total(e, s)`: the sum of `e` over the points of the last `s` seconds, this one included
    /// (a turn accumulated over a stretch: `total(turned, 3)`).
    Total,
    /// `change(e, s)`: `e` now minus `e` at the earliest point of the last `s` seconds (since
    /// the start, early in a run): a distance that stops closing, `change(dist, 1) > 0`.
    Change,
}

impl WindowKind {
    pub const ALL: [WindowKind; 2] = [WindowKind::Total, WindowKind::Change];

    pub fn word(self) -> &'static str {
        match self {
            WindowKind::Total => "total",
            WindowKind::Change => "change",
        }
    }

    pub fn named(word: &str) -> Option<WindowKind> {
        WindowKind::ALL.into_iter().find(|k| k.word() == word)
    }

    /// How it is written, with what it means.
    pub fn signature(self) -> &'static str {
        match self {
            WindowKind::Total => {
                "total(VALUE, SECONDS): the sum of VALUE over the points of the last SECONDS s, this one included"
            }
            WindowKind::Change => {
                "change(VALUE, SECONDS): VALUE now minus VALUE SECONDS s ago (at the run's start, early on)"
            }
        }
    }
}

/// `flaw NAME when COND [for SECONDS]`: what a poor run looks like at a point. A flaw *holds*
/// over a stretch of an execution where `cond` was true at every point for at least `hold_s`
/// seconds; the stretch is the chunk `suggest` proposes advice on.
#[derive(Clone, Debug, PartialEq)]
pub struct FlawDef {
    pub name: String,
    /// Reads the task's slots, the windows' slots and `prev`; at a point, the action slots hold
    /// the action taken there.
    pub cond: Ir,
    pub hold_s: f64,
    /// The clause as written, spaces collapsed (`flaw loop when abs(total(turned, 4)) > pi`).
    pub text: String,
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

/// The shapes a task can draw, each from a fixed number of values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeKind {
    /// `pose(x, y, heading)`: a cross with a heading arrow.
    Pose,
    /// `point(x, y)`: a cross.
    Point,
    /// `circle(x, y, radius)`: a ring.
    Circle,
}

impl ShapeKind {
    pub const ALL: [ShapeKind; 3] = [ShapeKind::Pose, ShapeKind::Point, ShapeKind::Circle];

    pub fn word(self) -> &'static str {
        match self {
            ShapeKind::Pose => "pose",
            ShapeKind::Point => "point",
            ShapeKind::Circle => "circle",
        }
    }

    /// How it is written, with what each value is.
    pub fn signature(self) -> &'static str {
        match self {
            ShapeKind::Pose => "pose(x, y, heading): a position in m and a heading in rad",
            ShapeKind::Point => "point(x, y): a position in m",
            ShapeKind::Circle => "circle(x, y, radius): a centre and a radius in m",
        }
    }

    /// How many values it takes.
    pub fn arity(self) -> usize {
        match self {
            ShapeKind::Pose | ShapeKind::Circle => 3,
            ShapeKind::Point => 2,
        }
    }

    pub fn named(word: &str) -> Option<ShapeKind> {
        ShapeKind::ALL.into_iter().find(|k| k.word() == word)
    }
}

/// A `draw` shape as checked: its values are expressions of the goal's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawDef {
    /// What the legend calls it; the one named [`GOAL_DRAWING`] is the goal.
    pub name: String,
    pub shape: ShapeKind,
    pub args: Vec<Ir>,
}

/// The name of the drawing that is the goal (`S start  E end  G goal` in the terminal).
pub const GOAL_DRAWING: &str = "goal";

/// A drawing evaluated for one goal: what a picture draws, in metres and radians.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawn {
    pub name: String,
    pub shape: ShapeKind,
    /// `[x, y, heading]` of a pose, `[x, y]` of a point, `[x, y, radius]` of a circle.
    pub values: Vec<f64>,
}

impl Drawn {
    pub fn is_goal(&self) -> bool {
        self.name == GOAL_DRAWING
    }

    /// Where it is, `(x, y)`.
    pub fn at(&self) -> (f64, f64) {
        let v = |i: usize| self.values.get(i).copied().unwrap_or(f64::NAN);
        (v(0), v(1))
    }

    /// The radius of a circle (its absolute value), else 0.
    pub fn radius(&self) -> f64 {
        match self.shape {
            ShapeKind::Circle => self.values.get(2).map_or(0.0, |r| r.abs()),
            _ => 0.0,
        }
    }

    /// The heading of a pose.
    pub fn heading(&self) -> Option<f64> {
        (self.shape == ShapeKind::Pose).then(|| self.values.get(2).copied().unwrap_or(f64::NAN))
    }

    /// Whether every value is a number a picture can place.
    pub fn is_finite(&self) -> bool {
        self.values.iter().all(|v| v.is_finite())
    }
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
    /// `flaw` clauses, in declaration order.
    pub flaws: Vec<FlawDef>,
    /// The look-backs the flaws read, each in the slot [`TaskDef::window_slot`] gives.
    pub windows: Vec<Window>,
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
    /// What pictures of a run draw, from its goal (`draw`), in declaration order.
    pub draw: Vec<DrawDef>,
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

    /// The slot a flaw reads window `i` from: after the task's own slots.
    pub fn window_slot(&self, i: usize) -> usize {
        self.slots() + i
    }
}
