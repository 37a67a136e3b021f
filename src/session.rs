//! The advising session: the state a teacher works on and the commands that change it.
//!
//! A [`Session`] holds the task and its domain, the operator set (standard plus the teacher's own),
//! the backend, and per task the learner (dataset with provenance and the derived policy), the
//! recorded executions, the selection, and the undo/redo stacks. [`Session::execute`] runs one
//! statement (a command or an operator definition) and returns the text to show; the REPL and
//! `advise run` are thin layers over it, so everything here is testable without a terminal.
//!
//! A command does its work (drive, read, synthesize) and then commits an [`Effect`]: the effect
//! is applied to the state and appended to the journal. [`Session::restore`] applies a journal's
//! effects again, which re-runs nothing and never touches a robot.

pub mod effect;
pub mod journal;
pub mod plot;
pub mod script;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use miette::Diagnostic;
use thiserror::Error;

use crate::backend::rmp::{RmpBackend, RmpConfig};
use crate::backend::ros2::{Ros2Backend, Ros2Config};
use crate::backend::sim::wrap_angle;
use crate::backend::sim::{SimBackend, SimError, SimParams};
use crate::backend::{
    Backend, BackendError, BackendSpec, BackendSpecError, Interruptible, StopSignal,
};
use crate::check::{CheckErrors, OperatorSet, Source};
use crate::diagnostic::did_you_mean;
use crate::domain::Domain;
use crate::eval::{self, EvalOptions, Report};
use crate::interp::{self, ApplyError, Synthesized};
use crate::policy::dataset::{Dataset, Provenance};
use crate::policy::learner::{self, Learner, LearnerError, LearnerKind};
use crate::syntax::ParseError;
use crate::syntax::ast::{Ident, Item};
use crate::syntax::command::{COMMANDS, Command, PlotKind, Statement, parse_statement};
use crate::task::{self, Execution, Start, TaskKind, episode_seed};
use crate::trace::{Chunk, ChunkError, Episode, Pose, Trace, TraceError};
use effect::{DemoEpisode, Effect, Entry, ExecutionEntry, Header, RunEntry};
use journal::{Journal, JournalError};
use std::f64::consts::PI;

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
    File(#[from] crate::files::FileError),
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
    #[error("there is no execution {n}: this task has {count}")]
    #[diagnostic(
        code(advise::session::no_such_execution),
        help(
            "executions are numbered from 0 in the order they were recorded; `history` and `show` name them"
        )
    )]
    NoSuchExecution { n: usize, count: usize },
    #[error("unknown learner `{name}`")]
    #[diagnostic(
        code(advise::session::unknown_learner),
        help(
            "the learners are `bc` (1-NN with critique weights, the paper's BC) and `lwr` (locally weighted regression, the paper's A-OPI){hint}"
        )
    )]
    UnknownLearner { name: String, hint: String },
    #[error("execution {n} has no poses: there is no path to plot")]
    #[diagnostic(
        code(advise::session::no_poses),
        help(
            "a trace loaded without `x`, `y`, `theta` columns has no path; `plot actions FILE.svg` plots its actions"
        )
    )]
    NoPoses { n: usize },
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
    #[error("the goal ({goal}) is not a pose a run can reach")]
    #[diagnostic(
        code(advise::session::bad_goal),
        help(
            "x and y are metres from where the base stands, within ±{MAX_GOAL_M}; theta is radians within ±2π (±6.2832)"
        )
    )]
    BadGoal { goal: String },
    #[error("kappa must be a positive number up to {MAX_KAPPA}, not {kappa}")]
    #[diagnostic(
        code(advise::session::bad_kappa),
        help("the paper's kappa is a small positive constant, e.g. `critique 0.5`")
    )]
    BadKappa { kappa: String },
    #[error("the {task} dataset is empty: there is no policy to run")]
    #[diagnostic(
        code(advise::session::empty_policy),
        help(
            "add demonstrations first: `load demos teacher:9` records nine teacher runs in the simulator, `load demos FILE` loads yours"
        )
    )]
    EmptyPolicy { task: TaskKind },
    #[error(transparent)]
    #[diagnostic(transparent)]
    JournalRead(#[from] JournalError),
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
    /// A ROS 2 base (or `advise ros2-sim`), connected and receiving its odometry.
    Ros2 {
        backend: Box<Ros2Backend>,
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
    /// For each step of a run, the data point that recommended its action (what `critique`
    /// penalises); `None` for a trace loaded from a file.
    pub support: Option<Vec<Option<Provenance>>>,
    /// The learner's id for this execution (advice and critiques refer to it).
    pub id: learner::ExecutionId,
    /// Chunks critiqued and advised, for plots.
    pub flagged: Vec<Chunk>,
    pub advised: Vec<Chunk>,
}

/// An edit that `undo` can take back, holding everything `redo` needs to put it back exactly.
#[derive(Clone, Debug)]
enum Edit {
    Advice {
        /// The number `history` and `why` show (kept by undo and redo).
        number: usize,
        id: learner::AdviceId,
        execution: usize,
        /// The synthesized points themselves: redo adds these, never a re-synthesis with an
        /// operator that may have been redefined since.
        syn: Box<Synthesized>,
    },
    Critique {
        number: usize,
        id: learner::CritiqueId,
        execution: usize,
        chunk: Chunk,
        kappa: f64,
        increments: Vec<(Provenance, f64)>,
    },
}

impl Edit {
    fn number(&self) -> usize {
        match self {
            Edit::Advice { number, .. } | Edit::Critique { number, .. } => *number,
        }
    }

    fn describe(&self, executions: &[Recorded]) -> String {
        match self {
            Edit::Advice { execution, syn, .. } => format!(
                "#{} advise {} on {} of execution {} ({}): {} points",
                self.number(),
                syn.advice.invocation(),
                syn.advice.chunk,
                execution,
                executions.get(*execution).map_or("?", |e| e.label.as_str()),
                syn.points.len()
            ),
            Edit::Critique {
                execution,
                chunk,
                kappa,
                ..
            } => format!(
                "#{} critique {chunk} of execution {execution} ({}) with kappa {kappa}",
                self.number(),
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

/// What one task's work consists of. Each task keeps its own: switching task parks it and
/// switching back restores it.
struct TaskState {
    learner: Learner,
    /// Runs made so far (each run's simulator seed comes from this count).
    runs: u64,
    executions: Vec<Recorded>,
    current: Option<usize>,
    selection: Option<Chunk>,
    undo: Vec<Edit>,
    redo: Vec<Edit>,
    /// The number the next advice or critique gets.
    next_edit: usize,
    /// The last evaluation, to report what changed since.
    last_eval: Option<Report>,
}

impl TaskState {
    fn new(task: TaskKind, seed: u64) -> TaskState {
        TaskState::with_learner(Learner::new(&task.domain(), task, seed))
    }

    fn with_learner(learner: Learner) -> TaskState {
        TaskState {
            learner,
            runs: 0,
            executions: Vec::new(),
            current: None,
            selection: None,
            undo: Vec::new(),
            redo: Vec::new(),
            next_edit: 1,
            last_eval: None,
        }
    }

    fn take_number(&mut self) -> usize {
        self.next_edit += 1;
        self.next_edit - 1
    }
}

/// What `Session::restore` did with a journal.
#[derive(Debug)]
pub struct Restored {
    pub session: Session,
    /// Entries restored.
    pub entries: usize,
    /// What the teacher must be told: a cut statement dropped, a damaged line, the backend the
    /// session was on.
    pub notes: Vec<String>,
    /// Where the session journals from now on (the same journal, or a fresh one after damage).
    pub journal: PathBuf,
}

/// The longest run a goal can ask for: within this many metres of the start, in x and y.
pub const MAX_GOAL_M: f64 = 100.0;
/// The largest `critique` kappa (the paper's kappa is a small constant; the experiments use up to
/// 100).
pub const MAX_KAPPA: f64 = 1000.0;

/// The state of an advising session.
pub struct Session {
    ops: OperatorSet,
    task: TaskKind,
    domain: Domain,
    backend: BackendChoice,
    seed: u64,
    /// The current task's work.
    state: TaskState,
    /// The other tasks' work, parked.
    parked: Vec<(TaskKind, TaskState)>,
    journal: Option<Journal>,
    /// Set while restoring a journal: effects are applied without connecting to anything.
    restoring: bool,
    /// The backend a restored journal was on last (the session itself is on `sim`).
    restored_backend: Option<String>,
    progress: bool,
    /// Raised by Ctrl-C: stops the base and ends the running execution.
    stop: StopSignal,
    /// The statement being executed (journalled with its effect).
    statement: Option<(String, String)>,
    /// Warnings of the last definition checked (shadowed standard operators), for its reply.
    warnings: Vec<crate::check::CheckWarning>,
    /// Effects made before a journal was started (the starting demonstrations), written first
    /// into the journal when one is started; `None` once one was (or never will be).
    preamble: Option<Vec<Entry>>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field("task", &self.task)
            .field("seed", &self.seed)
            .field("points", &self.state.learner.len())
            .field("executions", &self.state.executions.len())
            .finish_non_exhaustive()
    }
}

impl Session {
    /// A session on the simulator; with `default_demos > 0` the task's teacher records that many
    /// demonstrations first and the policy is derived from them.
    pub fn new(opts: SessionOptions) -> Result<Session, SessionError> {
        opts.sim.validate()?;
        let mut s = Session::empty(opts.task, opts.seed, opts.sim);
        s.progress = opts.progress;
        // What the session starts with is kept for a journal started later.
        s.preamble = Some(Vec::new());
        if opts.default_demos > 0 {
            s.statement = Some((
                format!("load demos teacher:{}", opts.default_demos),
                "--demos".into(),
            ));
            let r = s.load_demos(&format!("teacher:{}", opts.default_demos));
            s.statement = None;
            r?;
        }
        Ok(s)
    }

    fn empty(task: TaskKind, seed: u64, sim: SimParams) -> Session {
        Session {
            ops: OperatorSet::standard(),
            task,
            domain: task.domain(),
            backend: BackendChoice::Sim(sim),
            seed,
            state: TaskState::new(task, seed),
            parked: Vec::new(),
            journal: None,
            restoring: false,
            restored_backend: None,
            progress: false,
            stop: StopSignal::new(),
            statement: None,
            warnings: Vec::new(),
            preamble: None,
        }
    }

    /// The header a journal of this session starts with.
    pub fn journal_header(&self) -> Header {
        Header {
            format: effect::JOURNAL_FORMAT.into(),
            task: self.task,
            seed: self.seed,
            sim: self.sim_params(),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            pid: std::process::id(),
        }
    }

    /// Start journalling into a new journal in `dir`. What the session already holds (the
    /// starting demonstrations) is written first, so the journal alone restores it.
    pub fn start_journal(&mut self, dir: &Path) -> std::io::Result<PathBuf> {
        let mut j = Journal::create_in(dir, &self.journal_header())?;
        for entry in self.preamble.take().unwrap_or_default() {
            j.record(&entry)?;
        }
        let path = j.path().to_path_buf();
        self.journal = Some(j);
        Ok(path)
    }

    /// Restore a journalled session: every effect is applied as it was recorded; nothing is
    /// re-run, no file but the journal is read, and no robot is connected or driven. The session
    /// then journals into the same file (or, if it was damaged, a fresh one in `dir`).
    pub fn restore(path: &Path, dir: &Path) -> Result<Restored, SessionError> {
        let loaded = journal::read(path)?;
        let h = &loaded.header;
        // A header edited by hand is held to the simulator's ranges like any parameters file.
        h.sim.validate()?;
        let mut s = Session::empty(h.task, h.seed, h.sim.clone());
        s.restoring = true;
        let mut notes = Vec::new();
        let mut damaged = loaded.damaged.clone();
        let mut restored = 0;
        for (line, entry) in &loaded.entries {
            if let Err(e) = s.apply(&entry.effect) {
                damaged = Some((
                    *line,
                    format!("`{}` could not be restored: {e}", entry.statement),
                ));
                break;
            }
            restored += 1;
        }
        s.restoring = false;
        if let Some(cut) = &loaded.cut {
            notes.push(format!(
                "the last statement was cut off by the crash and is dropped ({} bytes: {})",
                cut.len(),
                first_chars(cut, 60)
            ));
        }
        let journal = match &damaged {
            None => Journal::append_to(path, loaded.good_len).map_err(|source| {
                SessionError::Journal {
                    path: path.display().to_string(),
                    source,
                }
            })?,
            Some((line, what)) => {
                notes.push(format!(
                    "line {line} of the journal is damaged ({what}): restored up to line {}, nothing after it; the journal is left as it was",
                    line - 1
                ));
                let mut j = Journal::create_in(dir, h).map_err(|source| SessionError::Journal {
                    path: dir.display().to_string(),
                    source,
                })?;
                for (_, entry) in loaded.entries.iter().take(restored) {
                    j.record(entry).map_err(|source| SessionError::Journal {
                        path: j.path().display().to_string(),
                        source,
                    })?;
                }
                notes.push(format!(
                    "this session continues in a new journal: {}",
                    j.path().display()
                ));
                j
            }
        };
        if let Some(spec) = s.restored_backend.as_deref().filter(|b| *b != "sim") {
            notes.push(format!(
                "the session was on `{spec}`; it is on `sim` now, and nothing was driven: `backend {spec}` connects again"
            ));
        }
        let journal_path = journal.path().to_path_buf();
        s.journal = Some(journal);
        Ok(Restored {
            session: s,
            entries: restored,
            notes,
            journal: journal_path,
        })
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
        &self.state.learner
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
            self.state.learner.len(),
            self.state.learner.kind_name(),
            self.state.executions.len()
        )
    }

    fn backend_name(&self) -> String {
        match &self.backend {
            BackendChoice::Sim(_) => "sim".into(),
            BackendChoice::Rmp { backend, .. } => backend.name(),
            BackendChoice::Ros2 { backend, .. } => backend.name(),
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
            BackendChoice::Ros2 { backend, .. } => match backend.stop() {
                Ok(()) => format!(
                    "{} stopped (zero commanded for half a second)",
                    backend.name()
                ),
                Err(e) => format!("{} was told to stop but: {e}", backend.name()),
            },
        }
    }

    /// Run one statement. `origin` names it in diagnostics (`<repl>`, `script.adv:12`).
    pub fn execute(&mut self, text: &str, origin: &str) -> Result<Reply, SessionError> {
        let statement = parse_statement(origin, text)?;
        self.statement = Some((text.trim_end().to_string(), origin.to_string()));
        let reply = match statement {
            Statement::Empty => Ok(Reply::default()),
            Statement::Item(item) => self.define(item, text, origin),
            Statement::Command(cmd, _) => self.command(cmd),
        };
        self.statement = None;
        reply
    }

    /// Apply `effect` and journal it. The one way a command changes the session.
    fn commit(&mut self, effect: Effect) -> Result<(), SessionError> {
        self.apply(&effect)?;
        self.journal_effect(effect)
    }

    fn journal_effect(&mut self, effect: Effect) -> Result<(), SessionError> {
        let (statement, origin) = self
            .statement
            .clone()
            .unwrap_or_else(|| (String::new(), String::new()));
        let entry = Entry {
            statement,
            origin,
            effect,
        };
        let Some(j) = &mut self.journal else {
            if let Some(preamble) = &mut self.preamble {
                preamble.push(entry);
            }
            return Ok(());
        };
        if let Err(source) = j.record(&entry) {
            let path = j.path().display().to_string();
            self.journal = None;
            return Err(SessionError::Journal { path, source });
        }
        Ok(())
    }

    /// Make the change an effect describes. Reads no file and drives no robot: a journal is
    /// restored by calling this on each of its effects.
    fn apply(&mut self, effect: &Effect) -> Result<(), SessionError> {
        match effect {
            Effect::Define { origin, text } => {
                let checked = self
                    .ops
                    .merge_with_warnings(&[Source::new(origin, text.clone())])?;
                self.ops = checked.set;
                self.warnings = checked.warnings;
            }
            Effect::Task { task } => self.switch_task(*task),
            Effect::Backend { spec } => {
                if self.restoring {
                    self.restored_backend = Some(spec.clone());
                }
            }
            Effect::Demos { episodes, .. } => {
                let episodes = episodes
                    .iter()
                    .map(|e| {
                        Ok(Episode {
                            name: e.name.clone(),
                            trace: Trace::from_json(&self.domain, &e.trace)?,
                        })
                    })
                    .collect::<Result<Vec<_>, TraceError>>()?;
                self.state.learner.add_demonstrations(&episodes)?;
            }
            Effect::Execution(entry) => {
                let trace = Trace::from_json(&self.domain, &entry.trace)?;
                let (execution, support) = match &entry.run {
                    Some(run) => {
                        self.state.runs = run.number + 1;
                        (
                            Some(Execution {
                                trace: trace.clone(),
                                true_poses: run.true_poses.clone(),
                                ball: run.ball.clone(),
                                outcome: run.outcome.clone(),
                            }),
                            Some(run.support.clone()),
                        )
                    }
                    None => (None, None),
                };
                let id = self.state.learner.add_execution(&trace);
                let st = &mut self.state;
                st.executions.push(Recorded {
                    label: entry.label.clone(),
                    trace,
                    goal: entry.goal,
                    execution,
                    support,
                    id,
                    flagged: Vec::new(),
                    advised: Vec::new(),
                });
                st.current = Some(st.executions.len() - 1);
                st.selection = None;
            }
            Effect::Select { execution, chunk } => {
                let rec = self.numbered(*execution)?;
                let chunk = Chunk::new(chunk.start, chunk.end, rec.trace.len())?;
                self.state.current = Some(*execution);
                self.state.selection = Some(chunk);
            }
            Effect::Advice {
                execution,
                applied,
                points,
                source_index,
            } => {
                let syn = Synthesized {
                    points: Trace::from_json(&self.domain, points)?,
                    source_index: source_index.clone(),
                    advice: applied.clone(),
                };
                let number = self.state.take_number();
                self.add_advice(*execution, Box::new(syn), number)?;
                self.state.redo.clear();
            }
            Effect::Critique {
                execution,
                chunk,
                kappa,
                increments,
            } => {
                let number = self.state.take_number();
                self.add_critique(*execution, *chunk, *kappa, increments.clone(), number)?;
                self.state.redo.clear();
            }
            Effect::Undo => self.undo_edit()?,
            Effect::Redo => self.redo_edit()?,
            Effect::Rederive => {
                self.state.learner.rederive();
            }
            Effect::Learner { learner } => {
                self.state.learner.set_kind(*learner);
                self.state.learner.rederive();
            }
            Effect::Evaluated { report } => self.state.last_eval = Some((**report).clone()),
            Effect::Open { path, dataset } => {
                let ds = Dataset::from_json_str(path, dataset).map_err(LearnerError::from)?;
                let learner =
                    Learner::with_dataset(ds, LearnerKind::for_task(self.task), self.seed);
                self.take_learner(learner);
            }
        }
        Ok(())
    }

    /// Work on an opened dataset from now on (its executions and history start empty).
    fn take_learner(&mut self, learner: Learner) {
        self.domain = learner.domain().clone();
        self.state = TaskState::with_learner(learner);
    }

    fn add_advice(
        &mut self,
        execution: usize,
        syn: Box<Synthesized>,
        number: usize,
    ) -> Result<(), SessionError> {
        let rec = self.numbered(execution)?;
        let id = self.state.learner.add_advice(rec.id, &syn)?;
        let st = &mut self.state;
        st.executions[execution].advised.push(syn.advice.chunk);
        st.undo.push(Edit::Advice {
            number,
            id,
            execution,
            syn,
        });
        Ok(())
    }

    fn add_critique(
        &mut self,
        execution: usize,
        chunk: Chunk,
        kappa: f64,
        increments: Vec<(Provenance, f64)>,
        number: usize,
    ) -> Result<(), SessionError> {
        let rec = self.numbered(execution)?;
        let id = self
            .state
            .learner
            .restore_critique(rec.id, chunk, kappa, increments.clone())?;
        let st = &mut self.state;
        st.executions[execution].flagged.push(chunk);
        st.undo.push(Edit::Critique {
            number,
            id,
            execution,
            chunk,
            kappa,
            increments,
        });
        Ok(())
    }

    fn define(&mut self, item: Item, text: &str, origin: &str) -> Result<Reply, SessionError> {
        self.commit(Effect::Define {
            origin: origin.to_string(),
            text: text.to_string(),
        })?;
        Ok(Reply::text(
            match item {
                Item::Operator(op) => format!(
                    "defined operator `{}` for {} (on {})",
                    op.name.name, op.domain.name, op.space
                ),
                Item::Domain(d) => format!("defined domain `{}`", d.name.name),
            } + &warnings_text(&std::mem::take(&mut self.warnings)),
        ))
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
            Command::Show(n) => self.show(n).map(Reply::text),
            Command::Select {
                start,
                end,
                execution,
                ..
            } => self.select(start, end, execution).map(Reply::text),
            Command::Critique(kappa) => self
                .critique(kappa.unwrap_or(DEFAULT_KAPPA))
                .map(Reply::text),
            Command::Advise(inv) => self.advise(&inv).map(Reply::text),
            Command::Preview(inv) => self.preview(&inv).map(Reply::text),
            Command::Undo => self.undo().map(Reply::text),
            Command::Redo => self.redo().map(Reply::text),
            Command::History => Ok(Reply::text(self.history())),
            Command::Rederive => self.rederive().map(Reply::text),
            Command::Eval { detail } => self.eval(detail).map(Reply::text),
            Command::Learner(name) => self.set_learner(&name).map(Reply::text),
            Command::Why(t) => self.why(t).map(Reply::text),
            Command::Plot { kind, path } => self.plot(kind, &path).map(Reply::text),
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
        if task == self.task {
            return Ok(Reply::text(format!(
                "already on task {task}: nothing changed ({} data points, {} executions)",
                self.state.learner.len(),
                self.state.executions.len()
            )));
        }
        let fresh = !self.parked.iter().any(|(t, _)| *t == task);
        self.commit(Effect::Task { task })?;
        let st = &self.state;
        Ok(Reply::text(if fresh {
            format!(
                "task {task}: an empty {} dataset; add demonstrations with `load demos FILE` or `load demos teacher:N`",
                st.learner.kind_name()
            )
        } else {
            format!(
                "task {task}: back to its {} data points and {} executions ({} learner)",
                st.learner.len(),
                st.executions.len(),
                st.learner.kind_name()
            )
        }))
    }

    /// Park the current task's work and take up `task`'s (new if it has none yet).
    fn switch_task(&mut self, task: TaskKind) {
        if task == self.task {
            return;
        }
        let next = match self.parked.iter().position(|(t, _)| *t == task) {
            Some(i) => self.parked.swap_remove(i).1,
            None => TaskState::new(task, self.seed),
        };
        let previous = std::mem::replace(&mut self.state, next);
        self.parked.push((self.task, previous));
        self.task = task;
        self.domain = self.state.learner.domain().clone();
    }

    /// `sim`, or `rmp:HOST:PORT`: the RMP is connected now (the vendor's start-up sequence), so a
    /// base that does not answer is reported here and the session stays on its backend. A base
    /// left behind is stopped (its driver stops it when dropped).
    fn set_backend(&mut self, spec: &str) -> Result<Reply, SessionError> {
        let params = self.sim_params();
        let reply = match spec.parse::<BackendSpec>()? {
            BackendSpec::Sim => {
                self.stop.set_base(None);
                self.backend = BackendChoice::Sim(params);
                "backend sim".to_string()
            }
            BackendSpec::Rmp(addr) => {
                // One link to a base at a time: the old one is stopped and closed first.
                if !matches!(self.backend, BackendChoice::Sim(_)) {
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
                self.stop.set_base(Some(backend.stop_handle().into()));
                let name = backend.name();
                self.backend = BackendChoice::Rmp {
                    backend: Box::new(backend),
                    sim: params,
                };
                format!(
                    "backend {name}: an {platform} in standby ({order} feedback); `run` drives it in tractor mode, Ctrl-C stops it"
                )
            }
            BackendSpec::Ros2(r) => {
                if !matches!(self.backend, BackendChoice::Sim(_)) {
                    self.stop.set_base(None);
                    self.backend = BackendChoice::Sim(params.clone());
                }
                let backend =
                    Ros2Backend::connect(&r, Ros2Config::for_sim(&params)).map_err(|error| {
                        SessionError::BackendUnavailable {
                            spec: spec.trim().to_string(),
                            current: self.backend_name(),
                            error,
                        }
                    })?;
                self.stop.set_base(Some(backend.stop_handle().into()));
                let reply = format!(
                    "backend {}: {}; `run` drives it, Ctrl-C stops it",
                    backend.name(),
                    backend.describe()
                );
                self.backend = BackendChoice::Ros2 {
                    backend: Box::new(backend),
                    sim: params,
                };
                reply
            }
        };
        // Journalled so a resume can say which base the session was on; a resume never connects.
        self.commit(Effect::Backend {
            spec: spec.trim().to_string(),
        })?;
        Ok(Reply::text(reply))
    }

    /// `teacher:N` records N demonstrations by the task's teacher in the simulator; anything else
    /// is a demonstrations file.
    fn load_demos(&mut self, path: &str) -> Result<String, SessionError> {
        let started = Instant::now();
        let mut from_dataset = String::new();
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
            None => {
                let demos =
                    crate::policy::dataset::load_demonstrations(&self.domain, Path::new(path))
                        .map_err(LearnerError::from)?;
                if let Some((d, a)) = demos.from_dataset {
                    from_dataset = format!(
                        ": a saved dataset's {d} demonstration{} and {a} piece{} of advice, each as one demonstration (critique weights are not carried)",
                        if d == 1 { "" } else { "s" },
                        if a == 1 { "" } else { "s" },
                    );
                }
                demos.episodes
            }
        };
        let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
        let count = episodes.len();
        self.commit(Effect::Demos {
            source: path.to_string(),
            episodes: episodes
                .into_iter()
                .map(|e| DemoEpisode {
                    name: e.name,
                    trace: e.trace.to_json(),
                })
                .collect(),
        })?;
        Ok(format!(
            "loaded {count} demonstrations ({points} points) from {path}{from_dataset}; the {} policy now has {} points ({} ms)",
            self.state.learner.kind_name(),
            self.state.learner.len(),
            started.elapsed().as_millis()
        ))
    }

    fn load_trace(&mut self, path: &str) -> Result<String, SessionError> {
        let trace = Trace::load(&self.domain, Path::new(path))?;
        let n = trace.len();
        self.commit(Effect::Execution(Box::new(ExecutionEntry {
            label: path.to_string(),
            trace: trace.to_json(),
            goal: None,
            run: None,
        })))?;
        Ok(format!(
            "loaded execution {} from {path}: {n} points",
            self.state.executions.len() - 1
        ))
    }

    fn load_operators(&mut self, path: &str) -> Result<String, SessionError> {
        let text = crate::files::read_text(Path::new(path))?;
        let before = self.ops.operator_count();
        self.commit(Effect::Define {
            origin: path.to_string(),
            text,
        })?;
        let warnings = warnings_text(&std::mem::take(&mut self.warnings));
        Ok(format!(
            "checked {path}: {} operators now ({} for {})",
            self.ops.operator_count(),
            self.ops.operator_names(&self.domain.name).len(),
            self.domain.name
        ) + &if self.ops.operator_count() == before {
            " (the file replaced existing operators)".to_string()
        } else {
            String::new()
        } + &warnings)
    }

    fn sim_params(&self) -> SimParams {
        match &self.backend {
            BackendChoice::Sim(p)
            | BackendChoice::Rmp { sim: p, .. }
            | BackendChoice::Ros2 { sim: p, .. } => p.clone(),
        }
    }

    fn run_goal(&mut self, x: f64, y: f64, theta: f64) -> Result<String, SessionError> {
        if self.task != TaskKind::Positioning {
            return Err(SessionError::GoalForWrongTask);
        }
        let within = |v: f64, limit: f64| v.is_finite() && v.abs() <= limit;
        if !(within(x, MAX_GOAL_M) && within(y, MAX_GOAL_M) && within(theta, 2.0 * PI)) {
            return Err(SessionError::BadGoal {
                goal: [x, y, theta].map(short_num).join(", "),
            });
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
        if self.state.learner.is_empty() {
            return Err(SessionError::EmptyPolicy { task: self.task });
        }
        self.state.learner.ensure_derived();
        let number = self.state.runs;
        let seed = episode_seed(self.seed, 1_000_000 + number);
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
            BackendChoice::Ros2 { backend, .. } => backend.as_mut(),
        };
        self.stop.clear();
        let mut guarded = Interruptible::new(base, self.stop.clone());
        let result = {
            let mut controller = self.state.learner.policy();
            let mut task = start.task();
            task::run_episode(&mut guarded, task.as_mut(), &mut controller, seed)
        };
        let (exec, failure) = match result {
            Ok(exec) => (exec, None),
            Err(interrupted) => {
                let task::Interrupted { execution, error } = interrupted;
                (*execution, Some(error))
            }
        };
        let label = match failure {
            Some(_) => format!("{label} (interrupted)"),
            None => label,
        };
        // The dataset has not changed during the run: the points nearest now are the ones that
        // recommended each action, kept for `critique`.
        let support = self.state.learner.support_provenance(&exec.trace);
        let summary = outcome_line(&exec);
        let n = exec.trace.len();
        let hint = worth_a_look(exec.path(), &exec.trace.t, 30);
        // What the base did is kept even when the run failed: on a robot it cannot be had again.
        self.commit(Effect::Execution(Box::new(ExecutionEntry {
            label: label.clone(),
            trace: exec.trace.to_json(),
            goal,
            run: Some(RunEntry {
                number,
                outcome: exec.outcome,
                true_poses: exec.true_poses,
                ball: exec.ball,
                support,
            }),
        })))?;
        let index = self.state.executions.len() - 1;
        if let Some(error) = failure {
            return Err(SessionError::RunInterrupted {
                index,
                label,
                steps: n,
                error,
            });
        }
        let mut out = format!("execution {index}: {label}: {n} points; {summary}");
        if let Some((chunk, what)) = hint {
            let _ = write!(
                out,
                "\nthe robot {what} most over {chunk}: `select {chunk}` to critique or advise it"
            );
        }
        Ok(out)
    }

    fn current(&self) -> Result<(usize, &Recorded), SessionError> {
        let i = self.state.current.ok_or(SessionError::NoExecution)?;
        Ok((i, &self.state.executions[i]))
    }

    fn show(&self, n: Option<usize>) -> Result<String, SessionError> {
        let (i, rec) = match n {
            Some(n) => (n, self.numbered(n)?),
            None => self.current()?,
        };
        let mut out = format!("execution {i}: {} ({} points", rec.label, rec.trace.len());
        if let (Some(first), Some(last)) = (rec.trace.t.first(), rec.trace.t.last()) {
            let _ = write!(out, ", {:.2} s", last - first);
        }
        out.push_str(")\n");
        if let Some(e) = &rec.execution {
            let _ = writeln!(out, "{}", outcome_line(e));
        }
        if let Some(sel) = self
            .state
            .selection
            .filter(|_| self.state.current == Some(i))
        {
            let _ = writeln!(out, "selected {sel} ({} points)", sel.len());
        }
        let view = self.plot_view(i, rec);
        if view.path.is_empty() {
            out.push_str("(no poses recorded: no path to plot)\n");
        } else {
            out.push_str(&plot::ascii(&view, 64, 16));
        }
        out.push_str(&plot::strip(&view, 64));
        Ok(out)
    }

    fn plot_poses<'a>(&self, rec: &'a Recorded) -> Option<&'a [Pose]> {
        rec.execution
            .as_ref()
            .and_then(|e| e.true_poses.as_deref())
            .or(rec.trace.pose.as_deref())
    }

    fn plot_view<'a>(&'a self, i: usize, rec: &'a Recorded) -> plot::PlotView<'a> {
        let rules = crate::task::interception::InterceptionRules::default();
        let interception = self.task == TaskKind::Interception;
        plot::PlotView {
            title: format!("execution {i}: {}", rec.label),
            domain: &self.domain,
            trace: &rec.trace,
            path: self.plot_poses(rec).unwrap_or(&[]),
            goal: rec.goal,
            ball: rec.execution.as_ref().and_then(|e| e.ball.as_deref()),
            arena: interception.then_some(plot::Arena {
                half_m: rules.arena_half_m,
                capture_m: rules.capture_m,
            }),
            outcome: rec.execution.as_ref().map(outcome_line),
            speed_limits: interception.then_some([rules.max_speed_mps, rules.max_rot_radps]),
            selection: self
                .state
                .selection
                .filter(|_| self.state.current == Some(i)),
            flagged: rec.flagged.clone(),
            advised: rec.advised.clone(),
        }
    }

    /// `select A..B` selects in the latest execution, `select A..B in N` in execution N; the
    /// selected execution is what `advise`, `critique`, `preview`, `why` and `plot` act on.
    fn select(
        &mut self,
        start: usize,
        end: usize,
        execution: Option<usize>,
    ) -> Result<String, SessionError> {
        let i = match execution {
            Some(n) => n,
            None => self
                .state
                .executions
                .len()
                .checked_sub(1)
                .ok_or(SessionError::NoExecution)?,
        };
        let rec = self.numbered(i)?;
        let chunk = Chunk::new(start, end, rec.trace.len())?;
        self.commit(Effect::Select {
            execution: i,
            chunk,
        })?;
        Ok(format!(
            "selected {chunk} of execution {i} ({} points)",
            chunk.len()
        ))
    }

    /// Execution `n`, or a diagnostic naming the executions there are.
    fn numbered(&self, n: usize) -> Result<&Recorded, SessionError> {
        let count = self.state.executions.len();
        self.state
            .executions
            .get(n)
            .ok_or(SessionError::NoSuchExecution { n, count })
    }

    fn selection(&self) -> Result<(usize, Chunk), SessionError> {
        let (i, _) = self.current()?;
        let chunk = self.state.selection.ok_or(SessionError::NoSelection)?;
        Ok((i, chunk))
    }

    fn critique(&mut self, kappa: f64) -> Result<String, SessionError> {
        if !(kappa.is_finite() && kappa > 0.0 && kappa <= MAX_KAPPA) {
            return Err(SessionError::BadKappa {
                kappa: short_num(kappa),
            });
        }
        let (i, chunk) = self.selection()?;
        let st = &mut self.state;
        let rec = &st.executions[i];
        let plan = st
            .learner
            .plan_critique(&rec.trace, chunk, kappa, rec.support.as_deref())?;
        self.commit(Effect::Critique {
            execution: i,
            chunk,
            kappa,
            increments: plan.increments.clone(),
        })?;
        Ok(self.state.learner.critique_summary(chunk, &plan))
    }

    fn advise(&mut self, inv: &crate::syntax::Invocation) -> Result<String, SessionError> {
        let (i, chunk) = self.selection()?;
        let started = Instant::now();
        let rec = &self.state.executions[i];
        let syn = interp::apply(&self.ops, inv, &rec.trace, chunk)?;
        let points = syn.points.len();
        let skipped = chunk.len() - points;
        let invocation = syn.advice.invocation();
        self.commit(Effect::Advice {
            execution: i,
            points: syn.points.to_json(),
            source_index: syn.source_index,
            applied: syn.advice,
        })?;
        let mut out =
            format!("advised {chunk} of execution {i} with {invocation}: {points} points added");
        if skipped > 0 {
            let _ = write!(out, " ({skipped} skipped by the operator's guard)");
        }
        let _ = write!(
            out,
            "; the policy has {} points, ready in {:.1} ms",
            self.state.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        );
        Ok(out)
    }

    fn preview(&self, inv: &crate::syntax::Invocation) -> Result<String, SessionError> {
        let (i, chunk) = self.selection()?;
        let rec = &self.state.executions[i];
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
        let edit = self.state.undo.last().ok_or(SessionError::NothingToUndo)?;
        let text = edit.describe(&self.state.executions);
        self.commit(Effect::Undo)?;
        Ok(format!(
            "undid: {text}; the policy has {} points",
            self.state.learner.len()
        ))
    }

    fn undo_edit(&mut self) -> Result<(), SessionError> {
        let st = &mut self.state;
        let edit = st.undo.pop().ok_or(SessionError::NothingToUndo)?;
        let result = match &edit {
            Edit::Advice {
                id, execution, syn, ..
            } => st
                .learner
                .remove_advice(*id)
                .map(|()| remove_chunk(&mut st.executions[*execution].advised, syn.advice.chunk)),
            Edit::Critique {
                id,
                execution,
                chunk,
                ..
            } => st
                .learner
                .remove_critique(*id)
                .map(|()| remove_chunk(&mut st.executions[*execution].flagged, *chunk)),
        };
        match result {
            Ok(()) => {
                st.redo.push(edit);
                Ok(())
            }
            Err(e) => {
                st.undo.push(edit);
                Err(e.into())
            }
        }
    }

    fn redo(&mut self) -> Result<String, SessionError> {
        let edit = self.state.redo.last().ok_or(SessionError::NothingToRedo)?;
        let text = edit.describe(&self.state.executions);
        self.commit(Effect::Redo)?;
        Ok(format!(
            "redid: {text}; the policy has {} points",
            self.state.learner.len()
        ))
    }

    /// Put back exactly what the last undo took: the same points, the same increments.
    fn redo_edit(&mut self) -> Result<(), SessionError> {
        let edit = self.state.redo.pop().ok_or(SessionError::NothingToRedo)?;
        let number = edit.number();
        let result = match edit.clone() {
            Edit::Advice { execution, syn, .. } => self.add_advice(execution, syn, number),
            Edit::Critique {
                execution,
                chunk,
                kappa,
                increments,
                ..
            } => self.add_critique(execution, chunk, kappa, increments, number),
        };
        if result.is_err() {
            self.state.redo.push(edit);
        }
        result
    }

    fn history(&self) -> String {
        let st = &self.state;
        if st.undo.is_empty() && st.redo.is_empty() {
            return "no advice or critiques yet".into();
        }
        let mut out = String::new();
        for e in &st.undo {
            let _ = writeln!(out, "  {}", e.describe(&st.executions));
        }
        for e in st.redo.iter().rev() {
            let _ = writeln!(out, "  (undone) {}", e.describe(&st.executions));
        }
        out
    }

    fn rederive(&mut self) -> Result<String, SessionError> {
        let started = Instant::now();
        // Re-derivation is deterministic for the session's seed, so the journal keeps the fact,
        // not the tuned numbers (`apply` makes the same call on restore).
        let what = self.state.learner.rederive();
        self.journal_effect(Effect::Rederive)?;
        Ok(format!(
            "re-derived the {} policy from {} points in {:.1} ms{what}",
            self.state.learner.kind_name(),
            self.state.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        ))
    }

    fn eval(&mut self, detail: bool) -> Result<String, SessionError> {
        if self.state.learner.is_empty() {
            return Err(SessionError::EmptyPolicy { task: self.task });
        }
        self.state.learner.ensure_derived();
        let opts = EvalOptions {
            seed: self.seed,
            params: self.sim_params(),
            progress: self.progress,
        };
        let report = eval::evaluate(self.task, self.state.learner.policy(), &opts);
        let mut out = report.render();
        match &self.state.last_eval {
            Some(before) => out.push_str(&eval_change(before, &report, detail)),
            None => out.push_str("  (the first evaluation of this task in the session: the next `eval` says what changed)\n"),
        }
        // The whole test set on a robot takes minutes and needs room: not from the prompt.
        if !matches!(self.backend, BackendChoice::Sim(_)) {
            let backend = &self.backend;
            let _ = writeln!(
                out,
                "(in the simulator; `advise eval --backend {}` runs the test set on the robot)",
                match backend {
                    BackendChoice::Rmp { backend, .. } => backend.name(),
                    BackendChoice::Ros2 { backend, .. } => backend.name(),
                    BackendChoice::Sim(_) => "sim".into(),
                }
            );
        }
        // Kept (and journalled) so the next `eval` can say what changed, after a resume too.
        self.commit(Effect::Evaluated {
            report: Box::new(report),
        })?;
        Ok(out)
    }

    fn set_learner(&mut self, name: &Ident) -> Result<String, SessionError> {
        let kind = match name.name.as_str() {
            "bc" => LearnerKind::Bc,
            "lwr" => LearnerKind::Lwr,
            other => {
                return Err(SessionError::UnknownLearner {
                    name: other.to_string(),
                    hint: did_you_mean(other, &["bc", "lwr"])
                        .map(|h| format!("; {h}"))
                        .unwrap_or_default(),
                });
            }
        };
        if kind == self.state.learner.kind() {
            return Ok(format!(
                "the running learner is already {}: nothing changed",
                self.state.learner.kind_name()
            ));
        }
        let started = Instant::now();
        self.commit(Effect::Learner { learner: kind })?;
        Ok(format!(
            "the running learner is now {} on {} points (re-derived in {:.1} ms); critique weights steer BC, advice points feed both",
            self.state.learner.kind_name(),
            self.state.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        ))
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
        self.state.learner.ensure_derived();
        let mut out = format!(
            "point {t} of execution {i}: z = {}, executed a = {}\n",
            fmt_vec(&z),
            fmt_vec(&a)
        );
        let name = |id: learner::AdviceId| {
            self.state
                .undo
                .iter()
                .find_map(|e| match e {
                    Edit::Advice { number, id: a, .. } if *a == id => {
                        Some(format!("advice #{number}"))
                    }
                    _ => None,
                })
                .unwrap_or_else(|| format!("advice (dataset id {id})"))
        };
        out.push_str(&self.state.learner.why(&z, &name)?);
        Ok(out)
    }

    /// `plot FILE` draws the selected execution's path, `plot actions FILE` its actions against
    /// point index, `plot compare FILE N M` the paths of executions N and M overlaid.
    fn plot(&self, kind: PlotKind, path: &str) -> Result<String, SessionError> {
        let file = Path::new(path);
        let no_poses = |n: usize| SessionError::NoPoses { n };
        match kind {
            PlotKind::Path => {
                let (i, rec) = self.current()?;
                let view = self.plot_view(i, rec);
                if view.path.is_empty() {
                    return Err(no_poses(i));
                }
                plot::svg(&view, file)?;
                Ok(format!("wrote {path}: the path of execution {i}"))
            }
            PlotKind::Actions => {
                let (i, rec) = self.current()?;
                plot::svg_actions(&self.plot_view(i, rec), file)?;
                Ok(format!(
                    "wrote {path}: the actions of execution {i} against point index"
                ))
            }
            PlotKind::Compare { before, after } => {
                let a = self.plot_view(before, self.numbered(before)?);
                let b = self.plot_view(after, self.numbered(after)?);
                for (n, v) in [(before, &a), (after, &b)] {
                    if v.path.is_empty() {
                        return Err(no_poses(n));
                    }
                }
                plot::svg_compare(&a, &b, file)?;
                Ok(format!(
                    "wrote {path}: execution {before} (blue) and {after} (green) overlaid"
                ))
            }
        }
    }

    fn save(&self, path: &str) -> Result<String, SessionError> {
        let format = self.state.learner.save(Path::new(path))?;
        Ok(format!(
            "saved {} points to {path} ({})",
            self.state.learner.len(),
            format.describe()
        ))
    }

    fn open(&mut self, path: &str) -> Result<String, SessionError> {
        // Validated whole before anything changes; the journal keeps the dataset itself.
        let learner = Learner::open(Path::new(path), self.task, self.seed)?;
        let dataset = learner.dataset().to_json_string();
        self.take_learner(learner);
        // Applied above without deriving the policy twice; `apply` does the same on restore.
        self.journal_effect(Effect::Open {
            path: path.to_string(),
            dataset,
        })?;
        Ok(format!(
            "opened {path}: {} points",
            self.state.learner.len()
        ))
    }

    fn export_advice(&self, path: &str) -> Result<String, SessionError> {
        let n = self.state.learner.export_advice(Path::new(path))?;
        Ok(format!(
            "wrote {n} advised points with their provenance to {path}"
        ))
    }

    fn help(&self, topic: Option<&Ident>) -> Result<String, SessionError> {
        let Some(topic) = topic else {
            let mut out = String::from("commands, by the steps of the teacher's workflow:\n");
            for (step, words) in WORKFLOW {
                let _ = writeln!(out, "  {step}");
                for w in *words {
                    if let Some((_, sig)) = COMMANDS.iter().find(|(c, _)| c == w) {
                        let _ = writeln!(out, "    {sig:<34} {}", command_doc(w));
                    }
                }
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

/// The commands grouped by the steps of the teacher's workflow, in `help`'s order.
const WORKFLOW: &[(&str, &[&str])] = &[
    ("demonstrate", &["task", "load", "operators"]),
    ("run", &["backend", "run", "show", "plot"]),
    ("select", &["select"]),
    ("correct", &["advise", "preview", "critique", "why"]),
    ("take back", &["undo", "redo", "history"]),
    ("measure", &["eval", "rederive", "learner"]),
    ("keep", &["save", "open", "export"]),
    ("session", &["help", "quit"]),
];

fn command_doc(name: &str) -> &'static str {
    match name {
        "task" => {
            "Switch task (positioning: A-OPI with LWR; interception: BC with 1-NN). Each task keeps its own dataset, executions and history."
        }
        "backend" => "Choose the robot: the simulator, or a Segway RMP at an address.",
        "load" => {
            "Load demonstrations (a file, or `teacher:N` to record N teacher runs in the simulator) or a trace to advise."
        }
        "operators" => "Check an operator file and add its operators on top of the standard ones.",
        "run" => {
            "Run the current policy to a goal (positioning) or from the N-th practice start, and record it."
        }
        "show" => "Summarise the selected execution (or execution N), with a small plot.",
        "select" => {
            "Select points A (inclusive) to B (exclusive) of the latest execution, or of execution N with `in N`; advise, critique, preview, why and plot act on it."
        }
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
        "eval" => {
            "Evaluate the policy on the task's fixed test set (never advised) and say what changed since the last eval; `--detail` lists the tests that changed outcome."
        }
        "learner" => {
            "Switch the running learner: `bc` (1-NN with critique weights) or `lwr` (locally weighted regression); the dataset is shared."
        }
        "why" => "Show which data points supported the action at point T, with their provenance.",
        "plot" => {
            "Write the selected execution's path as SVG, `plot actions FILE` its actions against point index, `plot compare FILE N M` executions N and M overlaid; selection, advice and critiques marked."
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

/// What changed between two evaluations of the same test set; with `detail`, the goals whose
/// outcome changed.
fn eval_change(before: &Report, now: &Report, detail: bool) -> String {
    let mut out = format!(
        "  since the last eval: success {:.1}% -> {:.1}% ({:+.1} points), mean position error {:.3} -> {:.3} m ({:+.3}), mean length {:.3} -> {:.3} m ({:+.3})\n",
        100.0 * before.success_rate,
        100.0 * now.success_rate,
        100.0 * (now.success_rate - before.success_rate),
        before.mean_position_error_m,
        now.mean_position_error_m,
        now.mean_position_error_m - before.mean_position_error_m,
        before.mean_length_m,
        now.mean_length_m,
        now.mean_length_m - before.mean_length_m,
    );
    let changed: Vec<String> = before
        .outcomes
        .iter()
        .zip(&now.outcomes)
        .enumerate()
        .filter(|(_, (b, n))| b.success != n.success)
        .map(|(i, (b, n))| {
            format!(
                "    test {i}: {} -> {} (position error {:.2} -> {:.2} m)",
                if b.success { "success" } else { "failure" },
                if n.success { "success" } else { "failure" },
                b.position_error_m,
                n.position_error_m
            )
        })
        .collect();
    if detail {
        if changed.is_empty() {
            out.push_str("  no test changed outcome\n");
        } else {
            let _ = writeln!(out, "  {} tests changed outcome:", changed.len());
            for c in changed {
                let _ = writeln!(out, "{c}");
            }
        }
    } else if !changed.is_empty() {
        let _ = writeln!(
            out,
            "  {} tests changed outcome (`eval --detail` lists them)",
            changed.len()
        );
    }
    out
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
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.4}")).collect();
    format!("[{}]", parts.join(", "))
}

/// Where a script line came from, for diagnostics: `path:line`.
pub fn origin(path: &Path, line: usize) -> String {
    format!("{}:{line}", path.display())
}

/// The stretch of `w` points of a path where the robot turned or slowed the most (what a teacher
/// most likely wants to look at), and which of the two it did; `None` if it never moved.
fn worth_a_look(path: &[Pose], t: &[f64], w: usize) -> Option<(Chunk, &'static str)> {
    let n = path.len().min(t.len());
    if n < 3 {
        return None;
    }
    let w = w.clamp(2, n);
    let speed: Vec<f64> = (0..n - 1)
        .map(|i| {
            let (a, b) = (path[i], path[i + 1]);
            let dt = (t[i + 1] - t[i]).max(1e-6);
            (b.x_m - a.x_m).hypot(b.y_m - a.y_m) / dt
        })
        .collect();
    // Per step: how much it turned (rad) and how much it slowed (m/s), both at least 0.
    let turn: Vec<f64> = (0..n - 1)
        .map(|i| wrap_angle(path[i + 1].theta_rad - path[i].theta_rad).abs())
        .collect();
    let slow: Vec<f64> = (0..n - 1)
        .map(|i| (speed[i.saturating_sub(1)] - speed[i]).max(0.0))
        .collect();
    let mut best: Option<(f64, usize, &'static str)> = None;
    for start in 0..=(n - w) {
        let steps = start..(start + w - 1);
        let moving = steps.clone().map(|i| speed[i]).sum::<f64>() / (w - 1) as f64;
        if moving < 0.02 {
            continue;
        }
        let turned: f64 = steps.clone().map(|i| turn[i]).sum();
        let slowed: f64 = steps.map(|i| slow[i]).sum();
        // A radian of turning and a metre per second of slowing weigh alike.
        let score = turned + slowed;
        if best.is_none_or(|(b, _, _)| score > b) {
            let what = if turned >= slowed { "turned" } else { "slowed" };
            best = Some((score, start, what));
        }
    }
    let (_, start, what) = best?;
    Some((Chunk::new(start, start + w, n).ok()?, what))
}

/// A number as a teacher typed it, unless it is huge or tiny: then in exponent form, so a
/// diagnostic never prints hundreds of digits.
fn short_num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn first_chars(s: &str, n: usize) -> String {
    match s.char_indices().nth(n) {
        Some((i, _)) => format!("{}...", &s[..i]),
        None => s.to_string(),
    }
}

/// Check warnings as a reply shows them, after a blank line; empty when there are none.
fn warnings_text(warnings: &[crate::check::CheckWarning]) -> String {
    warnings
        .iter()
        .map(|w| format!("\n\n{}", crate::check::render(w).trim_end()))
        .collect()
}
