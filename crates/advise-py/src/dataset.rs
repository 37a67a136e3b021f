//! The dataset with its provenance out as numpy arrays (`BC.dataset()`, `LWR.dataset()`), and
//! `advise.advise_demos`: advice on a chunk of one episode of any demonstrations file, written
//! next to the original as a saved dataset that says where every point came from.

use std::path::Path;

use advise::diag::SourceMap;
use advise::policy::dataset::{Dataset, Provenance};
use advise::recording::ImportOptions;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::arrays::{set_dim_names, str_array, to_numpy};
use crate::error::{from_diag, simple};
use crate::named::{task_files, task_in};
use crate::ops::{apply_on_chunk, merge};

/// The points of `ds` with their provenance and weights, as a dict of numpy arrays (see the
/// learners' `dataset()`).
pub fn dataset_dict<'py>(py: Python<'py>, ds: &Dataset) -> PyResult<Bound<'py, PyDict>> {
    let domain = ds.domain();
    let n = ds.len();
    let (mut z, mut a) = (Vec::with_capacity(n * domain.obs_dim()), Vec::new());
    let (mut source, mut source_id, mut index, mut from) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for i in 0..n {
        z.extend_from_slice(ds.z(i));
        a.extend_from_slice(ds.a(i));
        match ds.provenance(i) {
            Provenance::Demonstration { demo, index: k } => {
                source.push("demonstration");
                source_id.push(i64::from(demo));
                index.push(i64::from(k));
                from.push(-1);
            }
            Provenance::Advice {
                advice,
                index: k,
                source: s,
            } => {
                source.push("advice");
                source_id.push(i64::from(advice));
                index.push(i64::from(k));
                from.push(i64::from(s));
            }
        }
    }
    let d = PyDict::new(py);
    d.set_item("observations", to_numpy(py, z, n, domain.obs_dim())?)?;
    d.set_item("actions", to_numpy(py, a, n, domain.act_dim())?)?;
    d.set_item("weights", ds.weights().into_pyarray(py))?;
    d.set_item("source", str_array(py, source)?)?;
    d.set_item("source_id", source_id.into_pyarray(py))?;
    d.set_item("index", index.into_pyarray(py))?;
    d.set_item("execution_index", from.into_pyarray(py))?;
    let demos = PyList::empty(py);
    for r in ds.demos() {
        let e = PyDict::new(py);
        e.set_item("id", r.id)?;
        e.set_item("name", &r.name)?;
        e.set_item("points", r.points)?;
        demos.append(e)?;
    }
    d.set_item("demonstrations", demos)?;
    let advice = PyList::empty(py);
    for r in ds.advice() {
        let e = PyDict::new(py);
        e.set_item("id", r.id)?;
        e.set_item("execution", r.execution)?;
        e.set_item("operator", &r.applied.operator)?;
        e.set_item("invocation", r.applied.invocation())?;
        e.set_item("chunk", (r.applied.chunk.start, r.applied.chunk.end))?;
        advice.append(e)?;
    }
    d.set_item("advice", advice)?;
    d.set_item("domain", &domain.name)?;
    set_dim_names(&d, domain)?;
    Ok(d)
}

/// advise_demos(src, out, *, episode, frames, operator, params, task="positioning", tasks=None,
/// operators=(), cmd_topic=None, odom_topic=None) -> dict
///
/// Apply `operator` with `params` (a dict of numbers) to the points `frames` = (start, end) of
/// one episode of any demonstrations file `advise.load_demos` reads (CSV, JSON, Parquet, a saved
/// dataset, a ROS 2 bag or CSV log), `episode` being its index in the file or its name, and write
/// the result next to the original as a saved dataset in `out` (`.json`, what a session's `save`
/// writes, with provenance; `.csv` keeps the points and their source only): every episode of
/// `src` as a demonstration, the advised episode as the execution the advice was given on, and
/// the synthesized points as that advice (its operator, parameters, chunk and definition).
/// `load demos OUT` and `open OUT` read it back; `src` is never changed. `operators` are files of
/// operators checked on top of the standard ones. Returns a summary dict: `path`, `episode`
/// (its name), `demonstrations`, `synthesized`, `skipped`, `invocation`, and the corrected
/// episode as arrays (`observations`, `actions`, `source`: the points before the chunk, the
/// synthesized ones, the points after it).
#[pyfunction]
#[pyo3(signature = (src, out, *, episode, frames, operator, params, task = "positioning", tasks = None, operators = Vec::new(), cmd_topic = None, odom_topic = None))]
#[allow(clippy::too_many_arguments)] // Python's keyword arguments, each with its default.
pub fn advise_demos<'py>(
    py: Python<'py>,
    src: &str,
    out: &str,
    episode: &Bound<'py, PyAny>,
    frames: (usize, usize),
    operator: &str,
    params: &Bound<'py, PyDict>,
    task: &str,
    tasks: Option<&Bound<'py, PyAny>>,
    operators: Vec<String>,
    cmd_topic: Option<String>,
    odom_topic: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut inputs = vec![Path::new(src).to_path_buf()];
    if let Ok(entries) = std::fs::read_dir(src) {
        inputs.extend(entries.flatten().take(10_000).map(|e| e.path()));
    }
    advise::files::refuse_overwriting_inputs(Path::new(out), inputs.iter().map(|p| p.as_path()))
        .map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
    let files = task_files(py, tasks)?;
    let (kind, set) = task_in(py, task, &files)?;
    let (set, _warnings) = merge(py, &set, &operators)?;
    let domain = kind.domain();
    let options = ImportOptions {
        cmd_topic,
        odom_topic,
        ..ImportOptions::default()
    };
    let mut files = SourceMap::new();
    let read = advise::session::read_demos_file(
        &mut files,
        &set,
        &domain,
        kind.def().as_ref(),
        src,
        &options,
    )
    .map_err(|e| from_diag(py, &files, &e))?;
    let k = episode_index(py, &read.episodes, episode)?;
    let trace = &read.episodes[k].trace;
    let (applied, chunk) = apply_on_chunk(py, &set, &domain, operator, params, trace, frames)?;
    let mut ds = Dataset::new(&domain);
    let saved = py.detach(|| -> Result<_, advise::policy::dataset::DatasetError> {
        for e in &read.episodes {
            ds.add_demonstration(&e.name, &e.trace)?;
        }
        let execution = ds.add_execution(trace)?;
        ds.add_advice(
            execution,
            applied.advice.clone(),
            &applied.points,
            &applied.source_index,
        )?;
        ds.save(Path::new(out))
    });
    saved.map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
    // The corrected episode, as advise_lerobot writes it: the points before the chunk, the
    // synthesized ones, the points after it.
    let (od, ad) = (domain.obs_dim(), domain.act_dim());
    let (mut z, mut a, mut source) = (Vec::new(), Vec::new(), Vec::new());
    let mut push = |zi: &[f64], ai: &[f64], from: &'static str| {
        z.extend_from_slice(zi);
        a.extend_from_slice(ai);
        source.push(from);
    };
    for i in 0..chunk.start {
        push(trace.z(i), trace.a(i), "demonstration");
    }
    let synthesized = applied.source_index.len();
    for j in 0..synthesized {
        push(applied.points.z(j), applied.points.a(j), "advice");
    }
    for i in chunk.end..trace.len() {
        push(trace.z(i), trace.a(i), "demonstration");
    }
    let n = source.len();
    let reply = PyDict::new(py);
    reply.set_item("path", out)?;
    reply.set_item("episode", &read.episodes[k].name)?;
    reply.set_item("demonstrations", read.episodes.len())?;
    reply.set_item("synthesized", synthesized)?;
    reply.set_item("skipped", chunk.len() - synthesized)?;
    reply.set_item("invocation", applied.advice.invocation())?;
    reply.set_item("observations", to_numpy(py, z, n, od)?)?;
    reply.set_item("actions", to_numpy(py, a, n, ad)?)?;
    reply.set_item("source", str_array(py, source)?)?;
    Ok(reply)
}

/// The index of the episode `episode` names: an index into `episodes`, or an episode's name.
fn episode_index(
    py: Python<'_>,
    episodes: &[advise::trace::Episode],
    episode: &Bound<'_, PyAny>,
) -> PyResult<usize> {
    let names = || {
        let shown: Vec<&str> = episodes.iter().take(8).map(|e| e.name.as_str()).collect();
        format!(
            "the file holds {} episode{} (indices 0..{}): {}{}",
            episodes.len(),
            if episodes.len() == 1 { "" } else { "s" },
            episodes.len(),
            shown.join(", "),
            if episodes.len() > 8 { ", ..." } else { "" }
        )
    };
    let found = if let Ok(i) = episode.extract::<i64>() {
        usize::try_from(i).ok().filter(|&i| i < episodes.len())
    } else if let Ok(name) = episode.extract::<String>() {
        episodes.iter().position(|e| e.name == name)
    } else {
        return Err(simple(
            py,
            "advise::py::bad_argument",
            "`episode` is neither an index nor a name".into(),
            &names(),
        ));
    };
    found.ok_or_else(|| {
        simple(
            py,
            "advise::py::no_such_episode",
            format!("there is no episode {episode}"),
            &names(),
        )
    })
}
