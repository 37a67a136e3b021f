//! Which task a name means: the one resolver the command line (`--task NAME`), the session
//! (`task NAME`) and the Python package (`task=`) share, and the one way task files (`--tasks`,
//! `tasks=`) are read for them. It owns the rule (a paper's task by name, else a task the operator
//! set declares) and its refusal, `advise::task::unknown_task`; each front end only says how a
//! task file is given there ([`Front`]). It reads the files it is given and nothing else.

use std::path::PathBuf;

use crate::check::{CheckErrors, Checked};
use crate::diag::{SourceMap, did_you_mean};
use crate::files::FileError;
use crate::program::OperatorSet;

use super::TaskKind;

/// Where a task was named, for the help line: how a task file is given there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Front {
    /// `task NAME` in a session: `tasks FILE`.
    Session,
    /// `--task NAME`: `--tasks FILE`.
    CommandLine,
    /// `task=` in Python: `tasks="FILE.adv"`.
    Python,
}

impl Front {
    fn how_to_load(self) -> &'static str {
        match self {
            Front::Session => "load a file of task declarations with `tasks FILE`",
            Front::CommandLine => "a task declared in a file is named after `--tasks FILE`",
            Front::Python => "a task declared in a file needs it: `tasks=\"FILE.adv\"`",
        }
    }
}

/// A name that is neither one of the paper's tasks nor a task of the operator set.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error("unknown task `{name}`")]
#[diagnostic(code(advise::task::unknown_task), help("{help}"))]
pub struct UnknownTask {
    pub name: String,
    pub help: String,
}

/// Why task files and a name give no task: a file unread, a check's errors (every one, pointing
/// into the map the files were read into), or the name.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum TaskFilesError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    Read(#[from] FileError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Check(#[from] CheckErrors),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Unknown(#[from] UnknownTask),
}

/// Every task `set` knows: the paper's two, then the declared ones, each once.
pub fn task_names(set: &OperatorSet) -> Vec<String> {
    let mut names = vec!["positioning".to_string(), "interception".to_string()];
    for t in set.tasks() {
        if !names.iter().any(|n| n == t.name()) {
            names.push(t.name().to_string());
        }
    }
    names
}

/// The task called `name`: one of the paper's, or one `set` declares (a task file read into it).
pub fn resolve(name: &str, set: &OperatorSet, front: Front) -> Result<TaskKind, UnknownTask> {
    if let Some(t) = TaskKind::builtin(name) {
        return Ok(t);
    }
    if let Some(def) = set.task(name) {
        return Ok(TaskKind::Declared(def.clone()));
    }
    let names = task_names(set);
    let help = match did_you_mean(name, names.iter().map(String::as_str)) {
        Some(h) => h,
        None if set.domain(name).is_some() => format!(
            "`{name}` is a domain without task clauses (goal, observations' definitions, drives, success and end rules): see `operators/README.md`, Tasks"
        ),
        None => format!(
            "the tasks are {}; {}",
            names
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", "),
            front.how_to_load()
        ),
    };
    Err(UnknownTask {
        name: name.to_string(),
        help,
    })
}

/// The standard operators with the task files `files` read into `map` and checked on top, every
/// task they declare with the standard operators by role, as a session's `tasks FILE` gives them
/// ([`OperatorSet::merge_declaring`]). The warnings are the files'.
pub fn load_task_files(map: &mut SourceMap, files: &[PathBuf]) -> Result<Checked, TaskFilesError> {
    let mut ids = Vec::with_capacity(files.len());
    for f in files {
        ids.push(crate::files::read_source(map, f)?);
    }
    Ok(OperatorSet::standard().merge_declaring(map, &ids)?)
}

/// The task `name` among the paper's and those the task files `files` declare (read into `map`,
/// every mistake in them reported before the name is looked up), with the operator set they
/// make: what `--tasks FILE --task NAME` and Python's `tasks=..., task=...` both mean.
pub fn resolve_in_files(
    map: &mut SourceMap,
    name: &str,
    files: &[PathBuf],
    front: Front,
) -> Result<(TaskKind, OperatorSet), TaskFilesError> {
    let set = if files.is_empty() {
        OperatorSet::standard()
    } else {
        load_task_files(map, files)?.set
    };
    let kind = resolve(name, &set, front)?;
    Ok((kind, set))
}
