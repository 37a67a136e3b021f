//! `advise.AdviseError`: every refusal of the package, with its `advise::` code and diagnostics.

use advise::diag::SourceMap;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

use crate::diag::Diagnostic;

// Named `advise.AdviseError` (the package re-exports it there), so `pickle` finds the class by
// its module and name: an error raised in a `multiprocessing` worker arrives whole, its `code`
// and `diagnostics` with it (they are the instance's `__dict__`, which pickling keeps).
create_exception!(
    advise,
    AdviseError,
    PyException,
    "A refusal of advise: `code` is the first diagnostic's `advise::` code, `diagnostics` all of them (advise.Diagnostic)."
);

/// An `AdviseError` for the diagnostics `diags` (at least one): its text is the first one's
/// rendering, `code` its code.
pub fn raise(py: Python<'_>, diags: Vec<Diagnostic>) -> PyErr {
    let first = diags.first().cloned().unwrap_or_else(|| {
        Diagnostic::plain("advise::py::unknown", "an error without diagnostics", None)
    });
    let err = AdviseError::new_err(first.rendered.clone());
    let value = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail in practice; if it did, the
    // error still carries its text.
    let _ = value.setattr("code", first.code.clone());
    let _ = value.setattr("diagnostics", diags);
    err
}

/// An `AdviseError` for one diagnostic of `map`'s sources.
pub fn from_diag(py: Python<'_>, map: &SourceMap, d: &dyn miette::Diagnostic) -> PyErr {
    raise(py, vec![Diagnostic::of(map, d, "error")])
}

/// An `AdviseError` with a code of this package (bad arrays, unknown names).
pub fn simple(py: Python<'_>, code: &str, message: String, help: &str) -> PyErr {
    raise(py, vec![Diagnostic::plain(code, &message, Some(help))])
}
