//! `advise._advise`: the Python face of advise (issue 38). Thin bindings over the workspace's own
//! APIs: the language's check and interpreter ([`ops`]), the learners ([`learn`]) and the
//! simulator ([`env`]); nothing is computed here that the command line computes elsewhere.
//!
//! Every refusal is an `advise.AdviseError` carrying the `advise::` code of the diagnostic and
//! the diagnostics themselves ([`error`]), never a panic: arrays are checked for shape and
//! finiteness here before they reach code that asserts them.

use pyo3::prelude::*;

mod arrays;
mod dataset;
mod demos;
mod diag;
mod env;
mod error;
mod explain;
mod learn;
mod lerobot;
mod named;
mod ops;
mod session;
mod studies;
mod tools;

/// The module Python imports as `advise._advise` (re-exported by `advise/__init__.py`).
#[pymodule]
fn _advise(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("AdviseError", py.get_type::<error::AdviseError>())?;
    m.add_class::<diag::Diagnostic>()?;
    m.add_class::<diag::Span>()?;
    m.add_function(wrap_pyfunction!(diag::_diagnostic, m)?)?;
    m.add_function(wrap_pyfunction!(diag::_span, m)?)?;
    m.add_function(wrap_pyfunction!(ops::check, m)?)?;
    m.add_class::<ops::Operators>()?;
    m.add_class::<learn::BC>()?;
    m.add_class::<learn::LWR>()?;
    m.add_class::<explain::Critique>()?;
    m.add_class::<explain::Why>()?;
    m.add_class::<explain::Provenance>()?;
    m.add_class::<env::SimEnv>()?;
    m.add_class::<session::Session>()?;
    m.add_function(wrap_pyfunction!(lerobot::load_lerobot, m)?)?;
    m.add_function(wrap_pyfunction!(lerobot::advise_lerobot, m)?)?;
    m.add_function(wrap_pyfunction!(demos::load_demos, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::advise_demos, m)?)?;
    m.add_function(wrap_pyfunction!(tools::fmt, m)?)?;
    m.add_function(wrap_pyfunction!(tools::test, m)?)?;
    m.add_class::<tools::TestResult>()?;
    m.add_function(wrap_pyfunction!(studies::study, m)?)?;
    Ok(())
}
