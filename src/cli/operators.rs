//! The operator tools: `advise check` (the standard library or the given files) and `advise
//! apply` (an operator on a chunk of a recorded trace, points out as CSV).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use miette::{IntoDiagnostic, Report, WrapErr, miette};

use advise::check::{self, OperatorSet};
use advise::diag::{SourceId, SourceMap};
use advise::trace::{Chunk, Episode, Trace};

use super::print_report;

pub fn check_standard() -> miette::Result<ExitCode> {
    let mut map = SourceMap::new();
    let ids: Vec<SourceId> = check::STANDARD_SOURCES
        .iter()
        .map(|(n, t)| map.add(*n, *t))
        .collect();
    match check::check_in(&map, None, &ids) {
        Ok(checked) => {
            outln!(
                "checked {} domains ({}) and {} operators in operators/: all good",
                checked.set.domains().len(),
                tasks_listed(&checked.set),
                checked.set.operator_count()
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => Ok(report_check_errors(&map, errors, ids.len())),
    }
}

/// The domains that are tasks: "tasks: positioning, standoff".
fn tasks_listed(set: &OperatorSet) -> String {
    let names: Vec<&str> = set.tasks().iter().map(|t| t.name()).collect();
    match names.len() {
        0 => "no task".into(),
        1 => format!("task: {}", names[0]),
        _ => format!("tasks: {}", names.join(", ")),
    }
}

/// How many standard operators each declared task gets by role: " (by role: 11 for waypoint)".
fn by_role(set: &OperatorSet) -> String {
    let counts: Vec<String> = set
        .tasks()
        .iter()
        .filter_map(|t| {
            let role_origin = format!("rewritten for `{}`'s", t.name());
            let n = set
                .operators(t.name())
                .filter(|o| o.origin().contains(&role_origin))
                .count();
            (n > 0).then(|| format!("{n} for {}", t.name()))
        })
        .collect();
    if counts.is_empty() {
        String::new()
    } else {
        format!(" (standard ones by role: {})", counts.join(", "))
    }
}

/// Read `files` into `map`, the first unreadable one as the error. Files that together hold more
/// than one check reads ([`check::MAX_CHECK_BYTES`]) are refused before they are read.
fn read_sources(map: &mut SourceMap, files: &[PathBuf]) -> miette::Result<Vec<SourceId>> {
    let size: u64 = files
        .iter()
        .filter_map(|f| std::fs::metadata(f).ok())
        .filter(|m| m.is_file())
        .map(|m| m.len())
        .sum();
    if size > check::MAX_CHECK_BYTES as u64 {
        let what = match files {
            [one] => format!("`{}`", one.display()),
            many => format!("the {} files", many.len()),
        };
        return Err(check::CheckError::TooLarge {
            what,
            size: advise::files::fmt_bytes(size),
            limit: advise::files::fmt_bytes(check::MAX_CHECK_BYTES as u64),
        }
        .into());
    }
    files
        .iter()
        .map(|f| advise::files::read_source(map, f).map_err(|e| Report::from(map.attach(e))))
        .collect()
}

/// `advise check [--tasks FILE]... FILE...`: the task files first, then the operator files, all
/// on top of the standard operators.
pub fn check_files(tasks: &[PathBuf], files: &[PathBuf]) -> miette::Result<ExitCode> {
    let all: Vec<PathBuf> = tasks.iter().chain(files).cloned().collect();
    let files = all.as_slice();
    let mut map = SourceMap::new();
    let ids = read_sources(&mut map, files)?;
    // The task files first; then each of their tasks gets the standard operators by role, as a
    // session's `tasks FILE` gives them, so that an operator file's `slow_down` for the task
    // warns that it shadows one; then the operator files.
    let (task_ids, op_ids) = ids.split_at(tasks.len());
    let checked = merge_tasks_then_operators(&mut map, task_ids, op_ids);
    match checked {
        Ok(check::Checked { set, warnings }) => {
            let n = warnings.len();
            for w in warnings {
                print_report(&map, &w);
            }
            let ops: usize = set.operator_count();
            outln!(
                "checked {} file{}: {} domains ({}) and {} operators in all{}, no errors{}",
                files.len(),
                if files.len() == 1 { "" } else { "s" },
                set.domains().len(),
                tasks_listed(&set),
                ops,
                by_role(&set),
                match n {
                    0 => String::new(),
                    1 => ", 1 warning".into(),
                    n => format!(", {n} warnings"),
                }
            );
            // The process ends here: freeing a large file's operators one by one would only
            // add to the time the check takes (issue 31).
            std::mem::forget(set);
            Ok(ExitCode::SUCCESS)
        }
        Err(mut errors) => {
            name_domain_files(&mut errors, tasks, files);
            Ok(report_check_errors(&map, errors, files.len()))
        }
    }
}

/// The most `.adv` files looked through for a missing domain's declaration, and the most bytes
/// read of each: the search is a courtesy and stays quick in any folder.
const DOMAIN_SEARCH_FILES: usize = 200;
const DOMAIN_SEARCH_BYTES: u64 = 1 << 20;

/// An unknown domain declared by a file beside the checked ones (or in the working directory):
/// its help names that file and the command line that brings it in.
fn name_domain_files(errors: &mut check::CheckErrors, tasks: &[PathBuf], files: &[PathBuf]) {
    use std::io::Read as _;
    let mut dirs: Vec<PathBuf> = files
        .iter()
        .map(|f| f.parent().map_or_else(PathBuf::new, Path::to_path_buf))
        .collect();
    dirs.push(PathBuf::new());
    dirs.sort();
    dirs.dedup();
    let candidates: Vec<PathBuf> = dirs
        .iter()
        .filter_map(|d| {
            std::fs::read_dir(if d.as_os_str().is_empty() {
                Path::new(".")
            } else {
                d
            })
            .ok()
        })
        .flat_map(|entries| entries.flatten().map(|e| e.path()))
        .map(|p| p.strip_prefix("./").map(Path::to_path_buf).unwrap_or(p))
        .filter(|p| p.extension().is_some_and(|e| e == "adv") && !files.contains(p))
        .take(DOMAIN_SEARCH_FILES)
        .collect();
    let declares = |path: &Path, name: &str| {
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(DOMAIN_SEARCH_BYTES).read_to_string(&mut text))
            .is_ok()
            && text.lines().any(|l| {
                l.trim_start()
                    .strip_prefix("domain ")
                    .is_some_and(|r| r.trim_start().split([' ', '{']).next() == Some(name))
            })
    };
    for e in &mut errors.errors {
        let check::ParseOrCheckError::Check(check::CheckError::UnknownDomain {
            name, help, ..
        }) = e
        else {
            continue;
        };
        if let Some(found) = candidates.iter().find(|p| declares(p, name)) {
            let mut line: Vec<String> = vec!["advise check".into()];
            for t in tasks.iter().chain([found]) {
                line.push(format!("--tasks {}", t.display()));
            }
            line.extend(
                files
                    .iter()
                    .filter(|f| !tasks.contains(f))
                    .map(|f| f.display().to_string()),
            );
            *help = format!(
                "`{name}` is declared in {}: pass the task file, `{}` (in a session, `tasks {}` first)",
                found.display(),
                line.join(" "),
                found.display()
            );
        }
    }
}

fn report_check_errors(map: &SourceMap, errors: check::CheckErrors, files: usize) -> ExitCode {
    let n = errors.errors.len();
    for e in &errors.errors {
        print_report(map, e);
    }
    errln!(
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
    let inv = advise::syntax::parse_invocation(op)?;
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
        advise::check::bind(&mut files, &set, &trace.domain, &inv).map_err(|e| files.attach(e))?;
    let out = advise::interp::apply(&call, &trace, chunk)?;
    let mut stdout = std::io::stdout().lock();
    out.points
        .write_csv(&domain, &mut stdout)
        .into_diagnostic()
        .wrap_err("cannot write the points")?;
    errln!(
        "advise: {} synthesized {} of {} points ({} skipped by its guard)",
        out.advice.invocation(),
        out.points.len(),
        chunk.len(),
        chunk.len() - out.points.len()
    );
    Ok(ExitCode::SUCCESS)
}

/// `advise fmt [--check] FILE...`: each operator file rewritten in the canonical layout (session
/// scripts: trailing blanks and repeated blank lines only). Every file is tried; a file that is
/// neither an operator file nor a script (every statement one) is reported and left as it was
/// ([`advise::session::script::format_file`]).
pub fn fmt(files: &[PathBuf], check: bool) -> miette::Result<ExitCode> {
    let mut map = SourceMap::new();
    let (mut changed, mut failed) = (0, 0);
    for path in files {
        let id = match advise::files::read_source(&mut map, path) {
            Ok(id) => id,
            Err(e) => {
                print_report(&map, &e);
                failed += 1;
                continue;
            }
        };
        let text = map.text(id);
        let formatted = match advise::session::script::format_file(map.src(id)) {
            Ok(f) => f,
            Err(e) => {
                print_report(&map, &e);
                failed += 1;
                continue;
            }
        };
        if formatted == text {
            continue;
        }
        if check {
            changed += 1;
            outln!("would reformat {}", path.display());
        } else if let Err(e) = advise::files::write_bytes(path, formatted.as_bytes()) {
            // Refused (read-only, not a regular file, ...): not counted as reformatted.
            print_report(&map, &e);
            failed += 1;
        } else {
            changed += 1;
            outln!("formatted {}", path.display());
        }
    }
    let n = files.len();
    let files_word = |n: usize| if n == 1 { "file" } else { "files" };
    let failures = match failed {
        0 => String::new(),
        f => format!("; {f} failed"),
    };
    match (check, changed) {
        (true, 0) if failed == 0 => outln!("{n} {} already formatted", files_word(n)),
        (true, c) => outln!(
            "{c} of {n} {} would be reformatted{failures}",
            files_word(n)
        ),
        (false, c) => outln!("{c} of {n} {} reformatted{failures}", files_word(n)),
    }
    Ok(if failed > 0 || (check && changed > 0) {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// `advise test [FILE...]`: the doc examples of the files' operators (checked on top of the
/// standard ones), or of the standard operators.
pub fn test(tasks: &[PathBuf], files: &[PathBuf]) -> miette::Result<ExitCode> {
    let mut map = SourceMap::new();
    let (set, ids) = if !tasks.is_empty() {
        let all: Vec<PathBuf> = tasks.iter().chain(files).cloned().collect();
        let ids = read_sources(&mut map, &all)?;
        let (task_ids, op_ids) = ids.split_at(tasks.len());
        match merge_tasks_then_operators(&mut map, task_ids, op_ids) {
            Ok(checked) => (checked.set, ids),
            Err(errors) => return Ok(report_check_errors(&map, errors, ids.len())),
        }
    } else if files.is_empty() {
        let ids: Vec<SourceId> = check::STANDARD_SOURCES
            .iter()
            .map(|(n, t)| map.add(*n, *t))
            .collect();
        (OperatorSet::standard(), ids)
    } else {
        let ids = read_sources(&mut map, files)?;
        match OperatorSet::standard().merge_in(&map, &ids) {
            Ok(checked) => (checked.set, ids),
            Err(errors) => return Ok(report_check_errors(&map, errors, ids.len())),
        }
    };
    let outcome = advise::doctest::run(&mut map, &set, &ids);
    for f in &outcome.failures {
        print_report(&map, f);
    }
    if !outcome.without_example.is_empty() {
        outln!(
            "no example: {} (add a `/// Example: ...` line to test them)",
            outcome.without_example.join(", ")
        );
    }
    let m = outcome.failures.len();
    outln!(
        "{} example{}, {m} failed",
        outcome.examples,
        if outcome.examples == 1 { "" } else { "s" }
    );
    Ok(if m == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The standard operators, then the task files `task_ids`, each of their tasks with the standard
/// operators by role (as a session's `tasks FILE` gives them: [`OperatorSet::merge_declaring`]),
/// then the operator files `op_ids`. The task files' warnings come first.
fn merge_tasks_then_operators(
    map: &mut SourceMap,
    task_ids: &[SourceId],
    op_ids: &[SourceId],
) -> Result<check::Checked, check::CheckErrors> {
    let tasks = OperatorSet::standard().merge_declaring(map, task_ids)?;
    let mut rest = tasks.set.merge_in(map, op_ids)?;
    rest.warnings.splice(0..0, tasks.warnings);
    Ok(rest)
}
