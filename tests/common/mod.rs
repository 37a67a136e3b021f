//! What several test files share: a session as the REPL starts it, the raw transcript of scripted
//! lines (each statement, then its reply or its rendered diagnostic), the `advise` binary run on
//! scripts in a fresh directory, and the insta filters that mask what varies from run to run.

#![allow(dead_code)] // each test file uses its own part

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use advise::backend::sim::{SimBackend, SimParams};
use advise::backend::{Backend, BackendError, BaseState};
use advise::session::{Session, SessionOptions, script};
use advise::task::TaskKind;
use advise::trace::Pose;

/// An RMP emulator on the loopback address, quick to initialise.
pub fn emulator() -> advise::backend::rmp::EmulatorHandle {
    advise::backend::rmp::Emulator::bind_sim(
        "127.0.0.1:0".parse::<std::net::SocketAddr>().unwrap(),
        advise::backend::rmp::EmulatorConfig {
            init_s: 0.05,
            ..advise::backend::rmp::EmulatorConfig::default()
        },
        SimParams::default(),
        0,
    )
    .unwrap()
}

/// Resume `journal` while a socket sits on the robot's address `addr` (the emulator gone), and
/// check that the resume sent it nothing: a resumed session never drives a robot by itself.
pub fn restore_hearing_nothing(
    journal: &Path,
    dir: &Path,
    addr: std::net::SocketAddr,
) -> advise::session::Restored {
    let robot = std::net::UdpSocket::bind(addr).unwrap();
    robot
        .set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    let restored = Session::restore(journal, dir).unwrap();
    let mut buf = [0u8; 64];
    assert!(
        robot.recv_from(&mut buf).is_err(),
        "a resume sent a datagram to the robot"
    );
    restored
}

/// Run each statement of `lines` in `s`, panicking with the rendered diagnostic of the first that
/// fails; the replies in order.
pub fn execute_all(s: &mut Session, lines: &str) -> Vec<advise::session::Reply> {
    script::statements(lines)
        .iter()
        .map(|st| match s.execute(&st.text, "<test>") {
            Ok(r) => r,
            Err(e) => panic!(
                "{}: {}",
                st.text,
                advise_cli::repl::render(s.sources(), &e, false)
            ),
        })
        .collect()
}

/// A copy of a journal beside it: what a second session resumes while the first holds the
/// journal.
pub fn copy_of(journal: &Path) -> PathBuf {
    let copy = journal.with_extension("copy.jsonl");
    std::fs::copy(journal, &copy).unwrap();
    copy
}

/// What `save PATH` writes for `s`, as bytes.
pub fn saved(s: &mut Session, path: &Path) -> Vec<u8> {
    execute_all(s, &format!("save {}", path.display()));
    std::fs::read(path).unwrap()
}

/// A positioning session with `demos` teacher demonstrations.
pub fn positioning(demos: usize) -> Session {
    Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: demos,
        ..SessionOptions::default()
    })
    .unwrap()
}

/// Run `lines` and return each statement (`advise> ...`) followed by its reply or diagnostic.
pub fn raw_transcript(session: &mut Session, lines: &str) -> String {
    let mut out = String::new();
    for st in script::statements(lines) {
        out.push_str(&format!("advise> {}\n", st.text));
        match session.execute(&st.text, &format!("<line {}>", st.line)) {
            Ok(r) => {
                let text = r.to_string();
                if !text.is_empty() {
                    out.push_str(text.trim_end());
                    out.push('\n');
                }
            }
            Err(e) => out.push_str(&advise_cli::repl::render(session.sources(), &e, false)),
        }
    }
    out
}

/// Insta settings that mask wall-clock timings (`12.3 ms` as `<t>`) and, when given, a temporary
/// directory (as `<dir>`): everything else a transcript shows is deterministic.
pub fn masked(dir: Option<&Path>) -> insta::Settings {
    let dir = dir.map(|d| d.display().to_string());
    masked_as(dir.as_deref().map(|d| (d, "<dir>")).as_slice())
}

/// Insta settings that mask wall-clock timings and write each `(text, as)` pair's text as `as`
/// (a temporary path as the name the snapshot shows, say).
pub fn masked_as(literals: &[(&str, &str)]) -> insta::Settings {
    let mut settings = insta::Settings::clone_current();
    settings.add_filter(r"\b\d+(?:\.\d+)? (?:ms|µs)\b", "<t>");
    for (text, replacement) in literals {
        settings.add_filter(&escape(text), *replacement);
    }
    settings
}

/// `text` as a regex that matches it literally.
fn escape(text: &str) -> String {
    let mut out = String::new();
    for c in text.chars() {
        if r"\.+*?()|[]{}^$#&-~".contains(c) {
            out.push('\\');
        }
        out.push(c);
    }
    out
}

/// How long one run of the binary may take (the slowest case takes about a second).
const RUN_LIMIT: Duration = Duration::from_secs(120);

/// One run of the `advise` binary: `args` in a fresh temporary directory holding `files`, with
/// no journal (and `ADVISE_HOME` inside that directory, should one be written anyway).
pub struct Invocation {
    pub args: Vec<String>,
    pub files: Vec<(String, Vec<u8>)>,
}

/// What a user of the binary sees: stdout and stderr interleaved as printed, and the exit code;
/// `dir` is the directory it ran in (gone by now), for [`masked`].
pub struct Output {
    pub text: String,
    /// The exit code (`None` if a signal ended it).
    pub code: Option<i32>,
    pub dir: PathBuf,
}

impl Invocation {
    /// The command line as a user would type it.
    pub fn command_line(&self) -> String {
        format!("$ advise {}", self.args.join(" "))
    }

    pub fn run(&self) -> Output {
        let dir = tempfile::tempdir().unwrap();
        for (name, bytes) in &self.files {
            std::fs::write(dir.path().join(name), bytes).unwrap();
        }
        let (mut reader, writer) = std::io::pipe().unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_advise"))
            .args(&self.args)
            .current_dir(dir.path())
            .env("ADVISE_HOME", dir.path().join(".advise"))
            .env("NO_COLOR", "1")
            .stdin(Stdio::null())
            .stdout(writer.try_clone().unwrap())
            .stderr(writer)
            .spawn()
            .unwrap();
        let output = std::thread::spawn(move || {
            let mut bytes = Vec::new();
            reader.read_to_end(&mut bytes).map(|_| bytes)
        });
        // A case that hangs fails the test instead of hanging it.
        let deadline = Instant::now() + RUN_LIMIT;
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break Some(status);
            }
            if Instant::now() > deadline {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let text = String::from_utf8(output.join().unwrap().unwrap()).unwrap();
        let Some(status) = status else {
            panic!(
                "`{}` did not finish within {RUN_LIMIT:?}; it printed:\n{text}",
                self.command_line()
            );
        };
        Output {
            text,
            code: status.code(),
            dir: dir.path().to_path_buf(),
        }
    }
}

/// Run every invocation at once (each is its own process), keyed by name.
pub fn run_all(runs: Vec<(String, Invocation)>) -> HashMap<String, (Invocation, Output)> {
    std::thread::scope(|s| {
        let handles: Vec<_> = runs
            .into_iter()
            .map(|(name, inv)| {
                s.spawn(move || {
                    let out = inv.run();
                    (name, (inv, out))
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// The files of `dir` (relative to the package) whose names end in `.ext`, sorted.
pub fn cases(dir: &str, ext: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    out.sort();
    out
}

/// Fail on snapshots `tests/snapshots/<test>__<snapshot>@*.snap` whose case is not in `cases`
/// any more (a case removed or renamed leaves its snapshot behind, which insta does not notice).
pub fn assert_no_orphans(test: &str, snapshot: &str, cases: &[PathBuf]) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots");
    let prefix = format!("{test}__{snapshot}@");
    let names: Vec<String> = cases.iter().map(|p| name(p)).collect();
    let orphans: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| name(&e.unwrap().path()))
        .filter(|n| n.ends_with(".snap"))
        .filter(|n| {
            n.strip_prefix(&prefix)
                .and_then(|n| n.strip_suffix(".snap"))
                .is_some_and(|case| !names.iter().any(|c| c == case))
        })
        .collect();
    assert!(
        orphans.is_empty(),
        "snapshots without a case (delete them): {orphans:?}"
    );
}

/// A file's name, as the key of its case.
pub fn name(path: &Path) -> String {
    path.file_name().unwrap().to_string_lossy().into_owned()
}

/// Parse `text` as a file of its own, named `name` (an error's places are only inspected here).
pub fn parse(
    name: &str,
    text: &str,
) -> Result<advise::syntax::ast::File, advise::syntax::ParseError> {
    let (map, id) = advise::diag::SourceMap::single(name, text);
    advise::syntax::parse(map.src(id))
}

/// A sim whose link dies after a number of steps.
pub struct Flaky {
    pub inner: SimBackend,
    pub steps_left: usize,
    /// Whether `stop` was called.
    pub stopped: bool,
}

impl Flaky {
    /// The default simulator (seed 1) losing its link after `steps` steps.
    pub fn new(steps: usize) -> Flaky {
        Flaky {
            inner: SimBackend::new(SimParams::default(), 1),
            steps_left: steps,
            stopped: false,
        }
    }
}

impl Backend for Flaky {
    fn name(&self) -> String {
        "flaky".into()
    }
    fn period_s(&self) -> f64 {
        self.inner.period_s()
    }
    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        self.inner.reset(start)
    }
    fn command(&mut self, v: f64, w: f64) -> Result<(), BackendError> {
        self.inner.command(v, w)
    }
    fn step(&mut self) -> Result<BaseState, BackendError> {
        if self.steps_left == 0 {
            return Err(BackendError::LinkLost { waited_ms: 250 });
        }
        self.steps_left -= 1;
        self.inner.step()
    }
    fn stop(&mut self) -> Result<(), BackendError> {
        self.stopped = true;
        self.inner.stop()
    }
}

/// Run the `advise` binary with `args` in `dir` (no colour): whether it succeeded, and its
/// stdout then stderr.
pub fn advise_in(dir: &Path, args: &[&str]) -> (bool, String) {
    let (status, text) = advise_status(dir, args);
    (status.success(), text)
}

/// [`advise_in`], with the exit status itself.
pub fn advise_status(dir: &Path, args: &[&str]) -> (std::process::ExitStatus, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    let mut text = String::from_utf8_lossy(&out.stdout).into_owned();
    text.push_str(&String::from_utf8_lossy(&out.stderr));
    (out.status, text)
}
