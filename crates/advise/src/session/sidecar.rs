//! Demonstrations a journal refers to instead of copying: a loaded file's points go once into a
//! Parquet file beside the journal (the *sidecar*), and the journal line names it with its length
//! and a CRC-64 of its bytes.
//!
//! A sidecar holds one required `DOUBLE` column per observation dimension (`z0`, `z1`, ...) and
//! per action dimension (`a0`, ...), uncompressed and without dictionaries, in row groups of
//! [`ROW_GROUP`] points: the rows of the points the statement added, in order. Its name is
//! `demos-CRC.parquet`, so two loads of the same points share one file. It is written to a
//! temporary name in the journal's folder and renamed into place (a crash leaves either no
//! sidecar or a whole one) before its journal line is appended.
//!
//! Reading one back ([`read`]) checks, before anything is applied: that the file is there, no
//! larger than [`MAX_SIDECAR_BYTES`], of the length and CRC the line names, and of the schema
//! and row count the line implies. The points then go through the dataset's own rules as a live
//! `load demos` does. This module does no session work: it reads and writes files only.

use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use miette::Diagnostic;
use parquet::basic::{Repetition, Type as Physical};
use parquet::column::reader::get_typed_column_reader;
use parquet::data_type::DoubleType;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};

use crate::recording::parquet_guard::{self, ParquetGuardError};
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Points per row group: what the writer and the reader hold of one column at a time.
pub const ROW_GROUP: usize = 1 << 20;

/// The largest sidecar [`read`] accepts (16 GiB: 100 million points of 20 values).
pub const MAX_SIDECAR_BYTES: u64 = 16 << 30;

/// A sidecar as its journal line names it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SidecarRef {
    /// The file's name, in the journal's folder.
    pub file: String,
    /// Its length in bytes.
    pub bytes: u64,
    /// CRC-64/XZ of its bytes, 16 hexadecimal digits.
    pub crc64: String,
    /// Points (rows) it holds.
    pub points: u64,
}

/// Why a sidecar could not be read back.
#[derive(Debug, Error, Diagnostic)]
pub enum SidecarError {
    #[error("the demonstrations file `{path}` the journal refers to cannot be read")]
    #[diagnostic(
        code(advise::journal::sidecar_missing),
        help(
            "a journal keeps a loaded file's points in a `demos-*.parquet` file beside it: move or copy the journal together with its `demos-*.parquet` files"
        )
    )]
    Missing {
        path: String,
        #[source]
        source: io::Error,
    },
    #[error("the demonstrations file `{path}` is not the one the journal wrote: {what}")]
    #[diagnostic(
        code(advise::journal::sidecar_altered),
        help(
            "the file was changed, cut or replaced after the session wrote it; nothing of it is used: put back the original beside the journal to restore past this line"
        )
    )]
    Altered { path: String, what: String },
    #[error("the journal line names the demonstrations file `{file}`, which is no file beside it")]
    #[diagnostic(
        code(advise::journal::sidecar_name),
        help(
            "a sidecar is named `demos-CRC.parquet`, in the journal's folder; the line was edited"
        )
    )]
    Name { file: String },
    /// Not a regular file (a FIFO would block the restore), or larger than a sidecar may be.
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(crate::files::FileError),
    /// A sidecar whose footer lies (its CRC updated to match): refused before it is read.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Guard(#[from] ParquetGuardError),
}

/// The column names of a sidecar for `obs_dim` observations and `act_dim` actions.
fn column_names(obs_dim: usize, act_dim: usize) -> Vec<String> {
    (0..obs_dim)
        .map(|k| format!("z{k}"))
        .chain((0..act_dim).map(|k| format!("a{k}")))
        .collect()
}

/// A writer that keeps the CRC and length of what passes through it.
struct Summing<W> {
    inner: W,
    digest: crc::Digest<'static, u64>,
    bytes: u64,
}

static CRC64: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_XZ);

impl<W: Write> Write for Summing<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.digest.update(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// Write `points` points, `z` (rows of `obs_dim`) and `a` (rows of `act_dim`), into a new
/// sidecar in `dir`: to a temporary file first, synced, then renamed to its content's name. Returns what
/// the journal line names.
pub fn write(
    dir: &Path,
    (z, a): (&[f64], &[f64]),
    (obs_dim, act_dim): (usize, usize),
    points: usize,
) -> io::Result<SidecarRef> {
    let tmp = dir.join(format!(
        ".demos-{}-{}.parquet.tmp",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    let written = write_to(&tmp, z, a, obs_dim, act_dim, points);
    let (bytes, crc) = match written {
        Ok(w) => w,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    };
    let file = format!("demos-{crc:016x}.parquet");
    std::fs::rename(&tmp, dir.join(&file)).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })?;
    // The rename itself is made durable with the folder.
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(SidecarRef {
        file,
        bytes,
        crc64: format!("{crc:016x}"),
        points: points as u64,
    })
}

/// Write the Parquet file at `path`; its length and CRC.
fn write_to(
    path: &Path,
    z: &[f64],
    a: &[f64],
    obs_dim: usize,
    act_dim: usize,
    points: usize,
) -> io::Result<(u64, u64)> {
    let pq = |e: parquet::errors::ParquetError| io::Error::other(e.to_string());
    let fields = column_names(obs_dim, act_dim)
        .into_iter()
        .map(|name| {
            Type::primitive_type_builder(&name, Physical::DOUBLE)
                .with_repetition(Repetition::REQUIRED)
                .build()
                .map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(pq)?;
    let schema = Type::group_type_builder("advise_demos")
        .with_fields(fields)
        .build()
        .map_err(pq)?;
    let props = WriterProperties::builder()
        .set_dictionary_enabled(false)
        .set_max_row_group_row_count(Some(ROW_GROUP))
        .build();
    let file = File::create_new(path)?;
    let sink = Summing {
        inner: io::BufWriter::new(file),
        digest: CRC64.digest(),
        bytes: 0,
    };
    let mut w = SerializedFileWriter::new(sink, Arc::new(schema), Arc::new(props)).map_err(pq)?;
    let mut column = Vec::with_capacity(ROW_GROUP.min(points));
    for first in (0..points).step_by(ROW_GROUP) {
        let end = (first + ROW_GROUP).min(points);
        let mut rg = w.next_row_group().map_err(pq)?;
        for (values, dim) in [(z, obs_dim), (a, act_dim)] {
            for k in 0..dim {
                column.clear();
                column.extend((first..end).map(|i| values[i * dim + k]));
                let mut c = rg
                    .next_column()
                    .map_err(pq)?
                    .ok_or_else(|| io::Error::other("a sidecar column is missing"))?;
                c.typed::<DoubleType>()
                    .write_batch(&column, None, None)
                    .map_err(pq)?;
                c.close().map_err(pq)?;
            }
        }
        rg.close().map_err(pq)?;
    }
    let sink = w.into_inner().map_err(pq)?;
    let (bytes, crc) = (sink.bytes, sink.digest.finalize());
    let file = sink.inner.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()?;
    Ok((bytes, crc))
}

/// The path of the sidecar `r` names beside the journal in `dir`, if its name is one a session
/// writes (no folder, no `..`).
pub fn path_of(dir: &Path, r: &SidecarRef) -> Result<PathBuf, SidecarError> {
    let f = &r.file;
    let plain = f.starts_with("demos-")
        && f.ends_with(".parquet")
        && f.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '.')
        && !f.contains("..");
    if !plain {
        return Err(SidecarError::Name { file: f.clone() });
    }
    Ok(dir.join(f))
}

/// Read back the sidecar `r` beside the journal in `dir`: its points' observations and actions,
/// row after row, once its length, CRC, schema and row count are what the line says.
pub fn read(
    dir: &Path,
    r: &SidecarRef,
    obs_dim: usize,
    act_dim: usize,
) -> Result<(Vec<f64>, Vec<f64>), SidecarError> {
    let path = path_of(dir, r)?;
    let shown = path.display().to_string();
    let altered = |what: String| SidecarError::Altered {
        path: shown.clone(),
        what,
    };
    let missing = |source| SidecarError::Missing {
        path: shown.clone(),
        source,
    };
    // Refused before it is opened when it is not a regular file: a FIFO would block.
    let (mut file, len) =
        crate::files::open_regular(&path, MAX_SIDECAR_BYTES).map_err(|e| match e {
            crate::files::FileError::Read { source, .. } => missing(source),
            other => SidecarError::File(other),
        })?;
    if len != r.bytes || len > MAX_SIDECAR_BYTES {
        return Err(altered(format!(
            "it is {len} bytes long; the journal wrote {}",
            r.bytes
        )));
    }
    let mut digest = CRC64.digest();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file.read(&mut buf).map_err(missing)?;
        if n == 0 {
            break;
        }
        digest.update(&buf[..n]);
    }
    let crc = format!("{:016x}", digest.finalize());
    if crc != r.crc64 {
        return Err(altered(format!(
            "its CRC-64 is {crc}; the journal wrote {}",
            r.crc64
        )));
    }
    // A sidecar is written uncompressed: its points' values alone take 8 bytes each.
    let values = r.points.saturating_mul((obs_dim + act_dim) as u64 * 8);
    if values > len {
        return Err(altered(format!(
            "it is {len} bytes long, too short for the {} points the journal says",
            r.points
        )));
    }
    let reader = parquet_guard::reader(file, len, &shown)?;
    parquet_guard::guarded(&shown, || {
        read_columns(&reader, r.points, obs_dim, act_dim).map_err(altered)
    })
}

/// The rows of a sidecar whose bytes are known to be the ones written; the schema and row count
/// are still checked (a line edited to name another session's sidecar).
fn read_columns(
    reader: &SerializedFileReader<File>,
    points: u64,
    obs_dim: usize,
    act_dim: usize,
) -> Result<(Vec<f64>, Vec<f64>), String> {
    let pq = |e: parquet::errors::ParquetError| format!("it is not a sidecar Parquet file ({e})");
    let meta = reader.metadata();
    let schema = meta.file_metadata().schema_descr();
    let names = column_names(obs_dim, act_dim);
    let columns: Vec<(String, Physical)> = schema
        .columns()
        .iter()
        .map(|c| (c.name().to_string(), c.physical_type()))
        .collect();
    let expected: Vec<(String, Physical)> = names
        .iter()
        .map(|n| (n.clone(), Physical::DOUBLE))
        .collect();
    if columns != expected || schema.columns().iter().any(|c| c.max_def_level() != 0) {
        return Err(format!(
            "its columns are {:?}; a sidecar of this domain has {names:?}",
            columns.iter().map(|c| &c.0).collect::<Vec<_>>()
        ));
    }
    let rows = meta.file_metadata().num_rows();
    if u64::try_from(rows).ok() != Some(points) {
        return Err(format!("it holds {rows} points; the journal says {points}"));
    }
    let n = points as usize;
    let (mut z, mut a) = (vec![0.0; n * obs_dim], vec![0.0; n * act_dim]);
    let mut first = 0;
    let mut column = Vec::new();
    for g in 0..meta.num_row_groups() {
        let group = reader.get_row_group(g).map_err(pq)?;
        let len = usize::try_from(meta.row_group(g).num_rows()).unwrap_or(usize::MAX);
        if len > n - first {
            return Err(format!("its row groups hold more than {points} points"));
        }
        for c in 0..obs_dim + act_dim {
            let mut col =
                get_typed_column_reader::<DoubleType>(group.get_column_reader(c).map_err(pq)?);
            column.clear();
            let (records, _, _) = col.read_records(len, None, None, &mut column).map_err(pq)?;
            if records != len || column.len() != len {
                return Err(format!("row group {g} is shorter than it says"));
            }
            let (values, dim, k) = if c < obs_dim {
                (&mut z, obs_dim, c)
            } else {
                (&mut a, act_dim, c - obs_dim)
            };
            for (i, v) in column.iter().enumerate() {
                values[(first + i) * dim + k] = *v;
            }
        }
        first += len;
    }
    if first != n {
        return Err(format!(
            "it holds {first} points; the journal says {points}"
        ));
    }
    Ok((z, a))
}

/// Make the sidecar `r` of the journal in `from` available beside a journal in `to` (a restore
/// that continues in a new journal elsewhere): a hard link, or a copy where links fail.
pub fn carry(from: &Path, to: &Path, r: &SidecarRef) -> io::Result<()> {
    let (src, dst) = (from.join(&r.file), to.join(&r.file));
    if src == dst || dst.exists() {
        return Ok(());
    }
    std::fs::hard_link(&src, &dst).or_else(|_| std::fs::copy(&src, &dst).map(|_| ()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What is written reads back to the bit, across row groups; a byte changed anywhere is
    /// refused by the CRC, a cut file by its length.
    #[test]
    fn a_sidecar_reads_back_exactly_and_refuses_any_change() {
        let dir = tempfile::tempdir().unwrap();
        let n = ROW_GROUP + 17;
        let z: Vec<f64> = (0..n * 3).map(|i| (i as f64).sin() * 1e3).collect();
        let a: Vec<f64> = (0..n * 2).map(|i| -(i as f64) / 7.0).collect();
        let r = write(dir.path(), (&z, &a), (3, 2), n).unwrap();
        assert_eq!(r.points, n as u64);
        let (z2, a2) = read(dir.path(), &r, 3, 2).unwrap();
        assert!(z.iter().zip(&z2).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert!(a.iter().zip(&a2).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert_eq!((z2.len(), a2.len()), (z.len(), a.len()));
        let path = dir.path().join(&r.file);
        let mut bytes = std::fs::read(&path).unwrap();
        let mid = bytes.len() / 2;
        bytes[mid] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        let e = read(dir.path(), &r, 3, 2).unwrap_err();
        assert!(e.to_string().contains("CRC-64"), "{e}");
        bytes.truncate(100);
        std::fs::write(&path, &bytes).unwrap();
        let e = read(dir.path(), &r, 3, 2).unwrap_err();
        assert!(e.to_string().contains("bytes long"), "{e}");
        let other = SidecarRef {
            file: "../x.parquet".into(),
            ..r
        };
        assert!(matches!(
            read(dir.path(), &other, 3, 2),
            Err(SidecarError::Name { .. })
        ));
    }
}
