//! The `advise` command line: a thin layer over the library. Each subcommand parses its
//! arguments, calls one library function, and renders errors as miette diagnostics.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use miette::{Diagnostic, IntoDiagnostic, Report, WrapErr, miette};
use thiserror::Error;

use advise::backend::sim::SimParams;
use advise::eval::{self, EvalOptions, PolicyKind};
use advise::task::TaskKind;
use advise::trace::Episode;

use advise::check::{self, OperatorSet, Source};
use advise::domain::Domain;
use advise::trace::{Chunk, Trace};

#[derive(Parser)]
#[command(
    name = "advise",
    version,
    about = "Teach a robot's motion controller by critiquing and advising its executions"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Check advice-operator files (on top of the standard operators); every error of every file
    /// is reported, and the exit code is non-zero if there was any.
    Check {
        /// Operator files (`*.adv`).
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Apply an operator to a range of a trace and print the synthesized points as CSV.
    Apply {
        /// Extra operator files, checked on top of the standard operators (repeatable).
        #[arg(long = "operators", value_name = "FILE")]
        operators: Vec<PathBuf>,
        /// The operator and its arguments: `speed_up`, `speed_up(0.5)`, `speed_up(rate = 0.5)`.
        #[arg(long, value_name = "NAME[(ARGS)]")]
        op: String,
        /// The trace (CSV with a header, or JSON).
        #[arg(long, value_name = "TRACE")]
        trace: PathBuf,
        /// Half-open, 0-based range of points: `A..B`.
        #[arg(long, value_name = "A..B")]
        range: String,
        /// The trace's domain; by default it is recognised from the CSV header or JSON.
        #[arg(long)]
        domain: Option<String>,
    },
    /// Record teacher demonstrations in the simulator (one file, many episodes).
    Demo(DemoArgs),
    /// Run a policy over the task's fixed test set and print the figures.
    Eval(EvalArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum TaskArg {
    Positioning,
    Interception,
}

impl From<TaskArg> for TaskKind {
    fn from(t: TaskArg) -> TaskKind {
        match t {
            TaskArg::Positioning => TaskKind::Positioning,
            TaskArg::Interception => TaskKind::Interception,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum PolicyArg {
    /// 1-nearest-neighbour (BC)
    Bc,
    /// Locally weighted regression (A-OPI)
    Lwr,
    /// The task's own teacher (needs no dataset)
    Teacher,
}

#[derive(Args)]
struct DemoArgs {
    /// The task to demonstrate.
    #[arg(long)]
    task: TaskArg,
    /// How many demonstrations (episodes) to record.
    #[arg(long, default_value_t = 9, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    count: u64,
    /// Seeds the practice starts, the simulator noise and the teacher.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output file: `.json` writes JSON episodes, anything else CSV with an `episode` column.
    #[arg(long)]
    out: PathBuf,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    sim_params: Option<PathBuf>,
}

#[derive(Args)]
struct EvalArgs {
    /// The task whose test set to run.
    #[arg(long)]
    task: TaskArg,
    /// Demonstrations to derive the policy from (a file written by `advise demo`).
    #[arg(long, value_name = "FILE")]
    dataset: Option<PathBuf>,
    /// Which policy to derive (or `teacher` to evaluate the teacher itself).
    #[arg(long, default_value = "bc")]
    policy: PolicyArg,
    /// Seeds the simulator noise; the test set itself is fixed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    sim_params: Option<PathBuf>,
}

/// Errors that belong to the command line itself.
#[derive(Debug, Error, Diagnostic)]
enum CliError {
    #[error("cannot write `{path}`")]
    #[diagnostic(
        code(advise::cli::write),
        help("check that the directory exists and is writable")
    )]
    Write {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("`--policy {policy}` needs demonstrations to learn from")]
    #[diagnostic(
        code(advise::cli::no_dataset),
        help(
            "pass `--dataset FILE` (record one with `advise demo --task TASK --out FILE`), or use `--policy teacher`"
        )
    )]
    NoDataset { policy: &'static str },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => check_standard(),
        Some(Command::Check { files }) => check_files(&files),
        Some(Command::Apply {
            operators,
            op,
            trace,
            range,
            domain,
        }) => apply(&operators, &op, &trace, &range, domain.as_deref()),
        Some(Command::Demo(args)) => demo(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Eval(args)) => run_eval(args).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(report) => {
            eprintln!("{report:?}");
            ExitCode::FAILURE
        }
    }
}

/// With no arguments (until the REPL exists): check the embedded standard operators.
fn check_standard() -> miette::Result<ExitCode> {
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
            std::fs::read_to_string(f)
                .into_diagnostic()
                .wrap_err_with(|| format!("cannot read `{}`", f.display()))
                .map(|text| Source::new(f.display().to_string(), text))
        })
        .collect()
}

fn check_files(files: &[PathBuf]) -> miette::Result<ExitCode> {
    let sources = read_sources(files)?;
    match OperatorSet::standard().merge(&sources) {
        Ok(set) => {
            let ops: usize = set.operator_count();
            println!(
                "checked {} file{}: {} domains and {} operators in all, no errors",
                files.len(),
                if files.len() == 1 { "" } else { "s" },
                set.domains().len(),
                ops
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => Ok(report_check_errors(errors, files.len())),
    }
}

fn report_check_errors(errors: check::CheckErrors, files: usize) -> ExitCode {
    let n = errors.errors.len();
    for e in errors.errors {
        eprintln!("{:?}", Report::new(e));
    }
    eprintln!(
        "advise: {n} error{} in {files} file{}",
        if n == 1 { "" } else { "s" },
        if files == 1 { "" } else { "s" }
    );
    ExitCode::FAILURE
}

fn apply(
    operators: &[PathBuf],
    op: &str,
    trace_path: &Path,
    range: &str,
    domain: Option<&str>,
) -> miette::Result<ExitCode> {
    let sources = read_sources(operators)?;
    let set = match OperatorSet::standard().merge(&sources) {
        Ok(set) => set,
        Err(errors) => return Ok(report_check_errors(errors, sources.len())),
    };
    let inv = advise::syntax::parse_invocation(op)?;
    let domain = trace_domain(&set, trace_path, domain)?;
    let trace = Trace::load(&domain, trace_path)?;
    let (a, b) = parse_range(range)?;
    let chunk = Chunk::new(a, b, trace.len())?;
    let out = advise::interp::apply(&set, &inv, &trace, chunk)?;
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

/// `A..B` as two indices.
fn parse_range(s: &str) -> miette::Result<(usize, usize)> {
    let bad = || {
        miette!(
            code = "advise::cli::bad_range",
            help = "write a half-open, 0-based range of points such as `0..20`",
            "`{s}` is not a range"
        )
    };
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a = a.trim().parse().map_err(|_| bad())?;
    let b = b.trim().parse().map_err(|_| bad())?;
    Ok((a, b))
}

/// The domain named on the command line, or the one whose dimensions the trace's header names.
fn trace_domain(set: &OperatorSet, path: &Path, name: Option<&str>) -> miette::Result<Domain> {
    let known = || {
        set.domains()
            .iter()
            .map(|d| d.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(name) = name {
        return set.domain(name).cloned().ok_or_else(|| {
            miette!(
                code = "advise::cli::unknown_domain",
                help = format!("the known domains are: {}", known()),
                "there is no domain `{name}`"
            )
        });
    }
    let text = std::fs::read_to_string(path)
        .into_diagnostic()
        .wrap_err_with(|| format!("cannot read `{}`", path.display()))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let found = if is_json {
        serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v.get("domain")?.as_str().map(str::to_string))
            .and_then(|d| set.domain(&d).cloned())
    } else {
        let header: Vec<&str> = text
            .lines()
            .next()
            .unwrap_or("")
            .split(',')
            .map(str::trim)
            .collect();
        set.domains()
            .iter()
            .find(|d| {
                d.observe
                    .iter()
                    .chain(&d.act)
                    .all(|dim| header.contains(&dim.name.as_str()))
            })
            .cloned()
    };
    found.ok_or_else(|| {
        miette!(
            code = "advise::cli::unknown_trace_domain",
            help = format!(
                "name it with `--domain` (one of: {}), or give the trace a header with the domain's columns",
                known()
            ),
            "cannot tell which domain `{}` belongs to",
            path.display()
        )
    })
}

fn sim_params(path: Option<&Path>) -> miette::Result<SimParams> {
    Ok(match path {
        Some(p) => SimParams::load(p)?,
        None => SimParams::default(),
    })
}

fn demo(args: DemoArgs) -> miette::Result<()> {
    let kind = TaskKind::from(args.task);
    let params = sim_params(args.sim_params.as_deref())?;
    let domain = kind.domain();
    let recorded = advise::task::record_demos(kind, args.count as usize, args.seed, &params);
    let successes = recorded.iter().filter(|(_, o)| o.success).count();
    let episodes: Vec<Episode> = recorded.into_iter().map(|(e, _)| e).collect();
    let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
    let write_err = |source: std::io::Error| CliError::Write {
        path: args.out.display().to_string(),
        source,
    };
    let file = std::fs::File::create(&args.out).map_err(write_err)?;
    let out = std::io::BufWriter::new(file);
    let is_json = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    if is_json {
        serde_json::to_writer(out, &Episode::to_json(&domain, &episodes))
            .map_err(|e| write_err(e.into()))?;
    } else {
        Episode::write_csv(&domain, &episodes, out).map_err(write_err)?;
    }
    eprintln!(
        "recorded {} {kind} demonstrations ({points} points) to {}; the teacher succeeded in {successes}",
        episodes.len(),
        args.out.display(),
    );
    Ok(())
}

fn run_eval(args: EvalArgs) -> miette::Result<()> {
    let kind = TaskKind::from(args.task);
    let opts = EvalOptions {
        seed: args.seed,
        params: sim_params(args.sim_params.as_deref())?,
        progress: !args.json,
    };
    let report = match args.policy {
        PolicyArg::Teacher => eval::evaluate_teacher(kind, &opts),
        PolicyArg::Bc | PolicyArg::Lwr => {
            let (learner, name) = if args.policy == PolicyArg::Bc {
                (PolicyKind::Bc, "bc")
            } else {
                (PolicyKind::Lwr, "lwr")
            };
            let path = args
                .dataset
                .as_deref()
                .ok_or(CliError::NoDataset { policy: name })?;
            let domain = kind.domain();
            let episodes = Episode::load_all(&domain, path)?;
            let policy = eval::derive_policy(learner, &domain, &episodes)?;
            eval::evaluate(kind, policy.as_ref(), &opts)
        }
    };
    let text = if args.json {
        let mut t = serde_json::to_string_pretty(&report).expect("a report is plain data");
        t.push('\n');
        t
    } else {
        report.render()
    };
    print_stdout(&text)?;
    Ok(())
}

/// Print to stdout; a closed pipe (`advise eval --json | head`) is not an error.
fn print_stdout(text: &str) -> miette::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(CliError::Write {
            path: "standard output".into(),
            source: e,
        }
        .into()),
        _ => Ok(()),
    }
}
