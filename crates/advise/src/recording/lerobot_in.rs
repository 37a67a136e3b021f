//! A LeRobot dataset in: the episodes of a LeRobot v3.0 dataset directory (as [`super::lerobot`]
//! writes it, or as LeRobot itself does) as demonstrations of a domain.
//!
//! `meta/info.json` says the features; the frames are the rows of `data/chunk-*/file-*.parquet`.
//! A frame's `observation.state` and `action` (lists of floats) become a point's observation and
//! action: mapped by the features' `names` when they name every dimension of the domain (in any
//! order, extra ones ignored), else position by position when [`LeRobotReadOptions::by_position`]
//! says so or the feature has no names, the widths then equal. Frames are grouped by
//! `episode_index`, their `frame_index` increasing within an episode (as stored); a point's time is the frame's `timestamp` (or
//! `frame_index / fps`).
//!
//! Every refusal is an `advise::lerobot::*` diagnostic naming the file and the row. Hostile
//! input is bounded: `info.json` is read up to [`MAX_INFO_BYTES`], a parquet file up to
//! [`crate::files::MAX_READ_BYTES`], a list column to its rows times its width (from the row groups'
//! metadata, before a row is built), at most [`MAX_FRAMES`] frames (counted from the files' own
//! row counts, not from `info.json`), at most [`MAX_DATA_FILES`] files, and a declared width is
//! compared to the domain's before anything is allocated for it.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use miette::Diagnostic;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::{Field, Row};
use parquet::schema::types::Type;
use serde_json::Value;
use thiserror::Error;

use crate::domain::{Dim, Domain, Space};
use crate::trace::{Episode, Trace, ValueFault};

/// The most frames a LeRobot dataset may hold to be read (each one a point in memory).
pub const MAX_FRAMES: usize = 1_000_000;
/// The most parquet files of frames a dataset may hold.
pub const MAX_DATA_FILES: usize = 10_000;
/// The largest `meta/info.json` read.
pub const MAX_INFO_BYTES: u64 = 16 * 1024 * 1024;

/// Why a LeRobot dataset could not be read.
#[derive(Debug, Error, Diagnostic)]
pub enum LeRobotInError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    /// A frames file that is not a regular file, whose footer lies, or which declares more
    /// than is read ([`super::parquet_guard`]).
    #[error(transparent)]
    #[diagnostic(transparent)]
    Guard(#[from] super::parquet_guard::ParquetGuardError),
    #[error("{path} is missing: {what}")]
    #[diagnostic(
        code(advise::lerobot::missing_file),
        help(
            "give the dataset's root directory (the one holding `meta/info.json` and `data/chunk-000/file-000.parquet`)"
        )
    )]
    Missing { path: PathBuf, what: String },
    #[error("{path}: {what}")]
    #[diagnostic(
        code(advise::lerobot::info),
        help(
            "`meta/info.json` must be a LeRobot v3.0 info file: `codebase_version`, `fps` and `features` with `observation.state` and `action` (`dtype`, `shape`, `names`)"
        )
    )]
    Info { path: PathBuf, what: String },
    #[error("{path} is a LeRobot {version} dataset; `advise` reads v3.0")]
    #[diagnostic(
        code(advise::lerobot::version),
        help(
            "convert it with LeRobot's `python -m lerobot.datasets.v30.convert_dataset_v21_to_v30 --repo-id=...` first"
        )
    )]
    Version { path: PathBuf, version: String },
    #[error(
        "`{feature}` of {path} holds {found} values a frame, the domain `{domain}` has {want} {word} dimensions ({dims})"
    )]
    #[diagnostic(
        code(advise::lerobot::width),
        help(
            "import for a task whose domain has these dimensions (`--task`, `--tasks FILE`), or name the feature's values in `meta/info.json` (`names`) so that each of the domain's dimensions is found by name"
        )
    )]
    Width {
        path: PathBuf,
        feature: String,
        found: usize,
        want: usize,
        word: &'static str,
        domain: String,
        dims: String,
    },
    #[error(
        "`{feature}` of {path} names its values {names}, which do not name the {word} dimension{plural} {missing} of the domain `{domain}`"
    )]
    #[diagnostic(
        code(advise::lerobot::names),
        help(
            "rename the values in `meta/info.json` (`features.{feature}.names`) to the domain's dimensions, or map them position by position (`--by-position`, `by_position=True`) when the widths agree"
        )
    )]
    Names {
        path: PathBuf,
        feature: String,
        names: String,
        word: &'static str,
        plural: &'static str,
        missing: String,
        domain: String,
    },
    #[error("{path}, row {row}: column `{column}` is {found}, expected {want}")]
    #[diagnostic(
        code(advise::lerobot::column_type),
        help(
            "`observation.state` and `action` are lists of floats of the declared shape, `episode_index` and `frame_index` integers, `timestamp` a float"
        )
    )]
    ColumnType {
        path: PathBuf,
        row: usize,
        column: String,
        found: String,
        want: String,
    },
    #[error("{path} has no column `{column}`")]
    #[diagnostic(
        code(advise::lerobot::missing_column),
        help(
            "a LeRobot v3.0 frame table has `observation.state`, `action`, `episode_index` and `frame_index` columns"
        )
    )]
    MissingColumn { path: PathBuf, column: String },
    #[error("{path}, row {row} (episode {episode}, frame {frame}): {what} is {value}")]
    #[diagnostic(
        code(advise::lerobot::not_finite),
        help("every state and action value must be a finite number: repair or drop the frame")
    )]
    NotFinite {
        path: PathBuf,
        row: usize,
        episode: i64,
        frame: i64,
        what: String,
        value: String,
    },
    #[error(
        "episode {episode}, frame {frame}: action `{dim}` is {value}, outside its limits [{lo}, {hi}]"
    )]
    #[diagnostic(
        code(advise::lerobot::outside_limits),
        help(
            "a demonstration's actions stay within the domain's limits: check the mapping of the dataset's `action` to the domain's dimensions, or repair the frames"
        )
    )]
    OutsideLimits {
        episode: i64,
        frame: i64,
        dim: String,
        value: String,
        lo: String,
        hi: String,
    },
    #[error("{path}: {what}, more than the {limit} `advise` reads")]
    #[diagnostic(
        code(advise::lerobot::too_large),
        help("split the dataset (LeRobot's `split_dataset`) and import its parts")
    )]
    TooLarge {
        path: PathBuf,
        what: String,
        limit: usize,
    },
    #[error("{path} is not a readable parquet file: {reason}")]
    #[diagnostic(
        code(advise::lerobot::parquet),
        help(
            "the frames must be parquet files as LeRobot writes them; rewrite it with pyarrow if it came from elsewhere"
        )
    )]
    Parquet { path: PathBuf, reason: String },
    #[error(
        "{path}: column `{column}` holds {values} values in {rows} rows, more than its width {width} allows"
    )]
    #[diagnostic(
        code(advise::lerobot::list_too_long),
        help(
            "each frame's `{column}` holds exactly the width `meta/info.json` declares: rewrite the file, or fix `features.{column}.shape`"
        )
    )]
    ListTooLong {
        path: PathBuf,
        column: String,
        values: i64,
        rows: i64,
        width: usize,
    },
    #[error(
        "{path}, row {row}: episode {episode}'s frame_index {frame} does not follow its frame {previous}"
    )]
    #[diagnostic(
        code(advise::lerobot::frame_order),
        help(
            "an episode's frames are stored once each, in increasing `frame_index`: drop the repeated frames or renumber them"
        )
    )]
    FrameOrder {
        path: PathBuf,
        row: usize,
        episode: i64,
        frame: i64,
        previous: i64,
    },
    #[error(
        "{path}, row {row}: episode {episode}'s frame {frame} has the timestamp {t}, not after its frame before's {previous}"
    )]
    #[diagnostic(
        code(advise::lerobot::time_order),
        help(
            "a demonstration's times increase (`load demos` refuses a file whose times do not): repair the frames' `timestamp`, or drop the column so times are `frame_index / fps`"
        )
    )]
    TimeOrder {
        path: PathBuf,
        row: usize,
        episode: i64,
        frame: i64,
        t: f64,
        previous: f64,
    },
    #[error("{path} holds no frames")]
    #[diagnostic(
        code(advise::lerobot::no_frames),
        help("a demonstration has at least one point: import a dataset that holds episodes")
    )]
    NoFrames { path: PathBuf },
}

/// How to read a LeRobot dataset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LeRobotReadOptions {
    /// Map `observation.state` and `action` position by position even where their names do not
    /// name the domain's dimensions (the widths must agree).
    pub by_position: bool,
}

/// A LeRobot dataset read as demonstrations.
#[derive(Clone, Debug, PartialEq)]
pub struct LeRobotRead {
    /// One per episode, in `episode_index` order, named `episode N`.
    pub episodes: Vec<Episode>,
    /// Each episode's `episode_index` in the dataset.
    pub episode_ids: Vec<i64>,
    /// Each point's episode index (the dataset's), points in the episodes' order.
    pub episode_index: Vec<i64>,
    /// Each point's frame index within its episode (the dataset's).
    pub frame_index: Vec<i64>,
    /// The dataset's frames per second.
    pub fps: f64,
    /// How the dataset's values were mapped to the domain's dimensions, one line a feature.
    pub mapping: Vec<String>,
}

/// Where each of a domain's dimensions is in a feature's values.
struct Mapping {
    /// The feature's width (values a frame).
    width: usize,
    /// For each of the domain's dimensions, its position in the feature's values.
    at: Vec<usize>,
    /// What a user is told of it.
    described: String,
}

/// A feature's names in `info.json`: a list of strings, or (LeRobot's older style) an object
/// holding one such list.
fn feature_names(feature: &Value) -> Option<Vec<String>> {
    let names = match feature.get("names")? {
        Value::Object(m) if m.len() == 1 => m.values().next()?,
        v => v,
    };
    names
        .as_array()?
        .iter()
        .map(|n| n.as_str().map(str::to_string))
        .collect()
}

/// The mapping of `info.json`'s feature `key` (as `feature`) to the `space` dimensions `dims`.
fn mapping(
    info_path: &Path,
    domain: &Domain,
    space: Space,
    key: &str,
    feature: Option<&Value>,
    options: &LeRobotReadOptions,
) -> Result<Mapping, LeRobotInError> {
    let dims: &[Dim] = domain.dims(space);
    let info = |what: String| LeRobotInError::Info {
        path: info_path.to_path_buf(),
        what,
    };
    let feature = feature.ok_or_else(|| info(format!("no feature `{key}` in `features`")))?;
    let width = match feature
        .get("shape")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
    {
        Some([n]) => n.as_u64(),
        _ => None,
    }
    .ok_or_else(|| info(format!("`features.{key}.shape` is not `[N]` (one width)")))?;
    let width = usize::try_from(width).unwrap_or(usize::MAX);
    let names = feature_names(feature);
    let dim_names = || {
        dims.iter()
            .map(|d| format!("`{}`", d.name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let width_err = |found| LeRobotInError::Width {
        path: info_path.to_path_buf(),
        feature: key.to_string(),
        found,
        want: dims.len(),
        word: space.word(),
        domain: domain.name.clone(),
        dims: dim_names(),
    };
    if let Some(names) = names.as_ref().filter(|n| n.len() != width) {
        return Err(info(format!(
            "`features.{key}` declares {width} values a frame and names {}",
            names.len()
        )));
    }
    if let Some(names) = &names {
        let at: Vec<Option<usize>> = dims
            .iter()
            .map(|d| names.iter().position(|n| *n == d.name))
            .collect();
        if at.iter().all(Option::is_some) {
            return Ok(Mapping {
                width,
                at: at.into_iter().flatten().collect(),
                described: format!("`{key}` by name: {}", dim_names()),
            });
        }
        if !options.by_position {
            let missing: Vec<String> = dims
                .iter()
                .zip(&at)
                .filter(|(_, a)| a.is_none())
                .map(|(d, _)| format!("`{}`", d.name))
                .collect();
            let shown: Vec<String> = names.iter().take(16).map(|n| format!("`{n}`")).collect();
            return Err(LeRobotInError::Names {
                path: info_path.to_path_buf(),
                feature: key.to_string(),
                names: format!(
                    "[{}{}]",
                    shown.join(", "),
                    if names.len() > 16 { ", ..." } else { "" }
                ),
                word: space.word(),
                plural: if missing.len() == 1 { "" } else { "s" },
                missing: missing.join(", "),
                domain: domain.name.clone(),
            });
        }
    }
    if width != dims.len() {
        return Err(width_err(width));
    }
    Ok(Mapping {
        width,
        at: (0..width).collect(),
        described: format!("`{key}` by position: {}", dim_names()),
    })
}

/// The frames' parquet files, `data/chunk-*/file-*.parquet` in order.
fn data_files(dir: &Path) -> Result<Vec<PathBuf>, LeRobotInError> {
    let data = dir.join("data");
    let missing = |path: PathBuf, what: &str| LeRobotInError::Missing {
        path,
        what: what.to_string(),
    };
    let chunks = std::fs::read_dir(&data)
        .map_err(|_| missing(data.clone(), "the frames (`data/chunk-*/file-*.parquet`)"))?;
    let mut files = Vec::new();
    for chunk in chunks.flatten().take(MAX_DATA_FILES) {
        let Ok(entries) = std::fs::read_dir(chunk.path()) else {
            continue;
        };
        for e in entries.flatten().take(MAX_DATA_FILES + 1) {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "parquet") {
                files.push(p);
            }
            if files.len() > MAX_DATA_FILES {
                return Err(LeRobotInError::TooLarge {
                    path: data,
                    what: "more parquet files of frames".into(),
                    limit: MAX_DATA_FILES,
                });
            }
        }
    }
    files.sort();
    if files.is_empty() {
        return Err(missing(
            data.join("chunk-000/file-000.parquet"),
            "no parquet file of frames under `data/`",
        ));
    }
    Ok(files)
}

/// One frame as read: its row, episode, index, time and values.
struct Frame {
    episode: i64,
    frame: i64,
    t: Option<f64>,
    z: Vec<f64>,
    a: Vec<f64>,
}

/// What a field is, for a diagnostic.
fn kind_of(f: &Field) -> String {
    match f {
        Field::ListInternal(l) => match l.elements().first() {
            Some(e) => format!("a list of {}", kind_of(e)),
            None => "an empty list".into(),
        },
        Field::Null => "null".into(),
        Field::Bool(_) => "a boolean".into(),
        Field::Str(_) => "a string".into(),
        Field::Bytes(_) => "bytes".into(),
        Field::Float(_) | Field::Double(_) => "a float".into(),
        Field::Group(_) => "a struct".into(),
        _ => "an integer or other scalar".into(),
    }
}

fn as_int(f: &Field) -> Option<i64> {
    Some(match *f {
        Field::Byte(v) => v.into(),
        Field::Short(v) => v.into(),
        Field::Int(v) => v.into(),
        Field::Long(v) => v,
        Field::UByte(v) => v.into(),
        Field::UShort(v) => v.into(),
        Field::UInt(v) => v.into(),
        Field::ULong(v) => i64::try_from(v).ok()?,
        _ => return None,
    })
}

fn as_float(f: &Field) -> Option<f64> {
    match *f {
        Field::Float(v) => Some(v.into()),
        Field::Double(v) => Some(v),
        _ => None,
    }
}

/// Read the frames of one parquet file, appending to `out` (at most [`MAX_FRAMES`] in all).
fn read_frames(
    path: &Path,
    state: &Mapping,
    action: &Mapping,
    out: &mut Vec<Frame>,
) -> Result<(), LeRobotInError> {
    let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    if len > crate::files::MAX_READ_BYTES {
        return Err(LeRobotInError::TooLarge {
            path: path.to_path_buf(),
            what: format!("{len} bytes"),
            limit: crate::files::MAX_READ_BYTES as usize,
        });
    }
    let reader = super::parquet_guard::open(path, crate::files::MAX_READ_BYTES)?;
    let shown = path.display().to_string();
    super::parquet_guard::guarded(&shown, || read_frames_of(path, &reader, state, action, out))
}

/// [`read_frames`] of a reader whose footer was checked.
fn read_frames_of(
    path: &Path,
    reader: &SerializedFileReader<std::fs::File>,
    state: &Mapping,
    action: &Mapping,
    out: &mut Vec<Frame>,
) -> Result<(), LeRobotInError> {
    let bad = |reason: String| LeRobotInError::Parquet {
        path: path.to_path_buf(),
        reason,
    };
    refuse_list_scalars(path, reader)?;
    let rows = usize::try_from(reader.metadata().file_metadata().num_rows()).unwrap_or(0);
    if out.len().saturating_add(rows) > MAX_FRAMES {
        return Err(LeRobotInError::TooLarge {
            path: path.to_path_buf(),
            what: format!("{} frames", out.len().saturating_add(rows)),
            limit: MAX_FRAMES,
        });
    }
    refuse_long_lists(path, reader, state, action)?;
    let iter = reader
        .get_row_iter(Some(projection(path, reader)?))
        .map_err(|e| bad(e.to_string()))?;
    for (row, r) in iter.enumerate().take(MAX_FRAMES + 1 - out.len()) {
        let r = r.map_err(|e| bad(e.to_string()))?;
        out.push(frame_of(path, row, &r, state, action)?);
        if out.len() > MAX_FRAMES {
            return Err(LeRobotInError::TooLarge {
                path: path.to_path_buf(),
                what: "more frames".into(),
                limit: MAX_FRAMES,
            });
        }
    }
    Ok(())
}

/// Refuse a scalar column (`episode_index`, `frame_index`, `timestamp`) stored as a list: it
/// would be read whole into one row (a 1e8-value `frame_index` list), so it is refused before
/// any row is built.
fn refuse_list_scalars(
    path: &Path,
    reader: &SerializedFileReader<std::fs::File>,
) -> Result<(), LeRobotInError> {
    for c in reader.metadata().file_metadata().schema_descr().columns() {
        let column = c.path().parts().first().map_or("", String::as_str);
        let want = match column {
            "episode_index" | "frame_index" => "an integer",
            "timestamp" => "a float",
            _ => continue,
        };
        if c.max_rep_level() > 0 {
            return Err(LeRobotInError::ColumnType {
                path: path.to_path_buf(),
                row: 0,
                column: column.to_string(),
                found: "a list".into(),
                want: want.into(),
            });
        }
    }
    Ok(())
}

/// Refuse, before any row is built, a row group whose list columns hold more values than
/// rows * width (+ rows, for empty or null lists): a list longer than its width would be read
/// whole (a 4 KB file can hold a list of 100M zeros).
fn refuse_long_lists(
    path: &Path,
    reader: &SerializedFileReader<std::fs::File>,
    state: &Mapping,
    action: &Mapping,
) -> Result<(), LeRobotInError> {
    for group in reader.metadata().row_groups() {
        let rows = group.num_rows().max(0);
        for c in group.columns() {
            let column = c.column_path().parts().first().map_or("", String::as_str);
            let width = match column {
                "observation.state" => state.width,
                "action" => action.width,
                _ => continue,
            };
            let most = rows.saturating_mul(width as i64 + 1);
            if c.num_values() > most || c.uncompressed_size() > most.saturating_mul(16).max(1 << 20)
            {
                return Err(LeRobotInError::ListTooLong {
                    path: path.to_path_buf(),
                    column: column.to_string(),
                    values: c.num_values(),
                    rows,
                    width,
                });
            }
        }
    }
    Ok(())
}

/// The columns a frame is read from; all but `timestamp` are required.
const WANTED: [&str; 5] = [
    "observation.state",
    "action",
    "episode_index",
    "frame_index",
    "timestamp",
];

/// The file's schema cut to the [`WANTED`] columns, refusing a file without a required one.
fn projection(
    path: &Path,
    reader: &SerializedFileReader<std::fs::File>,
) -> Result<Type, LeRobotInError> {
    let schema = reader.metadata().file_metadata().schema();
    let fields: Vec<_> = schema
        .get_fields()
        .iter()
        .filter(|f| WANTED.contains(&f.name()))
        .cloned()
        .collect();
    for column in &WANTED[..4] {
        if !fields.iter().any(|f| f.name() == *column) {
            return Err(LeRobotInError::MissingColumn {
                path: path.to_path_buf(),
                column: column.to_string(),
            });
        }
    }
    Type::group_type_builder(schema.name())
        .with_fields(fields)
        .build()
        .map_err(|e| LeRobotInError::Parquet {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
}

/// Row `row` of the file at `path` as a frame: its indices, time, and the mapped values of
/// its lists, each column of the type and width it should have.
fn frame_of(
    path: &Path,
    row: usize,
    r: &Row,
    state: &Mapping,
    action: &Mapping,
) -> Result<Frame, LeRobotInError> {
    let mut frame = Frame {
        episode: 0,
        frame: 0,
        t: None,
        z: Vec::new(),
        a: Vec::new(),
    };
    let wrong = |column: &str, found: &Field, want: String| LeRobotInError::ColumnType {
        path: path.to_path_buf(),
        row,
        column: column.to_string(),
        found: kind_of(found),
        want,
    };
    for (name, field) in r.get_column_iter() {
        match name.as_str() {
            "episode_index" | "frame_index" => {
                let v = as_int(field).ok_or_else(|| wrong(name, field, "an integer".into()))?;
                if name == "episode_index" {
                    frame.episode = v;
                } else {
                    frame.frame = v;
                }
            }
            "timestamp" => {
                frame.t =
                    Some(as_float(field).ok_or_else(|| wrong(name, field, "a float".into()))?);
            }
            key => {
                let (m, into) = if key == "action" {
                    (action, &mut frame.a)
                } else {
                    (state, &mut frame.z)
                };
                let want = || format!("a list of {} floats", m.width);
                let values: Vec<f64> = match field {
                    Field::ListInternal(l) if l.elements().len() == m.width => l
                        .elements()
                        .iter()
                        .map(as_float)
                        .collect::<Option<_>>()
                        .ok_or_else(|| wrong(key, field, want()))?,
                    Field::ListInternal(l) => {
                        return Err(LeRobotInError::ColumnType {
                            path: path.to_path_buf(),
                            row,
                            column: key.to_string(),
                            found: format!("a list of {} values", l.elements().len()),
                            want: want(),
                        });
                    }
                    _ => return Err(wrong(key, field, want())),
                };
                *into = m.at.iter().map(|&k| values[k]).collect();
            }
        }
    }
    Ok(frame)
}

/// A frame's time: its `timestamp`, else `frame_index / fps`.
fn frame_time(f: &Frame, fps: f64) -> f64 {
    f.t.unwrap_or(f.frame as f64 / fps)
}

/// Read the LeRobot v3.0 dataset in `dir` as demonstrations of `domain`.
pub fn read_lerobot(
    dir: &Path,
    domain: &Domain,
    options: &LeRobotReadOptions,
) -> Result<LeRobotRead, LeRobotInError> {
    let info_path = dir.join("meta/info.json");
    let (info, fps) = read_info(dir, &info_path)?;
    let features = info.get("features");
    let feature = |key: &str| features.and_then(|f| f.get(key));
    let state = mapping(
        &info_path,
        domain,
        Space::Observation,
        "observation.state",
        feature("observation.state"),
        options,
    )?;
    let action = mapping(
        &info_path,
        domain,
        Space::Action,
        "action",
        feature("action"),
        options,
    )?;
    let mut frames = Vec::new();
    let mut rows_of = Vec::new();
    for path in data_files(dir)? {
        let before = frames.len();
        read_frames(&path, &state, &action, &mut frames)?;
        rows_of.push((path, before..frames.len()));
    }
    if frames.is_empty() {
        return Err(LeRobotInError::NoFrames {
            path: dir.join("data"),
        });
    }
    check_frames(&frames, &rows_of, fps, domain)?;
    let mut by_episode: BTreeMap<i64, Vec<Frame>> = BTreeMap::new();
    for f in frames {
        by_episode.entry(f.episode).or_default().push(f);
    }
    let mut read = LeRobotRead {
        episodes: Vec::with_capacity(by_episode.len()),
        episode_ids: by_episode.keys().copied().collect(),
        episode_index: Vec::new(),
        frame_index: Vec::new(),
        fps,
        mapping: vec![state.described, action.described],
    };
    for (e, fs) in by_episode {
        let trace = episode_trace(domain, e, &fs, fps)?;
        for f in &fs {
            read.episode_index.push(e);
            read.frame_index.push(f.frame);
        }
        read.episodes.push(Episode {
            name: format!("episode {e}"),
            trace,
        });
    }
    Ok(read)
}

/// The dataset's `meta/info.json` (at `info_path`, in `dir`), of the version this reader
/// knows, and its frames per second.
fn read_info(dir: &Path, info_path: &Path) -> Result<(Value, f64), LeRobotInError> {
    if !info_path.is_file() {
        return Err(LeRobotInError::Missing {
            path: info_path.to_path_buf(),
            what: "the dataset's description".into(),
        });
    }
    let text = crate::files::read_text_limited(info_path, MAX_INFO_BYTES)?;
    let info_err = |what: String| LeRobotInError::Info {
        path: info_path.to_path_buf(),
        what,
    };
    let info: Value =
        serde_json::from_str(&text).map_err(|e| info_err(format!("not JSON: {e}")))?;
    let version = info
        .get("codebase_version")
        .and_then(Value::as_str)
        .ok_or_else(|| info_err("no `codebase_version`".into()))?;
    if version != super::lerobot::CODEBASE_VERSION {
        return Err(LeRobotInError::Version {
            path: dir.to_path_buf(),
            version: version.to_string(),
        });
    }
    let fps = info
        .get("fps")
        .and_then(Value::as_f64)
        .filter(|f| f.is_finite() && *f > 0.0)
        .ok_or_else(|| info_err("`fps` is not a positive number".into()))?;
    Ok((info, fps))
}

/// Check the values where they were read (`rows_of`: each file's range of `frames`), before
/// grouping them: finite times and values, frame indices and times increasing within an
/// episode. The demonstration rules `load demos` holds (and the bag import), so an import never
/// writes what it refuses.
fn check_frames(
    frames: &[Frame],
    rows_of: &[(PathBuf, std::ops::Range<usize>)],
    fps: f64,
    domain: &Domain,
) -> Result<(), LeRobotInError> {
    let mut last_frame: HashMap<i64, (i64, f64)> = HashMap::new();
    for (path, range) in rows_of {
        for (row, f) in frames[range.clone()].iter().enumerate() {
            let t = frame_time(f, fps);
            if !t.is_finite() {
                return Err(LeRobotInError::NotFinite {
                    path: path.clone(),
                    row,
                    episode: f.episode,
                    frame: f.frame,
                    what: "`timestamp`".into(),
                    value: t.to_string(),
                });
            }
            if let Some((previous, previous_t)) = last_frame.insert(f.episode, (f.frame, t)) {
                if previous >= f.frame {
                    return Err(LeRobotInError::FrameOrder {
                        path: path.clone(),
                        row,
                        episode: f.episode,
                        frame: f.frame,
                        previous,
                    });
                }
                if t <= previous_t {
                    return Err(LeRobotInError::TimeOrder {
                        path: path.clone(),
                        row,
                        episode: f.episode,
                        frame: f.frame,
                        t,
                        previous: previous_t,
                    });
                }
            }
            let values =
                f.z.iter()
                    .zip(&domain.observe)
                    .map(|(v, d)| (v, d, "observation.state"));
            let values = values.chain(f.a.iter().zip(&domain.act).map(|(v, d)| (v, d, "action")));
            for (v, d, key) in values {
                if !v.is_finite() {
                    return Err(LeRobotInError::NotFinite {
                        path: path.clone(),
                        row,
                        episode: f.episode,
                        frame: f.frame,
                        what: format!("`{key}` value `{}`", d.name),
                        value: v.to_string(),
                    });
                }
            }
        }
    }
    Ok(())
}

/// Episode `e`'s frames `fs` (checked by [`check_frames`]) as a trace of `domain`, refused if
/// an action is outside its limits.
fn episode_trace(domain: &Domain, e: i64, fs: &[Frame], fps: f64) -> Result<Trace, LeRobotInError> {
    let mut trace = Trace::new(domain);
    for f in fs {
        // Finite and increasing within the episode: checked above.
        trace.push(frame_time(f, fps), &f.z, &f.a, None);
    }
    if let Some((i, _, k, v, ValueFault::OutsideLimits(l))) =
        crate::trace::demo_fault(domain, &trace)
    {
        return Err(LeRobotInError::OutsideLimits {
            episode: e,
            frame: fs[i].frame,
            dim: domain.act[k].name.clone(),
            value: crate::number::fmt_num(v),
            lo: crate::number::fmt_num(l.lo),
            hi: crate::number::fmt_num(l.hi),
        });
    }
    Ok(trace)
}
