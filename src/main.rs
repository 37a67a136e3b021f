//! The `advise` command line: a thin layer over the library. Each subcommand parses its
//! arguments, calls one library function, and renders errors as miette diagnostics.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use advise::backend::sim::SimParams;
use advise::eval::{self, EvalOptions, PolicyKind};
use advise::task::TaskKind;
use advise::trace::Episode;
use clap::{Args, Parser, Subcommand, ValueEnum};
use miette::Diagnostic;
use thiserror::Error;

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
        None => {
            println!("advise: see `advise --help` for the commands");
            Ok(())
        }
        Some(Command::Demo(args)) => demo(args),
        Some(Command::Eval(args)) => run_eval(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(report) => {
            eprintln!("{report:?}");
            ExitCode::FAILURE
        }
    }
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
