//! `advise.Session`: a teaching session (the REPL's statements) driven from Python, each reply as
//! a dict. No journal is kept (as `advise run --no-journal`).

use advise::session::Reply;
use advise::session::{Session as Inner, SessionOptions};
use advise::task::TaskKind;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::{from_diag, simple};

/// A session on a built-in task, in the simulator unless `backend` says otherwise.
#[pyclass(module = "advise", unsendable)]
pub struct Session {
    inner: Inner,
}

#[pymethods]
impl Session {
    #[new]
    #[pyo3(signature = (*, task="positioning", backend="sim", seed=0, demos=0))]
    fn new(
        py: Python<'_>,
        task: &str,
        backend: &str,
        seed: u64,
        demos: usize,
    ) -> PyResult<Session> {
        let kind = TaskKind::builtin(task).ok_or_else(|| {
            simple(
                py,
                "advise::py::unknown_task",
                format!("there is no built-in task `{task}`"),
                "the built-in tasks are `positioning` and `interception`",
            )
        })?;
        let opts = SessionOptions {
            task: kind,
            seed,
            default_demos: demos,
            ..SessionOptions::default()
        };
        let inner = Inner::new(opts).map_err(|e| from_diag(py, &Default::default(), &e))?;
        let mut s = Session { inner };
        if backend != "sim" {
            s.execute(py, &format!("backend {backend}"))?;
        }
        Ok(s)
    }

    /// execute(statement) -> dict
    ///
    /// Run one statement (`load demos FILE`, `run goal 2 -1 0.5`, `select 10..20`,
    /// `advise slow_down(0.3)`, `eval`...). The reply: `kind` (`ran`, `selected`, `advised`,
    /// `critiqued`, `evaluated`, `defined`, `message`, `nothing`, `quit`), `text` (what the
    /// REPL prints) and the kind's fields. A failing statement raises AdviseError.
    fn execute<'py>(&mut self, py: Python<'py>, statement: &str) -> PyResult<Bound<'py, PyDict>> {
        let reply = self
            .inner
            .execute(statement, "<python>")
            .map_err(|e| from_diag(py, self.inner.sources(), &e))?;
        reply_dict(py, &reply)
    }

    /// The number of data points the policy holds.
    fn __len__(&self) -> usize {
        self.inner.learner().len()
    }
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
            "advised"
        }
        Reply::Critiqued {
            execution, chunk, ..
        } => {
            d.set_item("execution", *execution)?;
            d.set_item("chunk", (chunk.start, chunk.end))?;
            "critiqued"
        }
        Reply::Evaluated(e) => {
            let json = serde_json::to_string(&e.report).expect("a report is plain data");
            let report = py.import("json")?.call_method1("loads", (json,))?;
            d.set_item("report", report)?;
            "evaluated"
        }
    };
    d.set_item("kind", kind)?;
    Ok(d)
}
