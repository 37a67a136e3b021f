//! [`DatasetError`]: what can go wrong with a dataset, in memory or in its file.

use miette::Diagnostic;
use thiserror::Error;

use super::*;

/// What can go wrong with a dataset.
#[derive(Debug, Error, Diagnostic)]
pub enum DatasetError {
    #[error("no advice with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_advice))]
    UnknownAdvice(AdviceId),
    #[error("no demonstration with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_demonstration))]
    UnknownDemonstration(DemoId),
    #[error("no critique with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_critique))]
    UnknownCritique(CritiqueId),
    #[error("no execution with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_execution))]
    UnknownExecution(ExecutionId),
    #[error("the points are for the `{found}` domain, the dataset is `{expected}`")]
    #[diagnostic(code(advise::dataset::domain_mismatch))]
    DomainMismatch { expected: String, found: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] advise_lang::files::FileError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Trace(#[from] advise_lang::trace::TraceError),
    #[error("`{path}`: a dataset is saved as `.json` (to open again) or `.csv` (points only)")]
    #[diagnostic(
        code(advise::dataset::unknown_format),
        help("name the file `{stem}.json`, or `{stem}.csv` for the points alone")
    )]
    UnknownFormat { path: String, stem: String },
    #[error("the dataset file is malformed: {message}")]
    #[diagnostic(
        code(advise::dataset::json),
        help(
            "dataset files are written by `save FILE.json`; a CSV export cannot be opened again (`load demos` reads it as demonstrations)"
        )
    )]
    Json {
        message: String,
        #[label("here")]
        at: Loc,
    },
    #[error("refused to add a value that is not finite: {what}")]
    #[diagnostic(
        code(advise::dataset::non_finite),
        help("every value in a dataset must be a finite number; nothing was added")
    )]
    NonFinite { what: String },
    #[error("the dataset file is inconsistent: {what}")]
    #[diagnostic(code(advise::dataset::inconsistent))]
    Inconsistent { what: String },
    #[error("`{at}`: {what}")]
    #[diagnostic(
        code(advise::dataset::dimension),
        help("every point has the domain's dimensions: {expected}")
    )]
    Dimension {
        at: String,
        what: String,
        expected: String,
    },
    #[error("a number of the dataset is `null`, not a finite number")]
    #[diagnostic(
        code(advise::dataset::null),
        help(
            "JSON writes NaN and infinity as `null`; a dataset holds finite numbers only, so the point must be repaired or removed"
        )
    )]
    Null {
        #[label("not a number")]
        at: Loc,
    },
    #[error("`{at}` is {value}, not a finite number")]
    #[diagnostic(
        code(advise::dataset::not_finite),
        help("a dataset holds finite numbers only (JSON writes NaN and infinity as `null`)")
    )]
    NotFinite { at: String, value: String },
    #[error("`{at}` is {value}, outside the `{dim}` limits [{lo}, {hi}]")]
    #[diagnostic(
        code(advise::dataset::out_of_limits),
        help(
            "the domain's limits hold for every point; the file was edited or is for another domain"
        )
    )]
    OutOfLimits {
        at: String,
        value: String,
        dim: String,
        lo: String,
        hi: String,
    },
    #[error("id {id} is used twice: by {first} and by {second}")]
    #[diagnostic(
        code(advise::dataset::duplicate_id),
        help("demonstrations, executions, advice and critiques share one sequence of ids")
    )]
    DuplicateId {
        id: u32,
        first: String,
        second: String,
    },
    #[error("`{at}` refers to {what} {id}, which the file does not hold")]
    #[diagnostic(code(advise::dataset::dangling))]
    Dangling {
        at: String,
        what: &'static str,
        id: u32,
    },
    #[error("`next_id` is {next_id}, but the file already uses id {max_id}")]
    #[diagnostic(
        code(advise::dataset::next_id),
        help(
            "`next_id` is the last id given out; it must be at least {max_id}, or new advice would reuse an id and `undo` would remove the wrong points"
        )
    )]
    NextId { next_id: u32, max_id: u32 },
    #[error(
        "`next_id` is {next_id}: no id is left for new demonstrations, executions, advice or critiques"
    )]
    #[diagnostic(
        code(advise::dataset::ids_exhausted),
        help(
            "ids are given one per record and never reused (a reused id would make `undo` remove the wrong points); `next_id` was edited to the top of the range: set it to the largest id the file uses"
        )
    )]
    IdsExhausted { next_id: u32 },
    #[error("`{at}`: {what}")]
    #[diagnostic(code(advise::dataset::inconsistent_record))]
    Record { at: String, what: String },
}
