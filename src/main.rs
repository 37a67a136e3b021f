//! The `advise` command line: a thin layer over the library. It parses the arguments
//! ([`advise_cli::cli`]), calls one library function per subcommand, and renders errors as miette
//! diagnostics. The session subcommands (`repl`, `run`, `resume`) are here; the operator tools
//! (`check`, `apply`) are in [`advise_cli::cli::operators`], the others in [`advise_cli::cli::tools`].

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use miette::{IntoDiagnostic, miette};

use advise::diag::SourceMap;
use advise::session::{Session, SessionOptions, journal, script};
use advise::task::TaskKind;
use advise_cli::cli::{self, CliError, Command, SessionArgs, operators, tools};
use advise_cli::web;

/// mimalloc, not glibc's malloc: parsing allocates for every token, and a tree built on one of
/// `advise check`'s parse threads is freed on the checker's, which glibc makes slow (a 50 MB file
/// took 9.3 s of CPU on two threads against 6.4 s on one; with mimalloc 5.2 s, and 5.0 s on one).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    advise_cli::terminal::install();
    let cli = match cli::parse_args() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    let result = match cli.command {
        None => repl(SessionArgs::default(), None),
        Some(Command::Repl { session, view }) => repl(
            session,
            view.view.then_some((view.listen, view.allow_hosts)),
        ),
        Some(Command::Serve {
            session,
            listen,
            allow_hosts,
        }) => serve(session, listen, allow_hosts),
        Some(Command::Run {
            script,
            keep_going,
            session,
        }) => run_script(&script, keep_going, &session),
        Some(Command::Resume { journal }) => resume(journal),
        Some(Command::Check { tasks, files }) if files.is_empty() && tasks.is_empty() => {
            operators::check_standard()
        }
        Some(Command::Check { tasks, files }) => operators::check_files(&tasks, &files),
        Some(Command::Fmt { check, files }) => operators::fmt(&files, check),
        Some(Command::Test { tasks, files }) => operators::test(&tasks, &files),
        Some(Command::Lsp) => advise_lsp::run_stdio().map(|()| ExitCode::SUCCESS),
        Some(Command::Apply {
            operators,
            op,
            trace,
            range,
            domain,
            episode,
        }) => operators::apply(&operators, &op, &trace, &range, domain.as_deref(), episode),
        Some(Command::Demo(args)) => tools::demo(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Eval(args)) => tools::eval(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Experiment(args)) => tools::experiment(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Calibrate(args)) => tools::calibrate(args).map(|()| ExitCode::SUCCESS),
        Some(Command::RmpEmulator(args)) => tools::rmp_emulator(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Import(args)) => tools::import(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Export(args)) => tools::export(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Ros2Sim(args)) => tools::ros2_sim(args).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(report) => {
            cli::print_report(&advise::diag::SourceMap::new(), report.as_ref());
            ExitCode::FAILURE
        }
    }
}

/// A session on `--task`, with `--tasks FILE...` loaded. A declared task is reached as a teacher
/// would reach it, by the statements `tasks FILE` and `task NAME` (journalled, so a resumed
/// session has them), then `load demos teacher:N` when the task has a teacher.
fn new_session(args: &SessionArgs, demos: usize) -> miette::Result<Session> {
    // Every mistake in the files, or an unknown name, is reported before anything starts.
    cli::resolve_task(&args.task, &args.tasks)?;
    let builtin = TaskKind::builtin(&args.task).is_some();
    let opts = SessionOptions {
        progress: true,
        ..SessionOptions::starting_on(&args.task, args.seed, demos)
    };
    let mut session = Session::new(opts)?;
    // The session starts on `--task`: a file's hint to switch to it would be a step already taken.
    let switch = format!("; switch with `task {}`", args.task);
    session.reach_task(&args.task, &args.tasks, demos, &mut |origin, reply| {
        let reply = reply.to_string();
        match origin {
            "--tasks" => match reply.strip_suffix(&switch).filter(|_| !builtin) {
                Some(checked) => {
                    advise_cli::errln!("{checked}; the session starts on task {}", args.task)
                }
                None => advise_cli::errln!("{reply}"),
            },
            "--demos" => advise_cli::errln!("{reply}"),
            _ => {}
        }
    })?;
    Ok(session)
}

/// The main job: the REPL on the simulator with the default demonstrations loaded; with
/// `--view` (`view` is its address), the web view of the same session beside it.
fn repl(
    args: SessionArgs,
    view: Option<(std::net::SocketAddr, Vec<String>)>,
) -> miette::Result<ExitCode> {
    let mut session = new_session(&args, args.demos)?;
    start_journal(&mut session, &args)?;
    choose_backend(&mut session, &args)?;
    let Some((listen, allow_hosts)) = view else {
        advise_cli::repl::run(&mut session).into_diagnostic()?;
        return Ok(ExitCode::SUCCESS);
    };
    let hub = web::Hub::new(session);
    let server = start_view(&hub, listen, allow_hosts)?;
    hub.with(|s| advise_cli::repl::greet(s));
    let signal = hub.stop_signal();
    let ended = advise_cli::repl::run_on(&mut web::ReplSide(hub.clone()), &signal);
    // `quit` or end of input: a page's statement under way is finished (journalled) and
    // answered before the process leaves; none starts after.
    hub.close();
    server.shutdown(VIEW_GRACE);
    ended.into_diagnostic()?;
    Ok(ExitCode::SUCCESS)
}

/// How long the view, once the REPL ends, gives a page's reply under way to be sent.
const VIEW_GRACE: std::time::Duration = std::time::Duration::from_secs(5);

/// `advise serve`: the session with only the web view, until Ctrl-C (the first stops the base,
/// a second leaves).
fn serve(
    args: SessionArgs,
    listen: std::net::SocketAddr,
    allow_hosts: Vec<String>,
) -> miette::Result<ExitCode> {
    let mut session = new_session(&args, args.demos)?;
    start_journal(&mut session, &args)?;
    choose_backend(&mut session, &args)?;
    let hub = web::Hub::new(session);
    advise_cli::repl::install_ctrl_c(&hub.stop_signal());
    let server = start_view(&hub, listen, allow_hosts)?;
    hub.with(|s| advise_cli::outln!("advise: {}", s.status()));
    advise_cli::outln!("Ctrl-C stops the base; twice leaves");
    server.wait();
    Ok(ExitCode::SUCCESS)
}

/// Start the web view on `listen` and print its URLs: this machine's (also the one an SSH tunnel
/// opens, with its local port), and listening beyond loopback, another machine's, with a warning.
fn start_view(
    hub: &web::Hub,
    listen: std::net::SocketAddr,
    allow_hosts: Vec<String>,
) -> miette::Result<web::Server> {
    let server = web::start_allowing(hub.clone(), listen, web::Limits::default(), allow_hosts)?;
    if !web::is_private(&server.addr) {
        advise_cli::errln!(
            "warning: the view listens on {}, reachable from other machines; anyone with the URL can drive the session (and its robot)",
            server.addr
        );
    }
    advise_cli::outln!("view: {}", server.url);
    for url in &server.remote_urls {
        advise_cli::outln!("view from another machine: {url}");
    }
    if web::is_private(&server.addr) {
        advise_cli::outln!(
            "(from another machine: `ssh -L 8765:localhost:{} THIS_HOST`, then open the URL with port 8765)",
            server.addr.port()
        );
    }
    hub.with(|s| {
        if let Some(j) = s.journal_path() {
            advise_cli::outln!("journal: {}", j.display());
        }
    });
    Ok(server)
}

/// `--backend`: the same as the statement `backend SPEC` (journalled, so a resume can say which
/// base the session was on; a resume never connects).
fn choose_backend(session: &mut Session, args: &SessionArgs) -> miette::Result<()> {
    let backend = cli::backend_with_topics(
        &args.backend,
        args.cmd_topic.as_deref(),
        args.odom_topic.as_deref(),
    )?;
    if backend != "sim" {
        let reply = session.execute(&format!("backend {backend}"), "--backend")?;
        advise_cli::errln!("{reply}");
    }
    Ok(())
}

/// A new journal (unless `--no-journal`), starting with what the session already holds.
fn start_journal(session: &mut Session, args: &SessionArgs) -> miette::Result<()> {
    if args.no_journal {
        session.without_journal();
        return Ok(());
    }
    session.start_journal(&journal::default_dir())?;
    Ok(())
}

/// Run a script as the REPL would run its lines: the same starting demonstrations (`--demos`),
/// the same journal; the first failing statement stops it (unless `keep_going`).
fn run_script(path: &Path, keep_going: bool, args: &SessionArgs) -> miette::Result<ExitCode> {
    let mut files = SourceMap::new();
    let text = match advise::files::read_source(&mut files, path) {
        Ok(id) => files.text(id).to_string(),
        Err(e) => return Err(files.attach(e).into()),
    };
    let mut session = new_session(args, args.demos)?;
    start_journal(&mut session, args)?;
    if let Some(j) = session.journal_path() {
        advise_cli::errln!("journal: {} (`advise resume` restores it)", j.display());
    }
    choose_backend(&mut session, args)?;
    // A script that drives a real base is stopped by Ctrl-C like the REPL.
    advise_cli::repl::install_ctrl_c(&session.stop_signal());
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let failures = script::replay(
        &mut session,
        path,
        &text,
        keep_going,
        colour,
        &mut std::io::stdout(),
        &mut std::io::stderr(),
    )
    .map_err(|source| CliError::Write {
        path: "standard output".into(),
        source,
    })?;
    if failures > 0 {
        advise_cli::errln!(
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
    advise_cli::outln!("{}", restored.summary(&path));
    let mut session = restored.session;
    if let Some(stopped) = &restored.stopped {
        cli::print_report(session.sources(), stopped);
    }
    for note in &restored.notes {
        advise_cli::outln!("note: {note}");
    }
    advise_cli::repl::run(&mut session).into_diagnostic()?;
    Ok(ExitCode::SUCCESS)
}
