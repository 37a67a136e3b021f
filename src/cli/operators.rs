//! The operator tools: `advise check` (the standard library or the given files) and `advise
//! apply` (an operator on a chunk of a recorded trace, points out as CSV).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use miette::{IntoDiagnostic, Report, WrapErr, miette};

use crate::check::{self, OperatorSet, Source};
use crate::diag::SourceMap;
use crate::trace::{Chunk, Episode, Trace};

use super::print_report;

pub fn check_standard() -> miette::Result<ExitCode> {
    let sources: Vec<Source> = check::STANDARD_SOURCES
        .iter()
        .map(|(n, t)| Source::new(*n, *t))
        .collect();
    match check::check(&sources) {
        Ok(set) => {
            println!(
                "checked {} domains and {} operators in operators/: all good",
                set.domains().len(),
                set.operator_count()
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => Ok(report_check_errors(errors, sources.len())),
    }
}

fn read_sources(files: &[PathBuf]) -> miette::Result<Vec<Source>> {
    files
        .iter()
        .map(|f| {
            let mut files = SourceMap::new();
            match crate::files::read_source(&mut files, f) {
                Ok(id) => Ok(Source::new(f.display().to_string(), files.text(id))),
                Err(e) => Err(Report::from(files.attach(e))),
            }
        })
        .collect()
}

pub fn check_files(files: &[PathBuf]) -> miette::Result<ExitCode> {
    let sources = read_sources(files)?;
    match OperatorSet::standard().merge_with_warnings(&sources) {
        Ok(check::Checked { set, warnings }) => {
            let n = warnings.len();
            for w in warnings {
                eprintln!("{:?}", Report::new(w));
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
        Err(errors) => Ok(report_check_errors(errors, files.len())),
    }
}

fn report_check_errors(errors: check::CheckErrors, files: usize) -> ExitCode {
    let n = errors.errors.len();
    for e in &errors.errors {
        print_report(e);
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
    let sources = read_sources(operators)?;
    let set = match OperatorSet::standard().merge(&sources) {
        Ok(set) => set,
        Err(errors) => return Ok(report_check_errors(errors, sources.len())),
    };
    let inv = crate::syntax::parse_invocation(op)?;
    let domain = set.trace_domain(trace_path, domain)?;
    let mut files = SourceMap::new();
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
    let call = crate::check::bind(&set, &trace.domain, &inv)?;
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
