//! Whether a task's observations and scores are numbers: what the checker can prove or bound
//! before a run does (at run time a value that is not a number stops the run,
//! `advise::task::non_finite`).
//!
//! Each observation is evaluated at the start of a run (the pose, speeds and time all 0, no
//! action yet, as every run in the simulator starts) for the corners, the middle and a few draws
//! of the goal ranges, and, with each score, at a few dozen states spread over the pose, the
//! speeds, the time up to the limit, the goal ranges and the actions' limits (half of them with a
//! different previous step, for `prev`). Where one is not a finite number, the value it starts in
//! (a `let` it reads, say) is found and reported once:
//! - an error where the answer is certain or nearly so: the value reads nothing (`0/0`,
//!   `1e308 * 1e308`), an observation is not a number at the start of any run tried (every run
//!   would stop at its first step), or a score at any state tried;
//! - a warning where it is only possible (`1 / dx` where `dx` may be 0).
//!
//! The states are fixed (a seeded generator), so a check says the same thing every time; their
//! number shrinks with the declaration's size so that the check stays cheap.

use std::collections::{HashMap, HashSet};

use super::super::{CheckError, CheckWarning, Checker};
use crate::program::ir::Ir;
use crate::program::task::{self as def, EndRule, TaskDef};
use crate::syntax::ast::Span;

/// How many expression nodes the check evaluates at most, over all its states.
const BUDGET: usize = 4_000_000;
/// Pairs of states (a step and the one before) tried for observations and scores.
const PAIRS: usize = 32;
/// The most warnings one task gets; the last says how many more values were left unsaid.
const MAX_WARNINGS: usize = 10;

/// Values the robot's state takes in the states tried (the time is filled in from the task).
const XY: [f64; 6] = [0.0, 1.0, -1.0, 2.5, -3.7, 12.0];
const THETA: [f64; 5] = [
    0.0,
    1.2,
    -2.9,
    std::f64::consts::PI,
    -std::f64::consts::FRAC_PI_2,
];
const V: [f64; 4] = [0.0, 0.4, -0.3, 1.0];
const W: [f64; 3] = [0.0, 0.6, -0.8];

/// One state the values are computed at.
struct Point {
    env: Vec<f64>,
    /// The previous step's environment (`None`: this one, as at a run's first step).
    prev: Option<usize>,
    /// At the start of a run.
    start: bool,
}

/// What one observation or score did over the states tried.
#[derive(Default)]
struct Sink {
    start_tried: usize,
    start_failed: usize,
    tried: usize,
    failed: usize,
    /// The first failure: the value it started in, whether at the previous step, and the state.
    first: Option<(usize, bool, usize)>,
}

/// SplitMix64: a fixed, dependency-free sequence for choosing the states.
struct Mix(u64);

impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = self.0;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^ (x >> 31)
    }

    fn pick(&mut self, of: &[f64]) -> f64 {
        of[(self.next() % of.len() as u64) as usize]
    }

    /// Uniform in `[lo, hi]`, to two decimals where the range allows (what a message shows).
    fn within(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next() >> 11) as f64 / (1u64 << 53) as f64;
        let v = lo + (hi - lo) * u;
        let r = (v * 100.0).round() / 100.0;
        if r >= lo && r <= hi { r } else { v }
    }

    /// A bound, the middle, or a value in between.
    fn in_range(&mut self, lo: f64, hi: f64) -> f64 {
        match self.next() % 4 {
            0 => lo,
            1 => hi,
            2 => lo / 2.0 + hi / 2.0,
            _ => self.within(lo, hi),
        }
    }
}

impl Checker<'_> {
    /// Report the observations and scores of `d` that are, or may be, not numbers. `defined` is
    /// where each value and score is defined.
    pub(super) fn finiteness(&mut self, f: usize, d: &TaskDef, defined: &HashMap<usize, Span>) {
        let size: usize = d
            .computed
            .iter()
            .chain(&d.score)
            .map(|(_, ir)| ir.size())
            .sum::<usize>()
            .max(1);
        let limit_s = d
            .ends
            .iter()
            .find_map(|e| match e {
                EndRule::After { limit_s } => Some(*limit_s),
                EndRule::When { .. } => None,
            })
            .unwrap_or(def::MAX_TIME_LIMIT_S);
        let points = states(d, limit_s, (BUDGET / size).clamp(4, 2 * PAIRS + 24));
        let irs: HashMap<usize, &Ir> = d
            .computed
            .iter()
            .chain(&d.score)
            .map(|(s, ir)| (*s, ir))
            .collect();
        let scores: HashSet<usize> = d.score.iter().map(|(s, _)| *s).collect();
        let observed: HashSet<usize> = d.observe.iter().copied().collect();
        let sinks = try_states(d, &points, &irs, &scores);
        // One diagnostic per value a failure starts in; an error where one of its sinks is
        // certain.
        let mut reported: HashSet<usize> = HashSet::new();
        let (mut warned, mut unsaid) = (0, 0);
        let mut order: Vec<(usize, bool, &Sink)> = sinks
            .iter()
            .filter_map(|(slot, s)| {
                let (root, _, _) = s.first.as_ref()?;
                let constant = irs.get(root).is_some_and(|ir| reads_nothing(ir));
                let certain = constant
                    || (s.start_tried > 0 && s.start_failed == s.start_tried)
                    || (scores.contains(slot) && s.failed == s.tried);
                Some((*slot, certain, s))
            })
            .collect();
        // Errors first, so a value both certain and possible is an error.
        order.sort_by_key(|(slot, certain, _)| (!*certain, *slot));
        for (sink, certain, s) in order {
            let Some((root, in_prev, point)) = &s.first else {
                continue;
            };
            let p = &points[*point];
            let prev = p.prev.map_or(&p.env, |i| &points[i].env);
            let env = if *in_prev { prev } else { &p.env };
            if !reported.insert(*root) {
                continue;
            }
            let Some(&span) = defined.get(root) else {
                continue;
            };
            if !certain && warned == MAX_WARNINGS {
                unsaid += 1;
                continue;
            }
            let word = what(&observed, &scores, *root);
            let name = d.slot_names[*root].clone();
            let through = if *root == sink {
                String::new()
            } else {
                format!(
                    "{} `{}` reads it, so ",
                    what(&observed, &scores, sink),
                    d.slot_names[sink]
                )
            };
            let value = env[*root].to_string();
            // Where it was tried, said only for what is reported (it walks what the value reads).
            let at = describe(d, &irs, *root, env, prev, p.start);
            if certain {
                let constant = irs.get(root).is_some_and(|ir| reads_nothing(ir));
                let is_score = scores.contains(&sink);
                let (never, at) = if constant {
                    ("is never a number".into(), "whatever the robot does".into())
                } else if is_score {
                    (
                        format!("is not a number at any of the {} states tried", s.tried),
                        at,
                    )
                } else {
                    ("is not a number at the start of any run".into(), at)
                };
                let effect = if is_score {
                    "every run would end with no score (a failure)"
                } else {
                    "every run would stop at its first step (`advise::task::non_finite`)"
                };
                self.err(
                    f,
                    span,
                    CheckError::TaskNotFinite {
                        what: word.into(),
                        name,
                        never,
                        value,
                        at,
                        help: capital(&format!(
                            "{through}{effect}. A division by zero, or the square root of a negative number? Guard it, e.g. `if(d == 0, 0, 1 / d)` or `sqrt(max(0, s))`"
                        )),
                        span: self.at(f, span),
                    },
                );
            } else {
                warned += 1;
                self.warnings.push((
                    f,
                    span.start,
                    CheckWarning::TaskMaybeNotFinite {
                        what: word.into(),
                        name,
                        value,
                        at,
                        help: capital(&format!(
                            "{through}a run that gets there is stopped (`advise::task::non_finite`); guard it, e.g. `if(d == 0, 0, 1 / d)` or `sqrt(max(0, s))`, or ignore this if the robot cannot be there"
                        )),
                        span: self.at(f, span),
                    },
                ));
            }
        }
        if unsaid > 0
            && let Some((_, _, CheckWarning::TaskMaybeNotFinite { help, .. })) =
                self.warnings.last_mut()
        {
            help.push_str(&format!(
                ". {unsaid} more value{} of this task may not be numbers either",
                if unsaid == 1 { "" } else { "s" }
            ));
        }
    }
}

/// Every observation and score tried at every state of `points` (a score not at a run's start):
/// how often it is not a number, and where the first failure starts.
fn try_states(
    d: &TaskDef,
    points: &[Point],
    irs: &HashMap<usize, &Ir>,
    scores: &HashSet<usize>,
) -> Vec<(usize, Sink)> {
    let mut sinks: Vec<(usize, Sink)> = d
        .observe
        .iter()
        .chain(d.score.iter().map(|(s, _)| s))
        .map(|s| (*s, Sink::default()))
        .collect();
    for (at, p) in points.iter().enumerate() {
        let prev = p.prev.map_or(&p.env, |i| &points[i].env);
        for (slot, sink) in &mut sinks {
            let is_score = scores.contains(slot);
            // A score is computed at the end of a run, which is never its start.
            if is_score && p.start {
                continue;
            }
            sink.tried += 1;
            sink.start_tried += usize::from(p.start);
            let v = p.env[*slot];
            if v.is_finite() {
                continue;
            }
            sink.failed += 1;
            sink.start_failed += usize::from(p.start);
            if sink.first.is_none() {
                let (root, in_prev) = root(*slot, &p.env, prev, irs, d.slots());
                sink.first = Some((root, in_prev, at));
            }
        }
    }
    sinks
}

/// The states to try: run starts first (for observations), then pairs of a state and the state
/// after it, `count` in all.
fn states(d: &TaskDef, limit_s: f64, count: usize) -> Vec<Point> {
    let mut mix = Mix(0x5EED_F1A1_7E57_0001);
    let g = d.goal_slot();
    let a = d.action_slot();
    let n_act = d.domain.act_dim();
    let mut out: Vec<Point> = Vec::new();
    // Run starts: every corner of up to four goal parameters, else both ends and alternations;
    // then the middle and a few draws.
    let mut goals: Vec<Vec<f64>> = Vec::new();
    let n_goal = d.goal.len();
    if n_goal <= 4 {
        for mask in 0..(1usize << n_goal) {
            goals.push(
                d.goal
                    .iter()
                    .enumerate()
                    .map(|(i, p)| if mask >> i & 1 == 1 { p.hi } else { p.lo })
                    .collect(),
            );
        }
    } else {
        for pattern in [0, 1, 2, 3] {
            goals.push(
                d.goal
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let hi = match pattern {
                            0 => false,
                            1 => true,
                            2 => i % 2 == 0,
                            _ => i % 2 == 1,
                        };
                        if hi { p.hi } else { p.lo }
                    })
                    .collect(),
            );
        }
    }
    goals.push(d.goal.iter().map(|p| p.lo / 2.0 + p.hi / 2.0).collect());
    for _ in 0..4 {
        goals.push(d.goal.iter().map(|p| mix.within(p.lo, p.hi)).collect());
    }
    let starts = goals.len().min(count / 3).max(1);
    for goal in goals.into_iter().take(starts) {
        let mut env = vec![0.0; d.slots()];
        env[g..g + goal.len()].copy_from_slice(&goal);
        compute(d, &mut env, None);
        out.push(Point {
            env,
            prev: None,
            start: true,
        });
    }
    // Pairs: a state (its own previous step), then one after it.
    let times = [0.1, 1.0, 7.5, limit_s];
    while out.len() + 2 <= count.max(starts + 2) {
        let base = |mix: &mut Mix| {
            let mut env = vec![0.0; d.slots()];
            env[def::X] = mix.pick(&XY);
            env[def::Y] = mix.pick(&XY);
            env[def::THETA] = mix.pick(&THETA);
            env[def::V] = mix.pick(&V);
            env[def::W] = mix.pick(&W);
            env[def::T] = mix.pick(&times);
            for (i, p) in d.goal.iter().enumerate() {
                env[g + i] = mix.in_range(p.lo, p.hi);
            }
            for (i, dim) in d.domain.act.iter().enumerate().take(n_act) {
                env[a + i] = match dim.limits {
                    Some(l) => mix.in_range(l.lo, l.hi),
                    None => mix.pick(&[0.0, 1.0, -1.0, 0.5]),
                };
            }
            env
        };
        let mut first = base(&mut mix);
        compute(d, &mut first, None);
        let i = out.len();
        out.push(Point {
            env: first,
            prev: None,
            start: false,
        });
        let mut second = base(&mut mix);
        compute(d, &mut second, Some(&out[i].env));
        out.push(Point {
            env: second,
            prev: Some(i),
            start: false,
        });
    }
    out
}

/// Fill the values and the scores of `env`, in their order.
fn compute(d: &TaskDef, env: &mut [f64], prev: Option<&[f64]>) {
    for (slot, ir) in d.computed.iter().chain(&d.score) {
        let v = match prev {
            Some(p) => ir.eval_task(env, p),
            None => ir.eval_task(env, env),
        };
        env[*slot] = v;
    }
}

/// The value a failure of `slot` starts in: follow what it reads that is not a number either,
/// down to a value whose inputs all are. The flag says it is in the previous step.
fn root(
    slot: usize,
    env: &[f64],
    prev: &[f64],
    irs: &HashMap<usize, &Ir>,
    slots: usize,
) -> (usize, bool) {
    let mut at = (slot, false);
    for _ in 0..slots {
        let Some(ir) = irs.get(&at.0) else { break };
        let mut reads = Vec::new();
        ir.slots(&mut reads);
        let here = if at.1 { prev } else { env };
        let next = reads.into_iter().find(|&(s, p)| {
            let e = if p || at.1 { prev } else { here };
            irs.contains_key(&s) && s != at.0 && !e.get(s).is_none_or(|v| v.is_finite())
        });
        match next {
            Some((s, p)) => at = (s, at.1 || p),
            None => break,
        }
    }
    at
}

/// Where a value was tried: the robot's state, goal and actions it reads (through other values
/// too), as `x = 1, px = 1.5`; at a run's start, said so.
fn describe(
    d: &TaskDef,
    irs: &HashMap<usize, &Ir>,
    root: usize,
    env: &[f64],
    prev: &[f64],
    start: bool,
) -> String {
    // Inputs reached from `root`: (slot, read at the previous step).
    let mut inputs: Vec<(usize, bool)> = Vec::new();
    let mut seen: HashSet<(usize, bool)> = HashSet::new();
    let mut todo = vec![(root, false)];
    while let Some((s, p)) = todo.pop() {
        if !seen.insert((s, p)) {
            continue;
        }
        match irs.get(&s) {
            Some(ir) => {
                let mut reads = Vec::new();
                ir.slots(&mut reads);
                todo.extend(reads.into_iter().map(|(r, rp)| (r, p || rp)));
            }
            None => inputs.push((s, p)),
        }
    }
    inputs.sort_unstable();
    inputs.dedup();
    let num = crate::number::fmt_readable;
    let parts: Vec<String> = inputs
        .iter()
        .filter(|(s, p)| !(start && *p) && *s < d.slots())
        .map(|&(s, p)| {
            let v = if p { prev[s] } else { env[s] };
            if p {
                format!("prev({}) = {}", d.slot_names[s], num(v))
            } else {
                format!("{} = {}", d.slot_names[s], num(v))
            }
        })
        .collect();
    let at = if parts.is_empty() {
        String::new()
    } else {
        format!("at {}", parts.join(", "))
    };
    match (start, at.is_empty()) {
        (true, true) => "at a run's start".into(),
        (true, false) => format!("{at} (a run's start)"),
        (false, _) => at,
    }
}

/// Whether an expression reads no value at all (its value is the same everywhere).
fn reads_nothing(ir: &Ir) -> bool {
    let mut reads = Vec::new();
    ir.slots(&mut reads);
    reads.is_empty()
}

fn what(observed: &HashSet<usize>, scores: &HashSet<usize>, slot: usize) -> &'static str {
    if observed.contains(&slot) {
        "the observation"
    } else if scores.contains(&slot) {
        "the score"
    } else {
        "the value"
    }
}

fn capital(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}
