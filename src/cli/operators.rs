//! The operator tools: `advise check` (the standard library or the given files) and `advise
//! apply` (an operator on a chunk of a recorded trace, points out as CSV).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use miette::{IntoDiagnostic, Report, WrapErr, miette};

use crate::check::{self, OperatorSet};
use crate::diag::{SourceId, SourceMap};
use crate::trace::{Chunk, Episode, Trace};

use super::print_report;

pub fn check_standard() -> miette::Result<ExitCode> {
    let mut map = SourceMap::new();
    let ids: Vec<SourceId> = check::STANDARD_SOURCES
        .iter()
        .map(|(n, t)| map.add(*n, *t))
        .collect();
    match check::check_in(&map, None, &ids) {
        Ok(checked) => {
            println!(
                "checked {} domains and {} operators in operators/: all good",
                checked.set.domains().len(),
                checked.set.operator_count()
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => Ok(report_check_errors(&map, errors, ids.len())),
    }
}

/// Read `files` into `map`, the first unreadable one as the error.
fn read_sources(map: &mut SourceMap, files: &[PathBuf]) -> miette::Result<Vec<SourceId>> {
    files
        .iter()
        .map(|f| crate::files::read_source(map, f).map_err(|e| Report::from(map.attach(e))))
        .collect()
}

pub fn check_files(files: &[PathBuf]) -> miette::Result<ExitCode> {
    let mut map = SourceMap::new();
    let ids = read_sources(&mut map, files)?;
    match OperatorSet::standard().merge_in(&map, &ids) {
        Ok(check::Checked { set, warnings }) => {
            let n = warnings.len();
            for w in warnings {
                print_report(&map, &w);
            }
            let ops: usize = set.operator_count();
            println!(
                "checked {} file{}: {} domains and {} operators in all, no errors{}",
                files.len(),
                if files.len() == 1 { "" } else { "s" },
                set.domains().len(),
                ops,
                match n {
                    0 => String::new(),
                    1 => ", 1 warning".into(),
                    n => format!(", {n} warnings"),
                }
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => Ok(report_check_errors(&map, errors, files.len())),
    }
}

fn report_check_errors(map: &SourceMap, errors: check::CheckErrors, files: usize) -> ExitCode {
    let n = errors.errors.len();
    for e in &errors.errors {
        print_report(map, e);
    }
    eprintln!(
        "advise: {n} error{} in {files} file{}",
        if n == 1 { "" } else { "s" },
        if files == 1 { "" } else { "s" }
    );
    ExitCode::FAILURE
}

pub fn apply(
    operators: &[PathBuf],
    op: &str,
    trace_path: &Path,
    range: &str,
    domain: Option<&str>,
    episode: Option<usize>,
) -> miette::Result<ExitCode> {
    let mut files = SourceMap::new();
    let ids = read_sources(&mut files, operators)?;
    let set = match OperatorSet::standard().merge_in(&files, &ids) {
        Ok(checked) => checked.set,
        Err(errors) => return Ok(report_check_errors(&files, errors, ids.len())),
    };
    let inv = crate::syntax::parse_invocation(op)?;
    let domain = set.trace_domain(trace_path, domain)?;
    let trace = match episode {
        None => Trace::load(&mut files, &domain, trace_path).map_err(|e| files.attach(e))?,
        Some(k) => {
            let mut episodes =
                Episode::load_all(&mut files, &domain, trace_path).map_err(|e| files.attach(e))?;
            let count = episodes.len();
            if k >= count {
                return Err(miette!(
                    code = "advise::cli::no_such_episode",
                    help = "episodes are numbered from 0 in file order",
                    "`{}` has {count} episodes, so there is no episode {k}",
                    trace_path.display()
                ));
            }
            episodes.swap_remove(k).trace
        }
    };
    let (a, b) = super::parse_range(range)?;
    let chunk = Chunk::new(a, b, trace.len())?;
    let call =
        crate::check::bind(&mut files, &set, &trace.domain, &inv).map_err(|e| files.attach(e))?;
    let out = crate::interp::apply(&call, &trace, chunk)?;
    let mut stdout = std::io::stdout().lock();
    out.points
        .write_csv(&domain, &mut stdout)
        .into_diagnostic()
        .wrap_err("cannot write the points")?;
    eprintln!(
        "advise: {} synthesized {} of {} points ({} skipped by its guard)",
        out.advice.invocation(),
        out.points.len(),
        chunk.len(),
        chunk.len() - out.points.len()
    );
    Ok(ExitCode::SUCCESS)
}

/// `advise fmt [--check] FILE...`.
pub fn fmt(files: &[PathBuf], check: bool) -> miette::Result<ExitCode> {
    let _ = (files, check);
    Err(miette!("not built yet"))
}

/// `advise test [FILE...]`.
pub fn test(files: &[PathBuf]) -> miette::Result<ExitCode> {
    let _ = files;
    Err(miette!("not built yet"))
}
