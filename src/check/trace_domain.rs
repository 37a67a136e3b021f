//! Which of an operator set's domains a trace belongs to: the one named, or the one a JSON trace
//! names, or the first whose dimensions all appear in a CSV trace's header.

use std::path::Path;

use miette::Diagnostic;
use thiserror::Error;

use super::OperatorSet;
use crate::domain::Domain;

/// Why a trace's domain is not known.
#[derive(Debug, Error, Diagnostic)]
pub enum TraceDomainError {
    #[error("there is no domain `{name}`")]
    #[diagnostic(
        code(advise::cli::unknown_domain),
        help("the known domains are: {known}")
    )]
    Unknown { name: String, known: String },
    #[error("cannot tell which domain `{path}` belongs to")]
    #[diagnostic(
        code(advise::cli::unknown_trace_domain),
        help(
            "name it with `--domain` (one of: {known}), or give the trace a header with the domain's columns"
        )
    )]
    Unrecognised { path: String, known: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
}

impl OperatorSet {
    /// The domain called `name` when given, else the one the trace at `path` belongs to: a JSON
    /// trace (`.json`) by its `domain` field, a CSV trace by its header's columns.
    pub fn trace_domain(
        &self,
        path: &Path,
        name: Option<&str>,
    ) -> Result<Domain, TraceDomainError> {
        let known = || {
            self.domains()
                .iter()
                .map(|d| d.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if let Some(name) = name {
            return self
                .domain(name)
                .cloned()
                .ok_or_else(|| TraceDomainError::Unknown {
                    name: name.to_string(),
                    known: known(),
                });
        }
        let text = crate::files::read_text(path)?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let found = if is_json {
            #[derive(serde::Deserialize)]
            struct Named {
                domain: String,
            }
            serde_json::from_str::<Named>(&text)
                .ok()
                .and_then(|n| self.domain(&n.domain).cloned())
        } else {
            let header: Vec<&str> = text
                .lines()
                .next()
                .unwrap_or("")
                .split(',')
                .map(str::trim)
                .collect();
            self.domains()
                .iter()
                .find(|d| {
                    d.observe
                        .iter()
                        .chain(&d.act)
                        .all(|dim| header.contains(&dim.name.as_str()))
                })
                .cloned()
        };
        found.ok_or_else(|| TraceDomainError::Unrecognised {
            path: path.display().to_string(),
            known: known(),
        })
    }
}
