//! What can be wrong with a trace or demonstrations file: [`TraceError`]. Each variant points
//! into the file through a [`Loc`] of the session's source map; none holds the text.

use miette::Diagnostic;
use thiserror::Error;

use crate::diag::Loc;

/// Everything that can be wrong with a trace file.
#[derive(Debug, Error, Diagnostic)]
pub enum TraceError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("the trace has no column `{column}`")]
    #[diagnostic(
        code(advise::trace::missing_column),
        help("the `{domain}` domain needs the columns: {expected}")
    )]
    MissingColumn {
        column: String,
        domain: String,
        expected: String,
        #[label("this header lacks `{column}`")]
        at: Loc,
    },
    #[error("the trace has an unknown column `{column}`")]
    #[diagnostic(code(advise::trace::unknown_column), help("{help}"))]
    UnknownColumn {
        column: String,
        help: String,
        #[label("not a dimension of the `{domain}` domain")]
        at: Loc,
        domain: String,
    },
    #[error("the column `{column}` appears twice")]
    #[diagnostic(code(advise::trace::duplicate_column), help("remove one of them"))]
    DuplicateColumn {
        column: String,
        #[label("second `{column}`")]
        at: Loc,
    },
    #[error("line {line}: the row has {found} fields, the header has {expected}")]
    #[diagnostic(code(advise::trace::row_length))]
    RowLength {
        line: u64,
        found: usize,
        expected: usize,
        #[label("this row")]
        at: Loc,
    },
    #[error("line {line}, column `{column}`: `{value}` is not a number")]
    #[diagnostic(
        code(advise::trace::not_a_number),
        help("write a decimal number such as 0.25")
    )]
    NotANumber {
        line: u64,
        column: String,
        value: String,
        #[label("not a number")]
        at: Loc,
    },
    #[error("line {line}, column `{column}`: the value is {value}, not a finite number")]
    #[diagnostic(
        code(advise::trace::not_finite),
        help("a NaN or infinity usually means a sensor dropout; remove or repair the row")
    )]
    NotFinite {
        line: u64,
        column: String,
        value: String,
        #[label("not finite")]
        at: Loc,
    },
    #[error("line {line}: time goes backwards ({t} after {prev})")]
    #[diagnostic(
        code(advise::trace::time_backwards),
        help("rows must be in time order")
    )]
    TimeBackwards {
        line: u64,
        t: f64,
        prev: f64,
        #[label("earlier than the row before")]
        at: Loc,
    },
    #[error(
        "line {line}, column `{column}`: the action {value} is outside its limits [{lo}, {hi}]"
    )]
    #[diagnostic(
        code(advise::trace::action_out_of_limits),
        help(
            "a demonstration's actions are ones the robot can execute; clamp the value into [{lo}, {hi}]"
        )
    )]
    ActionOutOfLimits {
        line: u64,
        column: String,
        value: String,
        lo: String,
        hi: String,
        #[label("outside [{lo}, {hi}]")]
        at: Loc,
    },
    #[error("line {line}: the time {t} repeats the row before")]
    #[diagnostic(
        code(advise::trace::time_repeated),
        help("each row is one control step, later than the one before; remove the repeated row")
    )]
    TimeRepeated {
        line: u64,
        t: f64,
        #[label("same time as the row before")]
        at: Loc,
    },
    #[error("line {line}: episode `{episode}` started before, on line {first_line}")]
    #[diagnostic(
        code(advise::trace::episode_split),
        help(
            "the rows of one episode are contiguous; move them together, or give this run of rows its own name"
        )
    )]
    EpisodeSplit {
        line: u64,
        first_line: u64,
        episode: String,
        #[label("`{episode}` again, after other episodes")]
        at: Loc,
    },
    #[error("episode `{episode}` has no points")]
    #[diagnostic(
        code(advise::trace::empty_episode),
        help("remove the episode, or record its points")
    )]
    EmptyEpisode {
        episode: String,
        #[label("no points")]
        at: Option<Loc>,
    },
    #[error("two episodes are named `{episode}`")]
    #[diagnostic(
        code(advise::trace::duplicate_episode),
        help("episode names tell demonstrations apart in provenance; rename one")
    )]
    DuplicateEpisode {
        episode: String,
        #[label("second `{episode}`")]
        at: Option<Loc>,
    },
    #[error("`{name}` holds no demonstrations")]
    #[diagnostic(
        code(advise::trace::no_demonstrations),
        help(
            "a demonstrations file has at least one row after its header (CSV) or one episode (JSON)"
        )
    )]
    NoDemonstrations { name: String },
    #[error("the file is empty: it has no header")]
    #[diagnostic(
        code(advise::trace::empty),
        help("a trace starts with a header line such as `t,dist2,bearing,dheading,trans,rot`")
    )]
    Empty,
    #[error("the file holds {count} episodes where one trace was expected")]
    #[diagnostic(
        code(advise::trace::many_episodes),
        help(
            "load it as demonstrations (`load demos FILE`), pick one with `advise apply --episode K`, or keep one episode's rows"
        )
    )]
    ManyEpisodes { count: usize },
    #[error("line {line}: the demonstrations hold more than {max} points")]
    #[diagnostic(
        code(advise::trace::too_many_points),
        help(
            "a demonstrations file read in a stream is bounded by its points, as memory holds them (about 200 bytes each once derived): split the file, or load a sample of its episodes"
        )
    )]
    TooManyPoints { line: u64, max: usize },
    #[error("the CSV is malformed: {message}")]
    #[diagnostic(code(advise::trace::csv))]
    Csv { message: String },
    #[error("the JSON trace is malformed: {message}")]
    #[diagnostic(
        code(advise::trace::json),
        help(r#"a JSON trace is {{"domain": NAME, "points": [{{"t": .., "z": [..], "a": [..], "pose": [x, y, theta]}}]}}"#)
    )]
    Json {
        message: String,
        #[label("here")]
        at: Loc,
    },
    #[error("point {index} of the JSON trace: {what}")]
    #[diagnostic(code(advise::trace::json_point))]
    JsonPoint { index: usize, what: String },
    #[error("the trace is for the `{found}` domain, not `{expected}`")]
    #[diagnostic(
        code(advise::trace::domain_mismatch),
        help("switch the task first, or load a trace recorded for `{expected}`")
    )]
    DomainMismatch { expected: String, found: String },
}
