//! The terminal REPL: the only code that talks to a terminal. It reads lines with rustyline (with
//! the [`helper::AdviseHelper`] for completion, hints and multi-line input), hands each statement to
//! [`advise::session::Session::execute`], and prints the reply or the diagnostic. History is kept
//! between sessions next to the journals. Ctrl-C stops the robot first and keeps the session: at
//! the prompt rustyline reads it as a key; while a statement runs (an execution on a real base) it
//! arrives as SIGINT, and [`install_ctrl_c`]'s handler raises the session's
//! [`StopSignal`](advise::backend::StopSignal), which commands the base to zero (and, on the
//! RMP, decelerate-to-zero) from the handler thread and ends the execution at its next control step. A
//! second Ctrl-C in the same statement leaves the program (after stopping the base again).
//! Ctrl-D or `quit` ends the session.

/// Write to standard output (`false`) or standard error (`true`) without ever panicking, as
/// `println!` and `eprintln!` do when the reader has gone (`advise ... 2>&1 | head -1`, issue 47):
/// the text has nowhere to go, so it is dropped, and advise goes on to end with its own exit
/// code. The REPL's and the command line's printing goes through it: [`outln!`](crate::outln),
/// [`errln!`](crate::errln) and [`err!`](crate::err) (usable without a path in the modules
/// declared after this one, which `lib.rs` marks `#[macro_use]`).
pub fn print_to(stderr: bool, args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let _ = if stderr {
        std::io::stderr().lock().write_fmt(args)
    } else {
        std::io::stdout().lock().write_fmt(args)
    };
}

/// `println!` that survives a closed pipe ([`print_to`]).
#[macro_export]
macro_rules! outln {
    () => {
        $crate::repl::print_to(false, ::std::format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::repl::print_to(false, ::std::format_args!("{}\n", ::std::format_args!($($arg)*)))
    };
}

/// `eprintln!` that survives a closed pipe ([`print_to`]).
#[macro_export]
macro_rules! errln {
    () => {
        $crate::repl::print_to(true, ::std::format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::repl::print_to(true, ::std::format_args!("{}\n", ::std::format_args!($($arg)*)))
    };
}

/// `eprint!` that survives a closed pipe ([`print_to`]).
#[macro_export]
macro_rules! err {
    ($($arg:tt)*) => {
        $crate::repl::print_to(true, ::std::format_args!($($arg)*))
    };
}

pub mod helper;

use std::sync::{Arc, Mutex, OnceLock};

use rustyline::error::ReadlineError;
use rustyline::history::DefaultHistory;
use rustyline::{CompletionType, Config, Editor};

use advise::backend::StopSignal;
use advise::session::Session;
use advise::syntax::command::is_incomplete;
use helper::{AdviseHelper, Facts};

/// Render a diagnostic whose places are in `sources` for the terminal (colour only when asked),
/// showing a bounded window of its source ([`advise::diag::render`]).
pub fn render(
    sources: &advise::diag::SourceMap,
    diag: &dyn miette::Diagnostic,
    colour: bool,
) -> String {
    advise::diag::render(sources, diag, colour)
}

/// The signal the process's SIGINT handler raises (one handler per process, so the signal it
/// raises can be replaced).
static CTRL_C: OnceLock<Mutex<Option<StopSignal>>> = OnceLock::new();

/// Make Ctrl-C (SIGINT) raise `signal` instead of killing the process: the base is stopped first.
/// A second Ctrl-C while the signal is still raised exits with status 130, after raising it again
/// (so a base is told to stop once more). Returns false if no handler could be installed (then
/// Ctrl-C kills the process as usual, and the platform's own 0.5 s command timeout and the
/// driver's watchdog are what stop the base).
pub fn install_ctrl_c(signal: &StopSignal) -> bool {
    let slot = CTRL_C.get_or_init(|| Mutex::new(None));
    *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some(signal.clone());
    static INSTALLED: OnceLock<bool> = OnceLock::new();
    *INSTALLED.get_or_init(|| {
        ctrlc::set_handler(|| {
            let current = CTRL_C
                .get()
                .and_then(|m| m.lock().unwrap_or_else(|e| e.into_inner()).clone());
            match current {
                Some(s) if s.is_raised() => {
                    s.raise();
                    errln!("\n^C again: leaving");
                    std::process::exit(130);
                }
                Some(s) => {
                    s.raise();
                    if s.has_base() {
                        errln!("\n^C: stopping the base (zero commanded)");
                    } else {
                        errln!("\n^C: stopping (Ctrl-C again to leave at once)");
                    }
                }
                None => std::process::exit(130),
            }
        })
        .is_ok()
    })
}

fn facts_of(session: &Session) -> Facts {
    Facts {
        operators: session.operator_signatures(),
        // The paper's tasks and those loaded with `tasks FILE`: refreshed after every statement.
        tasks: session.task_names(),
        backends: session.backends().completions(""),
    }
}

/// What one statement typed at the prompt gave: the text to print (or the diagnostic, rendered)
/// and whether it was `quit`.
pub struct Typed {
    pub shown: Result<String, String>,
    pub quit: bool,
}

/// The session the REPL's loop drives: one it owns ([`run`]), or one it shares with the web view
/// (`advise repl --view`, [`crate::web::Hub`]), which takes its lock for each statement.
pub trait Statements {
    /// Run one statement typed at the prompt (`origin` names it in diagnostics).
    fn execute(&mut self, text: &str, origin: &str, colour: bool) -> Typed;
    /// Stop the robot (Ctrl-C at the prompt).
    fn stop_robot(&mut self) -> String;
    /// What completion and hints offer.
    fn facts(&self) -> Facts;
}

impl Statements for Session {
    fn execute(&mut self, text: &str, origin: &str, colour: bool) -> Typed {
        typed(self, text, origin, colour)
    }

    fn stop_robot(&mut self) -> String {
        Session::stop_robot(self)
    }

    fn facts(&self) -> Facts {
        facts_of(self)
    }
}

/// Run `text` on `session` and render what it gave as the terminal shows it.
pub fn typed(session: &mut Session, text: &str, origin: &str, colour: bool) -> Typed {
    let result = session.execute(text, origin);
    shown(session, result, colour)
}

/// A statement's result as the terminal shows it (diagnostics rendered against `session`'s
/// sources).
pub fn shown(
    session: &Session,
    result: Result<advise::session::Reply, advise::session::SessionError>,
    colour: bool,
) -> Typed {
    match result {
        Ok(reply) => Typed {
            shown: Ok(reply.to_string()),
            quit: reply.is_quit(),
        },
        Err(e) => Typed {
            shown: Err(render(session.sources(), &e, colour)),
            quit: false,
        },
    }
}

/// Run the REPL on `session` until `quit` or end of input.
pub fn run(session: &mut Session) -> rustyline::Result<()> {
    greet(session);
    let signal = session.stop_signal();
    run_on(session, &signal)
}

/// The banner: the session, its journal, and what to type first.
pub fn greet(session: &Session) {
    outln!("advise: {}", session.status());
    if let Some(j) = session.journal_path() {
        outln!("journal: {} (`advise resume` restores it)", j.display());
    }
    let ds = session.learner().dataset();
    // A fresh start (not a resumed session with advice or critiques in it).
    if !ds.is_empty() && ds.advice().is_empty() && ds.critiques().is_empty() {
        outln!(
            "the starting policy comes from a few teacher demonstrations and is meant to be weak (the paper's baseline): run it, see where it goes wrong, advise it"
        );
    }
    let example = if session.task() == advise::task::TaskKind::Positioning {
        "`run goal 2 -1 0`, then `select 40..70`, `advise slow_down`"
    } else {
        "`run start 0`, then `select 40..70`, `advise NAME` (`help` lists the task's operators)"
    };
    outln!("type `help` for the commands, Tab to complete; e.g. {example}");
}

/// The REPL's loop on `statements` until `quit` or end of input; Ctrl-C raises `signal`.
pub fn run_on(statements: &mut dyn Statements, signal: &StopSignal) -> rustyline::Result<()> {
    let config = Config::builder()
        .completion_type(CompletionType::List)
        .auto_add_history(true)
        .max_history_size(10_000)?
        .build();
    let facts = Arc::new(Mutex::new(statements.facts()));
    let mut rl: Editor<AdviseHelper, DefaultHistory> = Editor::with_config(config)?;
    rl.set_helper(Some(AdviseHelper::new(facts.clone())));
    let history = advise::session::journal::default_dir().join("history.txt");
    let _ = rl.load_history(&history);
    let colour = std::io::IsTerminal::is_terminal(&std::io::stdout());
    install_ctrl_c(signal);
    let mut n = 0;
    loop {
        match read_statement(&mut rl) {
            Ok(line) => {
                n += 1;
                signal.clear();
                let typed = statements.execute(&line, &format!("<input {n}>"), colour);
                match typed.shown {
                    Ok(text) if !text.is_empty() => outln!("{}", text.trim_end()),
                    Ok(_) => {}
                    Err(diagnostic) => err!("{diagnostic}"),
                }
                if typed.quit {
                    break;
                }
                if let Ok(mut f) = facts.lock() {
                    *f = statements.facts();
                }
            }
            Err(ReadlineError::Interrupted) => {
                outln!("^C {}; `quit` or Ctrl-D to leave", statements.stop_robot());
            }
            Err(ReadlineError::Eof) => break,
            Err(e) => return Err(e),
        }
    }
    if let Some(dir) = history.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    let _ = rl.save_history(&history);
    Ok(())
}

/// One statement from the terminal: a line, and while it is unfinished (an operator definition
/// with an open `{`, a doc comment waiting for its item) more lines under a `...> ` prompt, so the
/// teacher sees that more is expected. Ctrl-C at `...> ` drops the unfinished statement. A
/// command is always one line.
fn read_statement(rl: &mut Editor<AdviseHelper, DefaultHistory>) -> rustyline::Result<String> {
    let mut text = rl.readline("advise> ")?;
    while is_incomplete(&text) {
        match rl.readline("...> ") {
            Ok(more) => {
                text.push('\n');
                text.push_str(&more);
            }
            Err(ReadlineError::Interrupted) => {
                outln!("^C the unfinished statement is dropped");
                return Ok(String::new());
            }
            // The end of the input: hand on what there is, so its error is reported.
            Err(ReadlineError::Eof) => break,
            Err(e) => return Err(e),
        }
    }
    Ok(text)
}
