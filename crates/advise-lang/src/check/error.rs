//! Check diagnostics: one variant per mistake, each with a stable code, the source, a label and,
//! where there is an obvious fix, a hint.

use miette::Diagnostic;
use thiserror::Error;

use crate::diag::Loc;
use crate::syntax::ParseError;

/// Something wrong with a program that parsed.
#[derive(Debug, Error, Diagnostic, Clone)]
pub enum CheckError {
    #[error("there is no domain `{name}`")]
    #[diagnostic(code(advise::check::unknown_domain))]
    UnknownDomain {
        name: String,
        #[help]
        help: String,
        #[label("unknown domain")]
        span: Loc,
    },
    #[error("`{name}` is not a dimension of the `{domain}` domain")]
    #[diagnostic(code(advise::check::unknown_dimension))]
    UnknownDimension {
        name: String,
        domain: String,
        #[help]
        help: String,
        #[label("unknown dimension")]
        span: Loc,
    },
    #[error("`{name}` is not a dimension, a parameter or a built-in")]
    #[diagnostic(code(advise::check::unknown_name))]
    UnknownName {
        name: String,
        #[help]
        help: String,
        #[label("unknown name")]
        span: Loc,
    },
    #[error("there is no function `{name}`")]
    #[diagnostic(code(advise::check::unknown_function))]
    UnknownFunction {
        name: String,
        #[help]
        help: String,
        #[label("unknown function")]
        span: Loc,
    },
    #[error("`{func}` takes {expected} argument{}, found {found}", if *expected == 1 { "" } else { "s" })]
    #[diagnostic(code(advise::check::function_arity), help("{signature}"))]
    WrongArity {
        func: String,
        expected: usize,
        found: usize,
        signature: String,
        #[label("{found} argument{}", if *found == 1 { "" } else { "s" })]
        span: Loc,
    },
    #[error("there is no operator `{name}` for the `{domain}` domain")]
    #[diagnostic(code(advise::check::unknown_operator))]
    UnknownOperator {
        name: String,
        domain: String,
        #[help]
        help: String,
        #[label("unknown operator")]
        span: Loc,
    },
    #[error("`{name}` is an operator for the `{op_domain}` domain, not `{domain}`")]
    #[diagnostic(
        code(advise::check::wrong_domain),
        help(
            "a composition can only use operators of its own domain, whose dimensions they modify"
        )
    )]
    WrongDomain {
        name: String,
        op_domain: String,
        domain: String,
        #[label("an operator for `{op_domain}`")]
        span: Loc,
    },
    #[error("`{operator}` has no parameter `{name}`")]
    #[diagnostic(code(advise::check::unknown_parameter))]
    UnknownParameter {
        name: String,
        operator: String,
        #[help]
        help: String,
        #[label("unknown parameter")]
        span: Loc,
    },
    #[error("`{operator}` takes {expected} argument{}, found {found}", if *expected == 1 { "" } else { "s" })]
    #[diagnostic(code(advise::check::wrong_arity), help("{signature}"))]
    TooManyArguments {
        operator: String,
        expected: usize,
        found: usize,
        signature: String,
        #[label("one too many")]
        span: Loc,
    },
    #[error("`{operator}` needs a value for `{param}`")]
    #[diagnostic(
        code(advise::check::missing_argument),
        help(
            "write `{operator}({param} = ...)`, or give `{param}` a default where `{operator}` is defined"
        )
    )]
    MissingArgument {
        operator: String,
        param: String,
        #[label("`{param}` is not given")]
        span: Loc,
    },
    #[error("`{name}` is given twice")]
    #[diagnostic(code(advise::check::duplicate_argument), help("remove one of them"))]
    DuplicateArgument {
        name: String,
        #[label("given again here")]
        span: Loc,
    },
    #[error("`{operator}` modifies {op_space}s, but `{dim}` is an {dim_space} dimension")]
    #[diagnostic(
        code(advise::check::mixed_spaces),
        help(
            "an operator pairs a modified observation with the executed action, or the executed observation with a modified action, never both; split it into two operators"
        )
    )]
    MixedSpaces {
        operator: String,
        dim: String,
        op_space: String,
        dim_space: String,
        #[label("an {dim_space} dimension")]
        span: Loc,
    },
    #[error("`{operator}` modifies {op_space}s, but `{callee}` modifies {callee_space}s")]
    #[diagnostic(
        code(advise::check::mixed_composition),
        help("a composition modifies one space: observations or actions, never both")
    )]
    MixedComposition {
        operator: String,
        callee: String,
        op_space: String,
        callee_space: String,
        #[label("modifies {callee_space}s")]
        span: Loc,
    },
    #[error("{value} is outside the limits of `{dim}`, [{lo}, {hi}]")]
    #[diagnostic(
        code(advise::check::literal_out_of_range),
        help("the result would be clamped to {clamped}; write a value in [{lo}, {hi}]")
    )]
    LiteralOutOfRange {
        dim: String,
        value: f64,
        lo: f64,
        hi: f64,
        clamped: f64,
        #[label("outside [{lo}, {hi}]")]
        span: Loc,
    },
    #[error("the {what} {value} of `{param}` is outside its limits [{lo}, {hi}]")]
    #[diagnostic(code(advise::check::parameter_out_of_range), help("{help}"))]
    ParamOutOfRange {
        what: String,
        param: String,
        value: f64,
        lo: f64,
        hi: f64,
        /// In a file: write another value or widen the limits; at the prompt: give another value.
        help: String,
        #[label("outside [{lo}, {hi}]")]
        span: Loc,
    },
    #[error("the domain `{name}` is declared twice")]
    #[diagnostic(code(advise::check::duplicate_domain), help("{first}"))]
    DuplicateDomain {
        name: String,
        first: String,
        #[label("declared again here")]
        span: Loc,
    },
    #[error("this `{name}` domain differs from the standard one: {difference}")]
    #[diagnostic(
        code(advise::check::conflicting_domain),
        help(
            "a file may use the standard `{name}` domain without declaring it; remove this declaration, make it identical, or rename the domain"
        )
    )]
    ConflictingDomain {
        name: String,
        difference: String,
        #[label("differs from the standard `{name}`")]
        span: Loc,
    },
    #[error("the dimension `{name}` is declared twice")]
    #[diagnostic(
        code(advise::check::duplicate_dimension),
        help("dimension names are unique across observations and actions; rename one")
    )]
    DuplicateDimension {
        name: String,
        #[label("declared again here")]
        span: Loc,
    },
    #[error("the operator `{name}` for `{domain}` is defined twice")]
    #[diagnostic(code(advise::check::duplicate_operator), help("{first}"))]
    DuplicateOperator {
        name: String,
        domain: String,
        first: String,
        #[label("defined again here")]
        span: Loc,
    },
    #[error("the parameter `{name}` is declared twice")]
    #[diagnostic(
        code(advise::check::duplicate_parameter),
        help("rename or remove one of them")
    )]
    DuplicateParameter {
        name: String,
        #[label("declared again here")]
        span: Loc,
    },
    #[error("`{name}` is assigned twice")]
    #[diagnostic(
        code(advise::check::duplicate_assignment),
        help(
            "every statement reads the point as it was before the operator, so the second assignment would silently win; combine them into one"
        )
    )]
    DuplicateAssignment {
        name: String,
        #[label("assigned again here")]
        span: Loc,
    },
    #[error("`{name}` is reserved: it means {meaning}")]
    #[diagnostic(code(advise::check::reserved_name), help("choose another name"))]
    ReservedName {
        name: String,
        meaning: String,
        #[label("reserved")]
        span: Loc,
    },
    #[error("the parameter `{name}` has the name of a dimension of `{domain}`")]
    #[diagnostic(
        code(advise::check::parameter_shadows_dimension),
        help(
            "inside the operator `{name}` could mean either; rename the parameter, e.g. `{name}_factor`"
        )
    )]
    ParamShadowsDimension {
        name: String,
        domain: String,
        #[label("also a dimension")]
        span: Loc,
    },
    #[error("the limits [{lo}, {hi}] are empty")]
    #[diagnostic(
        code(advise::check::empty_limits),
        help("write the lower limit first: [{hi}, {lo}]")
    )]
    EmptyLimits {
        lo: f64,
        hi: f64,
        #[label("lower limit above upper limit")]
        span: Loc,
    },
    #[error("{what} must be a constant")]
    #[diagnostic(
        code(advise::check::not_constant),
        help("use numbers, `pi` and arithmetic, e.g. `pi / 2`")
    )]
    NotConstant {
        what: String,
        #[label("`{name}` is not a constant")]
        span: Loc,
        name: String,
    },
    #[error("the constant is {value}, not a finite number")]
    #[diagnostic(code(advise::check::not_finite), help("a division by zero?"))]
    NotFinite {
        value: f64,
        #[label("not finite")]
        span: Loc,
    },
    #[error("expected {expected}, found {found}")]
    #[diagnostic(code(advise::check::type_mismatch))]
    TypeMismatch {
        expected: String,
        found: String,
        #[help]
        help: Option<String>,
        #[label("this is {found}")]
        span: Loc,
    },
    #[error("`{name}[...]` reads another point, but `{name}` is not a dimension")]
    #[diagnostic(
        code(advise::check::offset_needs_dimension),
        help("only dimensions have values at other points, e.g. `bearing[-3]`")
    )]
    OffsetNeedsDimension {
        name: String,
        #[label("not a dimension")]
        span: Loc,
    },
    #[error("`{name}` uses itself: {cycle}")]
    #[diagnostic(
        code(advise::check::recursive_operator),
        help("compositions must not loop, so that every operator terminates")
    )]
    RecursiveOperator {
        name: String,
        cycle: String,
        #[label("this call leads back to `{name}`")]
        span: Loc,
    },
    #[error("an argument of a composition cannot use `{name}`")]
    #[diagnostic(
        code(advise::check::per_point_argument),
        help(
            "arguments are evaluated once per application, before any point is visited: use parameters, numbers, `n` and `pi`"
        )
    )]
    PerPointArgument {
        name: String,
        #[label("differs from point to point")]
        span: Loc,
    },
    #[error("the operator `{name}` changes nothing")]
    #[diagnostic(
        code(advise::check::empty_operator),
        help("add a statement such as `rot = 0`")
    )]
    EmptyOperator {
        name: String,
        #[label("no statements")]
        span: Loc,
    },
    #[error("`{name}` expands to {stages} per-point stages, more than {limit}")]
    #[diagnostic(
        code(advise::check::composition_too_large),
        help(
            "every application runs each stage a composition expands to over the whole chunk, so compositions may expand to at most {limit} stages; {chain}. Compose fewer times, or advise with the parts one after another"
        )
    )]
    CompositionTooLarge {
        name: String,
        stages: String,
        limit: usize,
        chain: String,
        #[label("expands to {stages} stages")]
        span: Loc,
    },
    #[error("`{name}` computes {nodes} terms, more than {limit}")]
    #[diagnostic(
        code(advise::check::operator_too_large),
        help(
            "an operator's guard and statements may hold at most {limit} numbers, names and operators in all; split it into several operators and compose them"
        )
    )]
    OperatorTooLarge {
        name: String,
        nodes: usize,
        limit: usize,
        #[label("{nodes} terms")]
        span: Loc,
    },
    #[error("`{name}` declares {count} parameters, more than {limit}")]
    #[diagnostic(
        code(advise::check::too_many_parameters),
        help(
            "an operator may declare at most {limit} parameters; split it into several operators"
        )
    )]
    TooManyParameters {
        name: String,
        count: usize,
        limit: usize,
        #[label("parameter {} of {count}", limit + 1)]
        span: Loc,
    },
    #[error("stopped after {shown} errors; there may be more")]
    #[diagnostic(
        code(advise::check::too_many_errors),
        help("fix these and check again to see the rest")
    )]
    TooManyErrors { shown: usize },
    #[error("{what} holds {size} of operator text; one check takes at most {limit}")]
    #[diagnostic(
        code(advise::check::too_large),
        help(
            "split the operators into files checked apart (each check holds what it reads, about 20 times the text at worst, so this bound keeps one check's memory under about 1.5 GB)"
        )
    )]
    TooLarge {
        what: String,
        size: String,
        limit: String,
    },
    #[error("more than {limit} operators in one check")]
    #[diagnostic(
        code(advise::check::too_many_operators),
        help(
            "split the operators into files checked apart (each operator costs a few KB while it is checked, so this bound keeps one check's memory under about 1.5 GB)"
        )
    )]
    TooManyOperators {
        limit: usize,
        #[label("the operator past the limit")]
        span: Loc,
    },

    // Task declarations.
    #[error("`{name}` is not a value of the task `{task}`")]
    #[diagnostic(code(advise::check::task_unknown_name))]
    TaskUnknownName {
        name: String,
        task: String,
        #[help]
        help: String,
        #[label("unknown name")]
        span: Loc,
    },
    #[error("`{name}` cannot be read in {context}")]
    #[diagnostic(code(advise::check::task_name_not_here))]
    TaskNameNotHere {
        name: String,
        context: String,
        #[help]
        help: String,
        #[label("not available here")]
        span: Loc,
    },
    #[error("`{name}` depends on itself: {chain}")]
    #[diagnostic(
        code(advise::check::task_cycle),
        help(
            "a value is computed from the pose, the goal and values before it; to use the previous step's value write `prev(NAME)` of a value that does not itself read `prev`"
        )
    )]
    TaskCycle {
        name: String,
        chain: String,
        #[label("defined in terms of itself")]
        span: Loc,
    },
    #[error("the task `{task}` has no {what}")]
    #[diagnostic(code(advise::check::task_incomplete))]
    TaskIncomplete {
        task: String,
        what: String,
        #[help]
        help: String,
        #[label("this task")]
        span: Loc,
    },
    #[error("the task `{task}` has no success rule")]
    #[diagnostic(
        code(advise::check::task_missing_success),
        help(
            "say when a run succeeds, judged on its final state, e.g. `success when error < 0.2`"
        )
    )]
    TaskMissingSuccess {
        task: String,
        #[label("this task")]
        span: Loc,
    },
    #[error("the observation `{name}` has no definition")]
    #[diagnostic(
        code(advise::check::task_undefined_observation),
        help(
            "in a task every observation says how it is computed: `{name} = EXPR`, an expression of the pose (`x`, `y`, `theta`), the speeds (`v`, `w`), `t`, the goal and the task's `let`s"
        )
    )]
    TaskUndefinedObservation {
        name: String,
        #[label("computed how?")]
        span: Loc,
    },
    #[error("the action `{name}` does not drive the base")]
    #[diagnostic(
        code(advise::check::task_undriven_action),
        help(
            "say what it commands: `{name} drives speed`, `{name} drives turn`, or `{name} changes speed in [-1, 1]` for a change of speed the task adds up"
        )
    )]
    TaskUndrivenAction {
        name: String,
        #[label("drives what?")]
        span: Loc,
    },
    #[error("{what}")]
    #[diagnostic(code(advise::check::task_wrong_meaning))]
    TaskWrongMeaning {
        what: String,
        #[help]
        help: String,
        #[label("here")]
        span: Loc,
    },
    #[error("there is no axis `{name}` to drive")]
    #[diagnostic(
        code(advise::check::task_unknown_axis),
        help("a base has two axes: `speed` (translational, m/s) and `turn` (rotational, rad/s)")
    )]
    TaskUnknownAxis {
        name: String,
        #[label("not an axis")]
        span: Loc,
    },
    #[error("`{axis}` is driven by two actions")]
    #[diagnostic(
        code(advise::check::task_axis_driven_twice),
        help("each axis takes its command from one action; the first is `{first}`")
    )]
    TaskAxisTwice {
        axis: String,
        first: String,
        #[label("driven again here")]
        span: Loc,
    },
    #[error("`{name}` is declared twice in the task")]
    #[diagnostic(code(advise::check::task_duplicate_name), help("{help}"))]
    TaskDuplicateName {
        name: String,
        help: String,
        #[label("declared again here")]
        span: Loc,
    },
    #[error("the flaw `{name}` is declared twice in the task")]
    #[diagnostic(
        code(advise::check::flaw_twice),
        help(
            "each flaw has its own name, which `suggest` shows; rename one or join the conditions with `or`"
        )
    )]
    FlawTwice {
        name: String,
        #[label("declared again here")]
        span: Loc,
    },
    #[error("`{func}` looks back over a stretch of the run, which {context} cannot")]
    #[diagnostic(code(advise::check::window_not_here), help("{help}"))]
    WindowNotHere {
        func: String,
        context: String,
        help: String,
        #[label("not available here")]
        span: Loc,
    },
    #[error("a task has one `{clause}` clause")]
    #[diagnostic(code(advise::check::task_clause_twice), help("merge the two into one"))]
    TaskClauseTwice {
        clause: String,
        #[label("a second one")]
        span: Loc,
    },
    #[error("the goal parameter `{name}` has no range")]
    #[diagnostic(
        code(advise::check::task_goal_needs_range),
        help("practice and test goals are drawn from it: `{name} \"m\" in [-2, 2]`")
    )]
    TaskGoalNeedsRange {
        name: String,
        #[label("drawn from where?")]
        span: Loc,
    },
    #[error(
        "the goal parameter `{name}` is drawn from [{lo}, {hi}], which reaches past the largest goal, ±{max}"
    )]
    #[diagnostic(
        code(advise::check::task_goal_range_out_of_bounds),
        help(
            "practice and test goals are drawn uniformly from the range: keep both bounds within [-{max}, {max}] (in the parameter's unit), e.g. `{name} \"m\" in [-10, 10]`"
        )
    )]
    TaskGoalRangeOutOfBounds {
        name: String,
        /// The bounds and the largest magnitude, as numbers are written in the language.
        lo: String,
        hi: String,
        max: String,
        #[label("this range")]
        span: Loc,
    },
    #[error("{what} `{name}` {never}: it is {value} {at}")]
    #[diagnostic(code(advise::check::task_not_finite))]
    TaskNotFinite {
        /// "the observation", "the value", "the score".
        what: String,
        name: String,
        /// "is never a number", "is not a number at the start of any run", ...
        never: String,
        value: String,
        /// Where it was tried: "at x = 0, px = 1.5".
        at: String,
        #[help]
        help: String,
        #[label("not a number")]
        span: Loc,
    },
    #[error("{what} cannot hold: {why}")]
    #[diagnostic(code(advise::check::task_impossible_limit))]
    TaskImpossibleLimit {
        what: String,
        why: String,
        #[help]
        help: String,
        #[label("here")]
        span: Loc,
    },
    #[error("the teacher writes `{name}`, which is not an action")]
    #[diagnostic(code(advise::check::teacher_writes_non_action))]
    TeacherWritesNonAction {
        name: String,
        #[help]
        help: String,
        #[label("not an action of the domain")]
        span: Loc,
    },
    #[error("`{name}` is not a goal parameter")]
    #[diagnostic(code(advise::check::task_recorded_unknown))]
    TaskRecordedUnknown {
        name: String,
        #[help]
        help: String,
        #[label("not a goal parameter")]
        span: Loc,
    },
    #[error("`recorded` does not say how to read the goal parameter `{name}`")]
    #[diagnostic(
        code(advise::check::task_recorded_incomplete),
        help(
            "a recording's goal is read from the pose it ends at: add `{name} = ...` (an expression of `x`, `y` and `theta`)"
        )
    )]
    TaskRecordedIncomplete {
        name: String,
        #[label("this clause")]
        span: Loc,
    },
    #[error("`{shape}` is not a shape a task can draw")]
    #[diagnostic(code(advise::check::task_draw_shape))]
    TaskDrawShape {
        shape: String,
        /// "did you mean", or the shapes: `pose(x, y, heading)`, `point(x, y)`, `circle(x, y, radius)`.
        #[help]
        help: String,
        #[label("not `pose`, `point` or `circle`")]
        span: Loc,
    },
    #[error("`{shape}` takes {expected} values, found {found}")]
    #[diagnostic(code(advise::check::task_draw_arity), help("{signature}"))]
    TaskDrawArity {
        shape: String,
        expected: usize,
        found: usize,
        signature: String,
        #[label("{found} value{}", if *found == 1 { "" } else { "s" })]
        span: Loc,
    },
}

/// A diagnostic from either front-end phase (parse or check), so one list can hold all of a
/// check's errors. (Not [`crate::files::FileError`], which is a file that cannot be read.)
#[derive(Debug, Error, Diagnostic, Clone)]
pub enum ParseOrCheckError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    Parse(#[from] ParseError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Check(#[from] CheckError),
}

/// Every error of every file of one check, in file and source order.
#[derive(Debug, Error, Diagnostic, Clone)]
#[error("{}", summary(errors))]
#[diagnostic(code(advise::check::failed))]
pub struct CheckErrors {
    #[related]
    pub errors: Vec<ParseOrCheckError>,
}

fn summary(errors: &[ParseOrCheckError]) -> String {
    match errors.len() {
        1 => "1 error".into(),
        n => format!("{n} errors"),
    }
}

/// Something legal that may not be what the author meant; reported, never refused.
#[derive(Debug, Error, Diagnostic, Clone)]
pub enum CheckWarning {
    #[error("`{name}` shadows the standard operator `{name}` for `{domain}`")]
    #[diagnostic(
        code(advise::check::shadows_standard),
        severity(Warning),
        help(
            "the standard `{name}` is defined in {origin}; from here on `{name}` means this one (standard compositions keep using theirs). Rename it to keep both"
        )
    )]
    ShadowsStandard {
        name: String,
        domain: String,
        origin: String,
        #[label("shadows the standard `{name}`")]
        span: Loc,
    },
    /// A task's value that is not a number at some of the points the checker tried: a run that
    /// reaches such a point is stopped there (`advise::task::non_finite`).
    #[error("{what} `{name}` may not be a number: it is {value} {at}")]
    #[diagnostic(code(advise::check::task_maybe_not_finite), severity(Warning))]
    TaskMaybeNotFinite {
        what: String,
        name: String,
        value: String,
        at: String,
        #[help]
        help: String,
        #[label("not a number there")]
        span: Loc,
    },
}
