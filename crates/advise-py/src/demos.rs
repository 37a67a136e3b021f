//! `advise.load_demos`: a demonstrations file as numpy arrays, read as `load demos FILE` reads it.

use std::path::Path;

use advise::check::OperatorSet;
use advise::diag::SourceMap;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::to_numpy;
use crate::error::from_diag;
use crate::ops::domain_in;

/// What `load_demos` returns: observations, actions, each row's episode index, episode names.
type Loaded<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Vec<String>,
);

/// load_demos(path, *, task=None, domain=None) -> (observations, actions, episodes, names)
///
/// The demonstrations of a file (CSV or JSON demonstrations, or a dataset a session saved), read
/// as `load demos FILE` reads them for the domain named `domain` or that of `task` (default
/// positioning). Returns the observations and actions of every point (episode after episode),
/// each point's episode index, and the episodes' names. Raises AdviseError with the file's
/// diagnostic when it cannot be read.
#[pyfunction]
#[pyo3(signature = (path, *, task=None, domain=None))]
pub fn load_demos<'py>(
    py: Python<'py>,
    path: &str,
    task: Option<&str>,
    domain: Option<&str>,
) -> PyResult<Loaded<'py>> {
    let task = if domain.is_none() && task.is_none() {
        Some("positioning")
    } else {
        task
    };
    let domain = domain_in(py, &OperatorSet::standard(), domain, task)?;
    let mut files = SourceMap::new();
    let demos = advise::policy::dataset::load_demonstrations(&mut files, &domain, Path::new(path))
        .map_err(|e| from_diag(py, &files, &e))?;
    let (mut z, mut a, mut index, mut names) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, e) in demos.episodes.iter().enumerate() {
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
