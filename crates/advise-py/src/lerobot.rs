//! `advise.load_lerobot` and `advise.advise_lerobot`: LeRobot v3.0 datasets in as numpy arrays,
//! and advice on a chunk of one of their episodes written out as a new LeRobot dataset. The
//! reading and the writing are the application's ([`advise::recording::lerobot_in`],
//! [`advise::recording::lerobot`]); the operator is applied by the interpreter as
//! `Operators.apply` does.

use std::path::Path;

use advise::check::OperatorSet;
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::recording::lerobot_in::{LeRobotRead, LeRobotReadOptions, read_lerobot};
use advise::trace::Trace;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{set_dim_names, to_numpy};
use crate::error::{from_diag, simple};
use crate::named::domain_in;
use crate::ops::{apply_on_chunk, merge};

/// The dataset in `path` as demonstrations of `task`'s domain (an `AdviseError` with the
/// `advise::lerobot::*` diagnostic if it cannot be).
fn read(
    py: Python<'_>,
    set: &OperatorSet,
    path: &str,
    task: &str,
    by_position: bool,
) -> PyResult<(Domain, LeRobotRead)> {
    let domain = domain_in(py, set, None, Some(task))?;
    let options = LeRobotReadOptions { by_position };
    let read = py
        .detach(|| read_lerobot(Path::new(path), &domain, &options))
        .map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
    Ok((domain, read))
}

/// load_lerobot(path, task="positioning", *, by_position=False, tasks=()) -> dict
///
/// Read the LeRobot v3.0 dataset in directory `path` as demonstrations of `task`'s domain, as
/// `advise import --lerobot` does: its `observation.state` and `action` mapped to the domain's
/// dimensions by their names in `meta/info.json` (or position by position with `by_position`,
/// or when they have no names). Returns a dict of numpy arrays, one row per frame, episodes in
/// `episode_index` order and frames in `frame_index` order: `observations` (n, observation
/// dimensions), `actions` (n, action dimensions), `episode_index` and `frame_index` (n,) int64,
/// `timestamp` (n,); and `fps`, `domain`, `observation_names`, `action_names`, `mapping` (how
/// the values were mapped) and `path`. Raises AdviseError (`advise::lerobot::*`) when the widths
/// or names disagree, a file is missing, a column has the wrong type or a value is not finite.
/// `tasks` are task files declaring `task` (`advise import --lerobot DIR --tasks FILE`).
#[pyfunction]
#[pyo3(signature = (path, task = "positioning", *, by_position = false, tasks = Vec::new()))]
pub fn load_lerobot<'py>(
    py: Python<'py>,
    path: &str,
    task: &str,
    by_position: bool,
    tasks: Vec<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let (set, _warnings) = merge(py, &OperatorSet::standard(), &tasks)?;
    let (domain, read) = read(py, &set, path, task, by_position)?;
    let n = read.episode_index.len();
    let (mut z, mut a, mut t) = (Vec::new(), Vec::new(), Vec::new());
    for e in &read.episodes {
        z.extend_from_slice(&e.trace.z);
        a.extend_from_slice(&e.trace.a);
        t.extend_from_slice(&e.trace.t);
    }
    let out = PyDict::new(py);
    out.set_item("observations", to_numpy(py, z, n, domain.obs_dim())?)?;
    out.set_item("actions", to_numpy(py, a, n, domain.act_dim())?)?;
    out.set_item("episode_index", read.episode_index.into_pyarray(py))?;
    out.set_item("frame_index", read.frame_index.into_pyarray(py))?;
    out.set_item("timestamp", t.into_pyarray(py))?;
    out.set_item("fps", read.fps)?;
    out.set_item("domain", &domain.name)?;
    set_dim_names(&out, &domain)?;
    out.set_item("mapping", read.mapping)?;
    out.set_item("path", path)?;
    Ok(out)
}

/// The episode of `read` whose `episode_index` is `episode`.
fn episode_of<'a>(py: Python<'_>, read: &'a LeRobotRead, episode: i64) -> PyResult<&'a Trace> {
    match read.episode_ids.iter().position(|&e| e == episode) {
        Some(k) => Ok(&read.episodes[k].trace),
        None => Err(simple(
            py,
            "advise::lerobot::no_episode",
            format!(
                "the dataset has no episode {episode} (its episodes are {})",
                match (read.episode_ids.first(), read.episode_ids.last()) {
                    (Some(a), Some(b)) => format!("{a} to {b}"),
                    _ => "none".into(),
                }
            ),
            "give an `episode_index` of the dataset",
        )),
    }
}

/// `fps=`: None, or a whole number of frames per second from 1 to 1000 (`advise::py::fps`
/// otherwise: 0 is not made 1, nor 29.97 made 29).
fn fps_of(py: Python<'_>, fps: Option<&Bound<'_, PyAny>>) -> PyResult<Option<u32>> {
    let Some(f) = fps.filter(|f| !f.is_none()) else {
        return Ok(None);
    };
    let whole = f
        .extract::<i64>()
        .ok()
        .filter(|_| f.cast::<pyo3::types::PyBool>().is_err());
    match whole
        .and_then(|v| u32::try_from(v).ok())
        .filter(|v| (1..=1000).contains(v))
    {
        Some(v) => Ok(Some(v)),
        None => Err(simple(
            py,
            "advise::py::fps",
            format!(
                "`fps` is {}, not a whole number of frames per second from 1 to 1000",
                f.repr().map_or_else(|_| "?".into(), |r| r.to_string())
            ),
            "give the dataset's frame rate (`fps=30`), or leave it out to keep the source's",
        )),
    }
}

/// advise_lerobot(src, out, *, episode, frames, operator, params, task="positioning",
/// operators=(), by_position=False, fps=None, tasks=()) -> dict
///
/// Apply `operator` with `params` (a dict of numbers) to the frames `frames` = (start, end) of
/// episode `episode` (its `episode_index`) of the LeRobot v3.0 dataset `src`, and write the
/// corrected episode as a new LeRobot v3.0 dataset in the new directory `out`: its frames before
/// `start` and from `end` on unchanged (`advise.source` = `demonstration`), the chunk replaced by
/// the operator's synthesized points (`advise.source` = `advice`; a point the operator's guard
/// skipped is dropped). `meta/info.json`'s `advise.provenance` says the source dataset, episode,
/// frames, operator, parameters and the invocation. `operators` are files of operators checked
/// on top of the standard ones, `tasks` task files declaring `task`. Returns a summary dict:
/// `path`, `frames`, `kept`, `synthesized`, `skipped`, `invocation`.
#[pyfunction]
#[pyo3(signature = (src, out, *, episode, frames, operator, params, task = "positioning", operators = Vec::new(), by_position = false, fps = None, tasks = Vec::new()))]
#[allow(clippy::too_many_arguments)]
pub fn advise_lerobot<'py>(
    py: Python<'py>,
    src: &str,
    out: &str,
    episode: i64,
    frames: (usize, usize),
    operator: &str,
    params: &Bound<'py, PyDict>,
    task: &str,
    operators: Vec<String>,
    by_position: bool,
    fps: Option<&Bound<'py, PyAny>>,
    tasks: Vec<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let fps = fps_of(py, fps)?;
    let files: Vec<String> = tasks.into_iter().chain(operators).collect();
    let (set, _warnings) = merge(py, &OperatorSet::standard(), &files)?;
    let (domain, read) = read(py, &set, src, task, by_position)?;
    let trace = episode_of(py, &read, episode)?;
    let (applied, chunk) = apply_on_chunk(py, &set, &domain, operator, params, trace, frames)?;
    // The corrected episode: the frames before the chunk, the synthesized points, the frames
    // after it. Times are the dataset's (the export writes `frame_index / fps`).
    let mut corrected = Trace::new(&domain);
    for i in 0..chunk.start {
        corrected.push(trace.t[i], trace.z(i), trace.a(i), None);
    }
    for (k, &i) in applied.source_index.iter().enumerate() {
        corrected.push(trace.t[i], applied.points.z(k), applied.points.a(k), None);
    }
    for i in chunk.end..trace.len() {
        corrected.push(trace.t[i], trace.z(i), trace.a(i), None);
    }
    let synthesized = applied.source_index.len();
    let mut sources = vec!["demonstration"; chunk.start];
    sources.extend(vec!["advice"; synthesized]);
    sources.extend(vec!["demonstration"; trace.len() - chunk.end]);
    let invocation_text = applied.advice.invocation();
    let params_json: serde_json::Value = serde_json::from_str(
        &py.import("json")?
            .call_method1("dumps", (params,))?
            .extract::<String>()?,
    )
    .unwrap_or(serde_json::Value::Null);
    let provenance = serde_json::json!({
        "source": src,
        "episode_index": episode,
        "frames": [chunk.start, chunk.end],
        "operator": operator,
        "params": params_json,
        "invocation": invocation_text,
        "kept": "frames outside `frames` are the source episode's, unchanged (`advise.source` = `demonstration`)",
    });
    let fps = fps.unwrap_or_else(|| read.fps.round().clamp(1.0, 1000.0) as u32);
    let name = format!(
        "episode {episode}, frames {}..{}: {invocation_text}",
        chunk.start, chunk.end
    );
    let len = corrected.len();
    let summary = py
        .detach(|| {
            advise::recording::lerobot::export_corrected_episode(
                &domain,
                name,
                corrected,
                sources,
                Path::new(out),
                fps,
                provenance,
            )
        })
        .map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
    let reply = PyDict::new(py);
    reply.set_item("path", out)?;
    reply.set_item("frames", summary.frames)?;
    reply.set_item("kept", len - synthesized)?;
    reply.set_item("synthesized", synthesized)?;
    reply.set_item("skipped", chunk.len() - synthesized)?;
    reply.set_item("invocation", invocation_text)?;
    Ok(reply)
}
