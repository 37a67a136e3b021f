//! A dataset out as a LeRobot dataset, format v3.0 ([`CODEBASE_VERSION`]), so that the
//! demonstrations and the advice-synthesized data can train other policies.
//!
//! Every dataset point is one frame. Each demonstration is an episode, and so is each piece of
//! advice (its synthesized points in order); a frame says which in `advise.source`
//! (`demonstration` or `advice`) and carries its BC weight in `advise.weight`. The layout:
//! - `meta/info.json`: `codebase_version: "v3.0"`, the counts, `fps`, the paths and the features;
//! - `meta/stats.json`: per feature `min`, `max`, `mean`, `std`, `count`;
//! - `meta/tasks.parquet`: `task_index` and `task` (one task, the domain's);
//! - `meta/episodes/chunk-000/file-000.parquet`: one row per episode (index, tasks, length, where
//!   its frames are);
//! - `data/chunk-000/file-000.parquet`: the frames: `observation.state` and `action` (fixed-size
//!   lists of float32, the domain's dimensions in order, named in `info.json`), `timestamp`
//!   (`frame_index / fps`: a dataset keeps no times), `frame_index`, `episode_index`, `index`,
//!   `task_index`, `advise.source`, `advise.weight`.
//!
//! Tables are written with the arrow and parquet crates (snappy) into a temporary sibling
//! directory that is renamed into place once whole ([`crate::files::write_dir_atomic`]), so a
//! killed export leaves nothing half-written; a directory that exists and is not empty is refused
//! rather than mixed into.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::builder::{ListBuilder, StringBuilder};
use arrow_array::{
    ArrayRef, FixedSizeListArray, Float32Array, Int64Array, RecordBatch, StringArray,
};
use arrow_schema::{DataType, Field, Schema};
use miette::Diagnostic;
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;
use serde_json::{Value, json};
use thiserror::Error;

use crate::policy::dataset::{Dataset, Provenance};

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
    pub fps: u32,
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
    format!(
        "wrote {dir}: a LeRobot {CODEBASE_VERSION} dataset of {} frames at {} fps in {} episodes ({} demonstrations, {} advice), each frame's source and BC weight in `advise.source` and `advise.weight`",
        s.frames,
        s.fps,
        s.demonstration_episodes + s.advice_episodes,
        s.demonstration_episodes,
        s.advice_episodes
    )
}

/// The task a domain's episodes are labelled with.
fn task_text(domain: &str) -> String {
    match domain {
        "positioning" => "drive the base to the goal pose".into(),
        "interception" => "intercept the moving ball".into(),
        other => format!("the {other} task"),
    }
}

/// One episode: its source and the dataset points of its frames, in order.
struct EpisodePoints {
    source: &'static str,
    name: String,
    points: Vec<usize>,
}

fn episodes(dataset: &Dataset) -> Vec<EpisodePoints> {
    let mut demos: Vec<EpisodePoints> = dataset
        .demos()
        .iter()
        .map(|d| EpisodePoints {
            source: "demonstration",
            name: d.name.clone(),
            points: Vec::new(),
        })
        .collect();
    let mut advice: Vec<EpisodePoints> = dataset
        .advice()
        .iter()
        .map(|a| EpisodePoints {
            source: "advice",
            name: a.applied.invocation(),
            points: Vec::new(),
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

fn float_list(values: Vec<f32>, width: usize) -> Result<ArrayRef, String> {
    let item = Arc::new(Field::new("item", DataType::Float32, true));
    let width = i32::try_from(width).map_err(|e| e.to_string())?;
    FixedSizeListArray::try_new(item, width, Arc::new(Float32Array::from(values)), None)
        .map(|a| Arc::new(a) as ArrayRef)
        .map_err(|e| e.to_string())
}

fn list_type(width: usize) -> DataType {
    DataType::FixedSizeList(
        Arc::new(Field::new("item", DataType::Float32, true)),
        width as i32,
    )
}

/// A record batch as parquet bytes (snappy).
fn parquet_bytes(batch: &RecordBatch) -> Result<Vec<u8>, String> {
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .build();
    let mut out = Vec::new();
    let mut w =
        ArrowWriter::try_new(&mut out, batch.schema(), Some(props)).map_err(|e| e.to_string())?;
    w.write(batch).map_err(|e| e.to_string())?;
    w.close().map_err(|e| e.to_string())?;
    Ok(out)
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

/// Write `dataset` to the new directory `dir` as a LeRobot dataset at `fps` frames per second.
///
/// Over 150 lines because it lays out the dataset's files in sequence (the frames' parquet, the
/// episodes' table, `info.json`, the statistics), each block reading the same episode table.
pub fn export_lerobot(
    dataset: &Dataset,
    dir: &Path,
    fps: u32,
) -> Result<LeRobotSummary, LeRobotError> {
    let fps = fps.max(1);
    if std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_some()) {
        return Err(LeRobotError::Exists {
            path: dir.to_path_buf(),
        });
    }
    let fail = |path: &Path| {
        let path = path.to_path_buf();
        move |reason: String| LeRobotError::Write {
            path: path.clone(),
            reason,
        }
    };
    let domain = dataset.domain();
    let (zd, ad) = (domain.observe.len(), domain.act.len());
    let eps = episodes(dataset);
    let frames: usize = eps.iter().map(|e| e.points.len()).sum();
    let mut state = Vec::with_capacity(frames * zd);
    let mut action = Vec::with_capacity(frames * ad);
    let (mut timestamp, mut frame_index, mut episode_index, mut index) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut source, mut weight) = (Vec::new(), Vec::new());
    let mut rows = Vec::new();
    for (e, ep) in eps.iter().enumerate() {
        let from = index.len() as i64;
        for (f, &i) in ep.points.iter().enumerate() {
            state.extend_from_slice(dataset.z(i));
            action.extend_from_slice(dataset.a(i));
            timestamp.push(f as f64 / f64::from(fps.max(1)));
            frame_index.push(f as i64);
            episode_index.push(e as i64);
            index.push(index.len() as i64);
            source.push(ep.source);
            weight.push(dataset.m(i));
        }
        rows.push((e as i64, ep.points.len() as i64, from, index.len() as i64));
    }
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();

    let data_path = dir.join("data/chunk-000/file-000.parquet");
    let data = {
        let schema = Schema::new(vec![
            Field::new("observation.state", list_type(zd), false),
            Field::new("action", list_type(ad), false),
            Field::new("timestamp", DataType::Float32, false),
            Field::new("frame_index", DataType::Int64, false),
            Field::new("episode_index", DataType::Int64, false),
            Field::new("index", DataType::Int64, false),
            Field::new("task_index", DataType::Int64, false),
            Field::new("advise.source", DataType::Utf8, false),
            Field::new("advise.weight", DataType::Float32, false),
        ]);
        let columns: Vec<ArrayRef> = vec![
            float_list(f32s(&state), zd).map_err(fail(&data_path))?,
            float_list(f32s(&action), ad).map_err(fail(&data_path))?,
            Arc::new(Float32Array::from(f32s(&timestamp))),
            Arc::new(Int64Array::from(frame_index.clone())),
            Arc::new(Int64Array::from(episode_index.clone())),
            Arc::new(Int64Array::from(index.clone())),
            Arc::new(Int64Array::from(vec![0i64; frames])),
            Arc::new(StringArray::from(source)),
            Arc::new(Float32Array::from(f32s(&weight))),
        ];
        RecordBatch::try_new(Arc::new(schema), columns)
            .map_err(|e| fail(&data_path)(e.to_string()))?
    };

    let episodes_path = dir.join("meta/episodes/chunk-000/file-000.parquet");
    let episodes_batch = {
        let mut tasks = ListBuilder::new(StringBuilder::new());
        for _ in &rows {
            tasks.values().append_value(task_text(&domain.name));
            tasks.append(true);
        }
        let col = |f: fn(&(i64, i64, i64, i64)) -> i64| -> ArrayRef {
            Arc::new(Int64Array::from(rows.iter().map(f).collect::<Vec<_>>()))
        };
        let zeros = || -> ArrayRef { Arc::new(Int64Array::from(vec![0i64; rows.len()])) };
        let tasks: ArrayRef = Arc::new(tasks.finish());
        let schema = Schema::new(vec![
            Field::new("episode_index", DataType::Int64, false),
            Field::new("tasks", tasks.data_type().clone(), false),
            Field::new("length", DataType::Int64, false),
            Field::new("data/chunk_index", DataType::Int64, false),
            Field::new("data/file_index", DataType::Int64, false),
            Field::new("dataset_from_index", DataType::Int64, false),
            Field::new("dataset_to_index", DataType::Int64, false),
            Field::new("meta/episodes/chunk_index", DataType::Int64, false),
            Field::new("meta/episodes/file_index", DataType::Int64, false),
            Field::new("advise.source", DataType::Utf8, false),
            Field::new("advise.name", DataType::Utf8, false),
        ]);
        let columns: Vec<ArrayRef> = vec![
            col(|r| r.0),
            tasks,
            col(|r| r.1),
            zeros(),
            zeros(),
            col(|r| r.2),
            col(|r| r.3),
            zeros(),
            zeros(),
            Arc::new(StringArray::from(
                eps.iter().map(|e| e.source).collect::<Vec<_>>(),
            )),
            Arc::new(StringArray::from(
                eps.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(),
            )),
        ];
        RecordBatch::try_new(Arc::new(schema), columns)
            .map_err(|e| fail(&episodes_path)(e.to_string()))?
    };

    let tasks_path = dir.join("meta/tasks.parquet");
    let tasks_batch = RecordBatch::try_new(
        Arc::new(Schema::new(vec![
            Field::new("task_index", DataType::Int64, false),
            Field::new("task", DataType::Utf8, false),
        ])),
        vec![
            Arc::new(Int64Array::from(vec![0i64])),
            Arc::new(StringArray::from(vec![task_text(&domain.name)])),
        ],
    )
    .map_err(|e| fail(&tasks_path)(e.to_string()))?;

    let names = |dims: &[crate::domain::Dim]| -> Vec<String> {
        dims.iter().map(|d| d.name.clone()).collect()
    };
    let scalar = |dtype: &str| json!({"dtype": dtype, "shape": [1], "names": null});
    let info = json!({
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
            "sources": "each demonstration and each piece of advice is an episode; `advise.source` says which, `advise.weight` is the point's BC weight",
        },
    });
    let as_f64 = |v: &[i64]| v.iter().map(|&x| x as f64).collect::<Vec<_>>();
    let stats_json = json!({
        "observation.state": stats(&state, zd),
        "action": stats(&action, ad),
        "timestamp": stats(&timestamp, 1),
        "frame_index": stats(&as_f64(&frame_index), 1),
        "episode_index": stats(&as_f64(&episode_index), 1),
        "index": stats(&as_f64(&index), 1),
        "task_index": stats(&vec![0.0; frames], 1),
        "advise.weight": stats(&weight, 1),
    });

    let files: Vec<(PathBuf, Vec<u8>)> = vec![
        (
            data_path.clone(),
            parquet_bytes(&data).map_err(fail(&data_path))?,
        ),
        (
            episodes_path.clone(),
            parquet_bytes(&episodes_batch).map_err(fail(&episodes_path))?,
        ),
        (
            tasks_path.clone(),
            parquet_bytes(&tasks_batch).map_err(fail(&tasks_path))?,
        ),
        (dir.join("meta/info.json"), pretty(&info)),
        (dir.join("meta/stats.json"), pretty(&stats_json)),
    ];
    // Written whole into a temporary sibling and renamed into place: a killed export leaves no
    // half-written directory for the next one to refuse.
    crate::files::write_dir_atomic(dir, |tmp| {
        for (path, bytes) in &files {
            let path = tmp.join(path.strip_prefix(dir).unwrap_or(path));
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| fail(parent)(e.to_string()))?;
            }
            crate::files::write_atomic(&path, |w| w.write_all(bytes))?;
        }
        Ok::<(), LeRobotError>(())
    })?;
    let advice_episodes = eps.iter().filter(|e| e.source == "advice").count();
    Ok(LeRobotSummary {
        frames,
        demonstration_episodes: eps.len() - advice_episodes,
        advice_episodes,
        fps,
    })
}

fn pretty(v: &Value) -> Vec<u8> {
    let mut s = serde_json::to_vec_pretty(v).unwrap_or_default();
    s.push(b'\n');
    s
}
