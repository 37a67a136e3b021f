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

#[cfg(test)]
mod tests {
    use super::*;

    fn file(dir: &tempfile::TempDir, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn a_trace_is_recognised_by_its_header_or_its_domain_field_or_named() {
        let set = OperatorSet::standard();
        let dir = tempfile::tempdir().unwrap();
        let csv = file(
            &dir,
            "t.csv",
            "t, dist2,bearing,dheading,trans,rot\n0,1,0,0,0,0\n",
        );
        assert_eq!(set.trace_domain(&csv, None).unwrap().name, "positioning");
        let json = file(
            &dir,
            "t.json",
            r#"{"domain": "interception", "points": []}"#,
        );
        assert_eq!(set.trace_domain(&json, None).unwrap().name, "interception");
        let missing = dir.path().join("absent.csv");
        let named = set.trace_domain(&missing, Some("interception")).unwrap();
        assert_eq!(named.name, "interception");
    }

    #[test]
    fn an_unknown_domain_names_the_known_ones() {
        let set = OperatorSet::standard();
        let dir = tempfile::tempdir().unwrap();
        let csv = file(&dir, "t.csv", "a,b\n1,2\n");
        let e = set.trace_domain(&csv, None).unwrap_err();
        assert!(matches!(e, TraceDomainError::Unrecognised { .. }), "{e:?}");
        let help = e.help().unwrap().to_string();
        assert!(
            help.contains("positioning") && help.contains("interception"),
            "{help}"
        );
        let e = set.trace_domain(&csv, Some("position")).unwrap_err();
        assert_eq!(
            e.code().unwrap().to_string(),
            "advise::cli::unknown_domain",
            "{e:?}"
        );
        let e = set
            .trace_domain(&dir.path().join("absent.csv"), None)
            .unwrap_err();
        assert!(matches!(e, TraceDomainError::File(_)), "{e:?}");
    }
}
