//! The evaluation harness: run a controller over a task's fixed test set and summarise.
//!
//! Each test start runs as its own episode on a fresh simulator seeded with
//! [`episode_seed`]`(seed, index)`, in parallel with rayon, so a report depends only on the
//! policy, the task, the simulator parameters and the seed, never on thread scheduling. The
//! [`Report`] holds the paper's measures (success rate, mean position and heading errors, mean
//! trajectory length) and every episode's [`Outcome`]. A progress bar is drawn only when asked and
//! stderr is a terminal. [`derive_policy`] is the one place where a policy is derived from
//! demonstrations for the command line. This module prints nothing but the progress bar.

use std::collections::BTreeMap;

use miette::Diagnostic;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::backend::sim::SimParams;
use crate::backend::{Backend, BackendError};
use crate::domain::Domain;
use crate::policy::Policy;
use crate::policy::learner::{KernelCoverage, Learner, LearnerKind};
use crate::progress::{self, Unit};
use crate::task::{Controller, Ending, Outcome, TaskKind, episode_seed, run_episode, run_sim};
use crate::trace::Episode;

/// How to run an evaluation.
#[derive(Clone, Debug, Default)]
pub struct EvalOptions {
    /// Seeds the simulator's noise (and a teacher's choices), episode by episode.
    pub seed: u64,
    pub params: SimParams,
    /// Draw a progress bar on stderr (only if stderr is a terminal).
    pub progress: bool,
}

/// The figures of one evaluation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The task's name (a declared task's too: a journalled report is read back without its
    /// file).
    pub task: String,
    pub seed: u64,
    pub episodes: usize,
    pub successes: usize,
    /// Fraction of episodes that succeeded, in [0, 1].
    pub success_rate: f64,
    /// Positioning: mean final distance to the goal. Interception: mean final distance to the ball.
    pub mean_position_error_m: f64,
    /// Positioning only: mean final heading error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_heading_error_rad: Option<f64>,
    /// Mean path length over all episodes, m.
    pub mean_length_m: f64,
    /// Mean path length over the successful episodes (the paper's efficiency measure), m.
    pub mean_length_success_m: Option<f64>,
    /// A declared task's own efficiency measure (`score efficiency`), mean over the successful
    /// episodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_efficiency_success: Option<f64>,
    /// How many episodes ended each way.
    pub endings: BTreeMap<String, usize>,
    /// How many episodes each `end when` rule of a declared task ended, by the rule as written:
    /// with two rules, `endings` alone does not say which fired. Empty for the built-in tasks
    /// and in reports recorded before it was counted.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub end_rules: BTreeMap<String, usize>,
    /// LWR: how many of all the episodes' steps found data in the kernel (a policy without a
    /// kernel, and reports journalled before it was counted: `None`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kernel: Option<KernelCoverage>,
    /// Every episode, in test-set order.
    pub outcomes: Vec<Outcome>,
}

impl Report {
    /// Summarise outcomes.
    pub fn from_outcomes(task: TaskKind, seed: u64, outcomes: Vec<Outcome>) -> Report {
        let n = outcomes.len();
        let mean = |f: &dyn Fn(&Outcome) -> Option<f64>| -> Option<f64> {
            let vals: Vec<f64> = outcomes.iter().filter_map(f).collect();
            (!vals.is_empty()).then(|| vals.iter().sum::<f64>() / vals.len() as f64)
        };
        let successes = outcomes.iter().filter(|o| o.success).count();
        let mut endings = BTreeMap::new();
        let mut end_rules = BTreeMap::new();
        for o in &outcomes {
            if let Some(rule) = &o.end_rule {
                *end_rules.entry(rule.clone()).or_insert(0) += 1;
            }
            *endings
                .entry(ending_name(o.ending).to_string())
                .or_insert(0) += 1;
        }
        Report {
            task: task.name().to_string(),
            seed,
            episodes: n,
            successes,
            success_rate: if n == 0 {
                0.0
            } else {
                successes as f64 / n as f64
            },
            // A score that was not a number is not a figure to average (it is held as 0).
            mean_position_error_m: mean(&|o| o.scored().then_some(o.position_error_m))
                .unwrap_or(0.0),
            mean_heading_error_rad: mean(&|o| o.heading_error_rad.filter(|_| o.scored())),
            mean_length_m: mean(&|o| Some(o.length_m)).unwrap_or(0.0),
            mean_length_success_m: mean(&|o| o.success.then_some(o.length_m)),
            mean_efficiency_success: mean(&|o| o.efficiency.filter(|_| o.success)),
            endings,
            end_rules,
            outcomes,
            kernel: None,
        }
    }

    /// A few lines for a terminal.
    pub fn render(&self) -> String {
        let mut s = format!(
            "{} test set, {} episodes, seed {}\n  success rate       {:5.1}% ({}/{})\n  mean position error {:.3} m\n",
            self.task,
            self.episodes,
            self.seed,
            100.0 * self.success_rate,
            self.successes,
            self.episodes,
            self.mean_position_error_m,
        );
        if let Some(h) = self.mean_heading_error_rad {
            s.push_str(&format!("  mean heading error  {h:.3} rad\n"));
        }
        s.push_str(&format!(
            "  mean length         {:.3} m",
            self.mean_length_m
        ));
        if let Some(l) = self.mean_length_success_m {
            s.push_str(&format!(" ({l:.3} m over successes)"));
        }
        s.push('\n');
        if let Some(e) = self.mean_efficiency_success {
            s.push_str(&format!(
                "  mean efficiency     {e:.3} over successes (the task's own measure)\n"
            ));
        }
        let endings: Vec<String> = self
            .endings
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        s.push_str(&format!("  endings             {}\n", endings.join(", ")));
        if !self.end_rules.is_empty() {
            let rules: Vec<String> = self
                .end_rules
                .iter()
                .map(|(rule, n)| format!("`{rule}` {n}"))
                .collect();
            s.push_str(&format!("  ended by            {}\n", rules.join(", ")));
        }
        let stopped = self
            .outcomes
            .iter()
            .enumerate()
            .find_map(|(i, o)| o.non_finite.as_ref().map(|n| (i, n)));
        if let Some((i, n)) = stopped {
            let code = n.code().map(|c| format!(" [{c}]")).unwrap_or_default();
            s.push_str(&format!(
                "  stopped             episode {i} first: {n}{code}\n"
            ));
        }
        if let Some(k) = self.kernel {
            s.push_str(&format!(
                "  LWR kernel          {} of {} steps ({:.0}%) found data\n",
                k.covered,
                k.steps,
                100.0 * k.share()
            ));
            let w = crate::policy::learner::kernel_warning(
                k,
                "steps of the test runs",
                "the test starts lead where the data is sparse: run one (`run start N`), look with `why`, and demonstrate or advise there",
            );
            if !w.is_empty() {
                s.push_str(w.trim_start_matches('\n'));
                s.push('\n');
            }
        }
        s
    }
}

/// The name an ending goes by in a report's `endings` (and the JSON).
pub fn ending_name(e: Ending) -> &'static str {
    match e {
        Ending::Rested => "rested",
        Ending::TimeLimit => "time_limit",
        Ending::Captured => "captured",
        Ending::BallOut => "ball_out",
        Ending::RobotOut => "robot_out",
        Ending::Interrupted => "interrupted",
        Ending::Rule => "rule",
        Ending::NonFinite => "non_finite",
    }
}

/// Evaluate a (stateless) policy on the task's test set.
pub fn evaluate(kind: TaskKind, policy: &dyn Policy, opts: &EvalOptions) -> Report {
    evaluate_with(kind, || policy, opts)
}

/// Evaluate the task's own teacher on its test set.
pub fn evaluate_teacher(kind: TaskKind, opts: &EvalOptions) -> Report {
    let period = opts.params.period_s();
    evaluate_with(kind.clone(), || kind.teacher(period), opts)
}

/// Evaluate controllers made by `make` (one per episode, so stateful teachers work) on the task's
/// test set, in parallel.
pub fn evaluate_with<C, F>(kind: TaskKind, make: F, opts: &EvalOptions) -> Report
where
    C: ControllerBox,
    F: Fn() -> C + Sync,
{
    let starts = kind.test_set();
    let bar = progress::bar(
        opts.progress,
        starts.len() as u64,
        Unit::Items,
        &format!("evaluating {kind}"),
    );
    let outcomes: Vec<Outcome> = starts
        .par_iter()
        .enumerate()
        .map(|(i, start)| {
            let mut c = make();
            let exec = run_sim(
                start,
                c.controller(),
                &opts.params,
                episode_seed(opts.seed, i as u64),
            );
            bar.inc(1);
            exec.outcome
        })
        .collect();
    bar.finish();
    Report::from_outcomes(kind, opts.seed, outcomes)
}

/// An evaluation on a real base that could not finish: the figures over the episodes that ran
/// (the failed one included, as `interrupted`) and why it stopped.
#[derive(Debug, Error, Diagnostic)]
#[error("the evaluation stopped after {} of {planned} episodes: the base failed", .report.episodes)]
#[diagnostic(
    code(advise::eval::interrupted),
    help(
        "the figures so far are kept (the failed episode counts as `interrupted`); fix the base and run again"
    )
)]
pub struct EvalInterrupted {
    pub report: Report,
    pub planned: usize,
    #[source]
    #[diagnostic_source]
    pub error: BackendError,
}

/// Evaluate controllers made by `make` on one given base (a real robot), episode after episode in
/// test-set order, in real time; `limit` runs only the first starts of the test set (a quick
/// check). Episode `i` is seeded as in [`evaluate_with`]. The base is not reset between episodes
/// beyond what [`Backend::reset`] does: a real base re-zeroes its odometry where it stands, so
/// each goal is relative to where the previous episode ended. The first failing episode ends the
/// evaluation ([`EvalInterrupted`]).
pub fn evaluate_on<C, F>(
    kind: TaskKind,
    make: F,
    backend: &mut dyn Backend,
    opts: &EvalOptions,
    limit: Option<usize>,
) -> Result<Report, Box<EvalInterrupted>>
where
    C: ControllerBox,
    F: Fn() -> C,
{
    let mut starts = kind.test_set();
    starts.truncate(limit.unwrap_or(usize::MAX));
    let bar = progress::bar(
        opts.progress,
        starts.len() as u64,
        Unit::Items,
        &format!("evaluating {kind} on {}", backend.name()),
    );
    let mut outcomes = Vec::with_capacity(starts.len());
    for (i, start) in starts.iter().enumerate() {
        let mut c = make();
        let mut task = start.task();
        let seed = episode_seed(opts.seed, i as u64);
        match run_episode(backend, task.as_mut(), c.controller(), seed) {
            Ok(exec) => outcomes.push(exec.outcome),
            Err(interrupted) => {
                outcomes.push(interrupted.execution.outcome);
                bar.finish();
                return Err(Box::new(EvalInterrupted {
                    report: Report::from_outcomes(kind, opts.seed, outcomes),
                    planned: starts.len(),
                    error: interrupted.error,
                }));
            }
        }
        bar.inc(1);
    }
    bar.finish();
    Ok(Report::from_outcomes(kind, opts.seed, outcomes))
}

/// Anything that can lend a `&mut dyn Controller`: a `&dyn Policy`, a boxed teacher.
pub trait ControllerBox {
    fn controller(&mut self) -> &mut dyn Controller;
}

impl ControllerBox for &dyn Policy {
    fn controller(&mut self) -> &mut dyn Controller {
        self
    }
}

impl ControllerBox for Box<dyn Controller + Send> {
    fn controller(&mut self) -> &mut dyn Controller {
        self.as_mut()
    }
}

/// What `advise eval --policy` evaluates: a policy derived by one of the learners, or the task's
/// own teacher. The learners' names are [`LearnerKind`]'s, so each is spelled once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EvalPolicy {
    /// A policy derived from demonstrations by this learner.
    Learned(LearnerKind),
    /// The task's own teacher (needs no dataset).
    Teacher,
}

impl EvalPolicy {
    /// The name on the command line: the learner's, or `teacher`.
    pub fn name(self) -> &'static str {
        match self {
            EvalPolicy::Learned(kind) => kind.name(),
            EvalPolicy::Teacher => "teacher",
        }
    }
}

impl crate::choice::Choice for EvalPolicy {
    fn all() -> &'static [EvalPolicy] {
        &[
            EvalPolicy::Learned(LearnerKind::Bc),
            EvalPolicy::Learned(LearnerKind::Lwr),
            EvalPolicy::Teacher,
        ]
    }

    fn name(self) -> &'static str {
        EvalPolicy::name(self)
    }

    fn help(self) -> &'static str {
        match self {
            EvalPolicy::Learned(kind) => kind.summary(),
            EvalPolicy::Teacher => "The task's own teacher (needs no dataset)",
        }
    }
}

/// Why a policy could not be derived.
#[derive(Debug, Error, Diagnostic)]
pub enum EvalError {
    #[error("the dataset has no points to derive a policy from")]
    #[diagnostic(
        code(advise::eval::empty_dataset),
        help("record demonstrations first: `advise demo --task TASK --count 10 --out demos.csv`")
    )]
    EmptyDataset,
    #[error(transparent)]
    #[diagnostic(transparent)]
    Learner(Box<crate::policy::learner::LearnerError>),
}

/// Derive a policy of `kind` for `domain` from demonstration episodes: the one place the command
/// line turns data into a controller. Both learners come from [`crate::policy::learner`]; LWR is
/// tuned by seeded cross-validation.
pub fn derive_policy(
    kind: LearnerKind,
    domain: &Domain,
    episodes: &[Episode],
) -> Result<Box<dyn Policy>, EvalError> {
    derive_policy_with(kind, domain, episodes, None)
}

/// [`derive_policy`], LWR's kernel limited to its `lwr_k` nearest points when given (`--lwr-k`;
/// otherwise the protocol's rule, [`crate::policy::lwr::default_k`]).
pub fn derive_policy_with(
    kind: LearnerKind,
    domain: &Domain,
    episodes: &[Episode],
    lwr_k: Option<usize>,
) -> Result<Box<dyn Policy>, EvalError> {
    if episodes.iter().all(|e| e.trace.is_empty()) {
        return Err(EvalError::EmptyDataset);
    }
    let mut ds = crate::policy::dataset::Dataset::new(domain);
    for e in episodes {
        ds.add_demonstration(&e.name, &e.trace)
            .map_err(|e| EvalError::Learner(Box::new(e.into())))?;
    }
    let mut learner = Learner::with_dataset(ds, kind, 0);
    if lwr_k.is_some() {
        learner.set_lwr_k(lwr_k);
    }
    Ok(Box::new(learner))
}

/// Brute-force 1-nearest-neighbour over observations scaled inversely with each dimension's data
/// range; the first of equally near points wins. The reference the kd-tree BC learner is tested
/// and benchmarked against.
#[derive(Clone, Debug)]
pub struct NearestNeighbour {
    obs_dim: usize,
    act_dim: usize,
    /// Scaled observations, row after row.
    z: Vec<f64>,
    a: Vec<f64>,
    inv_range: Vec<f64>,
}

impl NearestNeighbour {
    pub fn new(domain: &Domain, episodes: &[Episode]) -> Result<NearestNeighbour, EvalError> {
        let (od, ad) = (domain.obs_dim(), domain.act_dim());
        let mut z = Vec::new();
        let mut a = Vec::new();
        for e in episodes {
            z.extend_from_slice(&e.trace.z);
            a.extend_from_slice(&e.trace.a);
        }
        if z.is_empty() {
            return Err(EvalError::EmptyDataset);
        }
        let inv_range: Vec<f64> = (0..od)
            .map(|j| {
                let (lo, hi) = z
                    .iter()
                    .skip(j)
                    .step_by(od)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(*v), hi.max(*v))
                    });
                if hi > lo { 1.0 / (hi - lo) } else { 1.0 }
            })
            .collect();
        for row in z.chunks_mut(od) {
            row.iter_mut().zip(&inv_range).for_each(|(v, s)| *v *= s);
        }
        Ok(NearestNeighbour {
            obs_dim: od,
            act_dim: ad,
            z,
            a,
            inv_range,
        })
    }

    pub fn len(&self) -> usize {
        self.z.len() / self.obs_dim
    }

    pub fn is_empty(&self) -> bool {
        self.z.is_empty()
    }
}

impl Policy for NearestNeighbour {
    fn act(&self, z: &[f64], a: &mut [f64]) {
        let mut best = (f64::INFINITY, 0);
        for (i, row) in self.z.chunks_exact(self.obs_dim).enumerate() {
            let d: f64 = row
                .iter()
                .zip(z.iter().zip(&self.inv_range))
                .map(|(p, (q, s))| (p - q * s) * (p - q * s))
                .sum();
            if d < best.0 {
                best = (d, i);
            }
        }
        a.copy_from_slice(&self.a[best.1 * self.act_dim..(best.1 + 1) * self.act_dim]);
    }
}
