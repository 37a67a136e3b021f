//! The advising session: the state a teacher works on and the commands that change it.
//!
//! A [`Session`] holds the task and its domain, the operator set (standard plus the teacher's own),
//! the backend, the learner (dataset with provenance and the derived policy), the recorded
//! executions, the selection, and the undo/redo stacks. [`Session::execute`] runs one statement
//! (a command or an operator definition) and returns the text to show; the REPL and `advise run`
//! are thin layers over it, so everything here is testable without a terminal. Successful
//! statements that change the session are appended to the journal.

pub mod journal;
pub mod plot;
pub mod script;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use miette::Diagnostic;
use thiserror::Error;

use crate::backend::rmp::{RmpBackend, RmpConfig};
use crate::backend::sim::{SimBackend, SimError, SimParams};
use crate::backend::{
    Backend, BackendError, BackendSpec, BackendSpecError, Interruptible, StopSignal,
};
use crate::check::{CheckErrors, OperatorSet, Source};
use crate::domain::Domain;
use crate::eval::{self, EvalOptions};
use crate::interp::{self, AppliedAdvice, ApplyError};
use crate::policy::learner::{self, Learner, LearnerError};
use crate::syntax::ParseError;
use crate::syntax::ast::{Ident, Item};
use crate::syntax::command::{COMMANDS, Command, Statement, parse_statement};
use crate::task::{self, Execution, Start, TaskKind, episode_seed};
use crate::trace::{Chunk, ChunkError, Episode, Pose, Trace, TraceError};
use journal::Journal;

/// Default kappa of `critique` (the paper leaves it open; 1.0 doubles the weight of a point met
/// at unit scaled distance).
pub const DEFAULT_KAPPA: f64 = 1.0;

/// Why a statement failed. Nothing in the session changes when a statement fails.
#[derive(Debug, Error, Diagnostic)]
pub enum SessionError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    Parse(#[from] ParseError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Check(#[from] CheckErrors),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Apply(#[from] ApplyError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Chunk(#[from] ChunkError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Learner(#[from] LearnerError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Plot(#[from] plot::PlotError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Interrupted(Box<task::Interrupted>),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    PracticeStart(#[from] task::PracticeStartOutOfRange),
    #[error("unknown task `{name}`")]
    #[diagnostic(code(advise::session::unknown_task), help("{help}"))]
    UnknownTask { name: String, help: String },
    #[error("there is no execution yet")]
    #[diagnostic(
        code(advise::session::no_execution),
        help("run the policy first (`run goal 2 -1 0` or `run start 0`), or `load trace FILE`")
    )]
    NoExecution,
    #[error("nothing is selected")]
    #[diagnostic(
        code(advise::session::no_selection),
        help("select the points to critique or advise first: `select 40..70`")
    )]
    NoSelection,
    #[error("point {t} is outside the execution, which has {len} points")]
    #[diagnostic(
        code(advise::session::point_out_of_range),
        help("points are numbered 0..{len}")
    )]
    PointOutOfRange { t: usize, len: usize },
    #[error("`run goal` is for the positioning task")]
    #[diagnostic(
        code(advise::session::goal_for_wrong_task),
        help("interception runs start from a ball: `run start N`")
    )]
    GoalForWrongTask,
    #[error("the goal ({x:.2}, {y:.2}, {theta:.2}) is not a finite pose")]
    #[diagnostic(code(advise::session::bad_goal))]
    BadGoal { x: f64, y: f64, theta: f64 },
    #[error("kappa must be a positive number, not {kappa}")]
    #[diagnostic(
        code(advise::session::bad_kappa),
        help("the paper's kappa is a small positive constant, e.g. `critique 0.5`")
    )]
    BadKappa { kappa: f64 },
    #[error("nothing to undo")]
    #[diagnostic(code(advise::session::nothing_to_undo))]
    NothingToUndo,
    #[error("nothing to redo")]
    #[diagnostic(
        code(advise::session::nothing_to_redo),
        help("redo puts back what `undo` took, until new advice is given")
    )]
    NothingToRedo,
    #[error(transparent)]
    #[diagnostic(transparent)]
    Backend(#[from] BackendSpecError),
    #[error("cannot drive `{spec}`")]
    #[diagnostic(
        code(advise::session::backend_unavailable),
        help("the session stays on `{current}`; `backend sim` drives the simulator")
    )]
    BackendUnavailable {
        spec: String,
        current: String,
        #[source]
        #[diagnostic_source]
        error: BackendError,
    },
    /// The one failure that changes the session: what the base recorded before it failed is kept
    /// as an execution, as on a real robot it cannot be had again.
    #[error(
        "execution {index} ({label}) was interrupted after {steps} steps; what was recorded is kept"
    )]
    #[diagnostic(
        code(advise::session::run_interrupted),
        help(
            "`show` it, and select, critique or advise it like any other; `run` again when the base is ready"
        )
    )]
    RunInterrupted {
        index: usize,
        label: String,
        steps: usize,
        #[source]
        #[diagnostic_source]
        error: BackendError,
    },
    #[error("nothing is known as `{topic}`")]
    #[diagnostic(code(advise::session::unknown_help), help("{help}"))]
    UnknownHelp { topic: String, help: String },
    #[error("cannot read `{path}`")]
    #[diagnostic(code(advise::session::io))]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write the journal `{path}`: the session stops recording")]
    #[diagnostic(
        code(advise::session::journal),
        help("check the disk and the folder's permissions")
    )]
    Journal {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

/// What a statement produced: text for the teacher, and whether the session should end.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reply {
    pub text: String,
    pub quit: bool,
}

impl Reply {
    fn text(text: impl Into<String>) -> Reply {
        Reply {
            text: text.into(),
            quit: false,
        }
    }
}

/// How the session drives its robot.
#[derive(Debug)]
pub enum BackendChoice {
    /// The in-process simulator, seeded per run.
    Sim(SimParams),
    /// A Segway RMP (or `advise rmp-emulator`), connected and in standby between runs. `sim` is
    /// still what teacher demonstrations and `eval` use.
    Rmp {
        backend: Box<RmpBackend>,
        sim: SimParams,
    },
}

/// One recorded execution and what the session knows of it.
#[derive(Clone, Debug)]
pub struct Recorded {
    /// Where it came from: `run goal 2 -1 0`, `run start 3`, or a file.
    pub label: String,
    pub trace: Trace,
    pub goal: Option<Pose>,
    pub execution: Option<Execution>,
    /// The learner's id for this execution (advice and critiques refer to it).
    pub id: learner::ExecutionId,
    /// Chunks critiqued and advised, for plots.
    pub flagged: Vec<Chunk>,
    pub advised: Vec<Chunk>,
}

/// An edit that `undo` can take back.
#[derive(Clone, Debug)]
enum Edit {
    Advice {
        id: learner::AdviceId,
        execution: usize,
        advice: AppliedAdvice,
        points: usize,
    },
    Critique {
        id: learner::CritiqueId,
        execution: usize,
        chunk: Chunk,
        kappa: f64,
    },
}

impl Edit {
    fn describe(&self, executions: &[Recorded]) -> String {
        match self {
            Edit::Advice {
                execution,
                advice,
                points,
                ..
            } => format!(
                "advise {} on {} of execution {} ({}): {points} points",
                advice.invocation(),
                advice.chunk,
                execution,
                executions.get(*execution).map_or("?", |e| e.label.as_str()),
            ),
            Edit::Critique {
                execution,
                chunk,
                kappa,
                ..
            } => format!(
                "critique {chunk} of execution {execution} ({}) with kappa {kappa}",
                executions.get(*execution).map_or("?", |e| e.label.as_str()),
            ),
        }
    }
}

/// Options for a new session.
#[derive(Clone, Debug)]
pub struct SessionOptions {
    pub task: TaskKind,
    /// Seeds simulator noise, practice starts and learner tuning.
    pub seed: u64,
    /// Record this many teacher demonstrations at start (0: start with an empty dataset).
    pub default_demos: usize,
    pub sim: SimParams,
    /// Show progress bars on a terminal.
    pub progress: bool,
}

impl Default for SessionOptions {
    fn default() -> Self {
        SessionOptions {
            task: TaskKind::Positioning,
            seed: 0,
            default_demos: 0,
            sim: SimParams::default(),
            progress: false,
        }
    }
}

/// The state of an advising session.
pub struct Session {
    ops: OperatorSet,
    task: TaskKind,
    domain: Domain,
    backend: BackendChoice,
    seed: u64,
    runs: u64,
    learner: Learner,
    executions: Vec<Recorded>,
    current: Option<usize>,
    selection: Option<Chunk>,
    undo: Vec<Edit>,
    redo: Vec<Edit>,
    journal: Option<Journal>,
    progress: bool,
    /// Raised by Ctrl-C: stops the base and ends the running execution.
    stop: StopSignal,
}

impl Session {
    /// A session on the simulator; with `default_demos > 0` the task's teacher records that many
    /// demonstrations first and the policy is derived from them.
    pub fn new(opts: SessionOptions) -> Result<Session, SessionError> {
        opts.sim.validate()?;
        let domain = opts.task.domain();
        let mut s = Session {
            ops: OperatorSet::standard(),
            task: opts.task,
            learner: Learner::new(&domain, opts.task, opts.seed),
            domain,
            backend: BackendChoice::Sim(opts.sim),
            seed: opts.seed,
            runs: 0,
            executions: Vec::new(),
            current: None,
            selection: None,
            undo: Vec::new(),
            redo: Vec::new(),
            journal: None,
            progress: opts.progress,
            stop: StopSignal::new(),
        };
        if opts.default_demos > 0 {
            s.load_demos(&format!("teacher:{}", opts.default_demos))?;
        }
        Ok(s)
    }

    /// Journal every successful statement that changes the session to `path`.
    pub fn set_journal(&mut self, journal: Journal) {
        self.journal = Some(journal);
    }

    pub fn journal_path(&self) -> Option<&Path> {
        self.journal.as_ref().map(|j| j.path())
    }

    pub fn task(&self) -> TaskKind {
        self.task
    }

    pub fn operators(&self) -> &OperatorSet {
        &self.ops
    }

    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    pub fn learner(&self) -> &Learner {
        &self.learner
    }

    /// Operators of the current domain with their signatures (for completion and hints).
    pub fn operator_signatures(&self) -> Vec<(String, String)> {
        self.ops
            .operators(&self.domain.name)
            .map(|o| (o.name().to_string(), o.signature()))
            .collect()
    }

    /// A one-line summary for banners and prompts.
    pub fn status(&self) -> String {
        format!(
            "task {}, backend {}, {} data points ({} learner), {} executions",
            self.task,
            self.backend_name(),
            self.learner.len(),
            self.learner.kind_name(),
            self.executions.len()
        )
    }

    fn backend_name(&self) -> String {
        match &self.backend {
            BackendChoice::Sim(_) => "sim".into(),
            BackendChoice::Rmp { backend, .. } => backend.name(),
        }
    }

    /// The signal that stops the robot and the running execution from another thread (the REPL's
    /// Ctrl-C handler holds a clone).
    pub fn stop_signal(&self) -> StopSignal {
        self.stop.clone()
    }

    /// Stop the robot (Ctrl-C at the REPL prompt). The simulator needs nothing; a real base is
    /// commanded to zero and decelerate-to-zero, and this waits (bounded) until it is at rest.
    pub fn stop_robot(&mut self) -> String {
        match &mut self.backend {
            BackendChoice::Sim(_) => "the simulated base is at rest".into(),
            BackendChoice::Rmp { backend, .. } => match backend.stop() {
                Ok(()) => format!("{} stopped (decelerate-to-zero)", backend.name()),
                Err(e) => format!(
                    "{} was told to stop (zero and decelerate-to-zero) but did not confirm it: {e}",
                    backend.name()
                ),
            },
        }
    }

    /// Run one statement. `origin` names it in diagnostics (`<repl>`, `script.adv:12`).
    pub fn execute(&mut self, text: &str, origin: &str) -> Result<Reply, SessionError> {
        let statement = parse_statement(origin, text)?;
        let (reply, changed) = match statement {
            Statement::Empty => (Reply::default(), false),
            Statement::Item(item) => (self.define(item, text, origin)?, true),
            Statement::Command(cmd, _) => {
                let changes = changes_session(&cmd);
                (self.command(cmd)?, changes)
            }
        };
        if changed && let Some(j) = &mut self.journal {
            let path = j.path().display().to_string();
            if let Err(source) = j.record(text) {
                self.journal = None;
                return Err(SessionError::Journal { path, source });
            }
        }
        Ok(reply)
    }

    fn define(&mut self, item: Item, text: &str, origin: &str) -> Result<Reply, SessionError> {
        self.ops = self.ops.merge(&[Source::new(origin, text)])?;
        Ok(Reply::text(match item {
            Item::Operator(op) => format!(
                "defined operator `{}` for {} (on {})",
                op.name.name, op.domain.name, op.space
            ),
            Item::Domain(d) => format!("defined domain `{}`", d.name.name),
        }))
    }

    fn command(&mut self, cmd: Command) -> Result<Reply, SessionError> {
        match cmd {
            Command::Task(name) => self.set_task(&name),
            Command::Backend(spec) => self.set_backend(&spec),
            Command::LoadDemos(path) => self.load_demos(&path).map(Reply::text),
            Command::LoadTrace(path) => self.load_trace(&path).map(Reply::text),
            Command::Operators(path) => self.load_operators(&path).map(Reply::text),
            Command::RunGoal {
                x_m,
                y_m,
                theta_rad,
            } => self.run_goal(x_m, y_m, theta_rad).map(Reply::text),
            Command::RunStart(n) => self.run_start(n).map(Reply::text),
            Command::Show => self.show().map(Reply::text),
            Command::Select { start, end, .. } => self.select(start, end).map(Reply::text),
            Command::Critique(kappa) => self
                .critique(kappa.unwrap_or(DEFAULT_KAPPA))
                .map(Reply::text),
            Command::Advise(inv) => self.advise(&inv).map(Reply::text),
            Command::Preview(inv) => self.preview(&inv).map(Reply::text),
            Command::Undo => self.undo().map(Reply::text),
            Command::Redo => self.redo().map(Reply::text),
            Command::History => Ok(Reply::text(self.history())),
            Command::Rederive => Ok(Reply::text(self.rederive())),
            Command::Eval => Ok(Reply::text(self.eval())),
            Command::Why(t) => self.why(t).map(Reply::text),
            Command::Plot(path) => self.plot(&path).map(Reply::text),
            Command::Save(path) => self.save(&path).map(Reply::text),
            Command::Open(path) => self.open(&path).map(Reply::text),
            Command::ExportAdvice(path) => self.export_advice(&path).map(Reply::text),
            Command::Help(topic) => self.help(topic.as_ref()).map(Reply::text),
            Command::Quit => Ok(Reply {
                text: String::new(),
                quit: true,
            }),
        }
    }

    fn set_task(&mut self, name: &Ident) -> Result<Reply, SessionError> {
        let task = match name.name.as_str() {
            "positioning" => TaskKind::Positioning,
            "interception" => TaskKind::Interception,
            other => {
                return Err(SessionError::UnknownTask {
                    name: other.to_string(),
                    help: did_you_mean(other, &["positioning", "interception"])
                        .unwrap_or_else(|| "the tasks are `positioning` and `interception`".into()),
                });
            }
        };
        self.task = task;
        self.domain = task.domain();
        self.learner = Learner::new(&self.domain, task, self.seed);
        self.executions.clear();
        self.current = None;
        self.selection = None;
        self.undo.clear();
        self.redo.clear();
        Ok(Reply::text(format!(
            "task {task}: an empty {} dataset; add demonstrations with `load demos FILE` or `load demos teacher:N`",
            self.learner.kind_name()
        )))
    }

    /// `sim`, or `rmp:HOST:PORT`: the RMP is connected now (the vendor's start-up sequence), so a
    /// base that does not answer is reported here and the session stays on its backend. A base
    /// left behind is stopped (its driver stops it when dropped).
    fn set_backend(&mut self, spec: &str) -> Result<Reply, SessionError> {
        let params = self.sim_params();
        match spec.parse::<BackendSpec>()? {
            BackendSpec::Sim => {
                self.stop.set_base(None);
                self.backend = BackendChoice::Sim(params);
                Ok(Reply::text("backend sim"))
            }
            BackendSpec::Rmp(addr) => {
                // One link to a base at a time: the old one is stopped and closed first.
                if matches!(self.backend, BackendChoice::Rmp { .. }) {
                    self.stop.set_base(None);
                    self.backend = BackendChoice::Sim(params.clone());
                }
                let backend =
                    RmpBackend::connect(addr, RmpConfig::for_sim(&params)).map_err(|error| {
                        SessionError::BackendUnavailable {
                            spec: spec.trim().to_string(),
                            current: self.backend_name(),
                            error,
                        }
                    })?;
                let platform = backend.platform().name();
                let order = backend.status().map_or("unknown", |s| s.order.name());
                self.stop.set_base(Some(backend.stop_handle()));
                let name = backend.name();
                self.backend = BackendChoice::Rmp {
                    backend: Box::new(backend),
                    sim: params,
                };
                Ok(Reply::text(format!(
                    "backend {name}: an {platform} in standby ({order} feedback); `run` drives it in tractor mode, Ctrl-C stops it"
                )))
            }
        }
    }

    /// `teacher:N` records N demonstrations by the task's teacher in the simulator; anything else
    /// is a demonstrations file.
    fn load_demos(&mut self, path: &str) -> Result<String, SessionError> {
        let started = Instant::now();
        let episodes = match path.strip_prefix("teacher:") {
            Some(n) => {
                let count: usize = n
                    .parse()
                    .ok()
                    .filter(|c| (1..=10_000).contains(c))
                    .ok_or_else(|| SessionError::Io {
                        path: path.to_string(),
                        source: std::io::Error::new(
                            std::io::ErrorKind::InvalidInput,
                            "`teacher:N` takes a count from 1 to 10000",
                        ),
                    })?;
                let params = self.sim_params();
                // A distinct stream from the practice starts the teacher's runs use.
                task::record_demos(self.task, count, self.seed ^ 0xD3E0, &params)
                    .into_iter()
                    .map(|(e, _)| e)
                    .collect()
            }
            None => Episode::load_all(&self.domain, Path::new(path))?,
        };
        let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
        self.learner.add_demonstrations(&episodes)?;
        Ok(format!(
            "loaded {} demonstrations ({points} points) from {path}; the {} policy now has {} points ({} ms)",
            episodes.len(),
            self.learner.kind_name(),
            self.learner.len(),
            started.elapsed().as_millis()
        ))
    }

    fn load_trace(&mut self, path: &str) -> Result<String, SessionError> {
        let trace = Trace::load(&self.domain, Path::new(path))?;
        let n = trace.len();
        self.record(path.to_string(), trace, None, None);
        Ok(format!(
            "loaded execution {} from {path}: {n} points",
            self.executions.len() - 1
        ))
    }

    fn load_operators(&mut self, path: &str) -> Result<String, SessionError> {
        let text = std::fs::read_to_string(path).map_err(|source| SessionError::Io {
            path: path.to_string(),
            source,
        })?;
        let before = self.ops.operator_count();
        self.ops = self.ops.merge(&[Source::new(path, text)])?;
        Ok(format!(
            "checked {path}: {} operators now ({} for {})",
            self.ops.operator_count(),
            self.ops.operator_names(&self.domain.name).len(),
            self.domain.name
        ) + &if self.ops.operator_count() == before {
            " (the file replaced existing operators)".to_string()
        } else {
            String::new()
        })
    }

    fn sim_params(&self) -> SimParams {
        match &self.backend {
            BackendChoice::Sim(p) | BackendChoice::Rmp { sim: p, .. } => p.clone(),
        }
    }

    fn run_goal(&mut self, x: f64, y: f64, theta: f64) -> Result<String, SessionError> {
        if self.task != TaskKind::Positioning {
            return Err(SessionError::GoalForWrongTask);
        }
        if !(x.is_finite() && y.is_finite() && theta.is_finite()) {
            return Err(SessionError::BadGoal { x, y, theta });
        }
        let goal = Pose::new(x, y, theta);
        self.run(
            Start::Goal(goal),
            format!("run goal {x} {y} {theta}"),
            Some(goal),
        )
    }

    fn run_start(&mut self, n: usize) -> Result<String, SessionError> {
        let start = self.task.practice_start(self.seed, n as u64)?;
        let goal = match start {
            Start::Goal(g) => Some(g),
            Start::Ball(_) => None,
        };
        self.run(start, format!("run start {n}"), goal)
    }

    fn run(
        &mut self,
        start: Start,
        label: String,
        goal: Option<Pose>,
    ) -> Result<String, SessionError> {
        self.learner.ensure_derived();
        let seed = episode_seed(self.seed, 1_000_000 + self.runs);
        self.runs += 1;
        let params = self.sim_params();
        // One control loop for every base: the simulator is made fresh per run (as `run_sim`
        // does), a real base is the connected one. Ctrl-C reaches the loop through `stop`.
        let mut sim;
        let base: &mut dyn Backend = match &mut self.backend {
            BackendChoice::Sim(_) => {
                sim = SimBackend::new(params, seed);
                &mut sim
            }
            BackendChoice::Rmp { backend, .. } => backend.as_mut(),
        };
        self.stop.clear();
        let mut guarded = Interruptible::new(base, self.stop.clone());
        let result = {
            let mut controller = self.learner.policy();
            let mut task = start.task();
            task::run_episode(&mut guarded, task.as_mut(), &mut controller, seed)
        };
        let exec = match result {
            Ok(exec) => exec,
            Err(interrupted) => {
                let task::Interrupted { execution, error } = interrupted;
                let steps = execution.trace.len();
                let label = format!("{label} (interrupted)");
                let trace = execution.trace.clone();
                self.record(label.clone(), trace, goal, Some(*execution));
                return Err(SessionError::RunInterrupted {
                    index: self.executions.len() - 1,
                    label,
                    steps,
                    error,
                });
            }
        };
        let summary = outcome_line(&exec);
        let n = exec.trace.len();
        let trace = exec.trace.clone();
        self.record(label.clone(), trace, goal, Some(exec));
        Ok(format!(
            "execution {}: {label}: {n} points; {summary}\nselect a range to critique or advise, e.g. `select {}..{}`",
            self.executions.len() - 1,
            n.saturating_sub(n.min(30)),
            n
        ))
    }

    fn record(
        &mut self,
        label: String,
        trace: Trace,
        goal: Option<Pose>,
        execution: Option<Execution>,
    ) {
        let id = self.learner.add_execution(&trace);
        self.executions.push(Recorded {
            label,
            trace,
            goal,
            execution,
            id,
            flagged: Vec::new(),
            advised: Vec::new(),
        });
        self.current = Some(self.executions.len() - 1);
        self.selection = None;
    }

    fn current(&self) -> Result<(usize, &Recorded), SessionError> {
        let i = self.current.ok_or(SessionError::NoExecution)?;
        Ok((i, &self.executions[i]))
    }

    fn show(&self) -> Result<String, SessionError> {
        let (i, rec) = self.current()?;
        let mut out = format!("execution {i}: {} ({} points", rec.label, rec.trace.len());
        if let (Some(first), Some(last)) = (rec.trace.t.first(), rec.trace.t.last()) {
            let _ = write!(out, ", {:.2} s", last - first);
        }
        out.push_str(")\n");
        if let Some(e) = &rec.execution {
            let _ = writeln!(out, "{}", outcome_line(e));
        }
        if let Some(sel) = self.selection {
            let _ = writeln!(out, "selected {sel} ({} points)", sel.len());
        }
        if let Some(poses) = self.plot_poses(rec) {
            let view = self.plot_view(i, rec, poses);
            out.push_str(&plot::ascii(&view, 64, 16));
        } else {
            out.push_str("(no poses recorded: nothing to plot)\n");
        }
        Ok(out)
    }

    fn plot_poses<'a>(&self, rec: &'a Recorded) -> Option<&'a [Pose]> {
        rec.execution
            .as_ref()
            .and_then(|e| e.true_poses.as_deref())
            .or(rec.trace.pose.as_deref())
    }

    fn plot_view<'a>(&self, i: usize, rec: &'a Recorded, poses: &'a [Pose]) -> plot::PlotView<'a> {
        plot::PlotView {
            title: format!("execution {i}: {}", rec.label),
            path: poses,
            goal: rec.goal,
            ball: rec.execution.as_ref().and_then(|e| e.ball.as_deref()),
            selection: self.selection,
            flagged: rec.flagged.clone(),
            advised: rec.advised.clone(),
        }
    }

    fn select(&mut self, start: usize, end: usize) -> Result<String, SessionError> {
        let (_, rec) = self.current()?;
        let chunk = Chunk::new(start, end, rec.trace.len())?;
        self.selection = Some(chunk);
        Ok(format!("selected {chunk} ({} points)", chunk.len()))
    }

    fn selection(&self) -> Result<(usize, Chunk), SessionError> {
        let (i, _) = self.current()?;
        let chunk = self.selection.ok_or(SessionError::NoSelection)?;
        Ok((i, chunk))
    }

    fn critique(&mut self, kappa: f64) -> Result<String, SessionError> {
        if !(kappa.is_finite() && kappa > 0.0) {
            return Err(SessionError::BadKappa { kappa });
        }
        let (i, chunk) = self.selection()?;
        let rec = &self.executions[i];
        let result = self.learner.critique(rec.id, &rec.trace, chunk, kappa)?;
        self.executions[i].flagged.push(chunk);
        self.undo.push(Edit::Critique {
            id: result.id,
            execution: i,
            chunk,
            kappa,
        });
        self.redo.clear();
        Ok(result.summary)
    }

    fn advise(&mut self, inv: &crate::syntax::Invocation) -> Result<String, SessionError> {
        let (i, chunk) = self.selection()?;
        let started = Instant::now();
        let rec = &self.executions[i];
        let syn = interp::apply(&self.ops, inv, &rec.trace, chunk)?;
        let points = syn.points.len();
        let skipped = chunk.len() - points;
        let id = self.learner.add_advice(rec.id, &syn)?;
        let advice = syn.advice.clone();
        self.executions[i].advised.push(chunk);
        self.undo.push(Edit::Advice {
            id,
            execution: i,
            advice: advice.clone(),
            points,
        });
        self.redo.clear();
        let mut out = format!(
            "advised {chunk} of execution {i} with {}: {points} points added",
            advice.invocation()
        );
        if skipped > 0 {
            let _ = write!(out, " ({skipped} skipped by the operator's guard)");
        }
        let _ = write!(
            out,
            "; the policy has {} points, ready in {:.1} ms",
            self.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        );
        Ok(out)
    }

    fn preview(&self, inv: &crate::syntax::Invocation) -> Result<String, SessionError> {
        let (i, chunk) = self.selection()?;
        let rec = &self.executions[i];
        let syn = interp::apply(&self.ops, inv, &rec.trace, chunk)?;
        let space = syn.advice.space;
        let dims = self.domain.dims(space);
        let mut out = format!(
            "{} on {chunk} of execution {i} would add {} points ({} skipped); {} before -> after:\n",
            syn.advice.invocation(),
            syn.points.len(),
            chunk.len() - syn.points.len(),
            space
        );
        let _ = write!(out, "{:>6}", "point");
        for d in dims {
            let _ = write!(out, "  {:>24}", format!("{} ({})", d.name, d.unit));
        }
        out.push('\n');
        let shown = syn.points.len().min(12);
        for (j, &src) in syn.source_index.iter().take(shown).enumerate() {
            let _ = write!(out, "{src:>6}");
            let (before, after) = match space {
                crate::domain::Space::Action => (rec.trace.a(src), syn.points.a(j)),
                crate::domain::Space::Observation => (rec.trace.z(src), syn.points.z(j)),
            };
            for (b, a) in before.iter().zip(after) {
                let _ = write!(out, "  {:>24}", format!("{b:.4} -> {a:.4}"));
            }
            out.push('\n');
        }
        if syn.points.len() > shown {
            let _ = writeln!(out, "   ... and {} more", syn.points.len() - shown);
        }
        Ok(out)
    }

    fn undo(&mut self) -> Result<String, SessionError> {
        let edit = self.undo.pop().ok_or(SessionError::NothingToUndo)?;
        let text = edit.describe(&self.executions);
        match &edit {
            Edit::Advice {
                id,
                execution,
                advice,
                ..
            } => {
                self.learner.remove_advice(*id)?;
                remove_chunk(&mut self.executions[*execution].advised, advice.chunk);
            }
            Edit::Critique {
                id,
                execution,
                chunk,
                ..
            } => {
                self.learner.remove_critique(*id)?;
                remove_chunk(&mut self.executions[*execution].flagged, *chunk);
            }
        }
        self.redo.push(edit);
        Ok(format!(
            "undid: {text}; the policy has {} points",
            self.learner.len()
        ))
    }

    fn redo(&mut self) -> Result<String, SessionError> {
        let edit = self.redo.pop().ok_or(SessionError::NothingToRedo)?;
        let text = edit.describe(&self.executions);
        let redone = match edit {
            Edit::Advice {
                execution, advice, ..
            } => {
                let rec = &self.executions[execution];
                // Re-synthesized from the record, so the points are exactly the undone ones.
                let syn = interp::reapply(&self.ops, &advice, &rec.trace)?;
                let points = syn.points.len();
                let id = self.learner.add_advice(rec.id, &syn)?;
                self.executions[execution].advised.push(advice.chunk);
                Edit::Advice {
                    id,
                    execution,
                    advice,
                    points,
                }
            }
            Edit::Critique {
                execution,
                chunk,
                kappa,
                ..
            } => {
                let rec = &self.executions[execution];
                let result = self.learner.critique(rec.id, &rec.trace, chunk, kappa)?;
                self.executions[execution].flagged.push(chunk);
                Edit::Critique {
                    id: result.id,
                    execution,
                    chunk,
                    kappa,
                }
            }
        };
        self.undo.push(redone);
        Ok(format!(
            "redid: {text}; the policy has {} points",
            self.learner.len()
        ))
    }

    fn history(&self) -> String {
        if self.undo.is_empty() && self.redo.is_empty() {
            return "no advice or critiques yet".into();
        }
        let mut out = String::new();
        for (n, e) in self.undo.iter().enumerate() {
            let _ = writeln!(out, "{:>3}  {}", n + 1, e.describe(&self.executions));
        }
        for e in self.redo.iter().rev() {
            let _ = writeln!(out, "  -  (undone) {}", e.describe(&self.executions));
        }
        out
    }

    fn rederive(&mut self) -> String {
        let started = Instant::now();
        let what = self.learner.rederive();
        format!(
            "re-derived the {} policy from {} points in {:.1} ms{what}",
            self.learner.kind_name(),
            self.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        )
    }

    fn eval(&mut self) -> String {
        self.learner.ensure_derived();
        let opts = EvalOptions {
            seed: self.seed,
            params: self.sim_params(),
            progress: self.progress,
        };
        let report = eval::evaluate(self.task, self.learner.policy(), &opts);
        match &self.backend {
            BackendChoice::Sim(_) => report.render(),
            // The whole test set on a robot takes minutes and needs room: not from the prompt.
            BackendChoice::Rmp { backend, .. } => format!(
                "{}(in the simulator; `advise eval --backend {}` runs the test set on the robot)",
                report.render(),
                backend.name()
            ),
        }
    }

    fn why(&mut self, t: usize) -> Result<String, SessionError> {
        let (i, rec) = self.current()?;
        if t >= rec.trace.len() {
            return Err(SessionError::PointOutOfRange {
                t,
                len: rec.trace.len(),
            });
        }
        let z = rec.trace.z(t).to_vec();
        let a = rec.trace.a(t).to_vec();
        self.learner.ensure_derived();
        let mut out = format!(
            "point {t} of execution {i}: z = {}, executed a = {}\n",
            fmt_vec(&z),
            fmt_vec(&a)
        );
        out.push_str(&self.learner.why(&z)?);
        Ok(out)
    }

    fn plot(&self, path: &str) -> Result<String, SessionError> {
        let (i, rec) = self.current()?;
        let Some(poses) = self.plot_poses(rec) else {
            return Err(SessionError::Io {
                path: path.to_string(),
                source: std::io::Error::other("the execution has no poses to plot"),
            });
        };
        plot::svg(&self.plot_view(i, rec, poses), Path::new(path))?;
        Ok(format!("wrote {path}"))
    }

    fn save(&self, path: &str) -> Result<String, SessionError> {
        self.learner.save(Path::new(path))?;
        Ok(format!(
            "saved {} points with their provenance to {path}",
            self.learner.len()
        ))
    }

    fn open(&mut self, path: &str) -> Result<String, SessionError> {
        let learner = Learner::open(Path::new(path), self.task, self.seed)?;
        self.domain = learner.domain().clone();
        self.learner = learner;
        self.executions.clear();
        self.current = None;
        self.selection = None;
        self.undo.clear();
        self.redo.clear();
        Ok(format!("opened {path}: {} points", self.learner.len()))
    }

    fn export_advice(&self, path: &str) -> Result<String, SessionError> {
        let n = self.learner.export_advice(Path::new(path))?;
        Ok(format!(
            "wrote {n} advised points with their provenance to {path}"
        ))
    }

    fn help(&self, topic: Option<&Ident>) -> Result<String, SessionError> {
        let Some(topic) = topic else {
            let mut out = String::from("commands:\n");
            for (_, sig) in COMMANDS {
                let _ = writeln!(out, "  {sig}");
            }
            let names = self.ops.operator_names(&self.domain.name);
            let _ = writeln!(
                out,
                "operators for {}: {}\n`help NAME` explains a command or an operator; an operator may be defined on the spot:\n  operator creep for {} on action {{ {} = 0.1 }}",
                self.domain.name,
                names.join(", "),
                self.domain.name,
                self.domain.act.first().map_or("a", |d| d.name.as_str()),
            );
            return Ok(out);
        };
        let name = topic.name.as_str();
        if let Some((_, sig)) = COMMANDS.iter().find(|(c, _)| *c == name) {
            return Ok(format!("{sig}\n  {}", command_doc(name)));
        }
        if let Some(op) = self.ops.operator(&self.domain.name, name) {
            return Ok(format!(
                "{}  (on {})\n{}",
                op.signature(),
                op.space(),
                op.doc()
            ));
        }
        let mut known: Vec<&str> = COMMANDS.iter().map(|(c, _)| *c).collect();
        known.extend(self.ops.operator_names(&self.domain.name));
        Err(SessionError::UnknownHelp {
            topic: name.to_string(),
            help: did_you_mean(name, &known)
                .unwrap_or_else(|| "`help` lists every command and operator".into()),
        })
    }
}

/// Whether a command changes the session (and so belongs in the journal).
fn changes_session(cmd: &Command) -> bool {
    !matches!(
        cmd,
        Command::Show
            | Command::History
            | Command::Help(_)
            | Command::Why(_)
            | Command::Preview(_)
            | Command::Plot(_)
            | Command::Save(_)
            | Command::ExportAdvice(_)
            | Command::Eval
            | Command::Quit
    )
}

fn command_doc(name: &str) -> &'static str {
    match name {
        "task" => {
            "Switch task (positioning: A-OPI with LWR; interception: BC with 1-NN). Starts an empty dataset."
        }
        "backend" => "Choose the robot: the simulator, or a Segway RMP at an address.",
        "load" => {
            "Load demonstrations (a file, or `teacher:N` to record N teacher runs in the simulator) or a trace to advise."
        }
        "operators" => "Check an operator file and add its operators on top of the standard ones.",
        "run" => {
            "Run the current policy to a goal (positioning) or from the N-th practice start, and record it."
        }
        "show" => "Summarise the current execution, with a small plot.",
        "select" => "Select points A (inclusive) to B (exclusive) of the current execution.",
        "critique" => {
            "Flag the selection as poor: the data points that recommended its actions are pushed away (BC)."
        }
        "advise" => {
            "Correct the selection with an advice operator: its points are synthesized and added (A-OPI)."
        }
        "preview" => "Show what `advise` would add, without adding it.",
        "undo" => "Take back the last advice or critique, exactly.",
        "redo" => "Put back what `undo` took.",
        "history" => "List the advice and critiques given so far.",
        "rederive" => "Re-derive the policy from scratch (LWR is re-tuned by cross-validation).",
        "eval" => "Evaluate the policy on the task's fixed test set (never advised).",
        "why" => "Show which data points supported the action at point T, with their provenance.",
        "plot" => {
            "Write the current execution as SVG, with the selection and advised/critiqued chunks marked."
        }
        "save" => "Save the dataset with provenance (.json), or its points only (.csv).",
        "open" => "Open a dataset saved with `save`.",
        "export" => "Write every advised point with its provenance as CSV.",
        "help" => "Help on commands and operators.",
        "quit" => "Leave the session (the journal keeps everything).",
        _ => "",
    }
}

fn remove_chunk(chunks: &mut Vec<Chunk>, chunk: Chunk) {
    if let Some(pos) = chunks.iter().rposition(|c| *c == chunk) {
        chunks.remove(pos);
    }
}

fn outcome_line(e: &Execution) -> String {
    let o = &e.outcome;
    let mut s = format!(
        "{} ({:?}) after {:.1} s, {:.2} m driven, position error {:.2} m",
        if o.success { "success" } else { "failure" },
        o.ending,
        o.duration_s,
        o.length_m,
        o.position_error_m
    );
    if let Some(h) = o.heading_error_rad {
        let _ = write!(s, ", heading error {h:.2} rad");
    }
    s
}

fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.3}")).collect();
    format!("[{}]", parts.join(", "))
}

fn did_you_mean(name: &str, known: &[&str]) -> Option<String> {
    known
        .iter()
        .map(|k| (strsim::jaro_winkler(k, name), k))
        .filter(|(s, _)| *s > 0.8)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, k)| format!("did you mean `{k}`?"))
}

/// Where a script line came from, for diagnostics: `path:line`.
pub fn origin(path: &Path, line: usize) -> String {
    format!("{}:{line}", path.display())
}

/// The path of a new journal in `dir`, named by the time the session started.
pub fn new_journal_path(dir: &Path) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    dir.join(format!("session-{secs}.adv"))
}
