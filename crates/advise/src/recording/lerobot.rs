//! A dataset out as a LeRobot dataset, format v3.0 ([`CODEBASE_VERSION`]), so that the
//! demonstrations and the advice-synthesized data can train other policies.
//!
//! Every dataset point is one frame. Each demonstration is an episode, and so is each piece of
//! advice (its synthesized points in order); a frame says which in `advise.source`
//! (`demonstration` or `advice`) and carries its BC weight in `advise.weight`. With
//! [`LeRobotOptions::with_executions`], each execution is an episode too (`execution`, weight 0:
//! not a training point). The layout:
//! - `meta/info.json`: `codebase_version: "v3.0"`, the counts, `fps`, the paths and the features;
//! - `meta/stats.json`: per feature `min`, `max`, `mean`, `std`, `count`;
//! - `meta/tasks.parquet`: `task_index` and `task` (one task, the domain's), with the `pandas`
//!   metadata that makes `task` the table's index, as LeRobot writes it: its loader reads a
//!   frame's task text as `tasks.iloc[task_index].name`;
//! - `meta/episodes/chunk-000/file-000.parquet`: one row per episode (index, tasks, length, where
//!   its frames are);
//! - `data/chunk-000/file-000.parquet`: the frames: `observation.state` and `action` (fixed-size
//!   lists of float32, the domain's dimensions in order, named in `info.json`), `timestamp`
//!   (`frame_index / fps`, as LeRobot's loader checks), `frame_index`, `episode_index`, `index`,
//!   `task_index`, `advise.source`, `advise.weight`.
//!
//! Tables are written with parquet's column writer (snappy), the schema pyarrow reads carried as
//! the `ARROW:schema` footer entry an arrow writer leaves ([`arrow_schema`]; without it the
//! fixed-size lists read back as plain lists), into a temporary sibling directory that is renamed into place once whole ([`crate::files::write_dir_atomic`]), so a
//! killed export leaves nothing half-written; a directory that exists and is not empty is refused
//! rather than mixed into.
//!
//! A LeRobot dataset has one `fps`; advise's sources each keep their own rate (a positioning
//! teacher's demonstrations 15 Hz, the executions and the advice on them the simulator's 30 Hz).
//! [`export_lerobot_with`] therefore writes one dataset per rate: `DIR` itself when every episode
//! has the same rate, else `DIR/15fps`, `DIR/30fps`, ... An episode's rate is its recorded
//! times' (a demonstration's as the dataset keeps them, an advice's and an execution's those of
//! the execution's points), rounded to whole frames per second; one without times (a file saved
//! before datasets kept them) is at [`LeRobotOptions::fps`]. Frames are not resampled: a frame
//! is a point the teacher or an operator gave.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use miette::Diagnostic;
use parquet::basic::{Compression, LogicalType, Repetition, Type as Physical};
use parquet::data_type::{ByteArray, ByteArrayType, FloatType, Int64Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use serde_json::{Value, json};
use thiserror::Error;

use crate::policy::dataset::{Dataset, DemoTimes, Provenance};

/// The LeRobot dataset format this export writes (its `meta/info.json` `codebase_version`).
pub const CODEBASE_VERSION: &str = "v3.0";

/// Why a dataset could not be exported as LeRobot.
#[derive(Debug, Error, Diagnostic)]
pub enum LeRobotError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("{path} exists and is not empty")]
    #[diagnostic(
        code(advise::export::lerobot_exists),
        help("give a new directory; an export never mixes its files into another dataset")
    )]
    Exists { path: PathBuf },
    #[error("cannot write {path}: {reason}")]
    #[diagnostic(code(advise::export::lerobot))]
    Write { path: PathBuf, reason: String },
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LeRobotSummary {
    pub frames: usize,
    pub demonstration_episodes: usize,
    pub advice_episodes: usize,
    pub execution_episodes: usize,
    pub fps: u32,
}

/// How to export.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LeRobotOptions {
    /// Frames per second of an episode without times (from a dataset saved before datasets kept
    /// them); every other episode is at its own rate.
    pub fps: u32,
    /// Each execution an episode too (`advise.source` = `execution`, `advise.weight` 0).
    pub with_executions: bool,
}

/// The frames per second of an export when none is given: the simulator's control rate, at
/// which the paper's tasks record their points.
pub fn default_fps() -> u32 {
    crate::backend::sim::SimParams::default()
        .rate_hz
        .round()
        .clamp(1.0, 1000.0) as u32
}

/// What a user is told of an export to `dir`.
pub fn describe(s: &LeRobotSummary, dir: &str) -> String {
    let executions = match s.execution_episodes {
        0 => String::new(),
        n => format!(", {n} executions"),
    };
    format!(
        "wrote {dir}: a LeRobot {CODEBASE_VERSION} dataset of {} frames at {} fps in {} episodes ({} demonstrations, {} advice{executions}), each frame's source and BC weight in `advise.source` and `advise.weight`",
        s.frames,
        s.fps,
        s.demonstration_episodes + s.advice_episodes + s.execution_episodes,
        s.demonstration_episodes,
        s.advice_episodes
    )
}

/// What a user is told of an export to `dir` of one dataset per rate (see the module's docs).
pub fn describe_parts(parts: &[(PathBuf, LeRobotSummary)], dir: &str) -> String {
    match parts {
        [(_, s)] => describe(s, dir),
        _ => {
            let each: Vec<String> = parts
                .iter()
                .map(|(p, s)| describe(s, &p.display().to_string()))
                .collect();
            format!(
                "a LeRobot dataset has one frame rate and these sources were recorded at {}: one dataset per rate under {dir}\n{}",
                parts
                    .iter()
                    .map(|(_, s)| format!("{} fps", s.fps))
                    .collect::<Vec<_>>()
                    .join(" and "),
                each.join("\n")
            )
        }
    }
}

/// The frames per second of times `t` (rounded, 1 to 1000), if they advance.
fn fps_of(t: &[f64]) -> Option<u32> {
    DemoTimes::of(t).map(|d| d.rate_hz().round().clamp(1.0, 1000.0) as u32)
}

/// The task a domain's episodes are labelled with.
fn task_text(domain: &str) -> String {
    match domain {
        "positioning" => "drive the base to the goal pose".into(),
        "interception" => "intercept the moving ball".into(),
        other => format!("the {other} task"),
    }
}

/// One episode: its source and the dataset points of its frames, in order (an execution's
/// frames are its trace's points, in `trace`).
struct EpisodePoints {
    source: &'static str,
    name: String,
    points: Vec<usize>,
    trace: Option<crate::trace::Trace>,
    /// Each frame's source where they differ (a corrected episode's); empty: `source` for all.
    frame_sources: Vec<&'static str>,
    /// The BC weight of a trace's frames (an execution's 0: not a training point).
    trace_weight: f64,
    /// Its frames per second, from its recorded times; `None` when it has none.
    fps: Option<u32>,
}

/// The dataset's executions as episodes, numbered in the order the session ran them.
fn execution_episodes(dataset: &Dataset) -> Vec<EpisodePoints> {
    dataset
        .executions()
        .iter()
        .enumerate()
        .filter_map(|(n, rec)| {
            let trace = dataset.execution(rec.id).ok()?;
            (!trace.is_empty()).then(|| EpisodePoints {
                source: "execution",
                name: format!("execution {n}"),
                points: Vec::new(),
                fps: fps_of(&trace.t),
                trace: Some(trace),
                frame_sources: Vec::new(),
                trace_weight: 0.0,
            })
        })
        .collect()
}

fn episodes(dataset: &Dataset) -> Vec<EpisodePoints> {
    let mut demos: Vec<EpisodePoints> = dataset
        .demos()
        .iter()
        .map(|d| EpisodePoints {
            source: "demonstration",
            name: d.name.clone(),
            points: Vec::new(),
            trace: None,
            frame_sources: Vec::new(),
            trace_weight: 0.0,
            fps: d
                .times()
                .map(|t| t.rate_hz().round().clamp(1.0, 1000.0) as u32),
        })
        .collect();
    let mut advice: Vec<EpisodePoints> = dataset
        .advice()
        .iter()
        .map(|a| EpisodePoints {
            source: "advice",
            name: a.applied.invocation(),
            points: Vec::new(),
            trace: None,
            frame_sources: Vec::new(),
            trace_weight: 0.0,
            // Synthesized on the execution's points, at its rate.
            fps: dataset
                .execution(a.execution)
                .ok()
                .and_then(|t| fps_of(&t.t)),
        })
        .collect();
    // (episode, index within it) of each point, to order the frames.
    let mut keyed: Vec<(bool, usize, u32, usize)> = Vec::with_capacity(dataset.len());
    for i in 0..dataset.len() {
        match dataset.provenance(i) {
            Provenance::Demonstration { demo, index } => {
                if let Some(k) = dataset.demos().iter().position(|d| d.id == demo) {
                    keyed.push((false, k, index, i));
                }
            }
            Provenance::Advice {
                advice: id, index, ..
            } => {
                if let Some(k) = dataset.advice().iter().position(|a| a.id == id) {
                    keyed.push((true, k, index, i));
                }
            }
        }
    }
    keyed.sort_unstable();
    for (is_advice, k, _, i) in keyed {
        let list = if is_advice { &mut advice } else { &mut demos };
        list[k].points.push(i);
    }
    demos.retain(|e| !e.points.is_empty());
    advice.retain(|e| !e.points.is_empty());
    demos.extend(advice);
    demos
}

/// A column's values.
enum Values {
    F32(Vec<f32>),
    I64(Vec<i64>),
    Str(Vec<String>),
}

/// How a column's rows hold its values.
enum Shape {
    /// One value a row.
    Scalar,
    /// `n` values a row (arrow's `fixed_size_list<item>[n]`).
    Fixed(usize),
    /// Each row's count of values (arrow's `list<item>`).
    List(Vec<usize>),
}

/// A table's column: every value present (the items of lists nullable in the schema only, as
/// arrow writes them).
struct Column {
    name: &'static str,
    values: Values,
    shape: Shape,
}

impl Column {
    fn new(name: &'static str, values: Values) -> Column {
        Column {
            name,
            values,
            shape: Shape::Scalar,
        }
    }

    fn physical(&self) -> Physical {
        match self.values {
            Values::F32(_) => Physical::FLOAT,
            Values::I64(_) => Physical::INT64,
            Values::Str(_) => Physical::BYTE_ARRAY,
        }
    }

    /// The column's parquet type, as an arrow writer lays it out: a required leaf, or a
    /// required `LIST` group of a repeated `list` group of an optional `item`.
    fn parquet_type(&self) -> parquet::errors::Result<Type> {
        let leaf = |name: &str, repetition| {
            let t = Type::primitive_type_builder(name, self.physical()).with_repetition(repetition);
            match self.values {
                Values::Str(_) => t.with_logical_type(Some(LogicalType::String)),
                _ => t,
            }
            .build()
        };
        if let Shape::Scalar = self.shape {
            return leaf(self.name, Repetition::REQUIRED);
        }
        let list = Type::group_type_builder("list")
            .with_fields(vec![Arc::new(leaf("item", Repetition::OPTIONAL)?)])
            .with_repetition(Repetition::REPEATED)
            .build()?;
        Type::group_type_builder(self.name)
            .with_fields(vec![Arc::new(list)])
            .with_logical_type(Some(LogicalType::List))
            .with_repetition(Repetition::REQUIRED)
            .build()
    }

    /// The definition and repetition levels of a list column's values (every item present:
    /// definition 2; repetition 0 at a row's first item, 1 after), or none for a scalar.
    fn levels(&self) -> Option<(Vec<i16>, Vec<i16>)> {
        let lengths: Vec<usize> = match &self.shape {
            Shape::Scalar => return None,
            Shape::Fixed(n) => vec![*n; self.len() / (*n).max(1)],
            Shape::List(lengths) => lengths.clone(),
        };
        let rep = lengths
            .iter()
            .flat_map(|&n| (0..n).map(|i| i16::from(i > 0)))
            .collect::<Vec<_>>();
        Some((vec![2; rep.len()], rep))
    }

    fn len(&self) -> usize {
        match &self.values {
            Values::F32(v) => v.len(),
            Values::I64(v) => v.len(),
            Values::Str(v) => v.len(),
        }
    }
}

/// The `pandas` metadata of the tasks table: `task` is the DataFrame's index (its rows named by
/// the task's text, as LeRobot's `DataFrame(..., index=tasks)` writes it), `task_index` a column.
fn pandas_tasks_metadata() -> KeyValue {
    let column = |name: &str, pandas: &str, numpy: &str| json!({"name": name, "field_name": name, "pandas_type": pandas, "numpy_type": numpy, "metadata": null});
    let meta = json!({
        "index_columns": ["task"],
        "column_indexes": [{"name": null, "field_name": null, "pandas_type": "unicode", "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
        "columns": [column("task_index", "int64", "int64"), column("task", "unicode", "object")],
        "creator": {"library": "advise", "version": env!("CARGO_PKG_VERSION")},
        "pandas_version": "2.2.3",
    });
    KeyValue::new("pandas".to_string(), meta.to_string())
}

/// A table as parquet bytes (snappy, one row group), with the `ARROW:schema` entry pyarrow reads
/// its column types from.
fn parquet_bytes(columns: &[Column]) -> Result<Vec<u8>, String> {
    parquet_bytes_with(columns, Vec::new())
}

/// [`parquet_bytes`] with more key-value metadata.
fn parquet_bytes_with(columns: &[Column], mut metadata: Vec<KeyValue>) -> Result<Vec<u8>, String> {
    let err = |e: parquet::errors::ParquetError| e.to_string();
    let fields = columns
        .iter()
        .map(|c| c.parquet_type().map(Arc::new))
        .collect::<Result<Vec<_>, _>>()
        .map_err(err)?;
    let schema = Type::group_type_builder("arrow_schema")
        .with_fields(fields)
        .build()
        .map_err(err)?;
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_key_value_metadata(Some({
            // pyarrow reads the schema's metadata from `ARROW:schema` when it is there: the
            // entries go in both places, as arrow's writer puts them.
            let schema = arrow_schema_with(columns, &metadata);
            metadata.insert(0, KeyValue::new("ARROW:schema".to_string(), schema));
            metadata
        }))
        .build();
    let mut out = Vec::new();
    let mut w =
        SerializedFileWriter::new(&mut out, Arc::new(schema), Arc::new(props)).map_err(err)?;
    let mut group = w.next_row_group().map_err(err)?;
    for column in columns {
        let mut writer = group
            .next_column()
            .map_err(err)?
            .ok_or("a column more than the schema holds")?;
        let levels = column.levels();
        let def = levels.as_ref().map(|l| &l.0[..]);
        let rep = levels.as_ref().map(|l| &l.1[..]);
        match &column.values {
            Values::F32(v) => writer.typed::<FloatType>().write_batch(v, def, rep),
            Values::I64(v) => writer.typed::<Int64Type>().write_batch(v, def, rep),
            Values::Str(v) => {
                let v: Vec<ByteArray> = v.iter().map(|s| s.as_bytes().to_vec().into()).collect();
                writer.typed::<ByteArrayType>().write_batch(&v, def, rep)
            }
        }
        .map_err(err)?;
        writer.close().map_err(err)?;
    }
    group.close().map_err(err)?;
    w.close().map_err(err)?;
    Ok(out)
}

/// The `ARROW:schema` footer entry of a table of `columns`: an Arrow IPC schema message (a
/// flatbuffer, built in the order arrow's IPC writer builds it, so the bytes are the ones it
/// wrote), after the continuation marker and its length, in base64. Columns are not nullable;
/// list items are.
#[cfg(test)]
fn arrow_schema(columns: &[Column]) -> String {
    arrow_schema_with(columns, &[])
}

/// [`arrow_schema`] with the schema's custom metadata (e.g. `pandas`).
fn arrow_schema_with(columns: &[Column], metadata: &[KeyValue]) -> String {
    use flatbuffers::{FlatBufferBuilder, WIPOffset};
    // Arrow's Schema.fbs: the type union's tags and each table's field slots.
    const INT: u8 = 2;
    const FLOATING_POINT: u8 = 3;
    const UTF8: u8 = 5;
    const LIST: u8 = 12;
    const FIXED_SIZE_LIST: u8 = 16;
    /// A field's type: its union tag, its type table and its children.
    type Typed = (u8, WIPOffset<()>, WIPOffset<()>);
    /// A value's type: no children.
    fn leaf(fbb: &mut FlatBufferBuilder<'_>, values: &Values) -> Typed {
        let empty = |fbb: &mut FlatBufferBuilder<'_>| {
            WIPOffset::new(fbb.create_vector::<WIPOffset<()>>(&[]).value())
        };
        // Arrow makes a number's (empty) children before its type table, a string's after.
        let (tag, children, table) = match values {
            Values::I64(_) => {
                let children = empty(fbb);
                let table = fbb.start_table();
                fbb.push_slot::<bool>(6, true, false); // Int.is_signed
                fbb.push_slot::<i32>(4, 64, 0); // Int.bitWidth
                (INT, children, fbb.end_table(table))
            }
            Values::F32(_) => {
                let children = empty(fbb);
                let table = fbb.start_table();
                fbb.push_slot::<i16>(4, 1, 0); // FloatingPoint.precision: SINGLE
                (FLOATING_POINT, children, fbb.end_table(table))
            }
            Values::Str(_) => {
                let table = fbb.start_table();
                let table = fbb.end_table(table);
                (UTF8, empty(fbb), table)
            }
        };
        (tag, WIPOffset::new(table.value()), children)
    }
    fn field<'a>(
        fbb: &mut FlatBufferBuilder<'a>,
        name: &str,
        nullable: bool,
        typed: impl FnOnce(&mut FlatBufferBuilder<'a>) -> Typed,
    ) -> WIPOffset<()> {
        let name = fbb.create_string(name);
        let (tag, table, children) = typed(fbb);
        let start = fbb.start_table();
        fbb.push_slot_always(4, name); // Field.name
        fbb.push_slot::<u8>(8, tag, 0); // Field.type_type
        fbb.push_slot::<bool>(6, nullable, false); // Field.nullable
        fbb.push_slot_always(14, children); // Field.children
        fbb.push_slot_always(10, table); // Field.type
        WIPOffset::new(fbb.end_table(start).value())
    }
    let mut fbb = FlatBufferBuilder::new();
    let fields: Vec<WIPOffset<()>> = columns
        .iter()
        .map(|c| {
            field(&mut fbb, c.name, false, |fbb| match c.shape {
                Shape::Scalar => leaf(fbb, &c.values),
                Shape::Fixed(_) | Shape::List(_) => {
                    let item = field(fbb, "item", true, |fbb| leaf(fbb, &c.values));
                    let table = fbb.start_table();
                    let tag = match c.shape {
                        Shape::Fixed(n) => {
                            fbb.push_slot::<i32>(4, n as i32, 0); // FixedSizeList.listSize
                            FIXED_SIZE_LIST
                        }
                        _ => LIST,
                    };
                    let table = fbb.end_table(table);
                    let children = fbb.create_vector(&[item]);
                    (
                        tag,
                        WIPOffset::new(table.value()),
                        WIPOffset::new(children.value()),
                    )
                }
            })
        })
        .collect();
    let fields = fbb.create_vector(&fields);
    let custom: Vec<WIPOffset<()>> = metadata
        .iter()
        .map(|kv| {
            let key = fbb.create_string(&kv.key);
            let value = fbb.create_string(kv.value.as_deref().unwrap_or(""));
            let table = fbb.start_table();
            fbb.push_slot_always(4, key); // KeyValue.key
            fbb.push_slot_always(6, value); // KeyValue.value
            WIPOffset::new(fbb.end_table(table).value())
        })
        .collect();
    let custom = (!custom.is_empty()).then(|| fbb.create_vector(&custom));
    let schema = fbb.start_table();
    if let Some(custom) = custom {
        fbb.push_slot_always(8, custom); // Schema.custom_metadata
    }
    fbb.push_slot_always(6, fields); // Schema.fields
    let schema = fbb.end_table(schema);
    let message = fbb.start_table();
    fbb.push_slot::<i16>(4, 4, 0); // Message.version: V5
    fbb.push_slot::<u8>(6, 1, 0); // Message.header_type: Schema
    fbb.push_slot::<i64>(10, 0, 0); // Message.bodyLength
    fbb.push_slot_always(8, schema); // Message.header
    let message = fbb.end_table(message);
    fbb.finish_minimal(message);
    let ipc = fbb.finished_data();
    let mut bytes = Vec::with_capacity(8 + ipc.len());
    bytes.extend([0xff; 4]);
    bytes.extend((ipc.len() as u32).to_le_bytes());
    bytes.extend(ipc);
    base64(&bytes)
}

/// `bytes` in standard base64, padded.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(char::from(ALPHABET[(n >> (18 - 6 * i) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Per-dimension statistics of `rows` (each `width` values).
fn stats(values: &[f64], width: usize) -> Value {
    let n = values.len().checked_div(width).unwrap_or(0);
    let mut min = vec![f64::INFINITY; width];
    let mut max = vec![f64::NEG_INFINITY; width];
    let mut sum = vec![0.0; width];
    for row in values.chunks_exact(width.max(1)) {
        for (d, &v) in row.iter().enumerate() {
            min[d] = min[d].min(v);
            max[d] = max[d].max(v);
            sum[d] += v;
        }
    }
    let mean: Vec<f64> = sum.iter().map(|s| s / n.max(1) as f64).collect();
    let mut var = vec![0.0; width];
    for row in values.chunks_exact(width.max(1)) {
        for (d, &v) in row.iter().enumerate() {
            var[d] += (v - mean[d]).powi(2);
        }
    }
    let std: Vec<f64> = var.iter().map(|v| (v / n.max(1) as f64).sqrt()).collect();
    json!({"min": min, "max": max, "mean": mean, "std": std, "count": [n]})
}

/// Write `dataset` to the new directory `dir` as LeRobot datasets, one per rate (`fps` for
/// sources without times): see the module's docs.
pub fn export_lerobot(
    dataset: &Dataset,
    dir: &Path,
    fps: u32,
) -> Result<Vec<(PathBuf, LeRobotSummary)>, LeRobotError> {
    let options = LeRobotOptions {
        fps,
        with_executions: false,
    };
    export_lerobot_with(dataset, dir, &options)
}

/// [`export_lerobot`] with its options: the datasets written, each its directory and summary.
pub fn export_lerobot_with(
    dataset: &Dataset,
    dir: &Path,
    options: &LeRobotOptions,
) -> Result<Vec<(PathBuf, LeRobotSummary)>, LeRobotError> {
    let mut eps = episodes(dataset);
    if options.with_executions {
        eps.extend(execution_episodes(dataset));
    }
    let mut by_rate: std::collections::BTreeMap<u32, Vec<EpisodePoints>> = Default::default();
    for e in eps {
        by_rate
            .entry(e.fps.unwrap_or(options.fps).max(1))
            .or_default()
            .push(e);
    }
    if by_rate.len() <= 1 {
        let (fps, eps) = by_rate
            .into_iter()
            .next()
            .unwrap_or((options.fps.max(1), Vec::new()));
        let s = write_lerobot(dataset, eps, dir, fps, Value::Null)?;
        return Ok(vec![(dir.to_path_buf(), s)]);
    }
    if std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_some()) {
        return Err(LeRobotError::Exists {
            path: dir.to_path_buf(),
        });
    }
    let mut parts = Vec::new();
    crate::files::write_dir_atomic(dir, |tmp| {
        for (fps, eps) in by_rate {
            let name = format!("{fps}fps");
            let s = write_lerobot(dataset, eps, &tmp.join(&name), fps, Value::Null)?;
            parts.push((dir.join(name), s));
        }
        Ok::<(), LeRobotError>(())
    })?;
    Ok(parts)
}

/// Write `trace`, one corrected episode of `domain` named `name`, as a new LeRobot dataset in
/// `dir` at `fps`: each frame's `advise.source` from `sources` (`demonstration` where it was
/// kept, `advice` where an operator synthesized it), BC weight 1, and `provenance` (what produced
/// it) in `info.json`'s `advise.provenance`.
pub fn export_corrected_episode(
    domain: &crate::domain::Domain,
    name: String,
    trace: crate::trace::Trace,
    sources: Vec<&'static str>,
    dir: &Path,
    fps: u32,
    provenance: Value,
) -> Result<LeRobotSummary, LeRobotError> {
    let episode = EpisodePoints {
        source: "advice",
        name,
        points: Vec::new(),
        trace: Some(trace),
        frame_sources: sources,
        trace_weight: 1.0,
        fps: Some(fps),
    };
    write_lerobot(&Dataset::new(domain), vec![episode], dir, fps, provenance)
}

/// Write the episodes `eps` (of `dataset`'s points, or traces) to `dir`; `provenance`, unless
/// null, goes in `info.json`'s `advise.provenance`.
fn write_lerobot(
    dataset: &Dataset,
    eps: Vec<EpisodePoints>,
    dir: &Path,
    fps: u32,
    provenance: Value,
) -> Result<LeRobotSummary, LeRobotError> {
    let fps = fps.max(1);
    if std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_some()) {
        return Err(LeRobotError::Exists {
            path: dir.to_path_buf(),
        });
    }
    let domain = dataset.domain();
    let (zd, ad) = (domain.observe.len(), domain.act.len());
    let frames = Frames::of(dataset, &eps, fps);
    let task = task_text(&domain.name);

    let data_path = dir.join("data/chunk-000/file-000.parquet");
    let data = frames_table(&frames, zd, ad);
    let episodes_path = dir.join("meta/episodes/chunk-000/file-000.parquet");
    let episodes = episodes_table(&frames.episodes, &eps, &task);
    let tasks_path = dir.join("meta/tasks.parquet");
    let tasks = vec![
        Column::new("task_index", Values::I64(vec![0])),
        Column::new("task", Values::Str(vec![task])),
    ];
    let info = info_json(domain, &eps, frames.count, fps, provenance);
    let statistics = stats_json(&frames, zd, ad);

    let files: Vec<(PathBuf, Vec<u8>)> = vec![
        (
            data_path.clone(),
            parquet_bytes(&data).map_err(fail(&data_path))?,
        ),
        (
            episodes_path.clone(),
            parquet_bytes(&episodes).map_err(fail(&episodes_path))?,
        ),
        (
            tasks_path.clone(),
            parquet_bytes_with(&tasks, vec![pandas_tasks_metadata()]).map_err(fail(&tasks_path))?,
        ),
        (dir.join("meta/info.json"), pretty(&info)),
        (dir.join("meta/stats.json"), pretty(&statistics)),
    ];
    write_files(dir, &files)?;
    let count = |source: &str| eps.iter().filter(|e| e.source == source).count();
    Ok(LeRobotSummary {
        frames: frames.count,
        demonstration_episodes: count("demonstration"),
        advice_episodes: count("advice"),
        execution_episodes: count("execution"),
        fps,
    })
}

/// The error of a file at `path` that could not be written, from its reason.
fn fail(path: &Path) -> impl Fn(String) -> LeRobotError {
    let path = path.to_path_buf();
    move |reason: String| LeRobotError::Write {
        path: path.clone(),
        reason,
    }
}

/// Every frame of an export, column by column (each dimension's values row after row), and
/// where each episode's frames lie.
struct Frames {
    count: usize,
    state: Vec<f64>,
    action: Vec<f64>,
    timestamp: Vec<f64>,
    frame_index: Vec<i64>,
    episode_index: Vec<i64>,
    index: Vec<i64>,
    source: Vec<&'static str>,
    weight: Vec<f64>,
    /// Per episode: its index, its length, and its first frame's `index` and one past its last.
    episodes: Vec<(i64, i64, i64, i64)>,
}

impl Frames {
    /// The frames of `eps` in order, each episode's timestamps from 0 at `fps`.
    fn of(dataset: &Dataset, eps: &[EpisodePoints], fps: u32) -> Frames {
        let (zd, ad) = (dataset.domain().observe.len(), dataset.domain().act.len());
        let count: usize = eps
            .iter()
            .map(|e| e.trace.as_ref().map_or(e.points.len(), |t| t.len()))
            .sum();
        let mut f = Frames {
            count,
            state: Vec::with_capacity(count * zd),
            action: Vec::with_capacity(count * ad),
            timestamp: Vec::new(),
            frame_index: Vec::new(),
            episode_index: Vec::new(),
            index: Vec::new(),
            source: Vec::new(),
            weight: Vec::new(),
            episodes: Vec::new(),
        };
        for (e, ep) in eps.iter().enumerate() {
            let from = f.index.len() as i64;
            let length = ep.trace.as_ref().map_or(ep.points.len(), |t| t.len());
            for k in 0..length {
                match &ep.trace {
                    Some(t) => {
                        f.state.extend_from_slice(t.z(k));
                        f.action.extend_from_slice(t.a(k));
                        f.weight.push(ep.trace_weight);
                    }
                    None => {
                        let i = ep.points[k];
                        f.state.extend_from_slice(dataset.z(i));
                        f.action.extend_from_slice(dataset.a(i));
                        f.weight.push(dataset.m(i));
                    }
                }
                f.timestamp.push(k as f64 / f64::from(fps.max(1)));
                f.frame_index.push(k as i64);
                f.episode_index.push(e as i64);
                f.index.push(f.index.len() as i64);
                f.source
                    .push(ep.frame_sources.get(k).copied().unwrap_or(ep.source));
            }
            f.episodes
                .push((e as i64, length as i64, from, f.index.len() as i64));
        }
        f
    }
}

/// Values as float32, as the tables store them.
fn f32s(v: &[f64]) -> Vec<f32> {
    v.iter().map(|&x| x as f32).collect()
}

/// The frames' table (`data/chunk-000/file-000.parquet`): states of `zd` values, actions of
/// `ad`.
fn frames_table(f: &Frames, zd: usize, ad: usize) -> Vec<Column> {
    vec![
        Column {
            shape: Shape::Fixed(zd),
            ..Column::new("observation.state", Values::F32(f32s(&f.state)))
        },
        Column {
            shape: Shape::Fixed(ad),
            ..Column::new("action", Values::F32(f32s(&f.action)))
        },
        Column::new("timestamp", Values::F32(f32s(&f.timestamp))),
        Column::new("frame_index", Values::I64(f.frame_index.clone())),
        Column::new("episode_index", Values::I64(f.episode_index.clone())),
        Column::new("index", Values::I64(f.index.clone())),
        Column::new("task_index", Values::I64(vec![0; f.count])),
        Column::new(
            "advise.source",
            Values::Str(f.source.iter().map(|s| s.to_string()).collect()),
        ),
        Column::new("advise.weight", Values::F32(f32s(&f.weight))),
    ]
}

/// The episodes' table (`meta/episodes/chunk-000/file-000.parquet`): a row per episode of
/// `eps` (`rows` as [`Frames::episodes`]), each of the one task `task`, its frames all in the
/// one data file.
fn episodes_table(rows: &[(i64, i64, i64, i64)], eps: &[EpisodePoints], task: &str) -> Vec<Column> {
    let col = |f: fn(&(i64, i64, i64, i64)) -> i64| Values::I64(rows.iter().map(f).collect());
    let zeros = || Values::I64(vec![0; rows.len()]);
    vec![
        Column::new("episode_index", col(|r| r.0)),
        Column {
            shape: Shape::List(vec![1; rows.len()]),
            ..Column::new("tasks", Values::Str(vec![task.to_string(); rows.len()]))
        },
        Column::new("length", col(|r| r.1)),
        Column::new("data/chunk_index", zeros()),
        Column::new("data/file_index", zeros()),
        Column::new("dataset_from_index", col(|r| r.2)),
        Column::new("dataset_to_index", col(|r| r.3)),
        Column::new("meta/episodes/chunk_index", zeros()),
        Column::new("meta/episodes/file_index", zeros()),
        Column::new(
            "advise.source",
            Values::Str(eps.iter().map(|e| e.source.to_string()).collect()),
        ),
        Column::new(
            "advise.name",
            Values::Str(eps.iter().map(|e| e.name.clone()).collect()),
        ),
    ]
}

/// `meta/info.json` of `frames` frames in the episodes `eps` of `domain` at `fps`; `provenance`,
/// unless null, in `advise.provenance`.
fn info_json(
    domain: &crate::domain::Domain,
    eps: &[EpisodePoints],
    frames: usize,
    fps: u32,
    provenance: Value,
) -> Value {
    let (zd, ad) = (domain.observe.len(), domain.act.len());
    let names = |dims: &[crate::domain::Dim]| -> Vec<String> {
        dims.iter().map(|d| d.name.clone()).collect()
    };
    let scalar = |dtype: &str| json!({"dtype": dtype, "shape": [1], "names": null});
    let mut info = json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": "differential_drive",
        "total_episodes": eps.len(),
        "total_frames": frames,
        "total_tasks": 1,
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 500,
        "fps": fps,
        "splits": {"train": format!("0:{}", eps.len())},
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "video_path": null,
        "features": {
            "observation.state": {"dtype": "float32", "shape": [zd], "names": names(&domain.observe)},
            "action": {"dtype": "float32", "shape": [ad], "names": names(&domain.act)},
            "timestamp": scalar("float32"),
            "frame_index": scalar("int64"),
            "episode_index": scalar("int64"),
            "index": scalar("int64"),
            "task_index": scalar("int64"),
            "advise.source": {"dtype": "string", "shape": [1], "names": null},
            "advise.weight": scalar("float32"),
        },
        "advise": {
            "domain": domain.name,
            "sources": "each demonstration and each piece of advice is an episode (and each execution with `--with-executions`); `advise.source` says which, `advise.weight` is the point's BC weight (0 for an execution's, which is not a training point)",
        },
    });
    if !provenance.is_null() {
        info["advise"]["provenance"] = provenance;
    }
    info
}

/// `meta/stats.json`: [`stats`] of each numeric feature of the frames.
fn stats_json(f: &Frames, zd: usize, ad: usize) -> Value {
    let as_f64 = |v: &[i64]| v.iter().map(|&x| x as f64).collect::<Vec<_>>();
    json!({
        "observation.state": stats(&f.state, zd),
        "action": stats(&f.action, ad),
        "timestamp": stats(&f.timestamp, 1),
        "frame_index": stats(&as_f64(&f.frame_index), 1),
        "episode_index": stats(&as_f64(&f.episode_index), 1),
        "index": stats(&as_f64(&f.index), 1),
        "task_index": stats(&vec![0.0; f.count], 1),
        "advise.weight": stats(&f.weight, 1),
    })
}

/// Write `files` (paths under `dir`, and their bytes) as the new directory `dir`.
fn write_files(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> Result<(), LeRobotError> {
    // Written whole into a temporary sibling and renamed into place: a killed export leaves no
    // half-written directory for the next one to refuse.
    crate::files::write_dir_atomic(dir, |tmp| {
        for (path, bytes) in files {
            let path = tmp.join(path.strip_prefix(dir).unwrap_or(path));
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| fail(parent)(e.to_string()))?;
            }
            crate::files::write_atomic(&path, |w| w.write_all(bytes))?;
        }
        Ok::<(), LeRobotError>(())
    })
}

fn pretty(v: &Value) -> Vec<u8> {
    let mut s = serde_json::to_vec_pretty(v).unwrap_or_default();
    s.push(b'\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_is_the_standard_alphabet_padded() {
        let cases = [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v")];
        for (plain, encoded) in cases {
            assert_eq!(base64(plain.as_bytes()), encoded);
        }
        assert_eq!(base64(&[0xfb, 0xff, 0xbf]), "+/+/");
    }

    /// The tasks table's `ARROW:schema` is byte for byte what arrow's writer (parquet's
    /// `ArrowWriter`, arrow 60) wrote for it before the export stopped using arrow.
    #[test]
    fn the_arrow_schema_entry_is_what_arrows_writer_wrote() {
        let tasks = [
            Column::new("task_index", Values::I64(vec![0])),
            Column::new("task", Values::Str(vec!["t".into()])),
        ];
        assert_eq!(
            arrow_schema(&tasks),
            "/////7AAAAAQAAAAAAAKAAwACgAJAAQACgAAABAAAAAAAQQACAAIAAAABAAIAAAABAAAAAIAAABEAAAABAAAANT\
///8YAAAADAAAAAAAAAUQAAAAAAAAAAQABAAEAAAABAAAAHRhc2sAAAAAEAAUABAAAAAPAAQAAAAIABAAAAAYAAAAIAAAA\
AAAAAIcAAAACAAMAAQACwAIAAAAQAAAAAAAAAEAAAAACgAAAHRhc2tfaW5kZXgAAA=="
        );
    }
}
