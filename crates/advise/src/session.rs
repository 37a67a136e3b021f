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

mod advice;
mod commit;
pub mod conflict;
pub mod effect;
mod error;
mod files;
pub use files::{DemosFile, read_demos_file};
mod help;
pub mod journal;
mod measure;
pub mod plot;
mod record;
mod reply;
mod run;
pub mod script;
pub mod sidecar;
pub mod suggest;
mod takeover;
mod text;
mod undo;
pub mod view;

use std::path::{Path, PathBuf};

use crate::backend::sim::{SimBackend, SimParams};
use crate::backend::{BackendSpecError, Base, Connect, Registry, StopSignal};
use crate::check::OperatorSet;
use crate::domain::Domain;
use crate::eval::Report;
use crate::policy::dataset::{CritiqueRule, Provenance};
use crate::policy::learner::{self, Learner};
use crate::syntax::ast::{Ident, Item};
use crate::syntax::command::{Command, Statement, parse_statement};
use crate::task::{Execution, TaskKind};
use crate::trace::{Chunk, Pose, Trace};
use effect::{Effect, Entry};
use journal::Journal;

pub use advice::check_kappa;
pub use error::SessionError;
pub use reply::{Advised, Defined, Evaluated, Ran, Reply, Since};
pub use takeover::{Both, Hold, LiveTakeover, RunInfo, TookOver};
use undo::Edit;

/// Default kappa of `critique` (the paper leaves it open; 1.0 doubles the weight of a point met
/// at unit scaled distance).
pub const DEFAULT_KAPPA: f64 = 1.0;

/// One execution the session holds (a run, or a trace loaded from a file) and what it knows of it.
#[derive(Clone, Debug)]
pub struct HeldExecution {
    /// Where it came from: `run goal 2 -1 0`, `run start 3`, or a file.
    pub label: String,
    pub trace: Trace,
    pub goal: Option<Pose>,
    /// A declared task's goal, a value per goal parameter (a positioning goal is `goal`).
    pub goal_values: Option<Vec<f64>>,
    pub execution: Option<Execution>,
    /// For each step of a run, the data point that recommended its action (what `critique`
    /// penalises); `None` for a trace loaded from a file.
    pub support: Option<Vec<Option<Provenance>>>,
    /// The learner's id for this execution (advice and critiques refer to it).
    pub id: learner::ExecutionId,
    /// The session's number of the run that made it (its simulator seed is
    /// `episode_seed(seed, 1_000_000 + number)`): what `suggest` re-runs; `None` for a file.
    pub run_number: Option<u64>,
    /// Chunks critiqued and advised, for plots.
    pub flagged: Vec<Chunk>,
    pub advised: Vec<Chunk>,
    /// The windows of steps the teacher drove (a takeover); every other step was the
    /// learner's.
    pub teacher: Vec<Chunk>,
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
    /// The kinds of base `backend SPEC` accepts ([`Registry::standard`], or more).
    pub backends: Registry,
}

impl Default for SessionOptions {
    fn default() -> Self {
        SessionOptions {
            task: TaskKind::Positioning,
            seed: 0,
            default_demos: 0,
            sim: SimParams::default(),
            progress: false,
            backends: Registry::standard(),
        }
    }
}

impl SessionOptions {
    /// Options for a session that starts on the task `name` (see [`Session::reach_task`]): a
    /// built-in task directly, with `demos` teacher demonstrations; a declared one starts on
    /// positioning, without any, and is reached by statements.
    pub fn starting_on(name: &str, seed: u64, demos: usize) -> SessionOptions {
        let builtin = TaskKind::builtin(name);
        SessionOptions {
            default_demos: if builtin.is_some() { demos } else { 0 },
            task: builtin.unwrap_or(TaskKind::Positioning),
            seed,
            ..SessionOptions::default()
        }
    }
}

impl Restored {
    /// What `advise resume` says of it: `resumed PATH: N statements restored; STATUS`.
    pub fn summary(&self, path: &Path) -> String {
        format!(
            "resumed {}: {} statements restored; {}",
            path.display(),
            self.entries,
            self.session.status()
        )
    }
}

/// What one task's work consists of. Each task keeps its own: switching task parks it and
/// switching back restores it.
struct TaskState {
    learner: Learner,
    /// Runs made so far (each run's simulator seed comes from this count).
    runs: u64,
    executions: Vec<HeldExecution>,
    current: Option<usize>,
    selection: Option<Chunk>,
    undo: Vec<Edit>,
    redo: Vec<Edit>,
    /// The number the next advice or critique gets.
    next_edit: usize,
    /// What each piece of advice contradicted when it was added ([`conflict`]), by its number.
    conflicts: Vec<conflict::Conflict>,
    /// The last `suggest` on this task: what `accept K` takes (not journalled: it changes
    /// nothing).
    suggested: Option<suggest::Suggestions>,
    /// The last evaluation, to report what changed since.
    last_eval: Option<Report>,
    /// The evaluation before it: what `eval --detail` compares the last one with while the policy
    /// is unchanged since.
    prev_eval: Option<Report>,
}

impl TaskState {
    fn new(task: &TaskKind, seed: u64) -> TaskState {
        TaskState::with_learner(Learner::new(&task.domain(), task.learner(), seed))
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
            conflicts: Vec::new(),
            suggested: None,
            last_eval: None,
            prev_eval: None,
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
    /// The line the restore stopped at (damaged, or refused by the rules a live statement
    /// follows), as a diagnostic to show; `None` when every line was restored.
    pub stopped: Option<journal::Stopped>,
    /// What else the teacher must be told: a cut statement dropped, the backend the session was
    /// on.
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
    /// The task the session was made on (a built-in one): what a journal's header names. A
    /// declared task is reached by the statements the journal holds first (`tasks FILE` with the
    /// file's text, `task NAME`), so a resume needs no file but the journal.
    started_on: TaskKind,
    domain: Domain,
    /// The base `run` and `teleop` drive: the simulator (made afresh per run) unless `backend`
    /// connected another.
    backend: Box<dyn Base>,
    /// The simulator's parameters: what teacher demonstrations and `eval` use on any base, and
    /// the limits and rate a robot's driver is given.
    sim: SimParams,
    /// The kinds of base `backend SPEC` reads and connects.
    backends: Registry,
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
    /// Set by [`Session::execute_previewing`]: `preview` leaves its points here as data.
    previewed: Option<serde_json::Value>,
    /// Effects made before a journal was started (the starting demonstrations), written first
    /// into the journal when one is started; `None` once one was (or never will be).
    preamble: Option<Vec<Entry>>,
    /// Every file and statement the session has read, for its diagnostics.
    sources: crate::diag::SourceMap,
    /// The files the session's commands read (`open`, `load`, `operators`, `tasks`), each with
    /// whether `open` read it: an output may not replace one ([`Session::check_output`]).
    inputs: Vec<(std::path::PathBuf, bool)>,
    /// When the session began, on the wall clock (an MCAP export's timeline starts there).
    started: std::time::SystemTime,
    /// How long `suggest` may spend re-running candidates, s.
    suggest_budget_s: f64,
    /// The live takeover a front end installed (a person's keys, a web page's pad, a ROS 2
    /// topic), asked at the start of each run.
    live_takeover: Option<Box<dyn takeover::LiveTakeover>>,
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
    /// The sources the session's errors point into: render them with [`crate::diag::render`].
    pub fn sources(&self) -> &crate::diag::SourceMap {
        &self.sources
    }

    /// A session on the simulator; with `default_demos > 0` the task's teacher records that many
    /// demonstrations first and the policy is derived from them.
    pub fn new(opts: SessionOptions) -> Result<Session, SessionError> {
        opts.sim.validate()?;
        let mut s = Session::empty(opts.task, opts.seed, opts.sim);
        s.progress = opts.progress;
        s.backends = opts.backends;
        // What the session starts with is kept for a journal started later.
        s.preamble = Some(Vec::new());
        if opts.default_demos > 0 {
            s.statement = Some((
                format!("load demos teacher:{}", opts.default_demos),
                "--demos".into(),
            ));
            let r = s.load_demos(
                &format!("teacher:{}", opts.default_demos),
                &Default::default(),
            );
            s.statement = None;
            r?;
        }
        Ok(s)
    }

    fn empty(task: TaskKind, seed: u64, sim: SimParams) -> Session {
        Session {
            ops: OperatorSet::standard(),
            domain: task.domain(),
            state: TaskState::new(&task, seed),
            started_on: task.clone(),
            task,
            backend: Box::new(SimBackend::new(sim.clone(), seed)),
            sim,
            backends: Registry::standard(),
            seed,
            parked: Vec::new(),
            journal: None,
            restoring: false,
            restored_backend: None,
            progress: false,
            stop: StopSignal::new(),
            statement: None,
            warnings: Vec::new(),
            previewed: None,
            preamble: None,
            sources: crate::diag::SourceMap::new(),
            inputs: Vec::new(),
            started: std::time::SystemTime::now(),
            suggest_budget_s: suggest::DEFAULT_BUDGET_S,
            live_takeover: None,
        }
    }

    /// How long `suggest` may spend re-running candidates on the simulator (s; at least 0:
    /// 0 re-runs only the baseline). What a front end or a test sets; the default is
    /// [`suggest::DEFAULT_BUDGET_S`].
    pub fn set_suggest_budget(&mut self, seconds: f64) {
        self.suggest_budget_s = if seconds.is_finite() {
            seconds.max(0.0)
        } else {
            suggest::DEFAULT_BUDGET_S
        };
    }

    /// The last `suggest` of the current task, as data (front ends list and preview it).
    pub fn suggestions(&self) -> Option<&suggest::Suggestions> {
        self.state.suggested.as_ref()
    }

    pub fn journal_path(&self) -> Option<&Path> {
        self.journal.as_ref().map(|j| j.path())
    }

    pub fn task(&self) -> TaskKind {
        self.task.clone()
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

    /// The executions the current task holds, in the order `show N` numbers them.
    pub fn executions(&self) -> &[HeldExecution] {
        &self.state.executions
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
        self.backend.name()
    }

    /// The kinds of base `backend SPEC` accepts here (completion reads its words).
    pub fn backends(&self) -> &Registry {
        &self.backends
    }

    /// This session keeps no journal (`--no-journal`, Python's default): what it holds is no
    /// longer kept for a journal started later, so a loaded file's points are not copied into
    /// journal lines nobody writes (20M points took twice the memory of a journalled load).
    pub fn without_journal(&mut self) {
        self.preamble = None;
    }

    /// The signal that stops the robot and the running execution from another thread (the REPL's
    /// Ctrl-C handler holds a clone).
    pub fn stop_signal(&self) -> StopSignal {
        self.stop.clone()
    }

    /// Stop the robot (Ctrl-C at the REPL prompt). The simulator needs nothing; a real base is
    /// commanded to zero and decelerate-to-zero, and this waits (bounded) until it is at rest.
    pub fn stop_robot(&mut self) -> String {
        self.backend.stop_now()
    }

    /// Reach the task `name` as a teacher would (`advise --tasks FILE... --task NAME --demos N`,
    /// on a session made with [`SessionOptions::starting_on`]): `tasks FILE` for each of `files`,
    /// then, for a declared task, `task NAME` and, when it has a teacher, `load demos teacher:N`.
    /// Each is journalled with its origin (`--tasks`, `--task`, `--demos`), so a resumed session
    /// has them; `said` is given each statement's origin and reply.
    pub fn reach_task(
        &mut self,
        name: &str,
        files: &[PathBuf],
        demos: usize,
        said: &mut dyn FnMut(&str, &Reply),
    ) -> Result<(), SessionError> {
        for file in files {
            let reply = self.execute(&format!("tasks \"{}\"", file.display()), "--tasks")?;
            said("--tasks", &reply);
        }
        if TaskKind::builtin(name).is_none() {
            let reply = self.execute(&format!("task {name}"), "--task")?;
            said("--task", &reply);
            if demos > 0 && self.task.has_teacher() {
                let reply = self.execute(&format!("load demos teacher:{demos}"), "--demos")?;
                said("--demos", &reply);
            }
        }
        Ok(())
    }

    /// Run one statement. `origin` names it in diagnostics (`<repl>`, `script.adv:12`).
    ///
    /// The statement's text joins the session's source map, with whatever else it adds (an
    /// invocation, a file that failed to load), for as long as an error may point into them: a
    /// statement that succeeds gives them back, so a long session holds only its failures.
    pub fn execute(&mut self, text: &str, origin: &str) -> Result<Reply, SessionError> {
        let mark = self.sources.len();
        let id = self.sources.add(origin, text);
        let reply = match parse_statement(self.sources.src(id)) {
            Ok(statement) => {
                self.statement = Some((text.trim_end().to_string(), origin.to_string()));
                let reply = match statement {
                    Statement::Empty => Ok(Reply::Nothing),
                    Statement::Item(item) => self.define(item, text, origin),
                    Statement::Command(cmd, _) => self.command(cmd),
                };
                self.statement = None;
                reply
            }
            Err(e) => Err(e.into()),
        };
        if reply.is_ok() {
            self.sources.truncate(mark);
        }
        reply
    }

    fn define(&mut self, item: Item, text: &str, origin: &str) -> Result<Reply, SessionError> {
        self.commit(Effect::Define {
            origin: origin.to_string(),
            text: text.to_string(),
            file: None,
        })?;
        let warnings = std::mem::take(&mut self.warnings)
            .iter()
            .map(|w| crate::diag::render(&self.sources, w, false))
            .collect();
        let item = match item {
            Item::Operator(op) => Defined::Operator {
                name: op.name.name,
                domain: op.domain.name,
                space: op.space,
            },
            Item::Domain(d) => Defined::Domain { name: d.name.name },
        };
        Ok(Reply::Defined { item, warnings })
    }

    fn command(&mut self, cmd: Command) -> Result<Reply, SessionError> {
        match cmd {
            Command::Task(name) => self.set_task(&name),
            Command::Tasks(path) => self.load_tasks(&path).map(Reply::Message),
            Command::Backend(spec) => self.set_backend(&spec),
            Command::LoadDemos {
                path,
                cmd_topic,
                odom_topic,
            } => {
                let options = crate::recording::ImportOptions {
                    cmd_topic,
                    odom_topic,
                    ..Default::default()
                };
                self.load_demos(&path, &options).map(Reply::Message)
            }
            Command::LoadTrace(path) => self.load_trace(&path).map(Reply::Message),
            Command::Operators(path) => self.load_operators(&path).map(Reply::Message),
            Command::RunGoal { goal, takeover } => self.run_goal(&goal, takeover),
            Command::RunStart { start, takeover } => self.run_start(start, takeover),
            Command::Show(n) => self.show(n).map(Reply::Message),
            Command::Select {
                range, execution, ..
            } => self.select(range, execution),
            Command::Critique { kappa, directional } => {
                let rule = if directional {
                    CritiqueRule::Directional
                } else {
                    CritiqueRule::Paper
                };
                self.critique(kappa.unwrap_or(DEFAULT_KAPPA), rule)
            }
            Command::Advise(inv) => self.advise(&inv),
            Command::Preview(inv) => self.preview(&inv).map(Reply::Message),
            Command::Suggest(n) => self.suggest(n),
            Command::Accept(k) => self.accept(k),
            Command::Undo => self.undo().map(Reply::Message),
            Command::Redo => self.redo().map(Reply::Message),
            Command::History { conflicts: false } => Ok(Reply::Message(self.history())),
            Command::History { conflicts: true } => Ok(Reply::Message(self.history_conflicts())),
            Command::Rederive => self.rederive().map(Reply::Message),
            Command::Eval { detail } => self.eval(detail),
            Command::Learner { name, k } => self.set_learner(&name, k).map(Reply::Message),
            Command::Why(t) => self.why(t).map(Reply::Message),
            Command::Plot { kind, path } => self.plot(kind, &path).map(Reply::Message),
            Command::Save(path) => self.save(&path).map(Reply::Message),
            Command::Open(path) => self.open(&path).map(Reply::Message),
            Command::ExportAdvice(path) => self.export_advice(&path).map(Reply::Message),
            Command::ExportMcap(path) => self.export_mcap(&path).map(Reply::Message),
            Command::ExportLeRobot(dir) => self.export_lerobot(&dir).map(Reply::Message),
            Command::Help(topic) => self.help(topic.as_ref()).map(Reply::Message),
            Command::Quit => Ok(Reply::Quit),
            Command::RecordDemo {
                topic,
                goal,
                seconds,
                keep_idle,
            } => self
                .record_demo(topic.as_deref(), goal, seconds, keep_idle)
                .map(Reply::Message),
            Command::Teleop { goal, seconds } => self.teleop(goal, seconds).map(Reply::Message),
        }
    }

    fn set_task(&mut self, name: &Ident) -> Result<Reply, SessionError> {
        let task = self.resolve_task(&name.name)?;
        if task == self.task {
            return Ok(Reply::Message(format!(
                "already on task {task}: nothing changed ({} data points, {} executions)",
                self.state.learner.len(),
                self.state.executions.len()
            )));
        }
        let fresh = !self.parked.iter().any(|(t, _)| *t == task);
        self.commit(Effect::Task {
            task: task.name().to_string(),
        })?;
        let st = &self.state;
        Ok(Reply::Message(if fresh {
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

    /// The task called `name`: one of the paper's, or one declared by a file loaded with
    /// `tasks FILE` (or `operators FILE`), by the one resolver ([`crate::task::resolve`]).
    pub(crate) fn resolve_task(&self, name: &str) -> Result<TaskKind, SessionError> {
        Ok(crate::task::resolve(
            name,
            &self.ops,
            crate::task::Front::Session,
        )?)
    }

    /// Every task the session knows: the paper's two, then the declared ones.
    pub fn task_names(&self) -> Vec<String> {
        crate::task::task_names(&self.ops)
    }

    /// The names of the tasks the operator set declares (positioning's and the files'): what a
    /// file that declares more is compared with.
    fn declared_task_names(&self) -> Vec<String> {
        self.ops
            .tasks()
            .iter()
            .map(|t| t.name().to_string())
            .collect()
    }

    /// Park the current task's work and take up `task`'s (new if it has none yet).
    fn switch_task(&mut self, task: TaskKind) {
        if task == self.task {
            return;
        }
        let next = match self.parked.iter().position(|(t, _)| *t == task) {
            Some(i) => self.parked.swap_remove(i).1,
            None => TaskState::new(&task, self.seed),
        };
        let previous = std::mem::replace(&mut self.state, next);
        self.parked.push((self.task.clone(), previous));
        self.task = task;
        self.domain = self.state.learner.domain().clone();
    }

    /// `backend SPEC`: the base is connected now by its kind (a robot's start-up sequence, a
    /// ROS 2 base's first odometry), so a base that does not answer is reported here and the
    /// session stays on its backend. A robot left behind is stopped and closed (its driver stops
    /// it when dropped) before another is connected: one link to a base at a time.
    fn set_backend(&mut self, spec: &str) -> Result<Reply, SessionError> {
        let parsed = match self.backends.parse(spec) {
            Ok(p) => p,
            Err(e) => return Err(self.locate_spec(e, spec).into()),
        };
        if !self.backend.is_simulator() {
            self.stop.set_base(None);
            self.backend = Box::new(SimBackend::new(self.sim.clone(), self.seed));
        }
        let with = Connect {
            sim: &self.sim,
            seed: self.seed,
        };
        let base = parsed
            .connect(&with)
            .map_err(|error| SessionError::BackendUnavailable {
                spec: spec.trim().to_string(),
                current: self.backend_name(),
                error,
            })?;
        self.stop.set_base(base.remote_stop());
        let reply = match base.describe() {
            Some(what) => format!("backend {}: {what}", base.name()),
            None => format!("backend {}", base.name()),
        };
        self.backend = base;
        // Journalled so a resume can say which base the session was on; a resume never connects.
        self.commit(Effect::Backend {
            spec: spec.trim().to_string(),
        })?;
        Ok(Reply::Message(reply))
    }

    /// An unknown backend pointed at where the statement names it (the grammar takes any word
    /// after `backend`; the registry says what it is not).
    fn locate_spec(&mut self, e: BackendSpecError, spec: &str) -> BackendSpecError {
        let Some((text, origin)) = self.statement.clone() else {
            return e;
        };
        let spec = spec.trim();
        let Some(start) = text
            .find("backend")
            .map(|k| k + "backend".len())
            .and_then(|k| text[k..].find(spec).map(|i| k + i))
        else {
            return e;
        };
        let id = self.sources.add(origin, text);
        e.at(id.span(start, spec.len()))
    }
}

/// Where a script line came from, for diagnostics: `path:line`.
pub fn origin(path: &Path, line: usize) -> String {
    format!("{}:{line}", path.display())
}
