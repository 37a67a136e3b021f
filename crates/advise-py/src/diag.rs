//! `advise.Diagnostic` and `advise.Span`: a diagnostic of the language or of a data file as plain
//! fields, with the text the command line prints.

use advise::diag::SourceMap;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// Where a diagnostic points: the source's name (a path, or `<text>`), 1-based line and column,
/// and the byte range in that source.
#[pyclass(module = "advise", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct Span {
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub start: usize,
    pub end: usize,
}

#[pymethods]
impl Span {
    fn __repr__(&self) -> String {
        format!("Span({}:{}:{})", self.file, self.line, self.column)
    }

    /// Pickled as its fields (an `AdviseError` from a worker process carries its spans).
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let args = (
            self.file.clone(),
            self.line,
            self.column,
            self.start,
            self.end,
        );
        Ok((
            py.import("advise._advise")?.getattr("_span")?,
            args.into_pyobject(py)?,
        ))
    }
}

/// A `Span` from its fields: what unpickling one calls.
#[pyfunction]
pub fn _span(file: String, line: usize, column: usize, start: usize, end: usize) -> Span {
    Span {
        file,
        line,
        column,
        start,
        end,
    }
}

/// A `Diagnostic` from its fields: what unpickling one calls.
#[pyfunction]
#[pyo3(signature = (code, message, span, help, severity, rendered))]
pub fn _diagnostic(
    code: String,
    message: String,
    span: Option<PyRef<'_, Span>>,
    help: Option<String>,
    severity: String,
    rendered: String,
) -> Diagnostic {
    Diagnostic {
        code,
        message,
        span: span.map(|s| s.clone()),
        help,
        severity,
        rendered,
    }
}

/// One diagnostic: `code` (`advise::area::name`), `message` (what), `span` (where, or None),
/// `help` (how to fix, or None), `severity` (`error` or `warning`) and `rendered` (the text the
/// command line prints).
#[pyclass(module = "advise", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct Diagnostic {
    pub code: String,
    pub message: String,
    pub span: Option<Span>,
    pub help: Option<String>,
    pub severity: String,
    pub rendered: String,
}

#[pymethods]
impl Diagnostic {
    fn __repr__(&self) -> String {
        format!("Diagnostic({}: {})", self.code, self.message)
    }

    fn __str__(&self) -> String {
        self.rendered.clone()
    }

    /// Pickled as its fields (an `AdviseError` from a worker process carries its diagnostics).
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let args = (
            self.code.clone(),
            self.message.clone(),
            self.span.clone(),
            self.help.clone(),
            self.severity.clone(),
            self.rendered.clone(),
        );
        Ok((
            py.import("advise._advise")?.getattr("_diagnostic")?,
            args.into_pyobject(py)?,
        ))
    }
}

impl Diagnostic {
    /// A diagnostic of this package, not pointing into any source.
    pub fn plain(code: &str, message: &str, help: Option<&str>) -> Diagnostic {
        let rendered = match help {
            Some(h) => format!("{code}: {message}\n  help: {h}"),
            None => format!("{code}: {message}"),
        };
        Diagnostic {
            code: code.into(),
            message: message.into(),
            span: None,
            help: help.map(Into::into),
            severity: "error".into(),
            rendered,
        }
    }

    /// `d` with its first label located in `map`.
    pub fn of(map: &SourceMap, d: &dyn miette::Diagnostic, severity: &str) -> Diagnostic {
        let span = d
            .labels()
            .and_then(|mut l| l.next())
            .and_then(|label| locate(map, label.inner()));
        Diagnostic {
            code: d.code().map_or_else(|| "advise".into(), |c| c.to_string()),
            message: d.to_string(),
            span,
            help: d.help().map(|h| h.to_string()),
            severity: severity.into(),
            rendered: advise::diag::render(map, d, false),
        }
    }

    /// Each diagnostic `d` gathers (`#[related]`, as a check's errors), or `d` itself.
    pub fn all_of(map: &SourceMap, d: &dyn miette::Diagnostic, severity: &str) -> Vec<Diagnostic> {
        match d.related() {
            Some(related) => {
                let v: Vec<Diagnostic> =
                    related.map(|r| Diagnostic::of(map, r, severity)).collect();
                if v.is_empty() {
                    vec![Diagnostic::of(map, d, severity)]
                } else {
                    v
                }
            }
            None => vec![Diagnostic::of(map, d, severity)],
        }
    }
}

/// The file, line and column (1-based, in characters) of a span of `map` (global offsets), by
/// the language's one line index.
fn locate(map: &SourceMap, span: &miette::SourceSpan) -> Option<Span> {
    use advise::diag::{Encoding, LineIndex};
    let (name, text, at) = map.local(span.offset())?;
    text.get(..at)?;
    let pos = LineIndex::new(text).line_col(text, at, Encoding::Utf32);
    Some(Span {
        file: name.to_string(),
        line: pos.line + 1,
        column: pos.col + 1,
        start: at,
        end: (at + span.len()).min(text.len()),
    })
}
