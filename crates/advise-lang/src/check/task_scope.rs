//! What a clause of a task declaration may name: each task name's [`Kind`] and the
//! [`TaskScope`] an expression is resolved in. Its own file so that the resolver
//! ([`super::names`]) and the task checker ([`super::task`]) both read it without reading each
//! other (issue 50).

use std::cell::RefCell;
use std::collections::HashMap;

use crate::program::task::Window;

/// What kind of value a task name is; each clause may read some kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Base,
    Goal,
    Action,
    /// A `let` or an observation.
    Value,
    Score,
    /// In a teacher: an observation.
    TeacherObs,
    /// In a teacher: one of its `let`s.
    TeacherLocal,
}

impl Kind {
    pub(super) fn word(self) -> &'static str {
        match self {
            Kind::Base => "the robot's state",
            Kind::Goal => "a goal parameter",
            Kind::Action => "an action",
            Kind::Value => "a value",
            Kind::Score => "a score",
            Kind::TeacherObs => "an observation",
            Kind::TeacherLocal => "a teacher's value",
        }
    }
}

/// The names an expression of a task may use, and where it is.
pub(super) struct TaskScope<'a> {
    pub(super) task: &'a str,
    pub(super) names: &'a HashMap<String, (usize, Kind)>,
    pub(super) allowed: &'a [Kind],
    /// Where the expression is, for messages: "an observation's definition".
    pub(super) context: &'a str,
    pub(super) prev_ok: bool,
    /// The task's names a teacher cannot see (so a use of one is explained, not "unknown").
    pub(super) hidden: Option<&'a HashMap<String, (usize, Kind)>>,
    /// In a flaw's condition: the look-backs (`total`, `change`) found so far, and the slot of
    /// the first (the task's slot count). Elsewhere `None`: only flaws look back.
    pub(super) windows: Option<(&'a RefCell<Vec<Window>>, usize)>,
}
