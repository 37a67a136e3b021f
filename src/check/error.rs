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
    #[error("`{name}` for `{domain}` has changed since this advice was given")]
    #[diagnostic(
        code(advise::check::redefined_operator),
        help(
            "the advice was given with `{definition}`; advise again to use the `{name}` defined in {origin}"
        )
    )]
    RedefinedOperator {
        name: String,
        domain: String,
        definition: String,
        origin: String,
    },
    #[error("stopped after {shown} errors; there may be more")]
    #[diagnostic(
        code(advise::check::too_many_errors),
        help("fix these and check again to see the rest")
    )]
    TooManyErrors { shown: usize },
}

/// A diagnostic from either front-end phase, so one list can hold all of a check's errors.
#[derive(Debug, Error, Diagnostic, Clone)]
pub enum FileError {
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
    pub errors: Vec<FileError>,
}

fn summary(errors: &[FileError]) -> String {
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
}
