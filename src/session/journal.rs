//! The session journal: every statement that changed the session, appended and flushed as it
//! succeeds, so that a crash loses nothing and `advise resume` can replay it.
//!
//! The journal is plain session script (one statement per entry, multi-line definitions kept
//! whole), headed by a comment: it can be read, edited and run with `advise run`. Statements that
//! only look (`show`, `history`, `help`, `why`, `preview`) are not journalled.

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// An append-only journal file.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: File,
}

impl Journal {
    /// Start a new journal at `path` (truncating an old one).
    pub fn create(path: &Path) -> io::Result<Journal> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)?;
        }
        let mut file = File::create(path)?;
        writeln!(
            file,
            "// advise session journal: replay with `advise resume` or `advise run {}`",
            path.display()
        )?;
        file.sync_data()?;
        Ok(Journal {
            path: path.to_path_buf(),
            file,
        })
    }

    /// Continue an existing journal (after `advise resume` replayed it).
    pub fn append_to(path: &Path) -> io::Result<Journal> {
        let file = OpenOptions::new().append(true).open(path)?;
        Ok(Journal {
            path: path.to_path_buf(),
            file,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Append one statement and flush it to disk before returning.
    pub fn record(&mut self, statement: &str) -> io::Result<()> {
        writeln!(self.file, "{}", statement.trim_end())?;
        self.file.flush()?;
        self.file.sync_data()
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_are_on_disk_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("j.adv");
        let mut j = Journal::create(&p).unwrap();
        j.record("select 1..4").unwrap();
        j.record("advise speed_up\n").unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.ends_with("select 1..4\nadvise speed_up\n"), "{text}");
        drop(j);
        let mut j = Journal::append_to(&p).unwrap();
        j.record("undo").unwrap();
        assert!(std::fs::read_to_string(&p).unwrap().ends_with("undo\n"));
    }
}
