//! The session journal: a record of effects, appended and flushed as each statement succeeds, so a
//! crash loses nothing and `advise resume` restores the session without re-running anything.
//!
//! The file is JSON Lines: a [`Header`] (task, seed, simulator parameters, who started it), then
//! one [`Entry`] per statement that changed the session: the statement as typed and its
//! [`Effect`](super::effect::Effect). Every line ends with a newline and is flushed to disk before
//! the statement's reply is shown. A journal is created with create-new semantics under a name
//! unique to the process (time, process id, a counter), so two sessions never share one and
//! nothing is ever truncated. A line cut by a crash is reported and dropped on resume; a damaged
//! line in the middle stops the restore there, and the session continues in a fresh journal
//! holding what was restored, leaving the damaged one as it was. A line that reads but holds an
//! effect a live statement could not have made (an action beyond its limits, a chunk past the end
//! of its execution, another task's dataset) is treated the same way.
//!
//! A journal is written by one session at a time: the session holding it holds an exclusive
//! advisory lock on it (`flock`, through std's `File::try_lock`) for its life, and names itself
//! in a file beside it (`NAME.jsonl.lock`: process id and when it took the lock). A second
//! session that would write it (`advise resume` of a journal in use) is refused with the owner
//! named. The kernel drops the lock when its process ends, however it ends, so a dead owner never
//! blocks anyone; its stale owner file is overwritten by the next holder.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use miette::Diagnostic;
use thiserror::Error;

use super::effect::{Entry, Header, JOURNAL_FORMAT};

/// An append-only journal file, locked for as long as this value lives.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    /// Open for appending, with the exclusive lock held on it.
    file: File,
}

impl Drop for Journal {
    fn drop(&mut self) {
        // The lock goes with the file; the owner file says nothing true any more.
        let _ = std::fs::remove_file(owner_path(&self.path));
    }
}

/// Why a journal could not be read.
#[derive(Debug, Error, Diagnostic)]
pub enum JournalError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("`{path}` is a journal of an earlier version of advise (a script of commands)")]
    #[diagnostic(
        code(advise::journal::old_format),
        help(
            "it holds commands, not their effects: `advise run {path} --demos 0` re-runs them in the simulator (a script that says `backend rmp:...` would drive that robot again: remove that line first)"
        )
    )]
    OldFormat { path: String },
    #[error("`{path}` does not start with a journal header: {message}")]
    #[diagnostic(
        code(advise::journal::header),
        help(
            "a journal's first line is written by `advise` when a session starts; this file is not one, or its first line was edited"
        )
    )]
    Header { path: String, message: String },
    #[error("the journal `{path}` is in use by another session: {owner}")]
    #[diagnostic(
        code(advise::journal::locked),
        help(
            "two sessions writing one journal would interleave their statements: wait for that session to end (`quit` in it), or copy the journal and resume the copy (`advise resume COPY`), which starts a history of its own"
        )
    )]
    Locked { path: String, owner: String },
    #[error("cannot create a session journal in `{path}`")]
    #[diagnostic(
        code(advise::journal::create),
        help(
            "journals are kept in $ADVISE_HOME (else ~/.advise): set ADVISE_HOME to a writable folder, or start the session with `--no-journal` (then nothing is recorded for `advise resume`)"
        )
    )]
    Create {
        path: String,
        #[source]
        source: io::Error,
    },
    #[error("cannot continue the journal `{path}`")]
    #[diagnostic(
        code(advise::journal::open),
        help(
            "a resumed session records into the journal it restored, so the file must be writable: copy it to a writable folder and resume the copy (`advise resume COPY`)"
        )
    )]
    Open {
        path: String,
        #[source]
        source: io::Error,
    },
}

/// Why a restore stopped before the end of its journal: everything before the line is restored,
/// nothing from it on, and the session continues in a new journal (the old one is left as it
/// was). Shown at resume; the session goes on.
#[derive(Debug, Error, Diagnostic)]
pub enum Stopped {
    #[error("line {line} of the journal `{path}` is damaged: {message}")]
    #[diagnostic(
        code(advise::journal::damaged_line),
        severity(Warning),
        help(
            "restored up to line {before}, nothing after it; the journal is left as it was, and this session continues in a new one"
        )
    )]
    Damaged {
        path: String,
        line: usize,
        before: usize,
        message: String,
    },
    #[error(
        "line {line} of the journal `{path}` holds what no statement could have done: `{statement}`"
    )]
    #[diagnostic(
        code(advise::journal::invalid_entry),
        severity(Warning),
        help(
            "a journal line is held to the rules a live statement is; restored up to line {before}, nothing after it, and nothing was driven; the journal is left as it was, and this session continues in a new one"
        )
    )]
    Invalid {
        path: String,
        line: usize,
        before: usize,
        statement: String,
        #[source]
        #[diagnostic_source]
        cause: super::SessionError,
    },
    #[error("line {line} of the journal `{path}` refers to demonstrations that cannot be restored")]
    #[diagnostic(
        code(advise::journal::sidecar),
        severity(Warning),
        help(
            "restored up to line {before}, nothing after it, and nothing was driven; the journal is left as it was, and this session continues in a new one"
        )
    )]
    Sidecar {
        path: String,
        line: usize,
        before: usize,
        #[source]
        #[diagnostic_source]
        cause: super::sidecar::SidecarError,
    },
}

impl Stopped {
    /// Why the restore stopped at `line` (of the journal at `path`) when applying it failed:
    /// the demonstrations file it refers to is missing or altered, or the effect breaks a rule.
    pub fn at(path: String, line: usize, statement: String, cause: super::SessionError) -> Stopped {
        match cause {
            super::SessionError::Sidecar(cause) => Stopped::Sidecar {
                path,
                line,
                before: line - 1,
                cause,
            },
            cause => Stopped::Invalid {
                path,
                line,
                before: line - 1,
                statement,
                cause,
            },
        }
    }
}

/// A journal read back: its header, the entries in order (with their 1-based line numbers), and
/// what could not be read.
#[derive(Debug)]
pub struct Loaded {
    pub header: Header,
    pub entries: Vec<(usize, Entry)>,
    /// A last line with no newline: a statement cut by a crash (its text, for the report).
    pub cut: Option<String>,
    /// The first damaged complete line (line number, what is wrong); nothing after it is read.
    pub damaged: Option<(usize, String)>,
    /// The length in bytes of the complete lines before any cut or damage.
    pub good_len: u64,
}

/// Longest journal `read` accepts (a session that loaded 10,000 teacher runs is some hundreds of
/// MiB; anything larger is not a journal this program wrote).
pub const MAX_JOURNAL_BYTES: u64 = 2 << 30;

impl Journal {
    /// Start a new journal in `dir` under a name no other session has, headed by `header`, and
    /// hold its lock.
    pub fn create_in(dir: &Path, header: &Header) -> Result<Journal, JournalError> {
        let failed = |path: &Path, source| JournalError::Create {
            path: path.display().to_string(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(|e| failed(dir, e))?;
        let mut last = None;
        // A name is unique to this process and time; create-new refuses a name that exists, so
        // the worst a collision costs is another try.
        for attempt in 0..64u32 {
            let path = dir.join(journal_name(header, attempt));
            match OpenOptions::new().append(true).create_new(true).open(&path) {
                Ok(file) => {
                    let mut j = Journal::hold(file, &path)?;
                    let line = serde_json::to_string(header).map_err(io::Error::other);
                    line.and_then(|l| j.write_line(&l))
                        .map_err(|e| failed(&path, e))?;
                    return Ok(j);
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
                Err(e) => return Err(failed(dir, e)),
            }
        }
        Err(failed(
            dir,
            last.unwrap_or_else(|| io::Error::other("no free journal name")),
        ))
    }

    /// Take an existing journal to continue it (what `advise resume` does before reading it),
    /// refused while another session holds it.
    pub fn continue_at(path: &Path) -> Result<Journal, JournalError> {
        // Opening a FIFO for writing would block until a reader comes: anything but a regular
        // file is refused by the reader's own check first (`advise::file::not_regular`).
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            read(path)?;
        }
        let file = match OpenOptions::new().append(true).open(path) {
            Ok(file) => file,
            Err(source) => {
                // A file that is no journal at all says so first.
                read(path)?;
                return Err(JournalError::Open {
                    path: path.display().to_string(),
                    source,
                });
            }
        };
        Journal::hold(file, path)
    }

    /// Lock `file` (the journal at `path`) for this session and name this process beside it.
    fn hold(file: File, path: &Path) -> Result<Journal, JournalError> {
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(JournalError::Locked {
                    path: path.display().to_string(),
                    owner: owner_of(path),
                });
            }
            Err(TryLockError::Error(source)) => {
                return Err(JournalError::Open {
                    path: path.display().to_string(),
                    source,
                });
            }
        }
        // Only a courtesy for whoever is refused: the lock itself is what excludes them.
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let _ = std::fs::write(owner_path(path), format!("{} {now}\n", std::process::id()));
        Ok(Journal {
            path: path.to_path_buf(),
            file,
        })
    }

    /// Cut off anything past `good_len` (a line cut by a crash), so the next entry starts on a
    /// line of its own.
    pub fn cut_to(&mut self, good_len: u64) -> io::Result<()> {
        if self.file.metadata()?.len() > good_len {
            self.file.set_len(good_len)?;
            self.file.sync_data()?;
        }
        Ok(())
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Append one entry and flush it to disk before returning.
    pub fn append(&mut self, entry: &Entry) -> io::Result<()> {
        self.write_line(&serde_json::to_string(entry).map_err(io::Error::other)?)
    }

    fn write_line(&mut self, line: &str) -> io::Result<()> {
        let mut buf = Vec::with_capacity(line.len() + 1);
        buf.extend_from_slice(line.as_bytes());
        buf.push(b'\n');
        // One write call for the whole line, so a crash leaves at most one cut line at the end.
        self.file.write_all(&buf)?;
        self.file.flush()?;
        self.file.sync_data()
    }
}

fn journal_name(header: &Header, attempt: u32) -> String {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    format!(
        "session-{}-{}-{:08x}{}.jsonl",
        header.started_unix_s,
        header.pid,
        nanos,
        if attempt == 0 {
            String::new()
        } else {
            format!("-{attempt}")
        }
    )
}

/// The file beside a journal that names the process holding it.
fn owner_path(journal: &Path) -> PathBuf {
    let mut name = journal.as_os_str().to_owned();
    name.push(".lock");
    PathBuf::from(name)
}

/// Who holds the journal at `path`, in words, from its owner file.
fn owner_of(path: &Path) -> String {
    // Through the one reader: a FIFO in its place is refused, not waited on.
    let text = crate::files::read_text_limited(&owner_path(path), 4096).unwrap_or_default();
    let mut words = text.split_whitespace().map(str::parse::<u64>);
    match (words.next(), words.next()) {
        (Some(Ok(pid)), Some(Ok(since))) => {
            let now = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            format!(
                "process {pid}, which took it {} ago",
                ago(now.saturating_sub(since))
            )
        }
        _ => "a process that did not name itself".into(),
    }
}

/// A duration in the unit a person would say it in.
fn ago(s: u64) -> String {
    match s {
        0..120 => format!("{s} s"),
        120..7200 => format!("{} min", s / 60),
        _ => format!("{} h", s / 3600),
    }
}

/// Read a journal back. Never panics on any file content.
pub fn read(path: &Path) -> Result<Loaded, JournalError> {
    let shown = path.display().to_string();
    let bytes = crate::files::read_bytes_limited(path, MAX_JOURNAL_BYTES)?;
    if bytes.starts_with(b"// advise session journal") {
        return Err(JournalError::OldFormat { path: shown });
    }
    let mut lines = bytes.split_inclusive(|b| *b == b'\n');
    let first = lines.next().unwrap_or_default();
    let header: Header = std::str::from_utf8(first)
        .map_err(|e| e.to_string())
        .and_then(|l| serde_json::from_str(l.trim_end()).map_err(|e| e.to_string()))
        .and_then(|h: Header| {
            if h.format == JOURNAL_FORMAT {
                Ok(h)
            } else {
                Err(format!(
                    "format `{}`, this version reads `{JOURNAL_FORMAT}`",
                    h.format
                ))
            }
        })
        .map_err(|message| JournalError::Header {
            path: shown.clone(),
            message,
        })?;
    let mut loaded = Loaded {
        header,
        entries: Vec::new(),
        cut: None,
        damaged: None,
        good_len: first.len() as u64,
    };
    if !first.ends_with(b"\n") {
        // Only a header, cut: nothing after it.
        return Ok(loaded);
    }
    for (i, line) in lines.enumerate() {
        let number = i + 2;
        if !line.ends_with(b"\n") {
            loaded.cut = Some(String::from_utf8_lossy(line).into_owned());
            break;
        }
        let parsed = std::str::from_utf8(line)
            .map_err(|e| e.to_string())
            .and_then(|l| serde_json::from_str::<Entry>(l).map_err(|e| e.to_string()));
        match parsed {
            Ok(entry) => {
                loaded.entries.push((number, entry));
                loaded.good_len += line.len() as u64;
            }
            Err(message) => {
                loaded.damaged = Some((number, message));
                break;
            }
        }
    }
    Ok(loaded)
}

/// Where journals live by default: `$ADVISE_HOME`, else `$HOME/.advise`, else `.advise`.
pub fn default_dir() -> PathBuf {
    if let Some(h) = std::env::var_os("ADVISE_HOME") {
        return PathBuf::from(h);
    }
    match std::env::var_os("HOME") {
        Some(h) => PathBuf::from(h).join(".advise"),
        None => PathBuf::from(".advise"),
    }
}

/// The most recently written journal in `dir`.
pub fn newest(dir: &Path) -> Option<PathBuf> {
    std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("session-") && n.ends_with(".jsonl"))
        })
        .filter_map(|p| Some((std::fs::metadata(&p).and_then(|m| m.modified()).ok()?, p)))
        .max()
        .map(|(_, p)| p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::sim::SimParams;
    use crate::session::effect::Effect;
    use crate::task::TaskKind;

    fn header() -> Header {
        Header {
            format: JOURNAL_FORMAT.into(),
            task: TaskKind::Positioning,
            seed: 3,
            sim: SimParams::default(),
            started_unix_s: 1_700_000_000,
            pid: 42,
        }
    }

    fn entry(s: &str) -> Entry {
        Entry {
            statement: s.into(),
            origin: "<repl>".into(),
            effect: Effect::Undo,
        }
    }

    #[test]
    fn entries_are_on_disk_at_once_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let mut j = Journal::create_in(dir.path(), &header()).unwrap();
        j.append(&entry("undo")).unwrap();
        let loaded = read(j.path()).unwrap();
        assert_eq!(loaded.header, header());
        assert_eq!(loaded.entries, vec![(2, entry("undo"))]);
        assert!(loaded.cut.is_none() && loaded.damaged.is_none());
    }

    #[test]
    fn two_journals_started_in_the_same_second_by_one_process_differ() {
        let dir = tempfile::tempdir().unwrap();
        let a = Journal::create_in(dir.path(), &header()).unwrap();
        let b = Journal::create_in(dir.path(), &header()).unwrap();
        assert_ne!(a.path(), b.path());
        assert_eq!(read(a.path()).unwrap().header, header());
        assert_eq!(read(b.path()).unwrap().header, header());
    }

    #[test]
    fn a_cut_line_is_reported_and_cut_off_before_appending() {
        let dir = tempfile::tempdir().unwrap();
        let mut j = Journal::create_in(dir.path(), &header()).unwrap();
        j.append(&entry("undo")).unwrap();
        let path = j.path().to_path_buf();
        drop(j);
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(br#"{"statement":"advise spe"#).unwrap();
        let loaded = read(&path).unwrap();
        assert_eq!(loaded.entries.len(), 1);
        assert_eq!(loaded.cut.as_deref(), Some(r#"{"statement":"advise spe"#));
        let mut j = Journal::continue_at(&path).unwrap();
        j.cut_to(loaded.good_len).unwrap();
        j.append(&entry("redo")).unwrap();
        let again = read(&path).unwrap();
        assert_eq!(again.entries.len(), 2);
        assert_eq!(again.entries[1].1, entry("redo"));
        assert!(again.cut.is_none() && again.damaged.is_none());
    }

    #[test]
    fn a_damaged_line_stops_the_read_there() {
        let dir = tempfile::tempdir().unwrap();
        let mut j = Journal::create_in(dir.path(), &header()).unwrap();
        j.append(&entry("undo")).unwrap();
        j.write_line("not json").unwrap();
        j.append(&entry("redo")).unwrap();
        let loaded = read(j.path()).unwrap();
        assert_eq!(loaded.entries.len(), 1);
        assert_eq!(loaded.damaged.as_ref().map(|d| d.0), Some(3));
    }

    #[test]
    fn a_journal_is_held_by_one_session_at_a_time_and_named_by_its_owner() {
        let dir = tempfile::tempdir().unwrap();
        let j = Journal::create_in(dir.path(), &header()).unwrap();
        let path = j.path().to_path_buf();
        // A second open file description (another session, here in this process) is refused.
        match Journal::continue_at(&path) {
            Err(JournalError::Locked { owner, .. }) => assert!(
                owner.starts_with(&format!("process {}, which took it ", std::process::id())),
                "{owner}"
            ),
            other => panic!("{other:?}"),
        }
        // Ended, it holds nothing and leaves no owner file.
        drop(j);
        assert!(!owner_path(&path).exists());
        let again = Journal::continue_at(&path).unwrap();
        // An owner file left by a killed process names nobody who holds the lock: it is
        // overwritten, not obeyed.
        drop(again);
        std::fs::write(owner_path(&path), "1 0\n").unwrap();
        let held = Journal::continue_at(&path).unwrap();
        let owner = std::fs::read_to_string(owner_path(&path)).unwrap();
        assert!(
            owner.starts_with(&format!("{} ", std::process::id())),
            "{owner}"
        );
        drop(held);
    }

    #[test]
    fn a_journal_that_cannot_be_created_says_where_and_what_to_do() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("in-the-way");
        std::fs::write(&file, "").unwrap();
        match Journal::create_in(&file, &header()) {
            Err(e @ JournalError::Create { .. }) => {
                assert_eq!(
                    miette::Diagnostic::code(&e).unwrap().to_string(),
                    "advise::journal::create"
                );
                assert!(e.to_string().contains("in-the-way"), "{e}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn old_journals_and_other_files_are_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        let old = dir.path().join("session-1.adv");
        std::fs::write(&old, "// advise session journal: replay\nrun goal 1 1 0\n").unwrap();
        assert!(matches!(read(&old), Err(JournalError::OldFormat { .. })));
        let other = dir.path().join("x.jsonl");
        std::fs::write(&other, "{}\n").unwrap();
        assert!(matches!(read(&other), Err(JournalError::Header { .. })));
        assert!(matches!(read(dir.path()), Err(JournalError::File(_))));
    }
}
