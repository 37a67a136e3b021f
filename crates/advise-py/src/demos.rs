//! `advise.load_demos`: a demonstrations file as numpy arrays, read as `load demos FILE` reads it.

use std::path::PathBuf;
use std::sync::Arc;

use advise::check::OperatorSet;
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::program::task::TaskDef;
use advise::recording::ImportOptions;
use advise::session::read_demos_file;
use advise::task::{Front, TaskKind};
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
/// positioning); `tasks` is a task file or a list of them (`advise --tasks FILE`) declaring
/// `task`. Returns the observations and actions of every point (episode after episode), each
/// point's episode index, and the episodes' names. Raises AdviseError with the file's diagnostic
/// when it cannot be read.
#[pyfunction]
#[pyo3(signature = (path, *, task=None, domain=None, tasks=None, cmd_topic=None, odom_topic=None, keep_idle=false))]
#[allow(clippy::too_many_arguments)] // Python's keyword arguments, each with its default.
pub fn load_demos<'py>(
    py: Python<'py>,
    path: &str,
    task: Option<&str>,
    domain: Option<&str>,
    tasks: Option<&Bound<'py, PyAny>>,
    cmd_topic: Option<String>,
    odom_topic: Option<String>,
    keep_idle: bool,
) -> PyResult<Loaded<'py>> {
    let files = task_files(py, tasks)?;
    let named = Named::new(py, domain, task, &files, Some("positioning"))?;
    let domain = named.domain;
    let options = ImportOptions {
        cmd_topic,
        odom_topic,
        keep_idle,
        ..ImportOptions::default()
    };
    let mut files = SourceMap::new();
    let read = read_demos_file(
        &mut files,
        &named.set,
        &domain,
        named.def.as_ref(),
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
