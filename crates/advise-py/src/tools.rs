//! `advise.fmt` and `advise.test`: the command line's `advise fmt` and `advise test` as functions
//! returning values (the formatted text, the examples' results) instead of printing.

use advise::check::{self, OperatorSet};
use advise::diag::{SourceId, SourceMap};
use pyo3::prelude::*;

use crate::diag::Diagnostic;
use crate::error::{from_diag, raise};
use crate::ops::source;

/// fmt(text_or_path) -> str
///
/// The canonical layout of an operator file or text (a session script: trailing blanks and
/// repeated blank lines removed), as `advise fmt FILE` writes it; the file is not changed.
/// Raises AdviseError with the parse error when the text is neither operators nor a script.
#[pyfunction]
pub fn fmt(py: Python<'_>, text_or_path: &str) -> PyResult<String> {
    let mut map = SourceMap::new();
    let id = source(py, &mut map, text_or_path)?;
    advise::syntax::script::format_file(map.src(id)).map_err(|e| from_diag(py, &map, &e))
}

/// The result of one doc example (`/// Example: ...`) run by `advise.test`.
#[pyclass(module = "advise", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct TestResult {
    /// The operator, `domain/name`.
    pub name: String,
    /// The example line, from `Example:` on.
    pub example: String,
    /// The source (a path, `<text>`, or a standard file's name) and the 1-based line.
    pub file: String,
    pub line: usize,
    pub passed: bool,
    /// Why it failed (the diagnostic's text as `advise test` prints it), or None.
    pub message: Option<String>,
    /// The failure as a diagnostic, or None.
    pub diagnostic: Option<Diagnostic>,
}

#[pymethods]
impl TestResult {
    fn __repr__(&self) -> String {
        let verdict = if self.passed { "passed" } else { "failed" };
        format!("TestResult({} {verdict}: {})", self.name, self.example)
    }

    fn __bool__(&self) -> bool {
        self.passed
    }
}

/// test(path_or_text=None) -> list[TestResult]
///
/// Run the doc examples (`/// Example: ...`) of an operator file or text, checked on top of the
/// standard operators, as `advise test FILE` does; with no argument, the standard operators'.
/// One TestResult per example, in file order. Raises AdviseError when the operators do not
/// check.
#[pyfunction]
#[pyo3(signature = (path_or_text=None))]
pub fn test(py: Python<'_>, path_or_text: Option<&str>) -> PyResult<Vec<TestResult>> {
    let mut map = SourceMap::new();
    let (set, ids): (OperatorSet, Vec<SourceId>) = match path_or_text {
        None => {
            let ids = check::STANDARD_SOURCES
                .iter()
                .map(|(n, t)| map.add(*n, *t))
                .collect();
            (OperatorSet::standard(), ids)
        }
        Some(s) => {
            let id = source(py, &mut map, s)?;
            match OperatorSet::standard().merge_in(&map, &[id]) {
                Ok(checked) => (checked.set, vec![id]),
                Err(errors) => return Err(raise(py, Diagnostic::all_of(&map, &errors, "error"))),
            }
        }
    };
    let outcome = advise::doctest::run(&mut map, &set, &ids);
    let results = outcome
        .ran
        .iter()
        .map(|r| {
            let text = map.text(r.id);
            let diagnostic = r
                .failure
                .and_then(|i| outcome.failures.get(i))
                .map(|e| Diagnostic::of(&map, e, "error"));
            TestResult {
                name: r.op.clone(),
                example: text.get(r.line.clone()).unwrap_or_default().to_string(),
                file: map.name(r.id).to_string(),
                line: text
                    .get(..r.line.start)
                    .map_or(0, |b| b.matches('\n').count())
                    + 1,
                passed: r.failure.is_none(),
                message: diagnostic.as_ref().map(|d| d.rendered.clone()),
                diagnostic,
            }
        })
        .collect();
    Ok(results)
}
