//! Episodes: the named traces of a demonstrations file, and loading them from one.

use std::path::Path;

use super::{Trace, TraceError, is_json};
use crate::diag::SourceMap;
use crate::domain::Domain;

/// One named trace of a file that holds several (a set of demonstrations).
#[derive(Clone, Debug, PartialEq)]
pub struct Episode {
    pub name: String,
    pub trace: Trace,
}

impl Episode {
    /// Load the episodes of a demonstration file, read into `sources`.
    ///
    /// CSV: an optional `episode` column labels each row; consecutive rows with the same label form
    /// one episode ([`Episode::parse_csv`]). JSON: either one trace or several episodes
    /// ([`Episode::parse_json`]).
    pub fn load_all(
        sources: &mut SourceMap,
        domain: &Domain,
        path: &Path,
    ) -> Result<Vec<Episode>, TraceError> {
        crate::files::parse_file(sources, path, |src| {
            if is_json(path) {
                Episode::parse_json(domain, src)
            } else {
                Episode::parse_csv(domain, src)
            }
        })
    }
}
