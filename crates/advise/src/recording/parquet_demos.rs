//! Demonstrations from a Parquet file (issue 36): the columns a CSV demonstrations file has
//! (`t`, the domain's observation and action dimensions by name, optionally `episode` and
//! `x`, `y`, `theta`), one row per control step, read a batch at a time from each row group,
//! never the whole file: up to [`crate::policy::dataset::MAX_STREAM_POINTS`] points whatever its
//! size. Every value is checked by the demonstration rule CSV files follow
//! ([`crate::trace::demo_value_fault`]), an episode's rows are contiguous and its times
//! increase; each refusal names the row and the column.

use std::path::Path;
use std::rc::Rc;

use miette::Diagnostic;
use parquet::basic::Type as Physical;
use parquet::column::reader::{ColumnReader, ColumnReaderImpl};
use parquet::data_type::{ByteArray, DataType};
use parquet::file::reader::{FileReader, RowGroupReader};
use thiserror::Error;

use super::parquet_guard::{self, ParquetGuardError};

use crate::domain::{Domain, Space};
use crate::trace::{Episode, Pose, Trace, ValueFault, demo_value_fault};

/// Rows read from each column at a time: the memory a read holds is this times the columns.
const BATCH: usize = 65_536;

/// The longest episode label read (bytes): a batch's distinct labels then hold at most
/// [`BATCH`] times this.
pub const MAX_LABEL_BYTES: usize = 1024;

/// Whether `path` names a Parquet file (by its extension).
pub fn is_parquet(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// A Parquet demonstrations file that cannot be read.
#[derive(Debug, Error, Diagnostic)]
pub enum ParquetDemosError {
    /// Not a regular file, a footer that lies, declared sizes beyond bounds.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Guard(#[from] ParquetGuardError),

    #[error("{path}: no column `{column}` for the `{domain}` domain")]
    #[diagnostic(
        code(advise::parquet::missing_column),
        help(
            "a demonstrations file has the columns {expected} (and optionally episode, x, y, theta)"
        )
    )]
    MissingColumn {
        path: String,
        column: String,
        domain: String,
        expected: String,
    },

    #[error("{path}: column `{column}` is not one of the `{domain}` domain's")]
    #[diagnostic(code(advise::parquet::unknown_column), help("{help}"))]
    UnknownColumn {
        path: String,
        column: String,
        domain: String,
        help: String,
    },

    #[error("{path}: column `{column}` holds {found} values")]
    #[diagnostic(
        code(advise::parquet::column_type),
        help("{expected}; cast it before writing (pyarrow: `table.cast(...)`, pandas: `astype`)")
    )]
    ColumnType {
        path: String,
        column: String,
        found: String,
        expected: String,
    },

    #[error("{path}: row {row} (counting from 0), column `{column}`: {what}")]
    #[diagnostic(code(advise::parquet::bad_value), help("{help}"))]
    BadValue {
        path: String,
        row: u64,
        column: String,
        what: String,
        help: String,
    },

    #[error(
        "{path}: episode `{episode}` starts again at row {row} (it began at row {first_row}; rows count from 0)"
    )]
    #[diagnostic(
        code(advise::parquet::episode_split),
        help("an episode's rows are contiguous: sort the table by episode, then by t")
    )]
    EpisodeSplit {
        path: String,
        episode: String,
        row: u64,
        first_row: u64,
    },

    #[error("{path}: {rows} rows, more than the {max} points a demonstrations file may hold")]
    #[diagnostic(
        code(advise::parquet::too_many_points),
        help("split it into files of at most {max} rows and load those you need")
    )]
    TooManyPoints { path: String, rows: u64, max: usize },

    #[error("{path}: no rows: a demonstrations file needs at least one point")]
    #[diagnostic(code(advise::parquet::no_rows))]
    NoRows { path: String },
}

/// What a column of the file is for.
#[derive(Clone, Copy, PartialEq)]
enum Slot {
    Episode,
    T,
    Z(usize),
    A(usize),
    Pose(usize),
}

/// One column's reader, by what it holds.
enum Values {
    Float(ColumnReaderImpl<parquet::data_type::FloatType>),
    Double(ColumnReaderImpl<parquet::data_type::DoubleType>),
    Int32(ColumnReaderImpl<parquet::data_type::Int32Type>),
    Int64(ColumnReaderImpl<parquet::data_type::Int64Type>),
    Text(ColumnReaderImpl<parquet::data_type::ByteArrayType>),
}

/// A column's values of one batch.
enum Batch {
    Numbers(Vec<f64>),
    /// Consecutive equal labels share one allocation (a dictionary-encoded label repeats on
    /// every row of its episode).
    Labels(Vec<Rc<str>>),
    /// A label longer than [`MAX_LABEL_BYTES`] at this row: nothing of the batch is kept.
    TooLong {
        row: u64,
        bytes: usize,
    },
}

/// Each of `values` as a label, consecutive equal values sharing one.
fn labels<T: PartialEq>(values: &[T], text: impl Fn(&T) -> String) -> Batch {
    let mut out: Vec<Rc<str>> = Vec::with_capacity(values.len());
    for (i, v) in values.iter().enumerate() {
        match out.last() {
            Some(prev) if i > 0 && values[i - 1] == *v => out.push(prev.clone()),
            _ => out.push(Rc::from(text(v))),
        }
    }
    Batch::Labels(out)
}

/// Read the demonstrations of `path` for `domain`, reporting `progress(rows read, rows)`.
pub fn read_demos(
    domain: &Domain,
    path: &Path,
    max_points: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Vec<Episode>, ParquetDemosError> {
    let shown = path.display().to_string();
    // The row count bounds what is read, not the file's length (a compressed file of
    // `max_points` rows may be any size).
    let reader = parquet_guard::open(path, u64::MAX)?;
    parquet_guard::guarded(&shown, || {
        read_rows(domain, path, &reader, max_points, progress)
    })
}

fn read_rows(
    domain: &Domain,
    path: &Path,
    reader: &parquet::file::reader::SerializedFileReader<std::fs::File>,
    max_points: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Vec<Episode>, ParquetDemosError> {
    let shown = path.display().to_string();
    let unreadable = |message: String| ParquetGuardError::Unreadable {
        path: shown.clone(),
        message,
    };
    let meta = reader.metadata();
    let rows = u64::try_from(meta.file_metadata().num_rows()).unwrap_or(0);
    if rows > max_points as u64 {
        return Err(ParquetDemosError::TooManyPoints {
            path: shown,
            rows,
            max: max_points,
        });
    }
    let schema = meta.file_metadata().schema_descr();
    let mut slots = Vec::with_capacity(schema.num_columns());
    for c in schema.columns() {
        let name = c.path().string();
        let slot = slot_of(domain, &name).ok_or_else(|| unknown(domain, &shown, &name))?;
        let numeric = matches!(
            c.physical_type(),
            Physical::FLOAT | Physical::DOUBLE | Physical::INT32 | Physical::INT64
        );
        let fits = match slot {
            Slot::Episode => numeric || c.physical_type() == Physical::BYTE_ARRAY,
            // Integer times or dimensions would be a column of the wrong kind, silently cast.
            _ => matches!(c.physical_type(), Physical::FLOAT | Physical::DOUBLE),
        };
        if !fits || c.max_rep_level() > 0 {
            return Err(ParquetDemosError::ColumnType {
                path: shown,
                column: name,
                found: if c.max_rep_level() > 0 {
                    "list".to_string()
                } else {
                    format!("{:?}", c.physical_type()).to_lowercase()
                },
                expected: if slot == Slot::Episode {
                    "an episode column holds text or integers".into()
                } else {
                    "a time or dimension column holds float64 (or float32) numbers".into()
                },
            });
        }
        slots.push((slot, name, c.max_def_level()));
    }
    check_required(domain, &shown, &slots)?;
    let mut out = Reading::new(domain, &shown, &slots);
    let mut done = 0u64;
    for g in 0..reader.num_row_groups() {
        let group = reader
            .get_row_group(g)
            .map_err(|e| unreadable(e.to_string()))?;
        let len = u64::try_from(meta.row_group(g).num_rows()).unwrap_or(0);
        let mut columns = open_columns(group.as_ref(), slots.len())
            .map_err(|e| unreadable(format!("row group {g}: {e}")))?;
        let mut left = len;
        while left > 0 {
            let n = left.min(BATCH as u64) as usize;
            let batch: Vec<Batch> = columns
                .iter_mut()
                .zip(&slots)
                .map(|(col, (_, name, def))| read_batch(col, n, *def, done, name, &shown))
                .collect::<Result<_, _>>()?;
            out.rows(&batch, n, done)?;
            left -= n as u64;
            done += n as u64;
            if done > rows {
                return Err(unreadable("its row groups hold more rows than it says".into()).into());
            }
            progress(done, rows);
        }
    }
    if done == 0 {
        return Err(ParquetDemosError::NoRows { path: shown });
    }
    Ok(out.episodes)
}

fn slot_of(domain: &Domain, name: &str) -> Option<Slot> {
    match name {
        "t" => Some(Slot::T),
        "episode" => Some(Slot::Episode),
        _ => domain
            .index_of(Space::Observation, name)
            .map(Slot::Z)
            .or_else(|| domain.index_of(Space::Action, name).map(Slot::A))
            .or_else(|| {
                ["x", "y", "theta"]
                    .iter()
                    .position(|p| *p == name)
                    .map(Slot::Pose)
            }),
    }
}

/// `t`, the observations and the actions, in the order a CSV file has them.
fn required(domain: &Domain) -> Vec<String> {
    std::iter::once("t".to_string())
        .chain(domain.observe.iter().map(|d| d.name.clone()))
        .chain(domain.act.iter().map(|d| d.name.clone()))
        .collect()
}

fn unknown(domain: &Domain, path: &str, name: &str) -> ParquetDemosError {
    let mut known = required(domain);
    known.extend(["episode", "x", "y", "theta"].map(String::from));
    ParquetDemosError::UnknownColumn {
        path: path.to_string(),
        column: name.to_string(),
        domain: domain.name.clone(),
        help: crate::diag::did_you_mean(name, &known)
            .unwrap_or_else(|| format!("the known columns are: {}", known.join(", "))),
    }
}

fn check_required(
    domain: &Domain,
    path: &str,
    slots: &[(Slot, String, i16)],
) -> Result<(), ParquetDemosError> {
    let has = |n: &str| slots.iter().any(|(_, name, _)| name == n);
    let expected = required(domain).join(",");
    let missing = required(domain).into_iter().find(|r| !has(r)).or_else(|| {
        let poses = ["x", "y", "theta"].iter().filter(|p| has(p)).count();
        (poses != 0 && poses != 3)
            .then(|| ["x", "y", "theta"].into_iter().find(|p| !has(p)))
            .flatten()
            .map(String::from)
    });
    match missing {
        Some(column) => Err(ParquetDemosError::MissingColumn {
            path: path.to_string(),
            column,
            domain: domain.name.clone(),
            expected,
        }),
        None => Ok(()),
    }
}

fn open_columns(group: &dyn RowGroupReader, n: usize) -> parquet::errors::Result<Vec<Values>> {
    (0..n)
        .map(|c| {
            Ok(match group.get_column_reader(c)? {
                ColumnReader::FloatColumnReader(r) => Values::Float(r),
                ColumnReader::DoubleColumnReader(r) => Values::Double(r),
                ColumnReader::Int32ColumnReader(r) => Values::Int32(r),
                ColumnReader::Int64ColumnReader(r) => Values::Int64(r),
                ColumnReader::ByteArrayColumnReader(r) => Values::Text(r),
                _ => {
                    return Err(parquet::errors::ParquetError::General(
                        "a column of an unexpected type".into(),
                    ));
                }
            })
        })
        .collect()
}

/// Up to `n` values of one column from row `first`: a null (or a short column) is refused.
fn read_batch(
    col: &mut Values,
    n: usize,
    max_def: i16,
    first: u64,
    name: &str,
    path: &str,
) -> Result<Batch, ParquetDemosError> {
    let mut defs: Vec<i16> = Vec::with_capacity(if max_def > 0 { n } else { 0 });
    let bad = |what: String| ParquetGuardError::Unreadable {
        path: path.to_string(),
        message: format!("column `{name}`: {what}"),
    };
    let null_at = |defs: &[i16]| {
        defs.iter()
            .position(|d| *d < max_def)
            .map(|i| ParquetDemosError::BadValue {
                path: path.to_string(),
                row: first + i as u64,
                column: name.to_string(),
                what: "no value (null)".into(),
                help: "every row needs every column; drop or fill the missing rows".into(),
            })
    };
    fn typed<T: DataType>(
        r: &mut ColumnReaderImpl<T>,
        n: usize,
        defs: Option<&mut Vec<i16>>,
    ) -> parquet::errors::Result<(usize, Vec<T::T>)> {
        let mut values = Vec::with_capacity(n);
        let (records, _, _) = r.read_records(n, defs, None, &mut values)?;
        Ok((records, values))
    }
    let defs_arg = (max_def > 0).then_some(&mut defs);
    let (records, batch) = match col {
        Values::Float(r) => typed(r, n, defs_arg)
            .map(|(k, v)| (k, Batch::Numbers(v.into_iter().map(f64::from).collect()))),
        Values::Double(r) => typed(r, n, defs_arg).map(|(k, v)| (k, Batch::Numbers(v))),
        Values::Int32(r) => typed(r, n, defs_arg).map(|(k, v)| (k, labels(&v, |x| x.to_string()))),
        Values::Int64(r) => typed(r, n, defs_arg).map(|(k, v)| (k, labels(&v, |x| x.to_string()))),
        Values::Text(r) => typed(r, n, defs_arg).map(|(k, v)| {
            if let Some(i) = v.iter().position(|b| b.len() > MAX_LABEL_BYTES) {
                return (
                    k,
                    Batch::TooLong {
                        row: first + i as u64,
                        bytes: v[i].len(),
                    },
                );
            }
            (
                k,
                labels(&v, |b: &ByteArray| {
                    String::from_utf8_lossy(b.data()).into_owned()
                }),
            )
        }),
    }
    .map_err(|e| bad(e.to_string()))?;
    if let Batch::TooLong { row, bytes } = &batch {
        return Err(ParquetDemosError::BadValue {
            path: path.to_string(),
            row: *row,
            column: name.to_string(),
            what: format!("an episode label of {bytes} bytes"),
            help: format!(
                "an episode is named in at most {MAX_LABEL_BYTES} bytes: use short names or numbers"
            ),
        });
    }
    if let Some(e) = null_at(&defs) {
        return Err(e);
    }
    let got = match &batch {
        Batch::Numbers(v) => v.len(),
        Batch::Labels(v) => v.len(),
        Batch::TooLong { .. } => 0,
    };
    if records != n || got != n {
        return Err(bad(format!("row group ends before its {n} rows")).into());
    }
    Ok(batch)
}

/// The episodes read so far.
struct Reading<'a> {
    domain: &'a Domain,
    path: &'a str,
    slots: &'a [(Slot, String, i16)],
    episodes: Vec<Episode>,
    /// Each episode's first row: an episode's rows are contiguous.
    starts: std::collections::HashMap<String, u64>,
    has_pose: bool,
}

impl<'a> Reading<'a> {
    fn new(domain: &'a Domain, path: &'a str, slots: &'a [(Slot, String, i16)]) -> Self {
        Reading {
            domain,
            path,
            slots,
            episodes: Vec::new(),
            starts: Default::default(),
            has_pose: slots.iter().any(|(s, _, _)| matches!(s, Slot::Pose(_))),
        }
    }

    fn bad(&self, row: u64, c: usize, what: String, help: String) -> ParquetDemosError {
        ParquetDemosError::BadValue {
            path: self.path.to_string(),
            row,
            column: self.slots[c].1.clone(),
            what,
            help,
        }
    }

    /// Rows `first..first + n`, one value per column in `batch`.
    fn rows(&mut self, batch: &[Batch], n: usize, first: u64) -> Result<(), ParquetDemosError> {
        let (mut z, mut a) = (
            vec![0.0; self.domain.obs_dim()],
            vec![0.0; self.domain.act_dim()],
        );
        let mut pose = [0.0; 3];
        let default_label = Path::new(self.path)
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        for r in 0..n {
            let row = first + r as u64;
            let mut t = 0.0;
            let mut label: Option<&str> = None;
            for (c, values) in batch.iter().enumerate() {
                let slot = self.slots[c].0;
                let v = match values {
                    Batch::Labels(l) => {
                        label = Some(&*l[r]);
                        continue;
                    }
                    // Refused where the batch was read.
                    Batch::TooLong { .. } => continue,
                    Batch::Numbers(v) => v[r],
                };
                let space = match slot {
                    Slot::A(_) => Space::Action,
                    _ => Space::Observation,
                };
                let k = match slot {
                    Slot::A(i) | Slot::Z(i) => i,
                    _ => 0,
                };
                match demo_value_fault(self.domain, space, k, v) {
                    Some(ValueFault::NotFinite) => {
                        return Err(self.bad(
                            row,
                            c,
                            format!("{v} is not a finite number"),
                            "every value of a demonstration is finite".into(),
                        ));
                    }
                    Some(ValueFault::OutsideLimits(l)) if matches!(slot, Slot::A(_)) => {
                        return Err(self.bad(
                            row,
                            c,
                            format!("{v} is outside the action's limits [{}, {}]", l.lo, l.hi),
                            "a demonstration commands what the robot may be commanded".into(),
                        ));
                    }
                    _ => {}
                }
                match slot {
                    Slot::T => t = v,
                    Slot::Z(i) => z[i] = v,
                    Slot::A(i) => a[i] = v,
                    Slot::Pose(p) => pose[p] = v,
                    Slot::Episode => {}
                }
            }
            let label = label.unwrap_or(&default_label);
            if self.episodes.last().is_none_or(|e| e.name != label) {
                if let Some(&first_row) = self.starts.get(label) {
                    return Err(ParquetDemosError::EpisodeSplit {
                        path: self.path.to_string(),
                        episode: label.to_string(),
                        row,
                        first_row,
                    });
                }
                self.starts.insert(label.to_string(), row);
                self.episodes.push(Episode {
                    name: label.to_string(),
                    trace: Trace::new(self.domain),
                });
            }
            let Some(Episode { trace, .. }) = self.episodes.last_mut() else {
                unreachable!("an episode was pushed above")
            };
            if let Some(&prev) = trace.t.last()
                && t <= prev
            {
                let c = self.slots.iter().position(|s| s.0 == Slot::T).unwrap_or(0);
                return Err(self.bad(
                    row,
                    c,
                    format!("t = {t} does not come after the row before's t = {prev}"),
                    "an episode's times increase: sort the table by episode, then by t".into(),
                ));
            }
            let p = self.has_pose.then_some(Pose {
                x_m: pose[0],
                y_m: pose[1],
                theta_rad: pose[2],
            });
            trace.push(t, &z, &a, p);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file that is not Parquet, or is cut short, is refused as unreadable, not read as CSV.
    #[test]
    fn what_is_not_parquet_is_refused_as_unreadable() {
        let dir = tempfile::tempdir().unwrap();
        let domain = Domain::positioning();
        for (name, bytes) in [
            ("empty.parquet", &b""[..]),
            ("text.parquet", &b"t,dist2\n0,1\n"[..]),
            ("cut.parquet", &b"PAR1\x00\x00\x00\x00PAR1"[..]),
        ] {
            let path = dir.path().join(name);
            std::fs::write(&path, bytes).unwrap();
            let err = read_demos(&domain, &path, 1000, &mut |_, _| {}).unwrap_err();
            assert!(
                matches!(
                    err,
                    ParquetDemosError::Guard(ParquetGuardError::Unreadable { .. })
                ),
                "{name}: {err}"
            );
        }
        assert!(is_parquet(Path::new("a/b.PARQUET")) && !is_parquet(Path::new("b.csv")));
    }
}
