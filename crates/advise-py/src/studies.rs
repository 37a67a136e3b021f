//! `advise.study`: the paper's studies as plain functions of a seed and the command line's
//! parameters, returning the data `advise experiment STUDY --seed SEED --json` prints (the same
//! function runs them), so a sweep over seeds can be mapped by any engine (Ray, Dask, a pool).

use advise::choice::Choice;
use pyo3::prelude::*;

use crate::error::simple;

/// `name` as one of `T`'s values, or an `AdviseError` coded `code` listing them.
fn parse<T: Choice>(py: Python<'_>, name: &str, what: &str) -> PyResult<T> {
    T::parse(name).ok_or_else(|| {
        simple(
            py,
            "advise::py::bad_argument",
            format!("`{name}` is not a {what}"),
            &format!("the {what}s are {}", T::names()),
        )
    })
}

/// study(study, seed, *, revert=None, critique=None, teacher=None, sim_params=None, practice=None) -> dict
///
/// Run one seed of `study` (`"bc"` or `"aopi"`) on the simulator and return the data that
/// `advise experiment STUDY --seed SEED --json` prints, as Python objects. `revert` puts one of
/// the protocol's choices back (`--revert`), `critique` picks the BC study's rules
/// (`--critique`), `teacher` its teachers' arms (`"controller"`, `"hand"` or `"both"`,
/// `--teacher`), `sim_params` is a simulator parameters file (`--sim-params`), `practice` caps
/// the A-OPI arms' practice goals (`--practice`, 1 to 1000). Runs without the GIL.
// Each argument is one of `advise experiment`'s options, as Python's keywords.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (study, seed, *, revert=None, critique=None, teacher=None, sim_params=None, practice=None))]
pub fn study<'py>(
    py: Python<'py>,
    study: &str,
    seed: u64,
    revert: Option<&str>,
    critique: Option<&str>,
    teacher: Option<&str>,
    sim_params: Option<std::path::PathBuf>,
    practice: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    use advise::experiment::{ablation::Revert, bc::Rules, bc::Teachers, study as s};
    let which: s::Study = parse(py, study, "study")?;
    let revert: Option<Revert> = revert
        .map(|r| parse(py, r, "protocol choice to revert"))
        .transpose()?;
    if let Some(choice) = revert
        && !choice.affects(which)
    {
        return Err(simple(
            py,
            "advise::py::bad_argument",
            format!(
                "the {study} study has no choice `{}` to revert",
                choice.name()
            ),
            "see `advise experiment --help` for each study's choices",
        ));
    }
    let rules = match (which, critique) {
        (s::Study::Bc, Some(c)) => parse(py, c, "critique rule")?,
        (s::Study::Bc, None) => Rules::default(),
        (s::Study::Aopi, Some(_)) => {
            return Err(simple(
                py,
                "advise::py::bad_argument",
                "`critique` is the BC study's".into(),
                "leave it out for the A-OPI study",
            ));
        }
        (s::Study::Aopi, None) => Rules::default(),
    };
    let teachers: Teachers = match (which, teacher) {
        (s::Study::Bc, Some(t)) => parse(py, t, "teacher arm")?,
        (s::Study::Aopi, Some(_)) => {
            return Err(simple(
                py,
                "advise::py::bad_argument",
                "`teacher` is the BC study's".into(),
                "leave it out for the A-OPI study",
            ));
        }
        (_, None) => Teachers::default(),
    };
    match (which, practice) {
        (s::Study::Bc, Some(_)) => {
            return Err(simple(
                py,
                "advise::py::bad_argument",
                "`practice` caps the A-OPI study's arms".into(),
                "leave it out for the BC study",
            ));
        }
        (_, Some(n)) if !(1..=1000).contains(&n) => {
            return Err(simple(
                py,
                "advise::py::bad_argument",
                format!("`practice` is {n}"),
                "give 1 to 1000 practice goals per arm",
            ));
        }
        _ => {}
    }
    let mut files = advise::diag::SourceMap::new();
    let sim = advise::experiment::sim_params(&mut files, sim_params.as_deref())
        .map_err(|e| crate::error::from_diag(py, &files, &e))?;
    let out = py
        .detach(|| {
            s::run(
                which,
                &s::Seeds::One(seed),
                sim,
                s::BcChoices {
                    critique: rules,
                    teachers,
                },
                revert,
                practice,
                None,
                false,
            )
        })
        .map_err(|e| crate::error::from_diag(py, &advise::diag::SourceMap::new(), &e))?;
    py.import("json")?.call_method1("loads", (out.json,))
}
