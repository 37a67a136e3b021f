//! Every file `advise` reads or writes goes through here: [`read_source`] (into a
//! [`SourceMap`], for loaders whose errors point into the text), [`read_text`] and
//! [`write_atomic`].
//!
//! Reading refuses anything that is not a regular file before opening it (`open` on a FIFO blocks
//! until a writer comes; `/dev/zero` never ends), reads at most a limit ([`MAX_READ_BYTES`]
//! unless the caller asks for less), accepts a UTF-8 byte-order mark, and names the line and byte
//! of invalid UTF-8. Writing goes to a temporary file in the destination's folder (created anew,
//! so it gets the umask's usual permissions, or the replaced file's), is flushed to disk, then
//! renamed over the destination: a failed write leaves the old file untouched and no temporary
//! behind. A symbolic link as destination is followed, so its target is replaced and the link
//! kept; an existing destination that is not a regular file (a folder, a FIFO, a device) is
//! refused, and so is one this user may not write (the rename needs only the folder's
//! permission, so a 0444 file would otherwise be replaced). A directory is written whole into a
//! temporary sibling and renamed into place ([`write_dir_atomic`]). Temporaries left by a process
//! that is gone (`kill -9` during a save) are removed by the next write beside them; a live
//! process's never. Commands that read and write refuse an output that is one of their inputs
//! ([`refuse_overwriting_inputs`], by device and inode, so links are caught). This module knows
//! no file format; it must not parse what it reads.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use miette::Diagnostic;
use thiserror::Error;

use crate::diag::{Loc, SourceId, SourceMap};

/// The most any loader reads from one file: 256 MiB. A saved dataset of 100,000 points with
/// its executions is some tens of MiB.
pub const MAX_READ_BYTES: u64 = 256 * 1024 * 1024;

/// How many symbolic links a destination may pass through before it is refused (Linux's own
/// limit is 40).
const MAX_LINKS: usize = 40;

/// What can go wrong reading or writing a file.
#[derive(Debug, Error, Diagnostic)]
pub enum FileError {
    #[error("cannot read `{path}`")]
    #[diagnostic(code(advise::file::read))]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("`{path}` is {kind}, not a regular file")]
    #[diagnostic(
        code(advise::file::not_regular),
        help("name a regular file; {kind} cannot be read or replaced as a whole")
    )]
    NotRegular { path: String, kind: &'static str },
    #[error("`{path}` is larger than {limit}")]
    #[diagnostic(
        code(advise::file::too_large),
        help("`advise` reads at most {limit} from one file; split the data into several files")
    )]
    TooLarge { path: String, limit: String },
    #[error("`{path}` is not UTF-8 text: line {line}, column {column} (byte offset {byte})")]
    #[diagnostic(
        code(advise::file::not_utf8),
        help("save the file as UTF-8 text; the mark shows the first byte that is not")
    )]
    NotUtf8 {
        path: String,
        line: usize,
        column: usize,
        byte: usize,
        /// The first bad byte, in the file's text as read (each bad byte as U+FFFD), when the
        /// file was read into a source map.
        #[label("not UTF-8")]
        at: Option<Loc>,
    },
    #[error("cannot write `{path}`")]
    #[diagnostic(
        code(advise::file::write),
        help(
            "check that the folder exists, is writable and the disk has room; nothing was changed"
        )
    )]
    Write {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("`{path}` is `{input}`, which this command reads")]
    #[diagnostic(
        code(advise::file::output_is_input),
        help(
            "writing there would replace what is being read (the same file, or a link to it); name another output; nothing was written"
        )
    )]
    OutputIsInput { path: String, input: String },
    #[error("`{path}` is read-only for you")]
    #[diagnostic(
        code(advise::file::read_only),
        help(
            "its permissions do not let you write it, so `advise` does not replace it either; make it writable (`chmod u+w`) or name another file; nothing was changed"
        )
    )]
    ReadOnly { path: String },
    #[error("`{path}` passes through more than {MAX_LINKS} symbolic links")]
    #[diagnostic(
        code(advise::file::link_loop),
        help("the links form a loop; name the file itself")
    )]
    LinkLoop { path: String },
}

/// Read a whole text file of at most [`MAX_READ_BYTES`] into `sources`, named by its path, as
/// [`read_text`] does; text that is not UTF-8 is kept too (each bad byte as U+FFFD), so the error
/// can show where.
pub fn read_source(sources: &mut SourceMap, path: &Path) -> Result<SourceId, FileError> {
    match read_text_or_lossy(path, MAX_READ_BYTES)? {
        Ok(text) => Ok(sources.add(path.display().to_string(), text)),
        Err(bad) => Err(bad.kept_in(sources, path)),
    }
}

/// Read a data file (a trace, a dataset, parameters) as [`read_source`] does and `parse` it; the
/// text stays in `sources` only if reading or parsing fails ([`SourceMap::scratch`]), as only its
/// diagnostics need it.
pub fn parse_file<T, E: From<FileError>>(
    sources: &mut SourceMap,
    path: &Path,
    parse: impl FnOnce(crate::diag::Src<'_>) -> Result<T, E>,
) -> Result<T, E> {
    match read_text_or_lossy(path, MAX_READ_BYTES)? {
        Ok(text) => sources.scratch(path.display().to_string(), text, parse),
        Err(bad) => Err(bad.kept_in(sources, path).into()),
    }
}

/// Read a whole text file of at most [`MAX_READ_BYTES`]; see [`read_text_limited`].
pub fn read_text(path: &Path) -> Result<String, FileError> {
    read_text_limited(path, MAX_READ_BYTES)
}

/// Read a whole text file of at most `limit` bytes. Refuses anything that is not a regular file
/// (without opening it), a longer file, and text that is not UTF-8 (naming its line and byte; no
/// label, as no source map holds the text: [`read_source`] has one); a UTF-8 byte-order mark is
/// dropped.
pub fn read_text_limited(path: &Path, limit: u64) -> Result<String, FileError> {
    read_text_or_lossy(path, limit)?.map_err(|bad| bad.into_error(path, None))
}

/// Text that is not UTF-8: where, and the text with each bad byte as U+FFFD.
struct BadUtf8 {
    lossy: String,
    /// The first bad byte's U+FFFD in `lossy`.
    range: std::ops::Range<usize>,
    line: usize,
    column: usize,
    byte: usize,
}

impl BadUtf8 {
    /// The error, its text kept in `sources` for the label.
    fn kept_in(mut self, sources: &mut SourceMap, path: &Path) -> FileError {
        let id = sources.add(path.display().to_string(), std::mem::take(&mut self.lossy));
        let at = id.at(self.range.clone());
        self.into_error(path, Some(at))
    }

    fn into_error(self, path: &Path, at: Option<Loc>) -> FileError {
        FileError::NotUtf8 {
            path: path.display().to_string(),
            line: self.line,
            column: self.column,
            byte: self.byte,
            at,
        }
    }
}

fn read_text_or_lossy(path: &Path, limit: u64) -> Result<Result<String, BadUtf8>, FileError> {
    let bytes = read_bytes_limited(path, limit)?;
    let (bom, text) = match bytes.strip_prefix(b"\xEF\xBB\xBF") {
        Some(rest) => (3, rest),
        None => (0, &bytes[..]),
    };
    Ok(match std::str::from_utf8(text) {
        Ok(text) => Ok(text.to_string()),
        Err(e) => Err(not_utf8(text, e.valid_up_to(), bom)),
    })
}

/// Open a regular file of at most `limit` bytes (`u64::MAX`: any) for reading, refusing anything
/// else before it is opened (a FIFO would block); the file and its length then.
pub fn open_regular(path: &Path, limit: u64) -> Result<(File, u64), FileError> {
    let name = || path.display().to_string();
    let read_err = |source| FileError::Read {
        path: name(),
        source,
    };
    // `metadata` follows links and never opens the file: a FIFO is refused before `open` could
    // block on it.
    let meta = std::fs::metadata(path).map_err(read_err)?;
    if let Some(kind) = special_kind(&meta) {
        return Err(FileError::NotRegular { path: name(), kind });
    }
    let too_large = || FileError::TooLarge {
        path: name(),
        limit: fmt_bytes(limit),
    };
    if meta.len() > limit {
        return Err(too_large());
    }
    let file = File::open(path).map_err(read_err)?;
    // The file may have been swapped between the check and the open.
    let meta = file.metadata().map_err(read_err)?;
    if let Some(kind) = special_kind(&meta) {
        return Err(FileError::NotRegular { path: name(), kind });
    }
    Ok((file, meta.len()))
}

/// Read a whole file of at most `limit` bytes, refusing anything that is not a regular file.
pub fn read_bytes_limited(path: &Path, limit: u64) -> Result<Vec<u8>, FileError> {
    let name = || path.display().to_string();
    let read_err = |source| FileError::Read {
        path: name(),
        source,
    };
    let too_large = || FileError::TooLarge {
        path: name(),
        limit: fmt_bytes(limit),
    };
    let (file, len) = open_regular(path, limit)?;
    let meta_len = len;
    // Files under /proc say they are empty and may be endless: the `take` bounds every file.
    let mut out = Vec::with_capacity(meta_len.min(limit) as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(read_err)?;
    if out.len() as u64 > limit {
        return Err(too_large());
    }
    Ok(out)
}

/// `bytes` follow a byte-order mark of `bom` bytes, which the message counts and the shown text
/// leaves out.
fn not_utf8(bytes: &[u8], valid: usize, bom: usize) -> BadUtf8 {
    let before = &bytes[..valid];
    let line = before.iter().filter(|b| **b == b'\n').count() + 1;
    let line_start = before
        .iter()
        .rposition(|b| *b == b'\n')
        .map_or(0, |p| p + 1);
    // The valid prefix reads back unchanged, so the offset holds in the lossy text; the bad
    // byte becomes one U+FFFD (3 bytes).
    let lossy = String::from_utf8_lossy(bytes).into_owned();
    let column = String::from_utf8_lossy(&before[line_start..])
        .chars()
        .count()
        + 1;
    BadUtf8 {
        lossy,
        range: valid..valid + '\u{FFFD}'.len_utf8(),
        line,
        column,
        byte: valid + bom,
    }
}

/// What a file is, in words, when it is not a regular file.
fn special_kind(meta: &std::fs::Metadata) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("a folder")
    } else if t.is_fifo() {
        Some("a FIFO (named pipe)")
    } else if t.is_char_device() || t.is_block_device() {
        Some("a device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        Some("a special file")
    }
}

/// `268435456` as `256 MiB`.
pub fn fmt_bytes(n: u64) -> String {
    const MIB: u64 = 1024 * 1024;
    if n >= MIB && n.is_multiple_of(MIB) {
        format!("{} MiB", n / MIB)
    } else if n >= 1024 && n.is_multiple_of(1024) {
        format!("{} KiB", n / 1024)
    } else {
        format!("{n} bytes")
    }
}

/// Write `bytes` to `path` atomically; see [`write_atomic`].
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Write a file atomically: `write` fills a new temporary file beside the destination, which is
/// flushed to disk and renamed over it. The destination's link (if it is one) is followed and
/// kept; an existing destination that is not a regular file is refused. On any error the
/// temporary file is removed and the destination is as it was.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let name = || path.display().to_string();
    let write_err = |source| FileError::Write {
        path: name(),
        source,
    };
    let target = resolve_links(path)?;
    let existing = match std::fs::metadata(&target) {
        Ok(meta) => {
            if let Some(kind) = special_kind(&meta) {
                return Err(FileError::NotRegular { path: name(), kind });
            }
            // The rename below needs only the folder's permission: a file the user may not
            // write (0444, or another user's) would be replaced all the same.
            if !writable(&target) {
                return Err(FileError::ReadOnly { path: name() });
            }
            Some(meta.permissions())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(write_err(e)),
    };
    let (tmp_path, file) = create_temp(&target).map_err(write_err)?;
    let result = (|| {
        let mut out = std::io::BufWriter::new(file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        if let Some(perm) = existing {
            // Replacing a file keeps its permissions (the umask applied when it was made).
            file.set_permissions(perm)?;
        }
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp_path, &target)?;
        // The rename itself is durable once the folder is flushed; not every filesystem allows
        // syncing a folder, and the file is in place either way.
        if let Ok(dir) = File::open(parent_dir(&target)) {
            let _ = dir.sync_all();
        }
        Ok(())
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp_path);
        write_err(e)
    })
}

/// Whether this process may write the existing file `path`, as `open` for writing would decide
/// (the effective user and groups, root included; a read-only filesystem says no).
fn writable(path: &Path) -> bool {
    use rustix::fs::{Access, AtFlags, CWD, accessat};
    match accessat(CWD, path, Access::WRITE_OK, AtFlags::EACCESS) {
        Ok(()) => true,
        Err(e) => !matches!(
            e,
            rustix::io::Errno::ACCESS | rustix::io::Errno::ROFS | rustix::io::Errno::PERM
        ),
    }
}

/// Whether two paths name one file (through links, hard ones included): the same device and
/// inode, or the same canonical path. A path that does not exist is no file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => {
            (x.dev(), x.ino()) == (y.dev(), y.ino())
                || std::fs::canonicalize(a).ok() == std::fs::canonicalize(b).ok()
        }
        _ => false,
    }
}

/// Refuse an `output` that is one of the command's `inputs` ([`same_file`]), before anything
/// is written: `advise export ds.json --mcap ds.json` replaced the dataset it read.
pub fn refuse_overwriting_inputs<'a>(
    output: &Path,
    inputs: impl IntoIterator<Item = &'a Path>,
) -> Result<(), FileError> {
    for input in inputs {
        if same_file(output, input) {
            return Err(FileError::OutputIsInput {
                path: output.display().to_string(),
                input: input.display().to_string(),
            });
        }
    }
    Ok(())
}

/// Write a directory atomically: `fill` writes its files into a new temporary sibling
/// (`.NAME.PID-N.tmp`), which is renamed into place once whole, so a killed export leaves no
/// half-written directory (only a temporary one, removed by the next write beside it once its
/// process is gone). `dir` may exist only as an empty directory (rename replaces it); the caller
/// refuses one that is not empty. On any error the temporary directory is removed.
pub fn write_dir_atomic<E: From<FileError>>(
    dir: &Path,
    fill: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let write_err = |source| FileError::Write {
        path: dir.display().to_string(),
        source,
    };
    let target = resolve_links(dir)?;
    let parent = parent_dir(&target);
    let tmp = temp_name(&target, |p| std::fs::create_dir(p)).map_err(write_err)?;
    let filled = fill(&tmp);
    let result = filled.and_then(|()| {
        std::fs::rename(&tmp, &target).map_err(|e| E::from(write_err(e)))?;
        if let Ok(d) = File::open(parent) {
            let _ = d.sync_all();
        }
        Ok(())
    });
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

/// The file a path finally names, following symbolic links (relative links are relative to the
/// link's folder). A dangling link gives the path it points to, so writing creates the target.
fn resolve_links(path: &Path) -> Result<PathBuf, FileError> {
    let mut current = path.to_path_buf();
    for _ in 0..=MAX_LINKS {
        match std::fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let to = std::fs::read_link(&current).map_err(|source| FileError::Write {
                    path: path.display().to_string(),
                    source,
                })?;
                current = if to.is_absolute() {
                    to
                } else {
                    parent_dir(&current).join(to)
                };
            }
            _ => return Ok(current),
        }
    }
    Err(FileError::LinkLoop {
        path: path.display().to_string(),
    })
}

fn parent_dir(path: &Path) -> &Path {
    path.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// A new file `.NAME.PID-N.tmp` beside `target`, created exclusively with mode 0666 (less the
/// umask), unlike `tempfile`'s 0600.
fn create_temp(target: &Path) -> std::io::Result<(PathBuf, File)> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut file = None;
    let tmp = temp_name(target, |p| {
        file = Some(
            OpenOptions::new()
                .write(true)
                .create_new(true)
                .mode(0o666)
                .open(p)?,
        );
        Ok(())
    })?;
    match file {
        Some(f) => Ok((tmp, f)),
        None => Err(std::io::Error::other("no temporary file was made")),
    }
}

/// A new temporary name `.NAME.PID-N.tmp` beside `target`, made by `make` (which fails with
/// `AlreadyExists` when the name is taken). Temporaries of this target left by processes that
/// are gone (`kill -9` during a save) are removed first.
fn temp_name(
    target: &Path,
    mut make: impl FnMut(&Path) -> std::io::Result<()>,
) -> std::io::Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let base = target
        .file_name()
        .map_or_else(|| "advise".into(), |n| n.to_string_lossy().into_owned());
    let dir = parent_dir(target);
    remove_stale_temps(dir, &base);
    let mut last = None;
    for _ in 0..16 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{base}.{}-{n}.tmp", std::process::id()));
        match make(&tmp) {
            Ok(()) => return Ok(tmp),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| std::io::Error::other("no free temporary name")))
}

/// The most entries of a folder looked at for stale temporaries on one write.
const MAX_STALE_SCAN: usize = 100_000;

/// The process id in a temporary name of `base`, `.BASE.PID-N.tmp`.
fn temp_owner(file_name: &str, base: &str) -> Option<u32> {
    let rest = file_name
        .strip_prefix('.')?
        .strip_prefix(base)?
        .strip_prefix('.')?
        .strip_suffix(".tmp")?;
    let (pid, n) = rest.split_once('-')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Whether a process `pid` exists (a signal 0 reaches it, or it belongs to another user).
fn alive(pid: u32) -> bool {
    let Some(pid) = i32::try_from(pid)
        .ok()
        .and_then(rustix::process::Pid::from_raw)
    else {
        return false;
    };
    !matches!(
        rustix::process::test_kill_process(pid),
        Err(rustix::io::Errno::SRCH)
    )
}

/// Remove the temporaries of `base` in `dir` whose process is gone. Never this process's own,
/// nor a live process's (a pid reused by another program keeps its temporaries: the safe side).
fn remove_stale_temps(dir: &Path, base: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let me = std::process::id();
    for entry in entries.take(MAX_STALE_SCAN).flatten() {
        let name = entry.file_name();
        let Some(pid) = temp_owner(&name.to_string_lossy(), base) else {
            continue;
        };
        if pid == me || alive(pid) {
            continue;
        }
        let path = entry.path();
        // Not following a link: a temporary is a plain file or (a directory export's) folder.
        match entry.file_type() {
            Ok(t) if t.is_dir() => {
                let _ = std::fs::remove_dir_all(&path);
            }
            Ok(t) if t.is_file() => {
                let _ = std::fs::remove_file(&path);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn mode(p: &Path) -> u32 {
        std::fs::metadata(p).unwrap().permissions().mode() & 0o777
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect()
    }

    #[test]
    fn a_new_file_gets_the_umask_permissions_not_0600() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_bytes(&p, b"hello").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"hello");
        // 0666 less whatever the umask takes: the group and others keep read access under the
        // usual umasks (022, 002), and never get execute.
        let m = mode(&p);
        assert_eq!(m & 0o600, 0o600);
        assert_eq!(m & 0o111, 0);
        assert_ne!(m, 0o600, "a temporary file's 0600 leaked through");
    }

    #[test]
    fn replacing_a_file_keeps_its_permissions() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        std::fs::write(&p, "old").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_bytes(&p, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(mode(&p), 0o640);
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        std::fs::write(&p, "good").unwrap();
        let err = write_atomic(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(matches!(err, FileError::Write { .. }));
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "good");
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn a_link_is_kept_and_its_target_replaced() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("real")).unwrap();
        let target = dir.path().join("real/data.json");
        std::fs::write(&target, "old").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink("real/data.json", &link).unwrap();
        write_bytes(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        // A dangling link creates its target.
        let dangling = dir.path().join("d.json");
        std::os::unix::fs::symlink("real/new.json", &dangling).unwrap();
        write_bytes(&dangling, b"x").unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("real/new.json")).unwrap(),
            "x"
        );
        // A loop is refused.
        let a = dir.path().join("loop-a");
        std::os::unix::fs::symlink("loop-b", &a).unwrap();
        std::os::unix::fs::symlink("loop-a", dir.path().join("loop-b")).unwrap();
        assert!(matches!(
            write_bytes(&a, b"x"),
            Err(FileError::LinkLoop { .. })
        ));
    }

    fn mkfifo(p: &Path) {
        let ok = std::process::Command::new("mkfifo")
            .arg(p)
            .status()
            .unwrap()
            .success();
        assert!(ok, "mkfifo failed");
    }

    #[test]
    fn special_files_are_refused_both_ways() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        mkfifo(&fifo);
        // Returns at once: the FIFO is never opened.
        assert!(matches!(
            read_text(&fifo),
            Err(FileError::NotRegular { kind, .. }) if kind.contains("FIFO")
        ));
        assert!(matches!(
            write_bytes(&fifo, b"x"),
            Err(FileError::NotRegular { .. })
        ));
        assert!(matches!(
            read_text(Path::new("/dev/zero")),
            Err(FileError::NotRegular {
                kind: "a device",
                ..
            })
        ));
        assert!(matches!(
            write_bytes(Path::new("/dev/null"), b"x"),
            Err(FileError::NotRegular {
                kind: "a device",
                ..
            })
        ));
        assert!(matches!(
            write_bytes(dir.path(), b"x"),
            Err(FileError::NotRegular {
                kind: "a folder",
                ..
            })
        ));
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn reads_are_capped() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big");
        std::fs::write(&p, vec![b'a'; 2048]).unwrap();
        assert_eq!(read_text_limited(&p, 2048).unwrap().len(), 2048);
        let err = read_text_limited(&p, 1024).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("`{}` is larger than 1 KiB", p.display())
        );
        // A /proc file says it is empty; the cap holds while reading.
        let status = read_text_limited(Path::new("/proc/self/status"), 16);
        assert!(matches!(status, Err(FileError::TooLarge { .. })));
    }

    #[test]
    fn a_byte_order_mark_is_dropped_and_bad_utf8_is_located() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bom");
        std::fs::write(&p, b"\xEF\xBB\xBFhello\n").unwrap();
        assert_eq!(read_text(&p).unwrap(), "hello\n");
        std::fs::write(&p, b"ok\nab\xFFcd\n").unwrap();
        match read_text(&p) {
            Err(FileError::NotUtf8 {
                line, column, byte, ..
            }) => assert_eq!((line, column, byte), (2, 3, 5)),
            other => panic!("{other:?}"),
        }
        // Read into a source map, the text is kept (bad byte replaced) and the mark points at it.
        let mut map = SourceMap::new();
        let err = read_source(&mut map, &p).unwrap_err();
        let out = crate::diag::render(&map, &err, false);
        assert!(out.contains(&format!("[{}:2:3]", p.display())), "{out}");
        assert!(out.contains("ab\u{FFFD}cd"), "{out}");
        assert_eq!(map.len(), 1);
        std::fs::write(&p, b"fine\n").unwrap();
        let id = read_source(&mut map, &p).unwrap();
        assert_eq!(map.text(id), "fine\n");
    }

    #[test]
    fn a_data_file_stays_in_the_map_only_when_it_fails() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("data.txt");
        std::fs::write(&p, "12\n").unwrap();
        let mut map = SourceMap::new();
        let parse = |src: crate::diag::Src<'_>| {
            src.text
                .trim()
                .parse::<u32>()
                .map_err(|_| FileError::NotUtf8 {
                    path: src.name.to_string(),
                    line: 1,
                    column: 1,
                    byte: 0,
                    at: Some(src.at(0..1)),
                })
        };
        for _ in 0..3 {
            assert_eq!(parse_file(&mut map, &p, parse).unwrap(), 12);
        }
        assert!(map.is_empty());
        std::fs::write(&p, "x\n").unwrap();
        let err = parse_file(&mut map, &p, parse).unwrap_err();
        assert_eq!(map.len(), 1);
        let out = crate::diag::render(&map, &err, false);
        assert!(out.contains("data.txt:1:1]") && out.contains(" x"), "{out}");
        // Bad UTF-8 is kept too, for its mark.
        std::fs::write(&p, b"\xFF").unwrap();
        assert!(parse_file(&mut map, &p, parse).is_err());
        assert_eq!(map.len(), 2);
    }
}
