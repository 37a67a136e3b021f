//! Tasks: what the base is asked to do, and the loop that runs a controller on a base.
//!
//! A [`Task`] turns base state (odometry) into the domain's observation, turns the controller's
//! action into a speed command, simulates whatever else is in its world (the interception ball),
//! decides when an episode ends, and scores it. [`run_episode`] is the one control loop: the same
//! loop drives the simulator, the RMP, teachers and learned policies, and records the execution as
//! a [`Trace`]. The controller only ever sees observations computed from odometry; scoring uses
//! the true pose where the backend knows it (the sim), so dead-reckoning drift costs success
//! honestly. [`TaskKind`] names the paper's two tasks and holds their fixed test sets and their
//! teachers; [`record_demos`] records teacher demonstrations.
//!
//! This module does no file IO and prints nothing; it does not know how policies are derived.

use std::sync::Arc;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::backend::sim::{SimBackend, SimParams};
use crate::backend::{Backend, BackendError, BaseState};
use crate::domain::Domain;
use crate::geometry::Pose;
use crate::policy::Policy;
use crate::policy::learner::{Learner, LearnerError, LearnerKind};
use crate::program::OperatorSet;
use crate::program::task::TaskDef;
use crate::trace::{Episode, Trace};

pub mod calibration;
pub mod declared;
pub mod human;
pub mod interception;
pub mod positioning;
pub mod resolve;
pub mod takeover;

pub use declared::{Declared, DeclaredTeacher};
pub use interception::{BallStart, Interception, InterceptionRules, InterceptionTeacher};
pub use positioning::PositioningTeacher;
pub use resolve::{
    Front, TaskFilesError, UnknownTask, load_task_files, resolve, resolve_in_files, task_names,
};

/// One episode of a task: its world, its observation and its scoring.
///
/// Call order per episode (as [`run_episode`] does): [`Task::begin`] once with the state after
/// the reset, then per control period [`Task::observe`], [`Task::command`], one backend step and
/// [`Task::advance`], until `advance` reports an [`Ending`]; then [`Task::score`].
pub trait Task: Send {
    /// The domain of the observations and actions.
    fn domain(&self) -> &Domain;

    /// Where the base starts.
    fn start(&self) -> Pose;

    /// Start the episode's own world (place the ball, clear memories of earlier steps).
    fn begin(&mut self, state: &BaseState);

    /// The observation the controller sees, from odometry. `z.len()` is the domain's `obs_dim`.
    fn observe(&self, state: &BaseState, z: &mut [f64]);

    /// The speed command `(m/s, rad/s)` for an action (already clamped to the domain's limits).
    fn command(&mut self, state: &BaseState, a: &[f64]) -> (f64, f64);

    /// After the base advanced by `dt_s`: move the task's world and decide whether the episode is
    /// over. `true_pose` is the backend's true pose when it knows it.
    fn advance(&mut self, dt_s: f64, state: &BaseState, true_pose: Option<Pose>) -> Option<Ending>;

    /// Score the final state; `pose` is the true pose where known, else odometry.
    fn score(&self, ending: Ending, pose: Pose) -> Score;

    /// The rule that ended the episode, as written (`end when range < 0.3`), for a task whose
    /// endings are rules of its own (a declared task); `None` otherwise.
    fn end_rule(&self) -> Option<String> {
        None
    }

    /// The ball's position, for tasks that have one (recorded for plots).
    fn ball_xy(&self) -> Option<[f64; 2]> {
        None
    }
}

/// Why an episode ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// The controller came to rest (positioning's stopping rule).
    Rested,
    /// The time limit passed.
    TimeLimit,
    /// The ball came within the capture distance (interception).
    Captured,
    /// The ball left the arena (interception).
    BallOut,
    /// The robot left the arena (interception).
    RobotOut,
    /// An end rule of a declared task held (`end when COND` without `for`).
    Rule,
    /// The backend failed (lost link, fault); the execution so far is kept.
    Interrupted,
    /// A value of the task was not a number (an observation, or a score at the end): the run was
    /// stopped there and what was recorded before it kept ([`Outcome::non_finite`] says which).
    NonFinite,
}

/// The most control steps one episode takes, whatever its task says: [`MAX_TIME_LIMIT_S`] at
/// 100 Hz, the simulator's highest rate. A declared task's `end after` is checked against
/// [`MAX_TIME_LIMIT_S`]; this bound holds for every task and base (a faster base, a Rust task), so
/// a trace stays a few megabytes. A run that reaches it ends as [`Ending::TimeLimit`].
///
/// [`MAX_TIME_LIMIT_S`]: crate::program::task::MAX_TIME_LIMIT_S
pub const MAX_EPISODE_STEPS: usize = 60_000;

/// Which kind of value of a task was not a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ValueKind {
    /// An observation, computed before the controller acts.
    Observation,
    /// A score, computed on the final state.
    Score,
}

impl std::fmt::Display for ValueKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ValueKind::Observation => "observation",
            ValueKind::Score => "score",
        })
    }
}

/// A value of a task that was not a finite number, and where: why a run was stopped.
///
/// An observation is checked before the controller sees it, so no policy is queried with it and
/// the base is never commanded on it; a score on the final state, so no report averages it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, thiserror::Error, miette::Diagnostic)]
#[error(
    "the {kind} `{name}` was {value} at step {step} (t = {t_s:.2} s), not a number: the run was stopped there"
)]
#[diagnostic(
    code(advise::task::non_finite),
    help(
        "the steps before it are kept and the base was stopped. In a task declared in a file, look for a division by zero or the square root of a negative number in `{name}` or what it reads (`advise check FILE` warns where it can); otherwise the base's odometry was not a number"
    )
)]
pub struct NonFinite {
    pub kind: ValueKind,
    /// The observation's or the score's name.
    pub name: String,
    /// The control step: the trace's point it would have been (for a score, the number of
    /// points recorded).
    pub step: usize,
    pub t_s: f64,
    /// `NaN`, `inf` or `-inf` (as text: JSON has no such number).
    pub value: String,
}

impl NonFinite {
    fn new(kind: ValueKind, name: &str, step: usize, t_s: f64, value: f64) -> NonFinite {
        NonFinite {
            kind,
            name: name.to_string(),
            step,
            // A time that is not a number either says so in the value; the time is a number.
            t_s: if t_s.is_finite() { t_s } else { 0.0 },
            value: value.to_string(),
        }
    }
}

/// A task's verdict on a final state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Score {
    pub success: bool,
    /// Positioning: distance to the goal. Interception: distance to the ball.
    pub position_error_m: f64,
    /// Positioning: `|theta_g - theta_r|`, wrapped. Interception: none.
    pub heading_error_rad: Option<f64>,
    /// A declared task's own efficiency measure (`score efficiency = ...`); none: the path
    /// length is the measure.
    pub efficiency: Option<f64>,
}

/// The measures of one execution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    pub success: bool,
    pub ending: Ending,
    pub position_error_m: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_error_rad: Option<f64>,
    /// Path length driven, m (true path where known, else odometry).
    pub length_m: f64,
    /// A declared task's own efficiency measure, when it declares one (`score efficiency`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub efficiency: Option<f64>,
    /// Control steps taken (points in the trace).
    pub steps: usize,
    pub duration_s: f64,
    /// Final pose: true where known, else odometry.
    pub final_pose: Pose,
    /// Why the run stopped when a value of the task was not a number ([`Ending::NonFinite`]).
    /// A score that was not a number is held as 0 in its field above and left out of a report's
    /// means.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub non_finite: Option<NonFinite>,
    /// The `end when` rule of a declared task that ended the run, as written
    /// (`end when range < 0.3`): with two rules, the ending alone does not say which. Absent
    /// from outcomes recorded before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_rule: Option<String>,
}

impl Outcome {
    /// Whether the scores (`position_error_m`, `heading_error_rad`, `efficiency`) are the
    /// task's: false when one of them was not a number.
    pub fn scored(&self) -> bool {
        self.non_finite
            .as_ref()
            .is_none_or(|n| n.kind != ValueKind::Score)
    }
}

/// A recorded execution: the trace (odometry poses), the true path where known, and the outcome.
#[derive(Clone, Debug)]
pub struct Execution {
    pub trace: Trace,
    /// True pose at each trace point, when the backend knows it.
    pub true_poses: Option<Vec<Pose>>,
    /// Ball position at each trace point (interception).
    pub ball: Option<Vec<[f64; 2]>>,
    pub outcome: Outcome,
}

impl Execution {
    /// The poses the path length was measured over: the true poses when the backend knew them,
    /// otherwise the recorded odometry.
    pub fn path(&self) -> &[Pose] {
        measured_path(self.true_poses.as_deref(), &self.trace)
    }
}

fn measured_path<'a>(true_poses: Option<&'a [Pose]>, trace: &'a Trace) -> &'a [Pose] {
    true_poses.or(trace.pose.as_deref()).unwrap_or(&[])
}

/// A backend error in the middle of an episode, with everything recorded up to it.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error("the execution stopped after {} steps: the backend failed", .execution.outcome.steps)]
#[diagnostic(
    code(advise::task::interrupted),
    help("the execution recorded so far is kept; fix the base and run again")
)]
pub struct Interrupted {
    pub execution: Box<Execution>,
    #[source]
    #[diagnostic_source]
    pub error: BackendError,
}

/// Something that chooses actions, possibly with memory within an episode.
///
/// Learned policies are stateless ([`Policy`], `&self`) and every `&P` is a `Controller`.
/// Teachers that stand in for a human (reaction lag, per-episode misjudgements) keep state and
/// implement this trait directly; [`Controller::begin`] resets that state for a new episode.
pub trait Controller {
    /// A new episode starts; `episode_seed` seeds any randomness of this episode.
    fn begin(&mut self, episode_seed: u64) {
        let _ = episode_seed;
    }

    /// The action for observation `z`, written into `a`.
    fn act(&mut self, z: &[f64], a: &mut [f64]);
}

impl<P: Policy + ?Sized> Controller for &P {
    fn act(&mut self, z: &[f64], a: &mut [f64]) {
        (**self).act(z, a)
    }
}

/// Run one episode of `task` on `backend` with `controller`, recording the execution.
///
/// Actions are sanitised before use and recorded as executed: a non-finite value becomes 0 and
/// every value is clamped to the domain's action limits. An observation that is not a number ends
/// the episode before the controller sees it ([`Ending::NonFinite`], the reason in
/// [`Outcome::non_finite`]; the base is stopped as at any other end), and so does a score that is
/// not a number at the end. An episode takes at most [`MAX_EPISODE_STEPS`] steps. A backend error
/// stops the episode; the base is asked to stop and the execution so far comes back inside
/// [`Interrupted`].
///
/// The one control loop is [`takeover::run_episode_with`]; this is it with no one taking over.
pub fn run_episode(
    backend: &mut dyn Backend,
    task: &mut dyn Task,
    controller: &mut dyn Controller,
    episode_seed: u64,
) -> Result<Execution, Interrupted> {
    takeover::run_episode_with(
        backend,
        task,
        controller,
        &mut takeover::Never,
        episode_seed,
    )
    .result
}

/// One episode, a step at a time: the loop of [`run_episode`], which drives it with a
/// controller, and of anything that acts step by step itself (Python's `SimEnv`, a person taking
/// over). It owns what the episode records, not the base or the task: each call is given them,
/// so a holder of both (an environment) keeps the stepper beside them.
///
/// Each step, in order: the action (a value that is not a number made 0, each clamped to the
/// domain's limits), [`Task::command`], the point recorded, the base commanded and stepped,
/// [`Task::advance`]; then, unless the task ended the episode, the time limit
/// ([`MAX_EPISODE_STEPS`]) and the next observation, which ends it if any value is not a number
/// (never acted on).
pub struct Stepper {
    rec: Recorder,
    act: Vec<Option<crate::domain::Limits>>,
    dt_s: f64,
    state: BaseState,
    z: Vec<f64>,
    a: Vec<f64>,
    ending: Option<Ending>,
    /// The observation that was not a number, if one ended the episode.
    stopped: Option<NonFinite>,
}

impl Stepper {
    /// Reset the base to the task's start, begin the task, and observe.
    pub fn begin(backend: &mut dyn Backend, task: &mut dyn Task) -> Result<Stepper, Interrupted> {
        let domain = task.domain().clone();
        let rec = Recorder {
            trace: Trace::new(&domain),
            true_poses: backend.true_pose().map(|_| Vec::new()),
            ball: None,
        };
        let mut ep = Stepper {
            rec,
            act: domain.act.iter().map(|d| d.limits).collect(),
            dt_s: backend.period_s(),
            state: BaseState::default(),
            z: vec![0.0; domain.obs_dim()],
            a: vec![0.0; domain.act_dim()],
            ending: None,
            stopped: None,
        };
        ep.state = match backend.reset(task.start()) {
            Ok(s) => s,
            Err(error) => return Err(ep.interrupt(backend, task, error)),
        };
        task.begin(&ep.state);
        ep.rec.ball = task.ball_xy().map(|_| Vec::new());
        ep.observe(task);
        Ok(ep)
    }

    /// What the task observes now: the observation the next action answers.
    pub fn observation(&self) -> &[f64] {
        &self.z
    }

    /// The base's state now.
    pub fn state(&self) -> &BaseState {
        &self.state
    }

    /// The action of the last step, as executed (made finite and clamped); zero before the
    /// first.
    pub fn action(&self) -> &[f64] {
        &self.a
    }

    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.rec.trace.len()
    }

    /// How the episode ended, once it has.
    pub fn ending(&self) -> Option<Ending> {
        self.ending
    }

    /// Whether the episode is over (no more steps are taken).
    pub fn is_over(&self) -> bool {
        self.ending.is_some()
    }

    /// One step with `action`. A backend error leaves the episode to [`Stepper::interrupt`].
    /// A step after the end does nothing.
    pub fn step(
        &mut self,
        backend: &mut dyn Backend,
        task: &mut dyn Task,
        action: &[f64],
    ) -> Result<Option<Ending>, BackendError> {
        if self.ending.is_some() {
            return Ok(self.ending);
        }
        for ((v, given), limits) in self.a.iter_mut().zip(action).zip(&self.act) {
            *v = if given.is_finite() { *given } else { 0.0 };
            if let Some(l) = limits {
                *v = l.clamp(*v);
            }
        }
        let (speed_mps, rot_radps) = task.command(&self.state, &self.a);
        self.rec.push(
            &self.state,
            &self.z,
            &self.a,
            backend.true_pose(),
            task.ball_xy(),
        );
        backend.command(speed_mps, rot_radps)?;
        self.state = backend.step()?;
        self.ending = task.advance(self.dt_s, &self.state, backend.true_pose());
        if self.ending.is_none() && self.rec.trace.len() >= MAX_EPISODE_STEPS {
            self.ending = Some(Ending::TimeLimit);
        }
        if self.ending.is_none() {
            self.observe(task);
        } else {
            // The last observation, for a caller that shows it (an environment's final one);
            // nothing acts on it.
            task.observe(&self.state, &mut self.z);
        }
        Ok(self.ending)
    }

    /// The task's observation of the base now; a value that is not a number ends the episode.
    fn observe(&mut self, task: &dyn Task) {
        task.observe(&self.state, &mut self.z);
        if let Some(i) = self.z.iter().position(|v| !v.is_finite()) {
            let name = task
                .domain()
                .observe
                .get(i)
                .map_or("?", |d| d.name.as_str());
            self.stopped = Some(NonFinite::new(
                ValueKind::Observation,
                name,
                self.rec.trace.len(),
                self.state.t_s,
                self.z[i],
            ));
            self.ending = Some(Ending::NonFinite);
        }
    }

    /// The episode as an execution, the base stopped. A failure to stop is still reported, with
    /// the execution so far.
    pub fn finish(
        self,
        backend: &mut dyn Backend,
        task: &dyn Task,
    ) -> Result<Execution, Interrupted> {
        let ending = self.ending.unwrap_or(Ending::Interrupted);
        let stopped = self.stopped;
        if let Err(error) = backend.stop() {
            let mut i = self.rec.interrupted(task, backend, self.state, error);
            i.execution.outcome.non_finite = stopped.or(i.execution.outcome.non_finite);
            return Err(i);
        }
        let mut exec = self.rec.finish(task, backend, &self.state, ending);
        if stopped.is_some() {
            // The observation came first; a score that is not a number either is held as 0 all
            // the same (`finish` did that).
            exec.outcome.non_finite = stopped;
            exec.outcome.success = false;
        }
        Ok(exec)
    }

    /// The episode cut short by `error` (the base stopped, best effort): the execution so far.
    pub fn interrupt(
        self,
        backend: &mut dyn Backend,
        task: &dyn Task,
        error: BackendError,
    ) -> Interrupted {
        self.rec.interrupted(task, backend, self.state, error)
    }
}

struct Recorder {
    trace: Trace,
    true_poses: Option<Vec<Pose>>,
    ball: Option<Vec<[f64; 2]>>,
}

impl Recorder {
    fn push(
        &mut self,
        state: &BaseState,
        z: &[f64],
        a: &[f64],
        truth: Option<Pose>,
        ball: Option<[f64; 2]>,
    ) {
        self.trace.push(state.t_s, z, a, Some(state.pose));
        if let (Some(v), Some(p)) = (&mut self.true_poses, truth) {
            v.push(p);
        }
        if let (Some(v), Some(b)) = (&mut self.ball, ball) {
            v.push(b);
        }
    }

    fn finish(
        self,
        task: &dyn Task,
        backend: &dyn Backend,
        state: &BaseState,
        ending: Ending,
    ) -> Execution {
        let final_pose = backend.true_pose().unwrap_or(state.pose);
        let path = measured_path(self.true_poses.as_deref(), &self.trace);
        let length_m = path_length(path.iter().chain(std::iter::once(&final_pose)));
        let mut score = task.score(ending, final_pose);
        let steps = self.trace.len();
        // A score that is not a number cannot be reported or saved (JSON has no NaN): the run is
        // a failure, the score 0, and the reason kept.
        let mut non_finite = None;
        let mut finite = |name: &str, v: &mut f64| {
            if !v.is_finite() {
                if non_finite.is_none() {
                    non_finite = Some(NonFinite::new(ValueKind::Score, name, steps, state.t_s, *v));
                }
                *v = 0.0;
            }
        };
        finite("error", &mut score.position_error_m);
        if let Some(h) = &mut score.heading_error_rad {
            finite("heading_error", h);
        }
        if let Some(e) = &mut score.efficiency {
            finite("efficiency", e);
        }
        let ending = if non_finite.is_some() && ending != Ending::Interrupted {
            Ending::NonFinite
        } else {
            ending
        };
        Execution {
            outcome: Outcome {
                success: score.success && non_finite.is_none(),
                ending,
                position_error_m: score.position_error_m,
                heading_error_rad: score.heading_error_rad,
                length_m,
                efficiency: score.efficiency,
                steps,
                duration_s: state.t_s,
                final_pose,
                non_finite,
                end_rule: if matches!(ending, Ending::Rule | Ending::Rested) {
                    task.end_rule()
                } else {
                    None
                },
            },
            trace: self.trace,
            true_poses: self.true_poses,
            ball: self.ball,
        }
    }

    fn interrupted(
        self,
        task: &dyn Task,
        backend: &mut dyn Backend,
        state: BaseState,
        error: BackendError,
    ) -> Interrupted {
        // Best effort: the base may be unreachable, and the first error is the one to report.
        let _ = backend.stop();
        let mut execution = self.finish(task, backend, &state, Ending::Interrupted);
        execution.outcome.success = false;
        Interrupted {
            execution: Box::new(execution),
            error,
        }
    }
}

fn path_length<'a>(poses: impl Iterator<Item = &'a Pose>) -> f64 {
    let mut len = 0.0;
    let mut prev: Option<&Pose> = None;
    for p in poses {
        if let Some(q) = prev {
            len += q.distance_to(*p);
        }
        prev = Some(p);
    }
    len
}

/// A seed for episode `index` of a run seeded with `seed` (SplitMix64 of the pair), so episodes
/// are independent of each other and of the order in which threads run them.
pub fn episode_seed(seed: u64, index: u64) -> u64 {
    let mut x = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A task: one of the paper's two, or one declared in the language.
///
/// The paper's positioning task is itself a declaration (`operators/positioning.adv`) run by
/// [`Declared`]; it keeps its name here for its Rust teleoperator model and its fixed place in
/// the paper's studies. Interception stays in Rust (see ARCHITECTURE.md: its ball is a simulated
/// world object with dynamics of its own, which the language does not declare).
#[derive(Clone, Debug)]
pub enum TaskKind {
    /// Segway RMP spatial positioning (A-OPI).
    Positioning,
    /// Simulated ball interception (BC).
    Interception,
    /// A task declared in a file (`domain NAME { goal ... success when ... }`).
    Declared(Arc<TaskDef>),
}

impl PartialEq for TaskKind {
    fn eq(&self, other: &TaskKind) -> bool {
        match (self, other) {
            (TaskKind::Positioning, TaskKind::Positioning)
            | (TaskKind::Interception, TaskKind::Interception) => true,
            (TaskKind::Declared(a), TaskKind::Declared(b)) => Arc::ptr_eq(a, b) || a == b,
            _ => false,
        }
    }
}

impl Eq for TaskKind {}

impl std::hash::Hash for TaskKind {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.name().hash(state)
    }
}

/// A task is written as its name (reports, journals).
impl Serialize for TaskKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Only the paper's tasks can be read back by name alone; a declared task needs its file.
impl<'de> Deserialize<'de> for TaskKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<TaskKind, D::Error> {
        let name = String::deserialize(d)?;
        TaskKind::builtin(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "`{name}` is not one of the built-in tasks (positioning, interception); a declared task is loaded from its file"
            ))
        })
    }
}

/// The highest practice start number, `run start 999999999`. Any `u64` could be drawn in constant
/// time; the bound keeps the number readable and every sum of it with a count of runs far from
/// overflow.
pub const MAX_PRACTICE_START: u64 = 999_999_999;

/// A practice start beyond [`MAX_PRACTICE_START`].
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error(
    "there is no practice start {index}: practice starts are numbered 0 to {MAX_PRACTICE_START}"
)]
#[diagnostic(
    code(advise::task::practice_start_out_of_range),
    help("every number in that range is a different start, e.g. `run start 0`, `run start 12345`")
)]
pub struct PracticeStartOutOfRange {
    pub index: u64,
}

/// The initial condition of one episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Start {
    /// A positioning goal; the robot starts at the origin, heading 0.
    Goal(Pose),
    /// An interception start; the robot starts at the origin, heading 0.
    Ball(BallStart),
    /// A goal of a declared task: a value for each goal parameter.
    #[serde(skip)]
    Declared(Arc<TaskDef>, Vec<f64>),
}

/// The standard positioning task, as `operators/positioning.adv` declares it.
pub fn positioning_def() -> Arc<TaskDef> {
    // The embedded library is checked by a test; its positioning domain is a task.
    OperatorSet::standard_task("positioning")
        .unwrap_or_else(|| panic!("operators/positioning.adv declares no positioning task"))
}

impl TaskKind {
    /// The paper's task of that name.
    pub fn builtin(name: &str) -> Option<TaskKind> {
        match name {
            "positioning" => Some(TaskKind::Positioning),
            "interception" => Some(TaskKind::Interception),
            _ => None,
        }
    }

    pub fn name(&self) -> &str {
        match self {
            TaskKind::Positioning => "positioning",
            TaskKind::Interception => "interception",
            TaskKind::Declared(d) => d.name(),
        }
    }

    /// The declaration a task runs by: positioning's and the declared tasks'.
    pub fn def(&self) -> Option<Arc<TaskDef>> {
        match self {
            TaskKind::Positioning => Some(positioning_def()),
            TaskKind::Interception => None,
            TaskKind::Declared(d) => Some(d.clone()),
        }
    }

    pub fn domain(&self) -> Domain {
        match self {
            TaskKind::Positioning => Domain::positioning(),
            TaskKind::Interception => Domain::interception(),
            TaskKind::Declared(d) => d.domain.clone(),
        }
    }

    /// Whether a recording's goal can be read from where it ends (the task's `recorded` clause):
    /// what teleoperated demonstrations and imported bags need.
    pub fn reads_recorded_goals(&self) -> bool {
        self.def().is_some_and(|d| d.recorded.is_some())
    }

    /// The fixed test set (25 goals; 100 interception starts; a declared task's `test` count).
    /// It never depends on a user's seed and never overlaps [`TaskKind::practice_set`].
    pub fn test_set(&self) -> Vec<Start> {
        match self {
            TaskKind::Positioning => declared::test_goals(&positioning_def())
                .iter()
                .map(|g| Start::Goal(goal_pose(g)))
                .collect(),
            TaskKind::Interception => interception::test_starts()
                .into_iter()
                .map(Start::Ball)
                .collect(),
            TaskKind::Declared(d) => declared::test_goals(d)
                .into_iter()
                .map(|g| Start::Declared(d.clone(), g))
                .collect(),
        }
    }

    /// `n` practice/demonstration starts drawn from `seed` (a stream disjoint from the test set's).
    pub fn practice_set(&self, seed: u64, n: usize) -> Vec<Start> {
        match self {
            TaskKind::Positioning => declared::practice_goals(&positioning_def(), seed, n)
                .iter()
                .map(|g| Start::Goal(goal_pose(g)))
                .collect(),
            TaskKind::Interception => interception::practice_starts(seed, n)
                .into_iter()
                .map(Start::Ball)
                .collect(),
            TaskKind::Declared(d) => declared::practice_goals(d, seed, n)
                .into_iter()
                .map(|g| Start::Declared(d.clone(), g))
                .collect(),
        }
    }

    /// Practice start `index` of `seed`, the same as `practice_set(seed, index + 1)[index]` but
    /// computed directly, in constant time and memory. Starts are numbered 0 to
    /// [`MAX_PRACTICE_START`].
    pub fn practice_start(&self, seed: u64, index: u64) -> Result<Start, PracticeStartOutOfRange> {
        if index > MAX_PRACTICE_START {
            return Err(PracticeStartOutOfRange { index });
        }
        Ok(match self {
            TaskKind::Positioning => Start::Goal(goal_pose(&declared::practice_goal(
                &positioning_def(),
                seed,
                index,
            ))),
            TaskKind::Interception => Start::Ball(interception::practice_start(seed, index)),
            TaskKind::Declared(d) => {
                Start::Declared(d.clone(), declared::practice_goal(d, seed, index))
            }
        })
    }

    /// The paper's learner for the task: A-OPI (LWR) for positioning, BC (1-NN) for
    /// interception; LWR for declared tasks (continuous actions, as positioning's).
    pub fn learner(&self) -> LearnerKind {
        match self {
            TaskKind::Positioning | TaskKind::Declared(_) => LearnerKind::Lwr,
            TaskKind::Interception => LearnerKind::Bc,
        }
    }

    /// Open a saved dataset for this task ([`Learner::open`]): a dataset of another task's
    /// domain is refused with the task to switch to.
    pub fn open_learner(
        &self,
        sources: &mut crate::diag::SourceMap,
        path: &std::path::Path,
        seed: u64,
    ) -> Result<Learner, LearnerError> {
        let ds = crate::policy::dataset::Dataset::load(sources, path)?;
        self.adopt_dataset(ds, seed)
    }

    /// A learner for this task on a dataset already validated whole (opened, or a journal's copy
    /// of an opened one), refused if the dataset is another task's: the rule `open` and a
    /// restored `open` share.
    pub fn adopt_dataset(
        &self,
        ds: crate::policy::dataset::Dataset,
        seed: u64,
    ) -> Result<Learner, LearnerError> {
        Learner::adopt(ds, &self.domain(), self.learner(), seed, |found| {
            let other = [TaskKind::Positioning, TaskKind::Interception]
                .into_iter()
                .find(|t| t.domain().name == found);
            LearnerError::OtherTask {
                found: found.to_string(),
                task: self.to_string(),
                help: match other {
                    Some(t) => {
                        format!("switch to its task first with `task {t}`, then `open` it")
                    }
                    None => format!(
                        "if `{found}` is a task declared in a file, load it with `tasks FILE` and switch with `task {found}`"
                    ),
                },
            }
        })
    }

    /// Whether the task has a teacher to demonstrate it in the simulator (the paper's tasks
    /// do; a declared task when it declares `teacher { ... }`).
    pub fn has_teacher(&self) -> bool {
        match self {
            TaskKind::Positioning | TaskKind::Interception => true,
            TaskKind::Declared(d) => d.teacher.is_some(),
        }
    }

    /// The task's teacher (the stand-in for teleoperation), for a base running at `period_s`. A
    /// declared task without a teacher gets one that stands still (ask [`TaskKind::has_teacher`]
    /// first).
    pub fn teacher(&self, period_s: f64) -> Box<dyn Controller + Send> {
        match self {
            TaskKind::Positioning => Box::new(PositioningTeacher::new(period_s)),
            TaskKind::Interception => Box::new(InterceptionTeacher::new(period_s).driver()),
            TaskKind::Declared(d) => match DeclaredTeacher::new(d.clone()) {
                Some(t) => Box::new(t),
                None => Box::new(StandStill),
            },
        }
    }
}

impl TaskKind {
    /// A demonstration of this task keeps every this many control steps (docs/protocol.md,
    /// point 7): positioning records at 15 Hz while the control runs at 30 Hz (the paper's 30 Hz
    /// is its encoder rate; its 9 demonstrations held 900 points); interception keeps every step
    /// (its observations and actions are changes per control step).
    pub fn record_every(&self) -> usize {
        match self {
            TaskKind::Positioning => positioning::RECORD_EVERY,
            TaskKind::Interception | TaskKind::Declared(_) => 1,
        }
    }
}

/// `trace` as recorded at every `every`-th control step (from the first): the points are the
/// steps' own, observation, action, time and pose unchanged.
pub fn recorded_at(trace: &Trace, every: usize) -> Trace {
    if every <= 1 {
        return trace.clone();
    }
    let mut out = Trace::with_dims(&trace.domain, trace.obs_dim(), trace.act_dim());
    for i in (0..trace.len()).step_by(every) {
        let pose = trace.pose.as_ref().and_then(|p| p.get(i).copied());
        out.push(trace.t[i], trace.z(i), trace.a(i), pose);
    }
    out
}

/// A positioning goal `[x_g, y_g, theta_g]` as a pose.
fn goal_pose(g: &[f64]) -> Pose {
    let at = |i: usize| g.get(i).copied().unwrap_or(0.0);
    Pose::new(at(0), at(1), at(2))
}

/// A controller that commands nothing.
struct StandStill;

impl Controller for StandStill {
    fn act(&mut self, _z: &[f64], a: &mut [f64]) {
        a.iter_mut().for_each(|v| *v = 0.0);
    }
}

impl Start {
    /// The task this start belongs to.
    pub fn kind(&self) -> TaskKind {
        match self {
            Start::Goal(_) => TaskKind::Positioning,
            Start::Ball(_) => TaskKind::Interception,
            Start::Declared(d, _) => TaskKind::Declared(d.clone()),
        }
    }

    /// A fresh episode of the task from this start.
    pub fn task(&self) -> Box<dyn Task> {
        match self {
            Start::Goal(g) => Box::new(Declared::new(
                positioning_def(),
                &[g.x_m, g.y_m, g.theta_rad],
            )),
            Start::Ball(b) => Box::new(Interception::new(*b)),
            Start::Declared(d, g) => Box::new(Declared::new(d.clone(), g)),
        }
    }

    /// [`Start::task`], with an interception start played in `world` instead of the default
    /// interception world (the BC study's world, or a candidate world under calibration).
    pub fn task_in(&self, world: &InterceptionRules) -> Box<dyn Task> {
        match self {
            Start::Ball(b) => Box::new(Interception::with_rules(*b, world.clone())),
            other => other.task(),
        }
    }

    /// The goal's values (a positioning goal is `x_g, y_g, theta_g`); none for interception.
    pub fn goal_values(&self) -> Option<Vec<f64>> {
        match self {
            Start::Goal(g) => Some(vec![g.x_m, g.y_m, g.theta_rad]),
            Start::Ball(_) => None,
            Start::Declared(_, g) => Some(g.clone()),
        }
    }
}

impl std::fmt::Display for TaskKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Run one episode from `start` on a fresh simulator seeded with `seed`.
pub fn run_sim(
    start: &Start,
    controller: &mut dyn Controller,
    params: &SimParams,
    seed: u64,
) -> Execution {
    run_sim_task(start.task(), controller, params, seed)
}

/// [`run_sim`] with an interception start played in `world` ([`Start::task_in`]).
pub fn run_sim_in(
    start: &Start,
    world: &InterceptionRules,
    controller: &mut dyn Controller,
    params: &SimParams,
    seed: u64,
) -> Execution {
    run_sim_task(start.task_in(world), controller, params, seed)
}

/// [`run_sim`] with `takeover` asked before every step whether the teacher drives it: the run
/// and the windows of steps the teacher drove. Up to the first step the teacher takes, it is the
/// run [`run_sim`] makes with the same arguments (one control loop).
pub fn run_sim_with(
    start: &Start,
    controller: &mut dyn Controller,
    takeover: &mut dyn takeover::Takeover,
    params: &SimParams,
    seed: u64,
) -> (Execution, Vec<crate::trace::Chunk>) {
    run_sim_task_with(start.task(), controller, takeover, params, seed)
}

fn run_sim_task(
    task: Box<dyn Task>,
    controller: &mut dyn Controller,
    params: &SimParams,
    seed: u64,
) -> Execution {
    run_sim_task_with(task, controller, &mut takeover::Never, params, seed).0
}

fn run_sim_task_with(
    mut task: Box<dyn Task>,
    controller: &mut dyn Controller,
    takeover: &mut dyn takeover::Takeover,
    params: &SimParams,
    seed: u64,
) -> (Execution, Vec<crate::trace::Chunk>) {
    let mut backend = SimBackend::new(params.clone(), seed);
    let driven =
        takeover::run_episode_with(&mut backend, task.as_mut(), controller, takeover, seed);
    match driven.result {
        Ok(e) => (e, driven.teacher),
        // The simulator never fails; keep what was recorded if that ever changes.
        Err(i) => (*i.execution, driven.teacher),
    }
}

/// Record `count` teacher demonstrations in the simulator from practice starts drawn from
/// `seed`, in parallel. Episode `i` is named `demo-i` and runs on a simulator seeded with
/// [`episode_seed`]`(seed, i)`, so the result does not depend on thread scheduling. What is kept
/// for a user goes through [`finite_demos`] first.
pub fn record_demos(
    kind: TaskKind,
    count: usize,
    seed: u64,
    params: &SimParams,
) -> Vec<(Episode, Outcome)> {
    record_demos_in(
        &kind.practice_set(seed, count),
        &InterceptionRules::default(),
        || kind.teacher(params.period_s()),
        params,
        seed,
    )
}

/// Refuse recorded demonstrations when one stopped on a value that is not a number
/// ([`Ending::NonFinite`]): its trace is cut short where the task broke, so it would teach a
/// policy a run that never reached its goal, and the task needs fixing before any demonstration
/// of it is worth keeping. `advise demo` and `load demos teacher:N` write or load nothing then.
pub fn finite_demos(kind: &TaskKind, recorded: &[(Episode, Outcome)]) -> Result<(), DemosStopped> {
    let mut stopped = recorded
        .iter()
        .enumerate()
        .filter_map(|(i, (_, o))| o.non_finite.as_ref().map(|n| (i, n)));
    let Some((index, reason)) = stopped.next() else {
        return Ok(());
    };
    Err(DemosStopped {
        task: kind.name().to_string(),
        index,
        stopped: 1 + stopped.count(),
        count: recorded.len(),
        reason: reason.clone(),
    })
}

/// Teacher demonstrations refused because one stopped on a value that is not a number.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error(
    "{stopped} of {count} {task} demonstrations stopped on a value that is not a number; the first is demo-{index}"
)]
#[diagnostic(
    code(advise::task::demos_not_finite),
    help(
        "nothing was recorded: a demonstration cut short where the task broke would teach a run that never reached its goal. Fix the task's declaration (`advise check FILE` warns where a value may not be a number) and record again"
    )
)]
pub struct DemosStopped {
    pub task: String,
    /// The first demonstration that stopped.
    pub index: usize,
    /// How many stopped.
    pub stopped: usize,
    pub count: usize,
    #[source]
    #[diagnostic_source]
    pub reason: NonFinite,
}

/// Demonstrations from `starts` by the teachers `teacher` makes, interception starts played in
/// `world`: demonstration `i` is named `demo-i` and runs on a simulator seeded with
/// [`episode_seed`]`(seed, i)`, in parallel, as [`record_demos`] does.
pub fn record_demos_in(
    starts: &[Start],
    world: &InterceptionRules,
    teacher: impl Fn() -> Box<dyn Controller + Send> + Sync,
    params: &SimParams,
    seed: u64,
) -> Vec<(Episode, Outcome)> {
    starts
        .par_iter()
        .enumerate()
        .map(|(i, start)| {
            let mut teacher = teacher();
            let exec = run_sim_in(
                start,
                world,
                teacher.as_mut(),
                params,
                episode_seed(seed, i as u64),
            );
            (
                Episode {
                    name: format!("demo-{i}"),
                    trace: recorded_at(&exec.trace, start.kind().record_every()),
                },
                exec.outcome,
            )
        })
        .collect()
}
