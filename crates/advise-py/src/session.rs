//! `advise.Session`: a teaching session (the REPL's statements) driven from Python, each reply as
//! a dict, each execution as numpy arrays. It starts as `advise --tasks FILE --task NAME` starts
//! (the same statements, journalled the same way), journals as the CLI does when asked
//! (`journal=True`: into `$ADVISE_HOME`, where `advise resume` finds it), and restores a journal
//! as `advise resume` does ([`Session::resume`]): nothing re-run, no robot connected or driven.

use std::path::PathBuf;
use std::sync::mpsc::RecvTimeoutError;
use std::sync::{Mutex, MutexGuard, TryLockError};
use std::time::Duration;

use advise::diag::SourceMap;
use advise::session::{HeldExecution, Hold, Reply};
use advise::session::{Session as Inner, SessionOptions, journal};
use advise::trace::Pose;
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList};

use crate::arrays::{set_dim_names, to_numpy};
use crate::diag::Diagnostic;
use crate::error::{from_diag, simple};
use crate::explain::Provenance;

/// Session(*, task="positioning", tasks=None, backend="sim", seed=0, demos=0, journal=None)
///
/// A teaching session (the REPL's statements) on a built-in task, or on one declared in the
/// `tasks` file(s), started as `advise --tasks FILE --task NAME --demos N --seed S` starts one:
/// `demos` teacher demonstrations recorded first (for a declared task, when it has a teacher).
/// In the simulator unless `backend` names a base (`backend SPEC`). `journal`: None (or False)
/// keeps no journal (`--no-journal`), True journals where `advise resume` looks ($ADVISE_HOME,
/// else ~/.advise), a folder journals there. A bad task, file or argument raises AdviseError.
/// Any thread may use it, one statement at a time: the GIL is released while a statement runs,
/// and another thread's call meanwhile raises AdviseError `advise::py::busy`.
#[pyclass(module = "advise")]
pub struct Session {
    /// None once `close` ended it (its journal closed and unlocked). Behind a lock so a session
    /// may be used from any Python thread; a second thread is refused while a statement runs
    /// (`advise::py::busy`), never made to wait: it would wait holding the GIL the first needs.
    inner: Mutex<Option<Inner>>,
    /// What the restore said, for a session made by [`Session::resume`].
    resumed: Option<Resumed>,
    /// The process that made it: a child `fork()`ed from it holds a copy of its journal's
    /// handle, and is refused (`advise::py::forked`) rather than let write into the parent's
    /// journal.
    pid: u32,
    /// `take_over`'s command: the session's live takeover, held without the session's lock
    /// (a run holds it while it drives).
    hold: Hold,
}

/// A Python caller's hold hands back after this long without a `take_over` (a script that
/// stopped calling it).
const HOLD_TIMEOUT: Duration = Duration::from_millis(300);

/// The session's live takeover: `take_over` holds it.
fn held(inner: &mut Inner) -> Hold {
    let hold = Hold::new(HOLD_TIMEOUT);
    inner.set_live_takeover(Some(Box::new(hold.clone())));
    hold
}

/// What `advise resume` prints when it restores a journal, kept for `Session.resumed`.
struct Resumed {
    path: String,
    entries: usize,
    notes: Vec<String>,
    stopped: Option<Diagnostic>,
    /// The CLI's line: `resumed PATH: N statements restored; STATUS`.
    text: String,
}

#[pymethods]
impl Session {
    #[new]
    #[pyo3(signature = (*, task="positioning", tasks=None, backend="sim", seed=0, demos=0, journal=None))]
    fn new(
        py: Python<'_>,
        task: &str,
        tasks: Option<&Bound<'_, PyAny>>,
        backend: &str,
        seed: u64,
        demos: usize,
        journal: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Session> {
        // A bad `journal` is refused before any demonstration is recorded.
        let journal_dir = journal_dir(py, journal)?;
        let tasks = crate::named::task_files(py, tasks)?;
        let mut inner = start(py, task, tasks, seed, demos)?;
        let hold = held(&mut inner);
        match journal_dir {
            Some(dir) => {
                inner
                    .start_journal(&dir)
                    .map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
            }
            None => inner.without_journal(),
        }
        let s = Session {
            inner: Mutex::new(Some(inner)),
            resumed: None,
            pid: std::process::id(),
            hold,
        };
        if backend != "sim" {
            s.run(py, &format!("backend {backend}"), "--backend")?;
        }
        Ok(s)
    }

    /// resume(path=None, journal_dir=None) -> Session
    ///
    /// Restore a journalled session as `advise resume PATH` does: every effect applied as it was
    /// recorded, nothing re-run, no file but the journal (and its sidecars) read, no robot
    /// connected or driven: a session that was on a robot is on `sim` and says so in a note;
    /// only an explicit `backend SPEC` statement connects again. Without `path`, the newest
    /// journal of `journal_dir`. The session journals on into the same file (or, when a line was
    /// damaged or refused, into a new one in `journal_dir`); `journal_dir` defaults to the CLI's,
    /// `$ADVISE_HOME` else `~/.advise`. What the restore said is `resumed`. A journal another
    /// session holds, or one that is not a journal, raises AdviseError.
    #[staticmethod]
    #[pyo3(signature = (path=None, journal_dir=None))]
    fn resume(
        py: Python<'_>,
        path: Option<PathBuf>,
        journal_dir: Option<PathBuf>,
    ) -> PyResult<Session> {
        let dir = journal_dir.unwrap_or_else(journal::default_dir);
        let path = match path {
            Some(p) => p,
            None => journal::newest(&dir).ok_or_else(|| {
                simple(
                    py,
                    "advise::resume::no_journal",
                    format!("there is no session journal in {}", dir.display()),
                    "start a session with a journal first (`advise.Session(journal=True)`, or \
                     `advise`); journals are kept in $ADVISE_HOME or ~/.advise",
                )
            })?,
        };
        let restored =
            Inner::restore(&path, &dir).map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
        let text = restored.summary(&path);
        let mut inner = restored.session;
        let hold = held(&mut inner);
        let stopped = restored
            .stopped
            .as_ref()
            .map(|s| Diagnostic::of(inner.sources(), s, "warning"));
        let resumed = Resumed {
            path: path.display().to_string(),
            entries: restored.entries,
            notes: restored.notes,
            stopped,
            text,
        };
        Ok(Session {
            inner: Mutex::new(Some(inner)),
            resumed: Some(resumed),
            pid: std::process::id(),
            hold,
        })
    }

    /// execute(statement) -> dict
    ///
    /// Run one statement (`load demos FILE`, `run goal 2 -1 0.5`, `select 10..20`,
    /// `advise slow_down(0.3)`, `eval`...). The reply: `kind` (`ran`, `selected`, `advised`,
    /// `critiqued`, `evaluated`, `defined`, `message`, `nothing`, `quit`), `text` (what the
    /// REPL prints) and the kind's fields. A failing statement raises AdviseError. With a
    /// journal, what the statement changed is journalled before the reply is returned.
    fn execute<'py>(&self, py: Python<'py>, statement: &str) -> PyResult<Bound<'py, PyDict>> {
        self.run(py, statement, "<python>")
    }

    /// suggest(execution=None, budget_s=None) -> dict
    ///
    /// `suggest [N]` as data: the chunks of execution `execution` (the latest by default) where
    /// the task's `flaw` clauses hold, and candidate advice for each, ranked by what a re-run of
    /// the same start with the same noise on a copy of the learner showed (on the simulator):
    /// `execution`, `label`, `flawed` (each `chunk` and `held` as {start, end} and `flaws`),
    /// `trial` (`{"kind": "simulated", "before": {...}, "seed": ...}` or
    /// `{"kind": "not_run", "why": ...}`), `suggestions` (each `number`, `execution`, `chunk`,
    /// `flaws`, `invocation`, `operator`, `rate`, `points`, and `after`: success, error,
    /// heading_error, length_m, steps, or None when not re-run), `no_better`, `candidates`,
    /// `not_rerun`, `budget_s`; and `text`, what the REPL prints. `budget_s` bounds the time
    /// spent re-running (30 s by default). `execute("accept K")` gives suggestion K, journalled
    /// as `select` + `advise`. A task without flaws raises AdviseError `advise::session::no_flaws`.
    #[pyo3(signature = (execution=None, budget_s=None))]
    fn suggest<'py>(
        &self,
        py: Python<'py>,
        execution: Option<usize>,
        budget_s: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        if let Some(b) = budget_s {
            self.with(py, |i| {
                i.set_suggest_budget(b);
                Ok(())
            })?;
        }
        let statement = match execution {
            Some(n) => format!("suggest {n}"),
            None => "suggest".to_string(),
        };
        let reply = self.run(py, &statement, "<python>")?;
        let data = self.with(py, |i| Ok(serde_json::to_string(&i.suggestions())))?;
        let d = json_value(py, data)?.cast_into::<PyDict>()?;
        d.set_item("text", reply.get_item("text")?)?;
        Ok(d)
    }

    /// take_over(speed, turn)
    ///
    /// Take over the run another thread is executing on a robot (`rmp:...`, `ros2`), as the web
    /// view's pad does: `speed` and `turn` are fractions of the base's limits, from -1 to 1, and
    /// must be given again at least every 0.3 s (a caller that stops hands back, as a released
    /// joystick does); `hand_back()` hands back at once. What the person drove is kept as a
    /// takeover demonstration linked to the run (the run's reply lists it in `takeovers`). A
    /// simulated run is over before another thread could call it. Never waits for the session:
    /// callable while `execute` runs. Values off the pad raise AdviseError.
    fn take_over(&self, py: Python<'_>, speed: f64, turn: f64) -> PyResult<()> {
        self.hold.hold(speed, turn).map_err(|why| {
            simple(
                py,
                "advise::py::takeover",
                why,
                "take_over(0.5, 0.0) drives at half the speed limit, straight on",
            )
        })
    }

    /// hand_back()
    ///
    /// Let go of `take_over`: the learner drives the run from its next step.
    fn hand_back(&self) {
        self.hold.release();
    }

    /// The journal this session writes (a path), or None when it keeps none.
    #[getter]
    fn journal_path(&self, py: Python<'_>) -> PyResult<Option<String>> {
        let path = |i: &mut Inner| i.journal_path().map(|p| p.display().to_string());
        Ok(self.lock(py)?.as_mut().and_then(path))
    }

    /// For a session made by `Session.resume`, what the restore said (what `advise resume`
    /// prints): `path`, `entries` (statements restored), `notes` (a cut statement dropped, the
    /// robot the session was on, a new journal), `stopped` (an advise.Diagnostic for the line the
    /// restore stopped at, or None) and `text` (`resumed PATH: N statements restored; STATUS`).
    /// None for a new session.
    #[getter]
    fn resumed<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(r) = &self.resumed else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("path", &r.path)?;
        d.set_item("entries", r.entries)?;
        d.set_item("notes", r.notes.clone())?;
        d.set_item("stopped", r.stopped.clone())?;
        d.set_item("text", &r.text)?;
        Ok(Some(d))
    }

    /// The session's one-line summary (task, backend, data points, learner, executions), as the
    /// REPL's banner prints it.
    #[getter]
    fn status(&self, py: Python<'_>) -> PyResult<String> {
        self.with(py, |i| Ok(i.status()))
    }

    /// The number of executions the current task holds (`execution(i)` gives each).
    #[getter]
    fn executions(&self, py: Python<'_>) -> PyResult<usize> {
        self.with(py, |i| Ok(i.executions().len()))
    }

    /// execution(index) -> dict
    ///
    /// Execution `index` of the current task (negative counts from the end) as arrays: `index`,
    /// `label`, `observations` (n x obs_dim), `actions` (n x act_dim), `t` (n), the recorded
    /// `pose` (n x 3: x, y, theta; None when the trace has none), and for a run `true_pose`
    /// (n x 3, when the simulator knew it), `ball` (n x 2, interception), `outcome` (dict), and
    /// `support`: for each step the data point whose action it took (an advise.Provenance, or
    /// None), with `support_points` its position in the dataset now (-1 for none or a point no
    /// longer there). `goal` ((x, y, theta) or None), `goal_values` (a declared task's goal),
    /// `flagged` and `advised` (the chunks critiqued and advised, as (start, end)),
    /// `observation_names` and `action_names`. An index out of range raises AdviseError.
    fn execution<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyDict>> {
        self.with(py, |inner| execution_at(py, inner, index))
    }

    /// dataset() -> dict
    ///
    /// The current task's data points with their provenance, in dataset order (what `save`
    /// writes): the same dict as `BC.dataset()` (`observations`, `actions`, `weights`, `source`
    /// `"demonstration"` or `"advice"`, `source_id`, `index`, `execution_index`,
    /// `demonstrations`, `advice`...). `advise.to_arrow` makes it a pyarrow table.
    fn dataset<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.with(py, |i| {
            crate::dataset::dataset_dict(py, i.learner().dataset())
        })
    }

    /// The number of data points the policy holds.
    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        self.with(py, |i| Ok(i.learner().len()))
    }

    /// close()
    ///
    /// End the session: its journal is closed and unlocked, so `advise resume` or
    /// `Session.resume` may continue it (nothing is lost: every statement was journalled as it
    /// ran). Any later use raises AdviseError `advise::py::closed`; closing again does nothing.
    /// `with advise.Session(...) as s:` closes it at the end of the block.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        if self.forked() {
            // A forked child's copy: the journal's handle and lock are the parent's, and closing
            // them here would unlock the parent's journal. The copy is put away unclosed.
            let mut inner = self.held(py)?;
            std::mem::forget(inner.take());
            return Ok(());
        }
        *self.lock(py)? = None;
        Ok(())
    }

    /// The session itself, for `with advise.Session(...) as s:`.
    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Close the session at the end of a `with` block (an exception goes on).
    fn __exit__(
        &self,
        py: Python<'_>,
        _kind: Option<&Bound<'_, PyAny>>,
        _value: Option<&Bound<'_, PyAny>>,
        _traceback: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        self.close(py)?;
        Ok(false)
    }
}

impl Session {
    /// Execute `statement` as coming from `origin` (journalled with it); the reply as a dict.
    fn run<'py>(
        &self,
        py: Python<'py>,
        statement: &str,
        origin: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.with(py, |inner| {
            let stop = inner.stop_signal();
            let mut interrupted: Option<PyErr> = None;
            // The statement runs on a thread of its own while this one, without the GIL but for
            // a moment every 50 ms, waits for it: other Python threads run meanwhile, and Ctrl-C
            // (a Python signal, which only this thread can see) stops a run as it does at the
            // REPL: the base is commanded to zero at once and the run ends at its next step.
            let result = std::thread::scope(|scope| {
                let (tx, rx) = std::sync::mpsc::channel();
                let work = &mut *inner;
                scope.spawn(move || {
                    let _ = tx.send(work.execute(statement, origin));
                });
                let mut rx = rx;
                loop {
                    // The receiver goes to the GIL-free closure and back (it is not `Sync`).
                    let (back, got) = py.detach(move || {
                        let got = rx.recv_timeout(Duration::from_millis(50));
                        (rx, got)
                    });
                    rx = back;
                    match got {
                        Ok(r) => return Some(r),
                        // The statement panicked: the scope raises it when it ends.
                        Err(RecvTimeoutError::Disconnected) => return None,
                        Err(RecvTimeoutError::Timeout) => {
                            // Raised again each time: a run starting after the signal clears it.
                            if interrupted.is_some() {
                                stop.raise();
                            } else if let Err(e) = py.check_signals() {
                                stop.raise();
                                interrupted = Some(e);
                            }
                        }
                    }
                }
            });
            if let Some(e) = interrupted {
                match &result {
                    // The statement finished before it saw the stop: its effect is kept and
                    // journalled, so its reply is returned, and the interrupt raised again to
                    // come right after (`_thread.interrupt_main`, as if Ctrl-C came then).
                    Some(Ok(_)) => {
                        py.import("_thread")?.call_method0("interrupt_main")?;
                    }
                    // It stopped: a statement that reads or records ends before its effect
                    // (nothing changed, nothing journalled); an interrupted run keeps what the
                    // base did, as at the REPL.
                    _ => return Err(e),
                }
            }
            let Some(result) = result else {
                return Err(simple(
                    py,
                    "advise::py::panicked",
                    "the statement ended without a reply".into(),
                    "this is a bug of advise; the session is as the statement left it",
                ));
            };
            let reply = result.map_err(|e| from_diag(py, inner.sources(), &e))?;
            reply_dict(py, &reply)
        })
    }

    /// The session's mutex, unless another thread holds it (whoever may then use it).
    fn held(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, Option<Inner>>> {
        match self.inner.try_lock() {
            Ok(g) => Ok(g),
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(TryLockError::WouldBlock) => Err(busy(py)),
        }
    }

    /// Whether this is a `fork()`ed child's copy of the session.
    fn forked(&self) -> bool {
        std::process::id() != self.pid
    }

    /// The session's lock, unless another thread holds it. A statement that panicked left the
    /// session as the panic found it; it is used on (the panic was raised in Python). In a
    /// `fork()`ed child, a journalled session is refused: its journal is the parent's.
    fn lock(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, Option<Inner>>> {
        let guard = self.held(py)?;
        if self.forked() && guard.as_ref().is_some_and(|i| i.journal_path().is_some()) {
            return Err(simple(
                py,
                "advise::py::forked",
                format!(
                    "this journalled session belongs to process {}; this is a child forked from it",
                    self.pid
                ),
                "a forked child may not write its parent's journal: start a session of its own in \
                 the child (`advise.Session(...)`, or `Session.resume` once the parent closed \
                 it), or use the `spawn` start method",
            ));
        }
        Ok(guard)
    }
}

impl Drop for Session {
    /// In a forked child, the session is left as it is (its journal's handle and lock belong to
    /// the parent): only the parent closes it.
    fn drop(&mut self) {
        if self.forked() {
            let inner = self
                .inner
                .get_mut()
                .map_or_else(|p| p.into_inner().take(), Option::take);
            std::mem::forget(inner);
        }
    }
}

/// `advise::py::busy`: a session another thread is running a statement in.
fn busy(py: Python<'_>) -> PyErr {
    simple(
        py,
        "advise::py::busy",
        "the session is running a statement in another thread".into(),
        "a session runs one statement at a time: wait for that thread (`join` it), or \
         give each thread a session of its own",
    )
}

impl Session {
    /// `f` on the session, unless `close` ended it or another thread is using it.
    fn with<R>(&self, py: Python<'_>, f: impl FnOnce(&mut Inner) -> PyResult<R>) -> PyResult<R> {
        f(self.lock(py)?.as_mut().ok_or_else(|| closed(py))?)
    }
}

/// Execution `index` of `inner` (negative from the end): see `Session.execution`.
fn execution_at<'py>(py: Python<'py>, inner: &Inner, index: isize) -> PyResult<Bound<'py, PyDict>> {
    let all = inner.executions();
    let i = if index < 0 {
        all.len().checked_sub(index.unsigned_abs())
    } else {
        Some(index.unsigned_abs()).filter(|&i| i < all.len())
    };
    let Some(i) = i else {
        return Err(simple(
            py,
            "advise::py::no_execution",
            format!(
                "there is no execution {index}: the session holds {} (task {})",
                all.len(),
                inner.task()
            ),
            "executions are numbered from 0 in the order they were run or loaded \
             (`Session.executions` counts them); a negative index counts from the end",
        ));
    };
    execution_dict(py, inner, i, &all[i])
}

/// Execution `i` (`rec`) of `inner` as a dict of arrays: see `Session.execution`.
fn execution_dict<'py>(
    py: Python<'py>,
    inner: &Inner,
    i: usize,
    rec: &HeldExecution,
) -> PyResult<Bound<'py, PyDict>> {
    let tr = &rec.trace;
    let n = tr.len();
    let d = PyDict::new(py);
    let domain = inner.domain();
    d.set_item("index", i)?;
    d.set_item("label", &rec.label)?;
    d.set_item("observations", to_numpy(py, tr.z.clone(), n, tr.obs_dim())?)?;
    d.set_item("actions", to_numpy(py, tr.a.clone(), n, tr.act_dim())?)?;
    d.set_item("t", tr.t.clone().into_pyarray(py))?;
    d.set_item("pose", poses(py, tr.pose.as_deref())?)?;
    let run = rec.execution.as_ref();
    d.set_item(
        "true_pose",
        poses(py, run.and_then(|e| e.true_poses.as_deref()))?,
    )?;
    let ball = match run.and_then(|e| e.ball.as_ref()) {
        Some(b) => Some(to_numpy(py, b.concat(), b.len(), 2)?),
        None => None,
    };
    d.set_item("ball", ball)?;
    let outcome = match run {
        Some(e) => Some(json_value(py, serde_json::to_string(&e.outcome))?),
        None => None,
    };
    d.set_item("outcome", outcome)?;
    let learner = inner.learner();
    let support = rec.support.as_ref().map(|s| {
        s.iter()
            .map(|p| p.map(|p| Provenance::of(learner, p)))
            .collect::<Vec<_>>()
    });
    let points = rec.support.as_ref().map(|s| {
        s.iter()
            .map(|p| {
                p.and_then(|p| learner.dataset().position(p))
                    .map_or(-1, |x| x as i64)
            })
            .collect::<Vec<i64>>()
            .into_pyarray(py)
    });
    d.set_item("support", support)?;
    d.set_item("support_points", points)?;
    d.set_item("goal", rec.goal.map(|g| (g.x_m, g.y_m, g.theta_rad)))?;
    d.set_item("goal_values", rec.goal_values.clone())?;
    let chunks = |c: &[advise::trace::Chunk]| -> Vec<(usize, usize)> {
        c.iter().map(|c| (c.start, c.end)).collect()
    };
    d.set_item("flagged", chunks(&rec.flagged))?;
    d.set_item("advised", chunks(&rec.advised))?;
    // The windows the teacher drove (a takeover); every other step was the learner's.
    d.set_item("teacher", chunks(&rec.teacher))?;
    set_dim_names(&d, domain)?;
    Ok(d)
}

/// The refusal of a session `close` ended.
fn closed(py: Python<'_>) -> PyErr {
    simple(
        py,
        "advise::py::closed",
        "the session is closed".into(),
        "a closed session's journal may be continued: `advise.Session.resume(PATH)`",
    )
}

/// `journal=`: None or False keeps none, True the CLI's directory, a path that directory.
fn journal_dir(py: Python<'_>, journal: Option<&Bound<'_, PyAny>>) -> PyResult<Option<PathBuf>> {
    let Some(j) = journal.filter(|j| !j.is_none()) else {
        return Ok(None);
    };
    if let Ok(b) = j.cast::<PyBool>() {
        return Ok(b.is_true().then(journal::default_dir));
    }
    j.extract::<PathBuf>().map(Some).map_err(|_| {
        simple(
            py,
            "advise::py::journal",
            format!(
                "`journal` is {}, not a folder, True or None",
                j.repr().map_or_else(|_| "?".into(), |r| r.to_string())
            ),
            "pass journal=True to journal where `advise resume` looks ($ADVISE_HOME or \
             ~/.advise), a folder (str or pathlib.Path) to journal there, or None for no journal",
        )
    })
}

/// A session on `task` as `advise --tasks FILE... --task NAME --demos N` starts one
/// ([`SessionOptions::starting_on`], [`Inner::reach_task`]). Every mistake in the files, or an
/// unknown name, is refused before anything starts.
fn start(
    py: Python<'_>,
    task: &str,
    files: Vec<PathBuf>,
    seed: u64,
    demos: usize,
) -> PyResult<Inner> {
    crate::named::task_in(py, task, &files)?;
    let opts = SessionOptions::starting_on(task, seed, demos);
    let mut inner = Inner::new(opts).map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
    inner
        .reach_task(task, &files, demos, &mut |_, _| {})
        .map_err(|e| from_diag(py, inner.sources(), &e))?;
    Ok(inner)
}

/// `poses` as an array of shape (n, 3): x, y, theta.
fn poses<'py>(
    py: Python<'py>,
    poses: Option<&[Pose]>,
) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
    let Some(p) = poses else {
        return Ok(None);
    };
    let values = p.iter().flat_map(|q| [q.x_m, q.y_m, q.theta_rad]).collect();
    to_numpy(py, values, p.len(), 3).map(Some)
}

/// `json` (what serde_json wrote) as Python data: dicts, lists, numbers.
fn json_value<'py>(
    py: Python<'py>,
    json: serde_json::Result<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let json = json.expect("plain data serializes");
    py.import("json")?.call_method1("loads", (json,))
}

/// `reply` as a dict: `kind`, `text` and the variant's fields.
fn reply_dict<'py>(py: Python<'py>, reply: &Reply) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("text", reply.to_string())?;
    let kind = match reply {
        Reply::Nothing => "nothing",
        Reply::Quit => "quit",
        Reply::Message(_) => "message",
        Reply::Defined { warnings, .. } => {
            d.set_item("warnings", warnings.clone())?;
            "defined"
        }
        Reply::Ran(r) => {
            d.set_item("execution", r.index)?;
            d.set_item("points", r.points)?;
            d.set_item("outcome", r.outcome.clone())?;
            let takeovers = PyList::empty(py);
            for t in &r.takeovers {
                let w = PyDict::new(py);
                w.set_item("steps", (t.steps.start, t.steps.end))?;
                w.set_item("from_s", t.from_s)?;
                w.set_item("to_s", t.to_s)?;
                w.set_item("points", t.points)?;
                w.set_item("number", t.number)?;
                takeovers.append(w)?;
            }
            d.set_item("takeovers", takeovers)?;
            "ran"
        }
        Reply::Selected { execution, chunk } => {
            d.set_item("execution", *execution)?;
            d.set_item("chunk", (chunk.start, chunk.end))?;
            "selected"
        }
        Reply::Advised(a) => {
            d.set_item("execution", a.execution)?;
            d.set_item("chunk", (a.chunk.start, a.chunk.end))?;
            d.set_item("invocation", a.invocation.clone())?;
            d.set_item("added", a.added)?;
            d.set_item("skipped", a.skipped)?;
            d.set_item("dataset", a.dataset)?;
            d.set_item(
                "conflict",
                json_value(py, serde_json::to_string(&a.conflict))?,
            )?;
            "advised"
        }
        Reply::Critiqued {
            execution, chunk, ..
        } => {
            d.set_item("execution", *execution)?;
            d.set_item("chunk", (chunk.start, chunk.end))?;
            "critiqued"
        }
        Reply::Suggested(sug) => {
            d.set_item("suggestions", json_value(py, serde_json::to_string(&sug))?)?;
            "suggested"
        }
        Reply::Evaluated(e) => {
            d.set_item("report", json_value(py, serde_json::to_string(&e.report))?)?;
            "evaluated"
        }
    };
    d.set_item("kind", kind)?;
    Ok(d)
}
