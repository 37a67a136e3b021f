//! `advise.check` and `advise.Operators`: the language's check and interpreter on numpy arrays.

use std::path::Path;

use advise::check::{Checked, OperatorSet};
use advise::diag::{SourceId, SourceMap};
use advise::domain::Domain;
use advise::trace::{Chunk, Trace};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};

use crate::arrays::{matrix, to_numpy};
use crate::diag::Diagnostic;
use crate::error::{from_diag, raise, simple};

/// `path_or_text` as a source of `map`: an existing file is read (with the files' rules: regular,
/// capped, UTF-8); text that looks like a path ([`looks_like_path`]) but names no file is refused
/// with `advise::py::no_such_file`; anything else is operator text named `<text>`.
pub(crate) fn source(
    py: Python<'_>,
    map: &mut SourceMap,
    path_or_text: &str,
) -> PyResult<SourceId> {
    let path = Path::new(path_or_text);
    if !path_or_text.contains('\n') && path.exists() {
        advise::files::read_source(map, path).map_err(|e| from_diag(py, map, &e))
    } else if looks_like_path(path_or_text) {
        Err(no_such_file(py, path_or_text))
    } else {
        Ok(map.add("<text>", path_or_text))
    }
}

/// Whether `s` is meant as a file's path rather than operator text: one line, no `{` (every
/// operator and domain written on one line has a block or a `=`) and no `=`, and either ending in
/// `.adv` or holding a path separator.
fn looks_like_path(s: &str) -> bool {
    let s = s.trim();
    !s.is_empty()
        && !s.contains(['\n', '{', '='])
        && (s.ends_with(".adv") || s.contains('/') || s.contains(std::path::MAIN_SEPARATOR))
}

/// `advise::py::no_such_file`: `path` names no file, said with where a relative path is read from.
fn no_such_file(py: Python<'_>, path: &str) -> PyErr {
    let here = std::env::current_dir()
        .map(|d| d.display().to_string())
        .unwrap_or_else(|_| "the working directory".into());
    let standard = advise::check::STANDARD_SOURCES
        .iter()
        .any(|(name, _)| Path::new(path).ends_with(name));
    let help = if standard {
        format!(
            "a relative path is read from the working directory, {here}; the standard operators \
             (`{path}`) are built in and always checked under yours: `advise.Operators()` holds \
             them, `advise.check(\"my_ops.adv\")` checks a file of your own on top of them"
        )
    } else {
        format!(
            "a relative path is read from the working directory, {here}: give the file's full \
             path, or pass the operator text itself (several lines, or one with its `{{ ... }}`)"
        )
    };
    simple(
        py,
        "advise::py::no_such_file",
        format!("there is no file `{path}`"),
        &help,
    )
}

/// Check `sources` (files or texts) on top of `base`, every task they declare given the standard
/// operators by role as a session's `tasks FILE` gives them
/// ([`OperatorSet::merge_declaring`]); the warnings, or an `AdviseError` with every error.
pub(crate) fn merge(
    py: Python<'_>,
    base: &OperatorSet,
    sources: &[String],
) -> PyResult<(OperatorSet, Vec<Diagnostic>)> {
    let mut map = SourceMap::new();
    let ids = sources
        .iter()
        .map(|s| source(py, &mut map, s))
        .collect::<PyResult<Vec<_>>>()?;
    match base.merge_declaring(&mut map, &ids) {
        Ok(Checked { set, warnings }) => {
            let w = warnings
                .iter()
                .map(|w| Diagnostic::of(&map, w, "warning"))
                .collect();
            Ok((set, w))
        }
        Err(errors) => Err(raise(py, Diagnostic::all_of(&map, &errors, "error"))),
    }
}

/// check(path_or_text) -> list[Diagnostic]
///
/// Check an operator file (a path) or operator text on top of the standard operators, as
/// `advise check FILE` does. Returns the warnings; raises AdviseError with every error.
#[pyfunction]
pub fn check(py: Python<'_>, path_or_text: &str) -> PyResult<Vec<Diagnostic>> {
    merge(py, &OperatorSet::standard(), &[path_or_text.to_string()]).map(|(_, w)| w)
}

/// What `apply` returns: the synthesized observations and actions, and the skipped mask.
type Applied<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<bool>>,
);

/// A checked set of advice operators: the standard ones plus those of the given files or texts.
#[pyclass(module = "advise", frozen)]
pub struct Operators {
    set: OperatorSet,
    warnings: Vec<Diagnostic>,
}

#[pymethods]
impl Operators {
    /// `Operators(*files, tasks=None)`: the standard operators, then `tasks` (a task file or a
    /// list of them) and `files` (operator files or texts), each task they declare with the
    /// standard operators by role, as `advise check --tasks TASKS FILES` checks them.
    #[new]
    #[pyo3(signature = (*files, tasks=None))]
    fn new(
        py: Python<'_>,
        files: Vec<String>,
        tasks: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Operators> {
        let mut sources: Vec<String> = crate::named::task_files(py, tasks)?
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        sources.extend(files);
        let (set, warnings) = merge(py, &OperatorSet::standard(), &sources)?;
        Ok(Operators { set, warnings })
    }

    /// The warnings the check of the files gave.
    #[getter]
    fn warnings(&self) -> Vec<Diagnostic> {
        self.warnings.clone()
    }

    /// The names of the domains the set declares.
    fn domains(&self) -> Vec<String> {
        self.set.domains().iter().map(|d| d.name.clone()).collect()
    }

    /// The names of the tasks the set knows: the built-in two, then those its files declare.
    fn tasks(&self) -> Vec<String> {
        advise::task::task_names(&self.set)
    }

    /// The names of the operators of `domain`.
    fn names(&self, py: Python<'_>, domain: &str) -> PyResult<Vec<String>> {
        self.domain_of(py, Some(domain), None)?;
        Ok(self
            .set
            .operator_names(domain)
            .into_iter()
            .map(String::from)
            .collect())
    }

    /// apply(name, args, observations, actions, *, domain=None, task=None, chunk=None, times=None)
    /// -> (observations, actions, skipped)
    ///
    /// Apply operator `name` with `args` (a dict of parameter values) to the points of `chunk`
    /// (a (start, end) pair, default all) of a trace. Returns the synthesized observations and
    /// actions (one row per point not skipped) and a boolean mask over the chunk, True where the
    /// operator's guard skipped the point.
    #[pyo3(signature = (name, args, observations, actions, *, domain=None, task=None, chunk=None, times=None))]
    #[allow(clippy::too_many_arguments)]
    fn apply<'py>(
        &self,
        py: Python<'py>,
        name: &str,
        args: &Bound<'py, PyDict>,
        observations: &Bound<'py, PyAny>,
        actions: &Bound<'py, PyAny>,
        domain: Option<&str>,
        task: Option<&str>,
        chunk: Option<(usize, usize)>,
        times: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Applied<'py>> {
        let domain = self.domain_of(py, domain, task)?;
        let trace = trace_of(py, &domain, observations, actions, times)?;
        let frames = chunk.unwrap_or((0, trace.len()));
        let (out, chunk) = apply_on_chunk(py, &self.set, &domain, name, args, &trace, frames)?;
        let mut skipped = vec![true; chunk.len()];
        for &i in &out.source_index {
            skipped[i - chunk.start] = false;
        }
        let n = out.points.len();
        Ok((
            to_numpy(py, out.points.z, n, domain.obs_dim())?,
            to_numpy(py, out.points.a, n, domain.act_dim())?,
            skipped.into_pyarray(py),
        ))
    }
}

impl Operators {
    /// The domain named `domain`, or the domain of task `task` (exactly one of them).
    fn domain_of(
        &self,
        py: Python<'_>,
        domain: Option<&str>,
        task: Option<&str>,
    ) -> PyResult<Domain> {
        crate::named::domain_in(py, &self.set, domain, task)
    }
}

/// A trace of `domain` from arrays of observations and actions (and times: by default the point
/// index times the simulator's control period).
pub fn trace_of(
    py: Python<'_>,
    domain: &Domain,
    observations: &Bound<'_, PyAny>,
    actions: &Bound<'_, PyAny>,
    times: Option<&Bound<'_, PyAny>>,
) -> PyResult<Trace> {
    let (z, n) = matrix(py, observations, "observations", Some(domain.obs_dim()))?;
    let (a, m) = matrix(py, actions, "actions", Some(domain.act_dim()))?;
    if n != m {
        return Err(simple(
            py,
            "advise::py::shape",
            format!("{n} rows of observations but {m} rows of actions"),
            "one action per observation",
        ));
    }
    let t = match times {
        Some(t) => {
            let np = py.import("numpy")?;
            let col = np.call_method1("reshape", (t, (-1, 1)))?;
            let (t, k) = matrix(py, &col, "times", Some(1))?;
            if k != n {
                return Err(simple(
                    py,
                    "advise::py::shape",
                    format!("{k} times for {n} points"),
                    "one time per point",
                ));
            }
            if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
                return Err(simple(
                    py,
                    "advise::trace::time_backwards",
                    format!("time does not increase at point {}", i + 1),
                    "times must strictly increase within a trace",
                ));
            }
            t
        }
        None => {
            let dt = advise::backend::sim::SimParams::default().period_s();
            (0..n).map(|i| i as f64 * dt).collect()
        }
    };
    let mut trace = Trace::new(domain);
    for i in 0..n {
        let (od, ad) = (domain.obs_dim(), domain.act_dim());
        trace.push(
            t[i],
            &z[i * od..(i + 1) * od],
            &a[i * ad..(i + 1) * ad],
            None,
        );
    }
    Ok(trace)
}

/// The invocation text `name(k = v, ...)` for a dict of numbers and booleans; numbers are written
/// so that they read back as the same float.
/// `operator` with `params` (a dict of numbers) applied by the interpreter to the points
/// `frames` = (start, end) of `trace`, as `Operators.apply` and the REPL's `advise` apply it:
/// the synthesized points (each with the trace's point it came from) and the chunk.
pub(crate) fn apply_on_chunk(
    py: Python<'_>,
    set: &OperatorSet,
    domain: &Domain,
    operator: &str,
    params: &Bound<'_, PyDict>,
    trace: &Trace,
    frames: (usize, usize),
) -> PyResult<(advise::interp::Synthesized, Chunk)> {
    let chunk = Chunk::new(frames.0, frames.1, trace.len())
        .map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
    let text = invocation(py, operator, params)?;
    let inv =
        advise::syntax::parse_invocation(&text).map_err(|e| from_diag(py, &e.sources, &e.error))?;
    let mut files = SourceMap::new();
    let call = advise::check::bind(&mut files, set, &domain.name, &inv)
        .map_err(|e| from_diag(py, &files, &e))?;
    let applied = py
        .detach(|| advise::interp::apply(&call, trace, chunk))
        .map_err(|e| from_diag(py, &files, &e))?;
    Ok((applied, chunk))
}

pub(crate) fn invocation(py: Python<'_>, name: &str, args: &Bound<'_, PyDict>) -> PyResult<String> {
    let mut parts = Vec::new();
    for (k, v) in args.iter() {
        let k: String = k.extract().map_err(|_| {
            simple(
                py,
                "advise::py::bad_argument",
                "argument names must be strings".into(),
                "`{\"rate\": 0.3}`",
            )
        })?;
        let text = if v.is_instance_of::<PyBool>() {
            v.extract::<bool>()?.to_string()
        } else if v.is_instance_of::<PyInt>() || v.is_instance_of::<PyFloat>() {
            let x: f64 = v.extract()?;
            if !x.is_finite() {
                return Err(simple(
                    py,
                    "advise::py::not_finite",
                    format!("argument `{k}` is {x}"),
                    "arguments must be finite numbers",
                ));
            }
            format!("{x:?}")
        } else if v.is_instance_of::<PyString>() {
            v.extract::<String>()?
        } else {
            return Err(simple(
                py,
                "advise::py::bad_argument",
                format!("argument `{k}` is not a number"),
                "operator arguments are numbers (or booleans)",
            ));
        };
        parts.push(format!("{k} = {text}"));
    }
    Ok(format!("{name}({})", parts.join(", ")))
}
