//! Task declarations: a domain's goal, values, drives, rules, scores and teacher checked into a
//! [`TaskDef`]. Names resolve through the same resolver as operator bodies ([`Scope::Task`]), so
//! functions, types and "did you mean" work alike; what is new here is which values each clause
//! may read, the order values are computed in (a cycle is an error), and what a task must say.

use std::collections::HashMap;

mod finite;

use super::names::{RESERVED, Scope, Ty};
use super::task_scope::{Kind, TaskScope};
use super::*;
use crate::domain::Space;
use crate::program::ir::{Func, Ir};
use crate::program::task::{
    Axis, BASE, DrawDef, Drive, EndRule, FlawDef, GoalParam, MAX_GOAL_ABS, MAX_GOAL_PARAMS,
    MAX_TEST_GOALS, MAX_TIME_LIMIT_S, ShapeKind, TaskDef, TeacherDef, TeacherTarget, Window,
    WindowKind,
};

const DEFAULT_TEST_GOALS: usize = 25;

/// What end rules read: everything but the scores.
const RULE_READS: &[Kind] = &[Kind::Base, Kind::Goal, Kind::Action, Kind::Value];
/// What scores and the success rule read: everything (a score only the scores before it).
const SCORE_READS: &[Kind] = &[
    Kind::Base,
    Kind::Goal,
    Kind::Action,
    Kind::Value,
    Kind::Score,
];

/// A task's names as they are declared: each name's slot and kind, and each slot's name.
struct TaskNames<'a> {
    task: &'a str,
    kinds: HashMap<String, (usize, Kind)>,
    slots: Vec<String>,
}

impl<'a> TaskNames<'a> {
    /// The robot's state, in the first slots.
    fn new(task: &'a str) -> Self {
        let mut names = TaskNames {
            task,
            kinds: HashMap::new(),
            slots: Vec::new(),
        };
        for (i, (n, _, _)) in BASE.iter().enumerate() {
            names.kinds.insert((*n).into(), (i, Kind::Base));
            names.slots.push((*n).into());
        }
        names
    }
}

/// The scores of a task, and which of them are the ones evaluations report.
#[derive(Default)]
struct Scores {
    score: Vec<(usize, Ir)>,
    error: Option<usize>,
    heading_error: Option<usize>,
    efficiency: Option<usize>,
}

impl Checker<'_> {
    /// A task name in an expression: its slot, or a diagnostic.
    pub(super) fn task_var(
        &mut self,
        f: usize,
        ts: &TaskScope<'_>,
        name: &str,
        span: Span,
    ) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        match ts.names.get(name) {
            Some(&(slot, kind)) if ts.allowed.contains(&kind) => (Ir::Slot(slot), Ty::Num),
            Some(&(_, kind)) => {
                let help = match kind {
                    Kind::Action => "an action is chosen after the observations are computed; end rules, scores and the success rule may read it".to_string(),
                    Kind::Score => "scores are computed at the end of a run, after everything else; only the success rule (and later scores) may read them".to_string(),
                    Kind::Goal | Kind::Base | Kind::Value if ts.context.contains("teacher") => {
                        "a teacher sees what a learned policy sees: the observations (and its own `let`s)".to_string()
                    }
                    _ => format!("{} may read: {}", ts.context, kinds(ts.allowed)),
                };
                self.err(
                    f,
                    span,
                    CheckError::TaskNameNotHere {
                        name: name.into(),
                        context: format!("{} ({name} is {})", ts.context, kind.word()),
                        help,
                        span: self.at(f, span),
                    },
                );
                bad
            }
            None if ts.hidden.is_some_and(|h| h.contains_key(name)) => {
                self.err(
                    f,
                    span,
                    CheckError::TaskNameNotHere {
                        name: name.into(),
                        context: ts.context.into(),
                        help: "a teacher sees what a learned policy sees: the observations (and its own `let`s); make what it needs an observation".into(),
                        span: self.at(f, span),
                    },
                );
                bad
            }
            None => {
                let mut candidates: Vec<&str> = ts
                    .names
                    .iter()
                    .filter(|(_, (_, k))| ts.allowed.contains(k))
                    .map(|(n, _)| n.as_str())
                    .collect();
                candidates.sort_unstable();
                candidates.push("pi");
                let help = hint(name, "names here", &candidates);
                self.err(
                    f,
                    span,
                    CheckError::TaskUnknownName {
                        name: name.into(),
                        task: ts.task.into(),
                        help,
                        span: self.at(f, span),
                    },
                );
                bad
            }
        }
    }

    /// `prev(NAME)`: the named value at the previous step.
    pub(super) fn task_prev(
        &mut self,
        f: usize,
        ts: &TaskScope<'_>,
        args: &[Expr],
        span: Span,
    ) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        let help = "write `prev(NAME)` with the name of the pose (`x`, `y`, `theta`), a speed (`v`, `w`), `t`, a `let` or an observation";
        if !ts.prev_ok {
            self.err(
                f,
                span,
                CheckError::TaskNameNotHere {
                    name: "prev".into(),
                    context: ts.context.into(),
                    help: "only the task's values, end rules, scores and success rule read the previous step".into(),
                    span: self.at(f, span),
                },
            );
            return bad;
        }
        let [arg] = args else {
            self.err(
                f,
                span,
                CheckError::WrongArity {
                    func: "prev".into(),
                    expected: 1,
                    found: args.len(),
                    signature: "prev(NAME): NAME's value at the previous control step (at the first step, its value now)".into(),
                    span: self.at(f, span),
                },
            );
            return bad;
        };
        let ExprKind::Var(name) = &arg.kind else {
            self.err(
                f,
                arg.span,
                CheckError::TaskWrongMeaning {
                    what: "`prev` takes a name, not an expression".into(),
                    help: help.into(),
                    span: self.at(f, arg.span),
                },
            );
            return bad;
        };
        match ts.names.get(name.as_str()) {
            Some(&(slot, Kind::Base | Kind::Value)) => (Ir::Prev(slot), Ty::Num),
            Some(&(_, kind)) => {
                self.err(
                    f,
                    arg.span,
                    CheckError::TaskNameNotHere {
                        name: name.clone(),
                        context: format!("`prev` ({name} is {})", kind.word()),
                        help: help.into(),
                        span: self.at(f, arg.span),
                    },
                );
                bad
            }
            None => self.task_var(f, ts, name, arg.span),
        }
    }

    /// The task a domain declares, when it has task clauses; `None` for a domain of shapes only
    /// or when the task has mistakes (they are reported).
    ///
    /// Names are declared first, clause by clause in a fixed order (goal, actions, `let`s,
    /// observations, scores), then each clause is checked by its own function in the order its
    /// diagnostics are reported.
    pub(super) fn task(&mut self, f: usize, d: &DomainDecl, domain: &Domain) -> Option<TaskDef> {
        let is_task = !d.clauses.is_empty() || d.dims.iter().any(|x| x.meaning.is_some());
        if !is_task || self.full() {
            return None;
        }
        let before = self.error_count();
        let task = domain.name.as_str();
        let mut names = TaskNames::new(task);
        let goal = self.task_goal(f, d, &mut names);
        let action_dims = self.task_actions(f, d, &mut names);
        let mut values = self.task_lets(f, d, &mut names);
        let observe = self.task_observations(f, d, &mut names, &mut values);
        let score_decls = self.task_score_names(f, d, &mut names);

        let computed = self.task_values(f, &names, &values);
        let (speed, turn) = self.task_drives(f, d, task, &action_dims);
        let ends = self.task_ends(f, d, &names);
        let (flaws, windows) = self.task_flaws(f, d, &names);
        let scores = self.task_scores(f, d, &names, &score_decls);
        let success = self.task_success(f, d, &names);

        let goal_names: Vec<String> = d
            .clauses
            .iter()
            .filter_map(|c| match c {
                Clause::Goal(ps) => Some(ps.iter().map(|p| p.name.name.clone())),
                _ => None,
            })
            .flatten()
            .collect();
        let recorded = self.recorded(f, d, task, &names.kinds, &goal_names);
        let draw = self.draw(f, d, task, &names.kinds);
        let (test_count, test_seed) = self.test_set(f, d, task);
        let teacher = self.teacher(f, d, task, domain, &names.kinds);

        if self.error_count() > before {
            return None;
        }
        let def = TaskDef {
            domain: domain.clone(),
            doc: d.doc.join("\n"),
            goal,
            test_count,
            test_seed,
            slot_names: names.slots,
            computed,
            observe,
            speed,
            turn,
            ends,
            flaws,
            windows,
            score: scores.score,
            error: scores.error?,
            heading_error: scores.heading_error,
            efficiency: scores.efficiency,
            success: success?,
            recorded,
            draw,
            teacher,
        };
        // Where each value and score is defined, for what the finiteness check finds.
        let defined: HashMap<usize, Span> = values
            .iter()
            .map(|(slot, _, e)| (*slot, e.span))
            .chain(score_decls.iter().map(|(slot, b)| (*slot, b.value.span)))
            .collect();
        self.finiteness(f, &def, &defined);
        (self.error_count() == before).then_some(def)
    }

    /// A new name of the task, or a diagnostic when it is taken.
    fn task_declare(
        &mut self,
        f: usize,
        names: &mut TaskNames<'_>,
        id: &Ident,
        kind: Kind,
    ) -> Option<usize> {
        let n = id.name.as_str();
        let taken = if let Some(b) = BASE.iter().find(|(b, _, _)| *b == n) {
            Some(format!(
                "`{n}` is the robot's state ({}); choose another name",
                b.2
            ))
        } else if let Some((_, meaning)) = RESERVED.iter().find(|(r, _)| *r == n) {
            Some(format!("`{n}` is {meaning}; choose another name"))
        } else if n == "prev" || Func::by_name(n).is_some() {
            Some(format!("`{n}` is a built-in function; choose another name"))
        } else if names.kinds.contains_key(n) {
            Some(
                "each goal parameter, `let`, observation, action and score has its own name".into(),
            )
        } else {
            None
        };
        if let Some(help) = taken {
            self.err(
                f,
                id.span,
                CheckError::TaskDuplicateName {
                    name: n.into(),
                    help,
                    span: self.at(f, id.span),
                },
            );
            return None;
        }
        let slot = names.slots.len();
        names.kinds.insert(n.into(), (slot, kind));
        names.slots.push(n.into());
        Some(slot)
    }

    /// An expression of a task clause: resolved with the names `allowed` there (`context` says
    /// where it is), and expected to be of type `want`.
    #[allow(clippy::too_many_arguments)]
    fn task_expr(
        &mut self,
        f: usize,
        names: &TaskNames<'_>,
        allowed: &[Kind],
        context: &str,
        e: &Expr,
        want: Ty,
        help: Option<&str>,
    ) -> Ir {
        let ts = TaskScope {
            task: names.task,
            names: &names.kinds,
            allowed,
            context,
            prev_ok: true,
            hidden: None,
            windows: None,
        };
        let (ir, ty) = self.resolve(f, Scope::Task(&ts), e, "");
        self.expect(f, e, ty, want, help);
        ir
    }

    /// `goal NAME "unit" in [lo, hi], ...`: the goal parameters, each declared.
    fn task_goal(&mut self, f: usize, d: &DomainDecl, names: &mut TaskNames<'_>) -> Vec<GoalParam> {
        let mut goal = Vec::new();
        for c in &d.clauses {
            let Clause::Goal(params) = c else { continue };
            for p in params {
                if goal.len() == MAX_GOAL_PARAMS {
                    self.err(
                        f,
                        p.span,
                        CheckError::TaskImpossibleLimit {
                            what: "this goal".into(),
                            why: format!("a goal has at most {MAX_GOAL_PARAMS} parameters"),
                            help: "describe the goal with fewer numbers".into(),
                            span: self.at(f, p.span),
                        },
                    );
                    break;
                }
                if let Some(m) = &p.meaning {
                    let span = meaning_span(m, p.span);
                    self.err(
                        f,
                        span,
                        CheckError::TaskWrongMeaning {
                            what: format!("the goal parameter `{}` is drawn, not defined", p.name.name),
                            help: "a goal parameter has a name, a unit and a range; compute other values with `let`".into(),
                            span: self.at(f, span),
                        },
                    );
                }
                self.task_declare(f, names, &p.name, Kind::Goal);
                let Some(l) = &p.limits else {
                    self.err(
                        f,
                        p.span,
                        CheckError::TaskGoalNeedsRange {
                            name: p.name.name.clone(),
                            span: self.at(f, p.span),
                        },
                    );
                    continue;
                };
                if let Some(lim) = self.limits(f, l) {
                    if lim.lo.abs() > MAX_GOAL_ABS || lim.hi.abs() > MAX_GOAL_ABS {
                        self.err(
                            f,
                            l.span,
                            CheckError::TaskGoalRangeOutOfBounds {
                                name: p.name.name.clone(),
                                lo: crate::number::fmt_readable(lim.lo),
                                hi: crate::number::fmt_readable(lim.hi),
                                max: crate::number::fmt_readable(MAX_GOAL_ABS),
                                span: self.at(f, l.span),
                            },
                        );
                        continue;
                    }
                    goal.push(GoalParam {
                        name: p.name.name.clone(),
                        unit: p.unit.clone().unwrap_or_default(),
                        lo: lim.lo,
                        hi: lim.hi,
                    });
                }
            }
        }
        goal
    }

    /// The action dimensions, each declared: `(slot, dimension)`.
    fn task_actions<'d>(
        &mut self,
        f: usize,
        d: &'d DomainDecl,
        names: &mut TaskNames<'_>,
    ) -> Vec<(usize, &'d DimDecl)> {
        let mut action_dims = Vec::new();
        for dim in d.dims.iter().filter(|x| x.space == Space::Action) {
            if let Some(slot) = self.task_declare(f, names, &dim.name, Kind::Action) {
                action_dims.push((slot, dim));
            }
        }
        action_dims
    }

    /// `let NAME = EXPR, ...`: each declared; `(slot, name, expression)` of each value to compute.
    fn task_lets<'d>(
        &mut self,
        f: usize,
        d: &'d DomainDecl,
        names: &mut TaskNames<'_>,
    ) -> Vec<(usize, &'d Ident, &'d Expr)> {
        let mut values = Vec::new();
        for c in &d.clauses {
            let Clause::Let(bs) = c else { continue };
            for b in bs {
                if let Some(slot) = self.task_declare(f, names, &b.name, Kind::Value) {
                    values.push((slot, &b.name, &b.value));
                }
            }
        }
        values
    }

    /// The observation dimensions, each declared and defined by `= EXPR` (added to `values`):
    /// their slots, in order.
    fn task_observations<'d>(
        &mut self,
        f: usize,
        d: &'d DomainDecl,
        names: &mut TaskNames<'_>,
        values: &mut Vec<(usize, &'d Ident, &'d Expr)>,
    ) -> Vec<usize> {
        let mut observe = Vec::new();
        for dim in d.dims.iter().filter(|x| x.space == Space::Observation) {
            let slot = self.task_declare(f, names, &dim.name, Kind::Value);
            match (&dim.meaning, slot) {
                (Some(DimMeaning::Def(e)), Some(slot)) => {
                    values.push((slot, &dim.name, e));
                    observe.push(slot);
                }
                (Some(m @ (DimMeaning::Drives(..) | DimMeaning::Changes(..))), _) => {
                    let span = meaning_span(m, dim.span);
                    self.err(
                        f,
                        span,
                        CheckError::TaskWrongMeaning {
                            what: format!("the observation `{}` cannot drive the base", dim.name.name),
                            help: "actions drive the base (`act trans \"m/s\" in [-1, 1] drives speed`); an observation is computed: `= EXPR`".into(),
                            span: self.at(f, span),
                        },
                    );
                }
                (None, _) => self.err(
                    f,
                    dim.name.span,
                    CheckError::TaskUndefinedObservation {
                        name: dim.name.name.clone(),
                        span: self.at(f, dim.name.span),
                    },
                ),
                _ => {}
            }
        }
        observe
    }

    /// `score NAME = EXPR, ...`: each declared; `(slot, binding)` of each score.
    fn task_score_names<'d>(
        &mut self,
        f: usize,
        d: &'d DomainDecl,
        names: &mut TaskNames<'_>,
    ) -> Vec<(usize, &'d Binding)> {
        let mut score_decls = Vec::new();
        for c in &d.clauses {
            let Clause::Score(bs) = c else { continue };
            for b in bs {
                if let Some(slot) = self.task_declare(f, names, &b.name, Kind::Score) {
                    score_decls.push((slot, b));
                }
            }
        }
        score_decls
    }

    /// The values (`let`s and observations) resolved, in the order to compute them.
    fn task_values(
        &mut self,
        f: usize,
        names: &TaskNames<'_>,
        values: &[(usize, &Ident, &Expr)],
    ) -> Vec<(usize, Ir)> {
        const VALUE_READS: &[Kind] = &[Kind::Base, Kind::Goal, Kind::Value];
        let mut resolved: HashMap<usize, Ir> = HashMap::new();
        for (slot, name, e) in values {
            let context = format!("the definition of `{}`", name.name);
            let ir = self.task_expr(
                f,
                names,
                VALUE_READS,
                &context,
                e,
                Ty::Num,
                Some("a value is a number; use `if(cond, a, b)` to choose between two"),
            );
            resolved.insert(*slot, ir);
        }
        let order = self.value_order(f, values, &resolved, &names.slots);
        order
            .into_iter()
            .filter_map(|slot| resolved.remove(&slot).map(|ir| (slot, ir)))
            .collect()
    }

    /// What each action drives (`drives speed`, `changes turn by ...`): the speed and turn
    /// drives, each at most once; a task without actions is reported.
    fn task_drives(
        &mut self,
        f: usize,
        d: &DomainDecl,
        task: &str,
        action_dims: &[(usize, &DimDecl)],
    ) -> (Option<Drive>, Option<Drive>) {
        let mut speed: Option<(Drive, String)> = None;
        let mut turn: Option<(Drive, String)> = None;
        for (i, (_, dim)) in action_dims.iter().enumerate() {
            let (axis, integrate) = match &dim.meaning {
                None => {
                    self.err(
                        f,
                        dim.name.span,
                        CheckError::TaskUndrivenAction {
                            name: dim.name.name.clone(),
                            span: self.at(f, dim.name.span),
                        },
                    );
                    continue;
                }
                Some(DimMeaning::Def(e)) => {
                    self.err(
                        f,
                        e.span,
                        CheckError::TaskWrongMeaning {
                            what: format!("the action `{}` is chosen by the controller, not computed", dim.name.name),
                            help: format!("say what it commands instead: `{} drives speed` or `drives turn`; a value computed from others is a `let`", dim.name.name),
                            span: self.at(f, e.span),
                        },
                    );
                    continue;
                }
                Some(DimMeaning::Drives(a)) => (a, None),
                Some(DimMeaning::Changes(a, l)) => (a, Some(l)),
            };
            let axis_kind = match axis.name.as_str() {
                "speed" => Axis::Speed,
                "turn" => Axis::Turn,
                _ => {
                    self.err(
                        f,
                        axis.span,
                        CheckError::TaskUnknownAxis {
                            name: axis.name.clone(),
                            span: self.at(f, axis.span),
                        },
                    );
                    continue;
                }
            };
            let integrate = match integrate {
                Some(l) => match self.limits(f, l) {
                    Some(lim) => Some(lim),
                    None => continue,
                },
                None => None,
            };
            let slot = match axis_kind {
                Axis::Speed => &mut speed,
                Axis::Turn => &mut turn,
            };
            if let Some((_, first)) = slot {
                self.err(
                    f,
                    axis.span,
                    CheckError::TaskAxisTwice {
                        axis: axis_kind.word().into(),
                        first: first.clone(),
                        span: self.at(f, axis.span),
                    },
                );
                continue;
            }
            *slot = Some((
                Drive {
                    action: i,
                    integrate,
                },
                dim.name.name.clone(),
            ));
        }
        if action_dims.is_empty() {
            self.err(
                f,
                d.name.span,
                CheckError::TaskIncomplete {
                    task: task.into(),
                    what: "action".into(),
                    help: "declare what the controller commands: `act trans \"m/s\" in [-1, 1] drives speed, rot \"rad/s\" in [-1, 1] drives turn`".into(),
                    span: self.at(f, d.name.span),
                },
            );
        }
        (speed.map(|(d, _)| d), turn.map(|(d, _)| d))
    }

    /// `end when COND [for SECONDS]` and `end after SECONDS` (exactly one).
    fn task_ends(&mut self, f: usize, d: &DomainDecl, names: &TaskNames<'_>) -> Vec<EndRule> {
        let mut ends = Vec::new();
        let mut limit_seen = false;
        for c in &d.clauses {
            match c {
                Clause::EndWhen { cond, hold, span } => {
                    let text = self.sources[f]
                        .text
                        .get(span.start..span.end)
                        .unwrap_or("end when")
                        .split_whitespace()
                        .collect::<Vec<_>>()
                        .join(" ");
                    let ir = self.task_expr(
                        f,
                        names,
                        RULE_READS,
                        "an end rule",
                        cond,
                        Ty::Bool,
                        Some("an end rule is a condition such as `abs(v) < 0.02`"),
                    );
                    let hold_s = match hold {
                        None => Some(0.0),
                        Some(h) => self.seconds(f, h, "the time a condition must hold", false),
                    };
                    if let Some(hold_s) = hold_s {
                        ends.push(EndRule::When {
                            cond: ir,
                            hold_s,
                            text,
                        });
                    }
                }
                Clause::EndAfter { limit, span } => {
                    if self.twice(f, limit_seen, "end after", *span) {
                        continue;
                    }
                    limit_seen = true;
                    if let Some(limit_s) = self.seconds(f, limit, "the time limit", true) {
                        ends.push(EndRule::After { limit_s });
                    }
                }
                _ => {}
            }
        }
        if !limit_seen {
            self.err(
                f,
                d.name.span,
                CheckError::TaskIncomplete {
                    task: names.task.into(),
                    what: "time limit".into(),
                    help: "every run must end, on a real base too: add `end after 60` (seconds)"
                        .into(),
                    span: self.at(f, d.name.span),
                },
            );
        }
        ends
    }

    /// `flaw NAME when COND [for SECONDS]`, any number, each name once: conditions over what end
    /// rules read, and the look-backs (`total`, `change`) only a flaw may use.
    fn task_flaws(
        &mut self,
        f: usize,
        d: &DomainDecl,
        names: &TaskNames<'_>,
    ) -> (Vec<FlawDef>, Vec<Window>) {
        let windows = std::cell::RefCell::new(Vec::new());
        let mut flaws: Vec<FlawDef> = Vec::new();
        for c in &d.clauses {
            let Clause::Flaw {
                name,
                cond,
                hold,
                span,
            } = c
            else {
                continue;
            };
            if flaws.iter().any(|x| x.name == name.name) {
                self.err(
                    f,
                    name.span,
                    CheckError::FlawTwice {
                        name: name.name.clone(),
                        span: self.at(f, name.span),
                    },
                );
                continue;
            }
            let text = self.sources[f]
                .text
                .get(span.start..span.end)
                .unwrap_or("flaw")
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ");
            let context = format!("the flaw `{}`", name.name);
            let ts = TaskScope {
                task: names.task,
                names: &names.kinds,
                allowed: RULE_READS,
                context: &context,
                prev_ok: true,
                hidden: None,
                windows: Some((&windows, names.slots.len())),
            };
            let (ir, ty) = self.resolve(f, Scope::Task(&ts), cond, "");
            self.expect(
                f,
                cond,
                ty,
                Ty::Bool,
                Some("a flaw is a condition such as `closing < 0`, true where the run goes wrong"),
            );
            let hold_s = match hold {
                None => Some(0.0),
                Some(h) => self.seconds(f, h, "a flaw's `for` time", false),
            };
            if let Some(hold_s) = hold_s {
                flaws.push(FlawDef {
                    name: name.name.clone(),
                    cond: ir,
                    hold_s,
                    text,
                });
            }
        }
        (flaws, windows.into_inner())
    }

    /// `total(VALUE, SECONDS)` or `change(VALUE, SECONDS)` in a flaw: the look-back's slot.
    pub(super) fn task_window(
        &mut self,
        f: usize,
        ts: &TaskScope<'_>,
        kind: WindowKind,
        args: &[Expr],
        span: Span,
    ) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        let Some((windows, first_slot)) = ts.windows else {
            let help = if ts.context.contains("look-back") {
                "a look-back's value is read at each point; look back over a `let` instead, or write a second flaw".to_string()
            } else {
                format!(
                    "only a `flaw` condition looks back over the run, e.g. `flaw loop when abs(total(turned, 4)) > pi`; {} reads this step{}",
                    ts.context,
                    if ts.prev_ok { " and `prev(NAME)`" } else { "" }
                )
            };
            self.err(
                f,
                span,
                CheckError::WindowNotHere {
                    func: kind.word().into(),
                    context: ts.context.into(),
                    help,
                    span: self.at(f, span),
                },
            );
            return bad;
        };
        let [value, seconds] = args else {
            self.err(
                f,
                span,
                CheckError::WrongArity {
                    func: kind.word().into(),
                    expected: 2,
                    found: args.len(),
                    signature: kind.signature().into(),
                    span: self.at(f, span),
                },
            );
            return bad;
        };
        let context = format!("a look-back's value in {}", ts.context);
        let inner = TaskScope {
            task: ts.task,
            names: ts.names,
            allowed: ts.allowed,
            context: &context,
            prev_ok: ts.prev_ok,
            hidden: ts.hidden,
            windows: None,
        };
        let (ir, ty) = self.resolve(f, Scope::Task(&inner), value, "");
        let ok = self.expect(
            f,
            value,
            ty,
            Ty::Num,
            Some("a look-back sums or compares a number, such as `total(turned, 3)`"),
        );
        if !is_constant(seconds) {
            self.err(
                f,
                seconds.span,
                CheckError::TaskWrongMeaning {
                    what: format!(
                        "how far `{}` looks back is a constant number of seconds",
                        kind.word()
                    ),
                    help: format!(
                        "write a number such as `{}(range, 1)`; {}",
                        kind.word(),
                        kind.signature()
                    ),
                    span: self.at(f, seconds.span),
                },
            );
            return bad;
        }
        let Some(seconds) = self.seconds(f, seconds, "a look-back's stretch", true) else {
            return bad;
        };
        if !ok {
            return bad;
        }
        let mut w = windows.borrow_mut();
        let slot = first_slot + w.len();
        w.push(Window {
            kind,
            value: ir,
            seconds,
        });
        (Ir::Slot(slot), Ty::Num)
    }

    /// The scores, in order: each may read the ones before it. A task without `error` is
    /// reported.
    fn task_scores(
        &mut self,
        f: usize,
        d: &DomainDecl,
        names: &TaskNames<'_>,
        score_decls: &[(usize, &Binding)],
    ) -> Scores {
        let mut scores = Scores::default();
        for (slot, b) in score_decls {
            let context = format!("the score `{}`", b.name.name);
            let ir = self.task_expr(f, names, SCORE_READS, &context, &b.value, Ty::Num, None);
            let mut reads = Vec::new();
            ir.slots(&mut reads);
            if let Some((later, _)) = reads.iter().find(|(s, _)| {
                *s >= *slot
                    && names
                        .kinds
                        .values()
                        .any(|(x, k)| x == s && *k == Kind::Score)
            }) {
                let later = &names.slots[*later];
                self.err(
                    f,
                    b.value.span,
                    CheckError::TaskNameNotHere {
                        name: later.clone(),
                        context: context.clone(),
                        help: "scores are computed in the order they are written; a score reads only the ones before it".into(),
                        span: self.at(f, b.value.span),
                    },
                );
            }
            match b.name.name.as_str() {
                "error" => scores.error = Some(*slot),
                "heading_error" => scores.heading_error = Some(*slot),
                "efficiency" => scores.efficiency = Some(*slot),
                _ => {}
            }
            scores.score.push((*slot, ir));
        }
        if scores.error.is_none() {
            self.err(
                f,
                d.name.span,
                CheckError::TaskIncomplete {
                    task: names.task.into(),
                    what: "`error` score".into(),
                    help: "say how far a run's end is from what was asked, e.g. `score error = hypot(x - x_g, y - y_g)`; evaluations report its mean".into(),
                    span: self.at(f, d.name.span),
                },
            );
        }
        scores
    }

    /// `success when COND` (exactly one).
    fn task_success(&mut self, f: usize, d: &DomainDecl, names: &TaskNames<'_>) -> Option<Ir> {
        let mut success = None;
        for c in &d.clauses {
            let Clause::Success { cond, span } = c else {
                continue;
            };
            if self.twice(f, success.is_some(), "success", *span) {
                continue;
            }
            success = Some(self.task_expr(
                f,
                names,
                SCORE_READS,
                "the success rule",
                cond,
                Ty::Bool,
                Some("success is a condition such as `error < 0.2`"),
            ));
        }
        if success.is_none() {
            self.err(
                f,
                d.name.span,
                CheckError::TaskMissingSuccess {
                    task: names.task.into(),
                    span: self.at(f, d.name.span),
                },
            );
        }
        success
    }

    /// Report a second clause of a kind a task has once; whether it was one.
    fn twice(&mut self, f: usize, seen: bool, clause: &str, span: Span) -> bool {
        if seen {
            self.err(
                f,
                span,
                CheckError::TaskClauseTwice {
                    clause: clause.into(),
                    span: self.at(f, span),
                },
            );
        }
        seen
    }

    /// A constant number of seconds: positive (or, where not `positive`, zero) and at most
    /// [`MAX_TIME_LIMIT_S`].
    fn seconds(&mut self, f: usize, e: &Expr, what: &str, positive: bool) -> Option<f64> {
        let v = self.constant(f, e, what)?;
        let why = if v < 0.0 || (positive && v == 0.0) {
            Some(format!(
                "{} s is not a time a run can take",
                crate::syntax::print::number(v)
            ))
        } else if v > MAX_TIME_LIMIT_S {
            Some(format!(
                "{} s is longer than a run may take ({} s, ten minutes: a run's trace stays a few megabytes)",
                crate::syntax::print::number(v),
                crate::syntax::print::number(MAX_TIME_LIMIT_S),
            ))
        } else {
            None
        };
        if let Some(why) = why {
            self.err(
                f,
                e.span,
                CheckError::TaskImpossibleLimit {
                    what: what.into(),
                    why,
                    help: format!(
                        "write a number of seconds up to {}, e.g. `end after 60` or `for 0.5`",
                        crate::syntax::print::number(MAX_TIME_LIMIT_S)
                    ),
                    span: self.at(f, e.span),
                },
            );
            return None;
        }
        Some(v)
    }

    /// The order to compute values in: each after the values it reads (this step's, and at the
    /// first step the ones it reads with `prev`, which are then this step's). A cycle is reported.
    fn value_order(
        &mut self,
        f: usize,
        values: &[(usize, &Ident, &Expr)],
        resolved: &HashMap<usize, Ir>,
        slot_names: &[String],
    ) -> Vec<usize> {
        let ids: HashMap<usize, usize> = values
            .iter()
            .enumerate()
            .map(|(i, (s, _, _))| (*s, i))
            .collect();
        let deps: Vec<Vec<usize>> = values
            .iter()
            .map(|(slot, _, _)| {
                let mut reads = Vec::new();
                if let Some(ir) = resolved.get(slot) {
                    ir.slots(&mut reads);
                }
                let mut d: Vec<usize> = reads
                    .into_iter()
                    .filter_map(|(s, _)| ids.get(&s).copied())
                    .collect();
                d.sort_unstable();
                d.dedup();
                d
            })
            .collect();
        // Iterative depth-first search: 0 unvisited, 1 on the path, 2 done.
        let mut state = vec![0u8; values.len()];
        let mut order = Vec::with_capacity(values.len());
        let mut reported = false;
        for root in 0..values.len() {
            if state[root] != 0 {
                continue;
            }
            let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
            state[root] = 1;
            while let Some(&mut (node, ref mut next)) = stack.last_mut() {
                if let Some(&dep) = deps[node].get(*next) {
                    *next += 1;
                    match state[dep] {
                        0 => {
                            state[dep] = 1;
                            stack.push((dep, 0));
                        }
                        1 if !reported => {
                            reported = true;
                            let start = stack.iter().position(|(n, _)| *n == dep).unwrap_or(0);
                            let mut chain: Vec<&str> = stack[start..]
                                .iter()
                                .map(|(n, _)| slot_names[values[*n].0].as_str())
                                .collect();
                            chain.push(slot_names[values[dep].0].as_str());
                            let (_, id, _) = values[dep];
                            self.err(
                                f,
                                id.span,
                                CheckError::TaskCycle {
                                    name: id.name.clone(),
                                    chain: chain.join(" -> "),
                                    span: self.at(f, id.span),
                                },
                            );
                        }
                        _ => {}
                    }
                } else {
                    state[node] = 2;
                    order.push(values[node].0);
                    stack.pop();
                }
            }
        }
        order
    }

    fn recorded(
        &mut self,
        f: usize,
        d: &DomainDecl,
        task: &str,
        names: &HashMap<String, (usize, Kind)>,
        goal: &[String],
    ) -> Option<Vec<Ir>> {
        let mut out: Option<Vec<Option<Ir>>> = None;
        let mut clause_span = None;
        for c in &d.clauses {
            let Clause::Recorded(bs) = c else { continue };
            let span = bs.first().map_or(d.name.span, |b| b.span);
            if self.twice(f, out.is_some(), "recorded", span) {
                continue;
            }
            clause_span = Some(span);
            let mut got: Vec<Option<Ir>> = vec![None; goal.len()];
            for b in bs {
                let Some(i) = goal.iter().position(|g| *g == b.name.name) else {
                    let gnames: Vec<&str> = goal.iter().map(String::as_str).collect();
                    self.err(
                        f,
                        b.name.span,
                        CheckError::TaskRecordedUnknown {
                            name: b.name.name.clone(),
                            help: hint(&b.name.name, "goal parameters", &gnames),
                            span: self.at(f, b.name.span),
                        },
                    );
                    continue;
                };
                if got[i].is_some() {
                    self.err(
                        f,
                        b.name.span,
                        CheckError::TaskDuplicateName {
                            name: b.name.name.clone(),
                            help: "each goal parameter is read once".into(),
                            span: self.at(f, b.name.span),
                        },
                    );
                    continue;
                }
                let ts = TaskScope {
                    task,
                    names,
                    allowed: &[Kind::Base],
                    context: "`recorded` (the pose a recording ends at)",
                    prev_ok: false,
                    hidden: None,
                    windows: None,
                };
                let (ir, ty) = self.resolve(f, Scope::Task(&ts), &b.value, "");
                self.expect(f, &b.value, ty, Ty::Num, None);
                got[i] = Some(ir);
            }
            out = Some(got);
        }
        let got = out?;
        let mut all = Vec::with_capacity(got.len());
        for (g, ir) in goal.iter().zip(got) {
            match ir {
                Some(ir) => all.push(ir),
                None => {
                    let span = clause_span.unwrap_or(d.name.span);
                    self.err(
                        f,
                        span,
                        CheckError::TaskRecordedIncomplete {
                            name: g.clone(),
                            span: self.at(f, span),
                        },
                    );
                }
            }
        }
        (all.len() == goal.len()).then_some(all)
    }

    /// The `draw` clauses: each shape known, with its number of values, each value an expression
    /// of the goal's parameters (a picture is drawn for a goal, before and after the run), and
    /// each name once.
    fn draw(
        &mut self,
        f: usize,
        d: &DomainDecl,
        task: &str,
        names: &HashMap<String, (usize, Kind)>,
    ) -> Vec<DrawDef> {
        let mut out = Vec::new();
        let mut seen: Vec<&str> = Vec::new();
        for c in &d.clauses {
            let Clause::Draw(drawings) = c else { continue };
            for dr in drawings {
                let name = dr.name.name.as_str();
                if seen.contains(&name) {
                    self.err(
                        f,
                        dr.name.span,
                        CheckError::TaskDuplicateName {
                            name: name.into(),
                            help: "each drawing has a name of its own: the legend's".into(),
                            span: self.at(f, dr.name.span),
                        },
                    );
                }
                seen.push(name);
                let Some(shape) = ShapeKind::named(&dr.shape.name) else {
                    let words: Vec<&str> = ShapeKind::ALL.iter().map(|k| k.word()).collect();
                    self.err(
                        f,
                        dr.shape.span,
                        CheckError::TaskDrawShape {
                            shape: dr.shape.name.clone(),
                            help: hint(&dr.shape.name, "shapes", &words),
                            span: self.at(f, dr.shape.span),
                        },
                    );
                    continue;
                };
                if dr.args.len() != shape.arity() {
                    self.err(
                        f,
                        dr.span,
                        CheckError::TaskDrawArity {
                            shape: shape.word().into(),
                            expected: shape.arity(),
                            found: dr.args.len(),
                            signature: shape.signature().into(),
                            span: self.at(f, dr.span),
                        },
                    );
                    continue;
                }
                let ts = TaskScope {
                    task,
                    names,
                    allowed: &[Kind::Goal],
                    context: "`draw` (a picture is drawn from the goal alone)",
                    prev_ok: false,
                    hidden: None,
                    windows: None,
                };
                let args = dr
                    .args
                    .iter()
                    .map(|e| {
                        let (ir, ty) = self.resolve(f, Scope::Task(&ts), e, "");
                        self.expect(f, e, ty, Ty::Num, None);
                        ir
                    })
                    .collect();
                out.push(DrawDef {
                    name: name.into(),
                    shape,
                    args,
                });
            }
        }
        out
    }

    fn test_set(&mut self, f: usize, d: &DomainDecl, task: &str) -> (usize, u64) {
        let mut out = None;
        for c in &d.clauses {
            let Clause::Test { count, seed, span } = c else {
                continue;
            };
            if self.twice(f, out.is_some(), "test", *span) {
                continue;
            }
            let whole = |v: f64, max: f64| v.fract() == 0.0 && v >= 0.0 && v <= max;
            if !whole(*count, MAX_TEST_GOALS as f64) || *count < 1.0 {
                self.err(
                    f,
                    *span,
                    CheckError::TaskImpossibleLimit {
                        what: "the test set".into(),
                        why: format!(
                            "{} is not a number of goals from 1 to {MAX_TEST_GOALS}",
                            crate::syntax::print::number(*count)
                        ),
                        help: "write a whole number, e.g. `test 25`".into(),
                        span: self.at(f, *span),
                    },
                );
                out = Some((DEFAULT_TEST_GOALS, 0));
                continue;
            }
            let max_seed = 9_007_199_254_740_992.0; // 2^53: every whole number below is exact.
            let seed = match seed {
                Some(s) if whole(*s, max_seed) => *s as u64,
                Some(s) => {
                    self.err(
                        f,
                        *span,
                        CheckError::TaskImpossibleLimit {
                            what: "the test seed".into(),
                            why: format!(
                                "{} is not a whole number from 0 to 2^53",
                                crate::syntax::print::number(*s)
                            ),
                            help: "write a whole number, e.g. `test 25 seed 7`".into(),
                            span: self.at(f, *span),
                        },
                    );
                    0
                }
                None => name_seed(task),
            };
            out = Some((*count as usize, seed));
        }
        out.unwrap_or((DEFAULT_TEST_GOALS, name_seed(task)))
    }

    fn teacher(
        &mut self,
        f: usize,
        d: &DomainDecl,
        task: &str,
        domain: &Domain,
        outer: &HashMap<String, (usize, Kind)>,
    ) -> Option<TeacherDef> {
        let mut out = None;
        for c in &d.clauses {
            let Clause::Teacher { stmts, span } = c else {
                continue;
            };
            if self.twice(f, out.is_some(), "teacher", *span) {
                continue;
            }
            let mut names: HashMap<String, (usize, Kind)> = domain
                .observe
                .iter()
                .enumerate()
                .map(|(i, o)| (o.name.clone(), (i, Kind::TeacherObs)))
                .collect();
            let mut slots = domain.obs_dim();
            let mut written: Vec<usize> = Vec::new();
            let mut out_stmts = Vec::new();
            for st in stmts {
                let b = &st.binding;
                let ts = TaskScope {
                    task,
                    names: &names,
                    allowed: &[Kind::TeacherObs, Kind::TeacherLocal],
                    context: "the teacher",
                    prev_ok: false,
                    hidden: Some(outer),
                    windows: None,
                };
                let (ir, ty) = self.resolve(f, Scope::Task(&ts), &b.value, "");
                self.expect(f, &b.value, ty, Ty::Num, None);
                let n = b.name.name.as_str();
                if st.is_let {
                    if names.contains_key(n)
                        || domain.find(n).is_some()
                        || RESERVED.iter().any(|(r, _)| *r == n)
                    {
                        self.err(
                            f,
                            b.name.span,
                            CheckError::TaskDuplicateName {
                                name: n.into(),
                                help: "a teacher's `let` needs a name of its own".into(),
                                span: self.at(f, b.name.span),
                            },
                        );
                        continue;
                    }
                    names.insert(n.into(), (slots, Kind::TeacherLocal));
                    out_stmts.push((TeacherTarget::Local(slots), ir));
                    slots += 1;
                } else if let Some(i) = domain.index_of(Space::Action, n) {
                    if written.contains(&i) {
                        self.err(
                            f,
                            b.name.span,
                            CheckError::TaskDuplicateName {
                                name: n.into(),
                                help: "the teacher sets each action once".into(),
                                span: self.at(f, b.name.span),
                            },
                        );
                        continue;
                    }
                    written.push(i);
                    out_stmts.push((TeacherTarget::Action(i), ir));
                } else {
                    let actions: Vec<&str> = domain.act.iter().map(|a| a.name.as_str()).collect();
                    let help = if domain.index_of(Space::Observation, n).is_some() {
                        format!(
                            "`{n}` is an observation: the teacher reads observations and sets actions ({})",
                            listing(&actions)
                        )
                    } else {
                        format!(
                            "{}; for a value of its own write `let {n} = ...`",
                            hint(n, "actions", &actions)
                        )
                    };
                    self.err(
                        f,
                        b.name.span,
                        CheckError::TeacherWritesNonAction {
                            name: n.into(),
                            help,
                            span: self.at(f, b.name.span),
                        },
                    );
                }
            }
            out = Some(TeacherDef {
                slots,
                stmts: out_stmts,
            });
        }
        out
    }
}

/// Whether `e` is built of numbers, `pi` and arithmetic alone (what a look-back's seconds are).
fn is_constant(e: &Expr) -> bool {
    match &e.kind {
        ExprKind::Num(_) => true,
        ExprKind::Var(v) => v == "pi",
        ExprKind::Unary(_, a) => is_constant(a),
        ExprKind::Binary(_, a, b) => is_constant(a) && is_constant(b),
        ExprKind::At { .. } | ExprKind::Call { .. } => false,
    }
}

fn meaning_span(m: &DimMeaning, fallback: Span) -> Span {
    let s = match m {
        DimMeaning::Def(e) => e.span,
        DimMeaning::Drives(a) | DimMeaning::Changes(a, _) => a.span,
    };
    if s.end > s.start { s } else { fallback }
}

fn kinds(allowed: &[Kind]) -> String {
    allowed
        .iter()
        .map(|k| k.word())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The test seed of a task that names none: FNV-1a of its name, so it is the same everywhere.
pub(crate) fn name_seed(name: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}
