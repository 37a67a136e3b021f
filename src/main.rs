//! The `advise` command line: a thin layer over the library. Each subcommand parses its
//! arguments, calls one library function, and renders errors as miette diagnostics.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use miette::{Diagnostic, IntoDiagnostic, Report, WrapErr, miette};
use thiserror::Error;

use advise::backend::rmp::codec::{Platform, WordOrder};
use advise::backend::rmp::config::FaultInjection;
use advise::backend::rmp::{Emulator, EmulatorConfig, RmpConfig};
use advise::backend::sim::SimParams;
use advise::backend::{BackendSpec, StopSignal};
use advise::eval::{self, EvalOptions, PolicyKind};
use advise::task::TaskKind;
use advise::trace::Episode;

use advise::check::{self, OperatorSet, Source};
use advise::domain::Domain;
use advise::session::{Session, SessionOptions, journal, script};
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
        /// Operator files (`*.adv`); with none, the standard operators are checked.
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
        /// For a demonstrations file of many episodes: which one (0-based, in file order).
        #[arg(long, value_name = "K")]
        episode: Option<usize>,
    },
    /// Record teacher demonstrations in the simulator (one file, many episodes).
    Demo(DemoArgs),
    /// Run a policy over the task's fixed test set and print the figures.
    Eval(EvalArgs),
    /// Run a session script (the REPL's commands, one per line); stops at the first failing
    /// statement unless `--keep-going`.
    Run {
        /// The script (`*.adv`).
        script: PathBuf,
        /// Report failing statements and go on.
        #[arg(long)]
        keep_going: bool,
        #[command(flatten)]
        session: SessionArgs,
    },
    /// Replay a session journal (the newest one by default) and continue in the REPL.
    Resume {
        /// The journal to replay; by default the newest in the journal folder.
        journal: Option<PathBuf>,
    },
    /// Open the REPL (what `advise` with no arguments does).
    Repl(SessionArgs),
    /// Reproduce one of the paper's studies with automated teachers and print its figures.
    Experiment(ExperimentArgs),
    /// Emulate a Segway RMP v3 on a UDP port, with the simulator behind it: what `--backend
    /// rmp:HOST:PORT` drives when no robot is at hand. Runs until Ctrl-C.
    RmpEmulator(EmulatorArgs),
    /// The simulator as a ROS 2 robot: subscribes `cmd_vel`, publishes `odom` at 50 Hz, what
    /// `--backend ros2` drives when no robot is at hand. Runs until Ctrl-C.
    Ros2Sim(Ros2SimArgs),
}

#[derive(Args)]
struct Ros2SimArgs {
    /// The robot's namespace, e.g. `/robot1` for `/robot1/cmd_vel` and `/robot1/odom`; options
    /// as in `--backend ros2:NAMESPACE?cmd=..&odom=..&domain=..`. The domain is ROS_DOMAIN_ID's.
    #[arg(long, default_value = "/", value_name = "NS")]
    namespace: String,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    sim_params: Option<PathBuf>,
    /// Seeds the simulator's noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(Clone, Copy, ValueEnum)]
enum StudyArg {
    /// Binary Critiquing on ball interception (Table 1, Figure 5).
    Bc,
    /// Advice-Operator Policy Improvement on spatial positioning (Figures 8, 9, 11).
    Aopi,
}

#[derive(Args)]
struct ExperimentArgs {
    /// Which study.
    study: StudyArg,
    /// Seeds everything: demonstrations, practice starts, simulator noise, LWR tuning.
    #[arg(long, default_value_t = 0, conflicts_with = "seeds")]
    seed: u64,
    /// Run several seeds (`0..5`: 0 to 4) and print each figure's mean and spread beside the
    /// paper's, and for how many seeds the paper's shape holds.
    #[arg(long, value_name = "A..B")]
    seeds: Option<String>,
    /// Print the result as JSON on stdout (every figure, the seed and the parameters; with
    /// `--seeds`, the summary and every run).
    #[arg(long)]
    json: bool,
    /// Write the study's plots as SVG files into this folder (created if needed).
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    sim_params: Option<PathBuf>,
}

#[derive(Args)]
struct EmulatorArgs {
    /// Address to listen on (port 0 picks a free port; the real RMP listens on 8080).
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "HOST:PORT")]
    bind: std::net::SocketAddr,
    /// Fraction of datagrams (either way) silently dropped, 0..1.
    #[arg(long, default_value_t = 0.0, value_name = "FRACTION")]
    drop: f64,
    /// Fraction of datagrams with one byte changed (the CRC catches every one), 0..1.
    #[arg(long, default_value_t = 0.0, value_name = "FRACTION")]
    corrupt: f64,
    /// Fraction of datagrams held back by `--delay-ms` (so they also arrive out of order), 0..1.
    #[arg(long, default_value_t = 0.0, value_name = "FRACTION")]
    delay: f64,
    /// How long a delayed datagram is held, ms.
    #[arg(long, default_value_t = 30)]
    delay_ms: u64,
    /// Seeds the fault injection and the simulator's noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Byte order of the feedback words (the driver detects it; the real firmware is little).
    #[arg(long, default_value = "little")]
    word_order: WordOrderArg,
    /// The platform it reports (balance mode needs an RMP 220).
    #[arg(long, default_value = "rmp220")]
    platform: PlatformArg,
    /// Simulator parameters of the base behind it (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    sim_params: Option<PathBuf>,
    /// Enter balance mode at once, without waiting for an operator to tip the base back.
    #[arg(long)]
    no_tip_back: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum WordOrderArg {
    Little,
    Big,
}

#[derive(Clone, Copy, ValueEnum)]
enum PlatformArg {
    Rmp220,
    Rmp210,
    Rmp440,
    Omni,
    Rmp110,
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
    /// The base: `sim` (the test set in parallel on fresh simulators) or `rmp:HOST:PORT` (a Segway
    /// RMP or `advise rmp-emulator`, episode after episode in real time).
    #[arg(long, default_value = "sim", value_name = "sim|rmp:HOST:PORT")]
    backend: String,
    /// Run only the first N starts of the test set (a quick check on a real base).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    limit: Option<u64>,
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

/// How a session starts.
#[derive(Args, Clone)]
struct SessionArgs {
    /// The task to start on.
    #[arg(long, default_value = "positioning")]
    task: TaskArg,
    /// Seeds the simulator, the practice starts and LWR tuning.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Teacher demonstrations recorded at start (0: start with an empty dataset).
    #[arg(long, default_value_t = 9)]
    demos: usize,
    /// Do not keep a journal.
    #[arg(long)]
    no_journal: bool,
    /// The base to drive: `sim`, or `rmp:HOST:PORT` for a Segway RMP (or `advise rmp-emulator`);
    /// the same as the session command `backend`.
    #[arg(long, default_value = "sim", value_name = "sim|rmp:HOST:PORT")]
    backend: String,
}

impl Default for SessionArgs {
    fn default() -> Self {
        SessionArgs {
            task: TaskArg::Positioning,
            seed: 0,
            demos: 9,
            no_journal: false,
            backend: "sim".into(),
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => repl(SessionArgs::default()),
        Some(Command::Repl(args)) => repl(args),
        Some(Command::Run {
            script,
            keep_going,
            session,
        }) => run_script(&script, keep_going, &session),
        Some(Command::Resume { journal }) => resume(journal),
        Some(Command::Check { files }) if files.is_empty() => check_standard(),
        Some(Command::Check { files }) => check_files(&files),
        Some(Command::Apply {
            operators,
            op,
            trace,
            range,
            domain,
            episode,
        }) => apply(&operators, &op, &trace, &range, domain.as_deref(), episode),
        Some(Command::Demo(args)) => demo(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Eval(args)) => run_eval(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Experiment(args)) => experiment(args).map(|()| ExitCode::SUCCESS),
        Some(Command::RmpEmulator(args)) => rmp_emulator(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Ros2Sim(args)) => ros2_sim(args).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(report) => {
            print_report(report.as_ref());
            ExitCode::FAILURE
        }
    }
}

/// Print a diagnostic on stderr, showing a bounded window of its source (never a whole file).
fn print_report(diag: &dyn Diagnostic) {
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr());
    eprintln!(
        "{}",
        advise::diagnostic::render_with_width(diag, colour, 80)
    );
}

fn new_session(args: &SessionArgs, demos: usize) -> miette::Result<Session> {
    let opts = SessionOptions {
        task: args.task.into(),
        seed: args.seed,
        default_demos: demos,
        progress: true,
        ..SessionOptions::default()
    };
    Ok(Session::new(opts)?)
}

/// The main job: the REPL on the simulator with the default demonstrations loaded.
fn repl(args: SessionArgs) -> miette::Result<ExitCode> {
    let mut session = new_session(&args, args.demos)?;
    start_journal(&mut session, &args)?;
    choose_backend(&mut session, &args)?;
    advise::repl::run(&mut session).into_diagnostic()?;
    Ok(ExitCode::SUCCESS)
}

/// `--backend`: the same as the statement `backend SPEC` (journalled, so a resume can say which
/// base the session was on; a resume never connects).
fn choose_backend(session: &mut Session, args: &SessionArgs) -> miette::Result<()> {
    if args.backend.trim() != "sim" {
        let reply = session.execute(&format!("backend {}", args.backend.trim()), "--backend")?;
        eprintln!("{}", reply.text);
    }
    Ok(())
}

/// A new journal (unless `--no-journal`), starting with what the session already holds.
fn start_journal(session: &mut Session, args: &SessionArgs) -> miette::Result<()> {
    if args.no_journal {
        return Ok(());
    }
    let dir = journal::default_dir();
    session
        .start_journal(&dir)
        .into_diagnostic()
        .wrap_err_with(|| format!("cannot create a journal in {}", dir.display()))?;
    Ok(())
}

/// Run a script as the REPL would run its lines: the same starting demonstrations (`--demos`),
/// the same journal; the first failing statement stops it (unless `keep_going`).
fn run_script(path: &Path, keep_going: bool, args: &SessionArgs) -> miette::Result<ExitCode> {
    let text = advise::files::read_text(path)?;
    let mut session = new_session(args, args.demos)?;
    start_journal(&mut session, args)?;
    if let Some(j) = session.journal_path() {
        eprintln!("journal: {} (`advise resume` restores it)", j.display());
    }
    choose_backend(&mut session, args)?;
    // A script that drives a real base is stopped by Ctrl-C like the REPL.
    advise::repl::install_ctrl_c(&session.stop_signal());
    let failures = replay(&mut session, path, &text, keep_going);
    if failures > 0 {
        eprintln!(
            "advise: {failures} statement{} of {} failed{}",
            if failures == 1 { "" } else { "s" },
            path.display(),
            if keep_going {
                ""
            } else {
                " (the script stopped there; `--keep-going` runs the rest)"
            }
        );
    }
    Ok(if failures == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Run the statements of `text` on `session`, printing replies and diagnostics; returns how many
/// failed.
fn replay(session: &mut Session, path: &Path, text: &str, keep_going: bool) -> usize {
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let signal = session.stop_signal();
    let mut failures = 0;
    for st in script::statements(text) {
        let origin = advise::session::origin(path, st.line);
        signal.clear();
        match session.execute(&st.text, &origin) {
            Ok(reply) => {
                let comment_only = st.text.lines().all(|l| {
                    let l = l.trim_start();
                    l.is_empty() || (l.starts_with("//") && !l.starts_with("///"))
                });
                if !comment_only {
                    println!("advise> {}", st.text.trim_end());
                    if !reply.text.is_empty() {
                        println!("{}", reply.text.trim_end());
                    }
                }
                if reply.quit {
                    break;
                }
            }
            Err(e) => {
                failures += 1;
                eprintln!("error at {origin}:");
                eprint!("{}", advise::repl::render(&e, colour));
                if !keep_going {
                    break;
                }
            }
        }
    }
    failures
}

/// Restore a journalled session (the newest by default) and continue in the REPL. Nothing is
/// re-run: no robot is connected or driven, no file but the journal is read.
fn resume(journal_path: Option<PathBuf>) -> miette::Result<ExitCode> {
    let dir = journal::default_dir();
    let path = match journal_path {
        Some(p) => p,
        None => journal::newest(&dir).ok_or_else(|| {
            miette!(
                code = "advise::resume::no_journal",
                help = "start a session with `advise` first; journals are kept in $ADVISE_HOME or ~/.advise",
                "there is no session journal in {}",
                dir.display()
            )
        })?,
    };
    let restored = Session::restore(&path, &dir)?;
    let mut session = restored.session;
    println!(
        "resumed {}: {} statements restored; {}",
        path.display(),
        restored.entries,
        session.status()
    );
    for note in &restored.notes {
        println!("note: {note}");
    }
    advise::repl::run(&mut session).into_diagnostic()?;
    Ok(ExitCode::SUCCESS)
}

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
            advise::files::read_text(f)
                .map(|text| Source::new(f.display().to_string(), text))
                .map_err(Report::from)
        })
        .collect()
}

fn check_files(files: &[PathBuf]) -> miette::Result<ExitCode> {
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

fn apply(
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
    let inv = advise::syntax::parse_invocation(op)?;
    let domain = trace_domain(&set, trace_path, domain)?;
    let trace = match episode {
        None => Trace::load(&domain, trace_path)?,
        Some(k) => {
            let mut episodes = Episode::load_all(&domain, trace_path)?;
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
    let text = advise::files::read_text(path)?;
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
    let is_json = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    advise::files::write_atomic(&args.out, |out| {
        if is_json {
            serde_json::to_writer(out, &Episode::to_json(&domain, &episodes)).map_err(Into::into)
        } else {
            Episode::write_csv(&domain, &episodes, out)
        }
    })?;
    eprintln!(
        "recorded {} {kind} demonstrations ({points} points) to {}; the teacher succeeded in {successes}",
        episodes.len(),
        args.out.display(),
    );
    Ok(())
}

fn run_eval(args: EvalArgs) -> miette::Result<()> {
    let kind = TaskKind::from(args.task);
    let backend: BackendSpec = args.backend.parse()?;
    let opts = EvalOptions {
        seed: args.seed,
        params: sim_params(args.sim_params.as_deref())?,
        progress: !args.json,
    };
    let limit = args.limit.map(|n| n as usize);
    let report = match args.policy {
        PolicyArg::Teacher if backend != BackendSpec::Sim => {
            let period = opts.params.period_s();
            eval_on_base(kind, backend.clone(), &opts, limit, || kind.teacher(period))?
        }
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
            let demos = advise::policy::dataset::load_demonstrations(&domain, path)?;
            let policy = eval::derive_policy(learner, &domain, &demos.episodes)?;
            if backend == BackendSpec::Sim {
                eval::evaluate(kind, policy.as_ref(), &opts)
            } else {
                let p: &dyn advise::policy::Policy = policy.as_ref();
                eval_on_base(kind, backend.clone(), &opts, limit, || p)?
            }
        }
    };
    let report = match (backend, limit) {
        // The simulator runs the whole test set in parallel; `--limit` keeps the first episodes.
        (BackendSpec::Sim, Some(n)) if n < report.episodes => {
            let outcomes = report.outcomes.into_iter().take(n).collect();
            eval::Report::from_outcomes(kind, args.seed, outcomes)
        }
        _ => report,
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

fn experiment(args: ExperimentArgs) -> miette::Result<()> {
    use advise::experiment::{aopi, bc, ensure_dir, plot, summary};
    let sim = sim_params(args.sim_params.as_deref())?;
    let seeds: Vec<u64> = match &args.seeds {
        None => vec![args.seed],
        Some(range) => {
            let (a, b) = parse_seeds(range)?;
            (a..b).collect()
        }
    };
    let many = args.seeds.is_some();
    let progress = true;
    let mut plots = Vec::new();
    let plot_dir = || -> miette::Result<Option<&Path>> {
        match &args.plot {
            Some(dir) => {
                ensure_dir(dir)?;
                Ok(Some(dir.as_path()))
            }
            None => Ok(None),
        }
    };
    let (text, json) = match args.study {
        StudyArg::Bc => {
            let params = bc::BcParams {
                sim,
                ..bc::BcParams::default()
            };
            let mut runs = Vec::new();
            for &seed in &seeds {
                let result = bc::run(seed, &params, progress);
                if let Some(dir) = plot_dir()? {
                    plots.extend(plot::bc(&result, dir)?);
                }
                runs.push(result);
            }
            if many {
                let s = summary::bc(runs);
                (s.render(), serde_json::to_string_pretty(&s))
            } else {
                let r = &runs[0];
                (r.render(), serde_json::to_string_pretty(r))
            }
        }
        StudyArg::Aopi => {
            let params = aopi::AopiParams {
                sim,
                ..aopi::AopiParams::default()
            };
            let mut runs = Vec::new();
            for &seed in &seeds {
                let result = aopi::run(seed, &params, progress);
                if let Some(dir) = plot_dir()? {
                    plots.extend(plot::aopi(&result, dir)?);
                }
                runs.push(result);
            }
            if many {
                let s = summary::aopi(runs);
                (s.render(), serde_json::to_string_pretty(&s))
            } else {
                let r = &runs[0];
                (r.render(), serde_json::to_string_pretty(r))
            }
        }
    };
    if args.json {
        let mut t = json.expect("a result is plain data");
        t.push('\n');
        print_stdout(&t)?;
    } else {
        print_stdout(&text)?;
    }
    for p in plots {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// `A..B` as a non-empty half-open range of seeds.
fn parse_seeds(s: &str) -> miette::Result<(u64, u64)> {
    let bad = || {
        miette!(
            code = "advise::cli::bad_seeds",
            help = "write a half-open range of seeds such as `0..5` (seeds 0 to 4)",
            "`{s}` is not a range of seeds"
        )
    };
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a: u64 = a.trim().parse().map_err(|_| bad())?;
    let b: u64 = b.trim().parse().map_err(|_| bad())?;
    if b <= a {
        return Err(bad());
    }
    Ok((a, b))
}

/// Evaluate on one real (or emulated) base, with Ctrl-C stopping it; an interrupted evaluation
/// prints the figures so far before its diagnostic.
fn eval_on_base<C, F>(
    kind: TaskKind,
    spec: BackendSpec,
    opts: &EvalOptions,
    limit: Option<usize>,
    make: F,
) -> miette::Result<eval::Report>
where
    C: eval::ControllerBox,
    F: Fn() -> C,
{
    let rmp = RmpConfig::for_sim(&opts.params);
    let mut base = spec.open(&opts.params, opts.seed, &rmp)?;
    let signal = StopSignal::new();
    let mut guarded = advise::backend::Interruptible::new(base.as_mut(), signal.clone());
    advise::repl::install_ctrl_c(&signal);
    eprintln!("evaluating {kind} on {spec} in real time; Ctrl-C stops the base");
    match eval::evaluate_on(kind, make, &mut guarded, opts, limit) {
        Ok(r) => Ok(r),
        Err(e) => {
            eprint!("{}", e.report.render());
            Err((*e).into())
        }
    }
}

/// Run the simulator as a ROS 2 robot until Ctrl-C.
fn ros2_sim(args: Ros2SimArgs) -> miette::Result<()> {
    let params = sim_params(args.sim_params.as_deref())?;
    let BackendSpec::Ros2(spec) = format!("ros2:{}", args.namespace).parse::<BackendSpec>()? else {
        unreachable!("a `ros2:` spelling parses as a ROS 2 spec")
    };
    let stop = StopSignal::new();
    advise::repl::install_ctrl_c(&stop);
    let counts = advise::backend::ros2::robot::run_robot(
        &spec,
        params,
        args.seed,
        &stop,
        |cmd, odom, domain| {
            eprintln!(
                "ros2-sim: commands on {cmd}, odometry on {odom} at 50 Hz, domain {domain}; drive it with `--backend {}`; Ctrl-C stops it",
                BackendSpec::Ros2(spec.clone())
            )
        },
    )?;
    eprintln!(
        "ros2-sim: {} commands received, {} odometry messages published",
        counts.commands, counts.odometry
    );
    Ok(())
}

/// Run the RMP emulator until Ctrl-C, printing its state changes.
fn rmp_emulator(args: EmulatorArgs) -> miette::Result<()> {
    let params = sim_params(args.sim_params.as_deref())?;
    let platform = match args.platform {
        PlatformArg::Rmp220 => Platform::Rmp220,
        PlatformArg::Rmp210 => Platform::Rmp210,
        PlatformArg::Rmp440 => Platform::Rmp440,
        PlatformArg::Omni => Platform::RmpOmni,
        PlatformArg::Rmp110 => Platform::Rmp110,
    };
    let cfg = EmulatorConfig {
        order: match args.word_order {
            WordOrderArg::Little => WordOrder::Little,
            WordOrderArg::Big => WordOrder::Big,
        },
        faults: FaultInjection {
            drop: args.drop,
            corrupt: args.corrupt,
            delay: args.delay,
            delay_ms: args.delay_ms,
        },
        seed: args.seed,
        balance_needs_tip_back: !args.no_tip_back,
        ..EmulatorConfig::for_platform(platform)
    };
    let emu = Emulator::bind_sim(args.bind, cfg.clone(), params, args.seed)?;
    let stop = StopSignal::new();
    advise::repl::install_ctrl_c(&stop);
    println!(
        "RMP emulator: an {} with {} feedback on {}, the simulator behind it{}",
        cfg.platform.name(),
        cfg.order.name(),
        emu.addr(),
        if cfg.faults.drop + cfg.faults.corrupt + cfg.faults.delay == 0.0 {
            String::new()
        } else {
            format!(
                "; dropping {}, corrupting {}, delaying {} ({} ms) of datagrams",
                cfg.faults.drop, cfg.faults.corrupt, cfg.faults.delay, cfg.faults.delay_ms
            )
        }
    );
    println!(
        "drive it with `--backend rmp:{}` (or `backend rmp:{}` in the REPL); Ctrl-C stops it",
        emu.addr(),
        emu.addr()
    );
    let mut last = None;
    while !stop.is_raised() {
        let s = emu.snapshot();
        if last != Some(s.state) {
            println!("state: {}", s.state.name());
            last = Some(s.state);
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let s = emu.snapshot();
    emu.shutdown();
    let c = s.counts;
    println!(
        "stopped in {}: {} datagrams received, {} accepted, {} bad CRC, {} bad length, {} unknown id, {} sent; injected {} drops, {} corruptions, {} delays",
        s.state.name(),
        c.received,
        c.accepted,
        c.bad_crc,
        c.bad_length,
        c.unknown_id,
        c.sent,
        c.injected_drops,
        c.injected_corruptions,
        c.injected_delays
    );
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
