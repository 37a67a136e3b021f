//! `advise.load_demos`: a demonstrations file as numpy arrays, read as `load demos FILE` reads it.

use advise::check::{CheckErrors, OperatorSet};
use advise::diag::{SourceMap, Sourced};
use advise::recording::ImportOptions;
use advise::session::read_demos_file;
use advise::task::TaskKind;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::to_numpy;
use crate::diag::Diagnostic;
use crate::error::{from_diag, raise, simple};
use crate::ops::domain_in;

/// What `load_demos` returns: observations, actions, each row's episode index, episode names.
type Loaded<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Vec<String>,
);

/// load_demos(path, *, task=None, domain=None, tasks=None, cmd_topic=None, odom_topic=None,
/// keep_idle=False) -> (observations, actions, episodes, names)
///
/// The demonstrations of a file, read as `load demos FILE` reads them, whatever the file: a CSV
/// or JSON demonstrations file, a dataset a session saved, a Parquet file of demonstrations, or a
/// ROS 2 bag (a rosbag2 folder or an `.mcap` file) or CSV log of a base's drive, made into
/// demonstrations as `advise import` makes them (`cmd_topic`/`odom_topic` name a bag's topics;
/// idle points are trimmed unless `keep_idle`). The domain is `domain`'s or `task`'s (default
/// positioning); `tasks` are task files (`advise --tasks FILE`) declaring `task`. Returns the
/// observations and actions of every point (episode after episode), each point's episode index,
/// and the episodes' names. Raises AdviseError with the file's diagnostic when it cannot be read.
#[pyfunction]
#[pyo3(signature = (path, *, task=None, domain=None, tasks=None, cmd_topic=None, odom_topic=None, keep_idle=false))]
#[allow(clippy::too_many_arguments)] // Python's keyword arguments, each with its default.
pub fn load_demos<'py>(
    py: Python<'py>,
    path: &str,
    task: Option<&str>,
    domain: Option<&str>,
    tasks: Option<Vec<String>>,
    cmd_topic: Option<String>,
    odom_topic: Option<String>,
    keep_idle: bool,
) -> PyResult<Loaded<'py>> {
    let (domain, def) = match (domain, task, tasks) {
        (Some(d), None, None) => (
            domain_in(py, &OperatorSet::standard(), Some(d), None)?,
            None,
        ),
        (None, task, files) => {
            let kind = task_kind(py, task.unwrap_or("positioning"), files)?;
            (kind.domain(), kind.def())
        }
        _ => {
            return Err(simple(
                py,
                "advise::py::domain_or_task",
                "give `domain=` alone, or `task=` (with `tasks=` for a declared task)".into(),
                "`domain=\"positioning\"`, `task=\"interception\"` or `task=\"dock\", tasks=[\"dock.adv\"]`",
            ));
        }
    };
    let options = ImportOptions {
        cmd_topic,
        odom_topic,
        keep_idle,
        ..ImportOptions::default()
    };
    let mut files = SourceMap::new();
    let read = read_demos_file(
        &mut files,
        &OperatorSet::standard(),
        &domain,
        def.as_ref(),
        path,
        &options,
    )
    .map_err(|e| from_diag(py, &files, &e))?;
    let (mut z, mut a, mut index, mut names) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, e) in read.episodes.iter().enumerate() {
        z.extend_from_slice(&e.trace.z);
        a.extend_from_slice(&e.trace.a);
        index.extend(std::iter::repeat_n(i as i64, e.trace.len()));
        names.push(e.name.clone());
    }
    let n = index.len();
    Ok((
        to_numpy(py, z, n, domain.obs_dim())?,
        to_numpy(py, a, n, domain.act_dim())?,
        index.into_pyarray(py),
        names,
    ))
}

/// The task `name`: a built-in one, or one declared in the task files `files` (checked as
/// `advise --tasks FILE` checks them).
pub fn task_kind(py: Python<'_>, name: &str, files: Option<Vec<String>>) -> PyResult<TaskKind> {
    match files {
        Some(files) => {
            let files: Vec<std::path::PathBuf> = files.into_iter().map(Into::into).collect();
            advise::cli::resolve_task(name, &files).map_err(|r| tasks_error(py, &r))
        }
        None => TaskKind::builtin(name).ok_or_else(|| {
            simple(
                py,
                "advise::py::unknown_task",
                format!("there is no built-in task `{name}`"),
                "the built-in tasks are `positioning` and `interception`; a declared task needs \
                 its file: `tasks=[\"FILE.adv\"]`",
            )
        }),
    }
}

/// The refusal of task files or a task name: a check's errors each with its place (as
/// `advise.check` gives them), anything else as it is.
fn tasks_error(py: Python<'_>, r: &miette::Report) -> PyErr {
    match r.downcast_ref::<Sourced<CheckErrors>>() {
        Some(s) => raise(py, Diagnostic::all_of(&s.sources, &s.error, "error")),
        None => from_diag(py, &SourceMap::new(), r.as_ref()),
    }
}
