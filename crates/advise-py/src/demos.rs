//! `advise.load_demos`: a demonstrations file as numpy arrays, read as `load demos FILE` reads it.

use advise::diag::SourceMap;
use advise::recording::ImportOptions;
use advise::session::read_demos_file;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::to_numpy;
use crate::error::from_diag;
use crate::named::{Named, task_files};

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
