//! What every binding's `domain=`, `task=` and `tasks=` name: the task files, a task by the
//! library's one resolver, a domain of an operator set. Its own file, below the bindings that
//! take those arguments (`demos`, `ops`, `learn`, `session`, `env`, `dataset`), so none of them
//! reaches into another for it (issue 50).

use std::path::PathBuf;
use std::sync::Arc;

use advise::check::OperatorSet;
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::program::task::TaskDef;
use advise::task::{Front, TaskKind};
use pyo3::prelude::*;

use crate::diag::Diagnostic;
use crate::error::{from_diag, raise, simple};

/// `tasks=`: a task file (a str or an `os.PathLike`) or a list of them, as `Session`,
/// `make_env`, the learners, `Operators` and `load_demos` all take it; None is none.
pub fn task_files(py: Python<'_>, tasks: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<PathBuf>> {
    let Some(t) = tasks.filter(|t| !t.is_none()) else {
        return Ok(Vec::new());
    };
    if let Ok(one) = t.extract::<PathBuf>() {
        return Ok(vec![one]);
    }
    t.extract::<Vec<PathBuf>>().map_err(|_| {
        simple(
            py,
            "advise::py::tasks",
            format!(
                "`tasks` is {}, not a task file or a list of them",
                t.repr().map_or_else(|_| "?".into(), |r| r.to_string())
            ),
            "pass the path of a file declaring the task (`tasks=\"dock.adv\"`) or a list of \
             paths (`tasks=[\"dock.adv\", \"more.adv\"]`)",
        )
    })
}

/// The task `name` among the built-in ones and those the task files `files` declare, with the
/// operator set the files make (the standard operators, the files', and each declared task's
/// standard operators by role): the library's one resolver, as `advise --tasks FILE --task NAME`
/// resolves it. Every mistake in the files is raised, each with its place.
pub fn task_in(py: Python<'_>, name: &str, files: &[PathBuf]) -> PyResult<(TaskKind, OperatorSet)> {
    let mut map = SourceMap::new();
    advise::task::resolve_in_files(&mut map, name, files, Front::Python)
        .map_err(|e| raise(py, Diagnostic::all_of(&map, &e, "error")))
}

/// The task `name`, built in or declared in the task files `files` ([`task_in`]).
pub fn task_kind(py: Python<'_>, name: &str, files: Option<Vec<String>>) -> PyResult<TaskKind> {
    let files: Vec<PathBuf> = files.into_iter().flatten().map(PathBuf::from).collect();
    task_in(py, name, &files).map(|(kind, _)| kind)
}

/// What `domain=`, `task=` and `tasks=` name together: a domain (of the standard operators or
/// the task files) or a task (built in or declared in the task files; `default` when neither
/// is given), and the operator set of the task files.
pub struct Named {
    pub domain: Domain,
    /// The task's definition, when a task was named: how a recording of a base's drive becomes
    /// demonstrations.
    pub def: Option<Arc<TaskDef>>,
    pub set: OperatorSet,
}

impl Named {
    pub fn new(
        py: Python<'_>,
        domain: Option<&str>,
        task: Option<&str>,
        files: &[PathBuf],
        default: Option<&str>,
    ) -> PyResult<Named> {
        let task = if domain.is_none() {
            task.or(default)
        } else {
            task
        };
        match (domain, task) {
            (Some(d), None) => {
                let set = if files.is_empty() {
                    OperatorSet::standard()
                } else {
                    let mut map = SourceMap::new();
                    advise::task::load_task_files(&mut map, files)
                        .map_err(|e| raise(py, Diagnostic::all_of(&map, &e, "error")))?
                        .set
                };
                let domain = domain_in(py, &set, Some(d), None)?;
                Ok(Named {
                    domain,
                    def: None,
                    set,
                })
            }
            (None, Some(t)) => {
                let (kind, set) = task_in(py, t, files)?;
                Ok(Named {
                    domain: kind.domain(),
                    def: kind.def(),
                    set,
                })
            }
            _ => Err(simple(
                py,
                "advise::py::domain_or_task",
                "give exactly one of `domain=` and `task=`".into(),
                "`domain=\"positioning\"`, `task=\"interception\"` or `task=\"dock\", \
                 tasks=\"dock.adv\"` (a task declared in a file)",
            )),
        }
    }
}

/// The domain named `domain`, or that of the task `task`, in `set` (exactly one of them given);
/// a task by the library's one resolver ([`advise::task::resolve`]).
pub fn domain_in(
    py: Python<'_>,
    set: &OperatorSet,
    domain: Option<&str>,
    task: Option<&str>,
) -> PyResult<Domain> {
    match (domain, task) {
        (Some(name), None) => set.domain(name).cloned().ok_or_else(|| {
            let names: Vec<&str> = set.domains().iter().map(|d| d.name.as_str()).collect();
            simple(
                py,
                "advise::py::unknown_domain",
                format!("there is no domain `{name}`"),
                &format!("the domains are: {}", names.join(", ")),
            )
        }),
        (None, Some(t)) => advise::task::resolve(t, set, advise::task::Front::Python)
            .map(|kind| kind.domain())
            .map_err(|e| from_diag(py, &SourceMap::new(), &e)),
        _ => Err(simple(
            py,
            "advise::py::domain_or_task",
            "give exactly one of `domain=` and `task=`".into(),
            "`domain=\"positioning\"` or `task=\"interception\"`",
        )),
    }
}
