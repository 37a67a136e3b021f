//! Traces (recorded executions and demonstrations) and chunks of them.
//!
//! A [`Trace`] is a time series of points `(t, z, a)`, optionally with the robot pose at each point
//! for plots. Storage is flat (`z` is `len * obs_dim` values in row order) so that operators and
//! policies stream over contiguous memory. A [`Chunk`] is a validated half-open index range into a
//! trace. Traces load from CSV (a header naming `t`, the domain's observation and action dimensions,
//! and optionally `x`, `y`, `theta`) and from JSON; every malformed input becomes a [`TraceError`]
//! that names the file, line and column, never a panic. This module knows nothing of operators or
//! policies.

use std::ops::Range;
use std::path::Path;

use miette::{Diagnostic, NamedSource, SourceSpan};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::domain::Domain;

/// The pose type lives in [`crate::geometry`]; traces hold one per point when recorded.
pub use crate::geometry::Pose;

/// A recorded execution or demonstration in one domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// Name of the domain the points belong to.
    pub domain: String,
    obs_dim: usize,
    act_dim: usize,
    /// Time stamp of each point, seconds, non-decreasing.
    pub t: Vec<f64>,
    /// Observations, `len * obs_dim` values, row after row.
    pub z: Vec<f64>,
    /// Actions, `len * act_dim` values, row after row.
    pub a: Vec<f64>,
    /// Robot pose at each point, when recorded.
    pub pose: Option<Vec<Pose>>,
}

impl Trace {
    /// An empty trace for `domain`.
    pub fn new(domain: &Domain) -> Self {
        Trace::with_dims(&domain.name, domain.obs_dim(), domain.act_dim())
    }

    /// An empty trace with explicit dimensions (for code that has no [`Domain`] at hand).
    pub fn with_dims(domain: &str, obs_dim: usize, act_dim: usize) -> Self {
        Trace {
            domain: domain.to_string(),
            obs_dim,
            act_dim,
            t: Vec::new(),
            z: Vec::new(),
            a: Vec::new(),
            pose: None,
        }
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// Observation of point `i`. Panics if `i >= len()` (an index the caller validated).
    #[inline]
    pub fn z(&self, i: usize) -> &[f64] {
        &self.z[i * self.obs_dim..(i + 1) * self.obs_dim]
    }

    /// Action of point `i`. Panics if `i >= len()` (an index the caller validated).
    #[inline]
    pub fn a(&self, i: usize) -> &[f64] {
        &self.a[i * self.act_dim..(i + 1) * self.act_dim]
    }

    #[inline]
    pub fn z_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.z[i * self.obs_dim..(i + 1) * self.obs_dim]
    }

    #[inline]
    pub fn a_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.a[i * self.act_dim..(i + 1) * self.act_dim]
    }

    /// Append a point. `z` and `a` must have the trace's dimensions; a pose is kept only if every
    /// point so far has one.
    pub fn push(&mut self, t: f64, z: &[f64], a: &[f64], pose: Option<Pose>) {
        assert_eq!(z.len(), self.obs_dim, "observation has the wrong dimension");
        assert_eq!(a.len(), self.act_dim, "action has the wrong dimension");
        let was_empty = self.is_empty();
        self.t.push(t);
        self.z.extend_from_slice(z);
        self.a.extend_from_slice(a);
        match (pose, &mut self.pose) {
            (Some(p), Some(poses)) => poses.push(p),
            (Some(p), None) if was_empty => self.pose = Some(vec![p]),
            _ => self.pose = None,
        }
    }

    /// The points of `chunk` as a new trace (same domain).
    pub fn slice(&self, chunk: Chunk) -> Trace {
        let r = chunk.range();
        Trace {
            domain: self.domain.clone(),
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
            t: self.t[r.clone()].to_vec(),
            z: self.z[r.start * self.obs_dim..r.end * self.obs_dim].to_vec(),
            a: self.a[r.start * self.act_dim..r.end * self.act_dim].to_vec(),
            pose: self.pose.as_ref().map(|p| p[r].to_vec()),
        }
    }

    /// Check the trace against a domain: name and dimensions.
    pub fn check_domain(&self, domain: &Domain) -> Result<(), TraceError> {
        if self.domain != domain.name
            || self.obs_dim != domain.obs_dim()
            || self.act_dim != domain.act_dim()
        {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: self.domain.clone(),
            });
        }
        Ok(())
    }

    /// The CSV header this trace writes: `t`, observation names, action names, then `x,y,theta`
    /// when poses are present.
    pub fn csv_header(&self, domain: &Domain) -> Vec<String> {
        let mut h = vec!["t".to_string()];
        h.extend(domain.observe.iter().map(|d| d.name.clone()));
        h.extend(domain.act.iter().map(|d| d.name.clone()));
        if self.pose.is_some() {
            h.extend(["x", "y", "theta"].map(String::from));
        }
        h
    }

    /// Write the trace as CSV with [`Trace::csv_header`].
    pub fn write_csv<W: std::io::Write>(&self, domain: &Domain, w: W) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        out.write_record(self.csv_header(domain))?;
        let mut row: Vec<String> = Vec::new();
        for i in 0..self.len() {
            row.clear();
            row.push(fmt_num(self.t[i]));
            row.extend(self.z(i).iter().map(|v| fmt_num(*v)));
            row.extend(self.a(i).iter().map(|v| fmt_num(*v)));
            if let Some(p) = &self.pose {
                row.extend([p[i].x_m, p[i].y_m, p[i].theta_rad].map(fmt_num));
            }
            out.write_record(&row)?;
        }
        out.flush()
    }

    /// Parse CSV text (`name` is used in diagnostics, usually the path).
    /// A file with an `episode` column must hold a single episode; use [`Episode`]'s loaders for
    /// demonstration files with many.
    pub fn from_csv_str(domain: &Domain, name: &str, text: &str) -> Result<Trace, TraceError> {
        let mut eps = csv_load::parse(domain, name, text, false)?;
        match eps.len() {
            0 => Ok(Trace::new(domain)),
            1 => Ok(eps.remove(0).trace),
            n => Err(TraceError::ManyEpisodes { count: n }),
        }
    }

    /// Parse JSON text (see [`JsonTrace`] for the format).
    pub fn from_json_str(domain: &Domain, name: &str, text: &str) -> Result<Trace, TraceError> {
        let src = || NamedSource::new(name, text.to_string());
        let doc: JsonTrace = serde_json::from_str(text).map_err(|e| TraceError::Json {
            message: e.to_string(),
            src: src(),
            span: line_col_span(text, e.line(), e.column()),
        })?;
        if doc.domain != domain.name {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: doc.domain,
            });
        }
        Trace::from_json_points(domain, name, text, &doc.points, false)
    }

    /// A trace from its JSON form, validated as a file's would be (a journal's traces).
    pub fn from_json(domain: &Domain, json: &JsonTrace) -> Result<Trace, TraceError> {
        if json.domain != domain.name {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: json.domain.clone(),
            });
        }
        Trace::from_json_points(domain, "<journal>", "", &json.points, false)
    }

    /// Validate parsed JSON points (dimensions, finiteness, time order, and for demonstrations
    /// the action limits) into a trace.
    fn from_json_points(
        domain: &Domain,
        name: &str,
        text: &str,
        points: &[JsonPoint],
        demo: bool,
    ) -> Result<Trace, TraceError> {
        let src = || NamedSource::new(name, text.to_string());
        let mut trace = Trace::new(domain);
        let with_pose = points.first().is_some_and(|p| p.pose.is_some());
        for (i, p) in points.iter().enumerate() {
            let bad = |what: String| TraceError::JsonPoint {
                index: i,
                what,
                src: src(),
            };
            if p.z.len() != domain.obs_dim() {
                return Err(bad(format!(
                    "`z` has {} values, the `{}` domain observes {}",
                    p.z.len(),
                    domain.name,
                    domain.obs_dim()
                )));
            }
            if p.a.len() != domain.act_dim() {
                return Err(bad(format!(
                    "`a` has {} values, the `{}` domain acts on {}",
                    p.a.len(),
                    domain.name,
                    domain.act_dim()
                )));
            }
            if p.pose.is_some() != with_pose {
                return Err(bad("some points have a `pose` and others do not".into()));
            }
            let vals = std::iter::once(p.t)
                .chain(p.z.iter().copied())
                .chain(p.a.iter().copied());
            if vals
                .chain(p.pose.into_iter().flatten())
                .any(|v| !v.is_finite())
            {
                return Err(bad("a value is not a finite number".into()));
            }
            if i > 0 && p.t < trace.t[i - 1] {
                return Err(bad(format!(
                    "time goes backwards ({} after {})",
                    p.t,
                    trace.t[i - 1]
                )));
            }
            if demo && let Some((k, v, l)) = outside_action_limits(domain, &p.a) {
                return Err(bad(format!(
                    "the action `{}` is {}, outside its limits [{}, {}]; a demonstration's actions are ones the robot can execute",
                    domain.act[k].name,
                    fmt_num(v),
                    fmt_num(l.lo),
                    fmt_num(l.hi)
                )));
            }
            if i > 0 && p.t == trace.t[i - 1] {
                return Err(bad(format!(
                    "the time {} repeats the point before; each point is one control step",
                    p.t
                )));
            }
            let pose = p.pose.map(|[x, y, th]| Pose::new(x, y, th));
            trace.push(p.t, &p.z, &p.a, pose);
        }
        Ok(trace)
    }

    /// The JSON form of the trace.
    pub fn to_json(&self) -> JsonTrace {
        JsonTrace {
            domain: self.domain.clone(),
            points: (0..self.len())
                .map(|i| JsonPoint {
                    t: self.t[i],
                    z: self.z(i).to_vec(),
                    a: self.a(i).to_vec(),
                    pose: self
                        .pose
                        .as_ref()
                        .map(|p| [p[i].x_m, p[i].y_m, p[i].theta_rad]),
                })
                .collect(),
        }
    }

    /// Load a trace from a file; `.json` is JSON, anything else is CSV.
    pub fn load(domain: &Domain, path: &Path) -> Result<Trace, TraceError> {
        let text = crate::files::read_text(path)?;
        let name = path.display().to_string();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            Trace::from_json_str(domain, &name, &text)
        } else {
            Trace::from_csv_str(domain, &name, &text)
        }
    }
}

/// The first action value outside its dimension's limits: (dimension, value, limits).
fn outside_action_limits(
    domain: &Domain,
    a: &[f64],
) -> Option<(usize, f64, crate::domain::Limits)> {
    a.iter()
        .zip(&domain.act)
        .enumerate()
        .find_map(|(k, (v, dim))| dim.limits.filter(|l| !l.contains(*v)).map(|l| (k, *v, l)))
}

/// Shortest text that reads back as the same `f64`.
pub fn fmt_num(v: f64) -> String {
    let s = format!("{v}");
    if s == "-0" { "0".into() } else { s }
}

/// One named trace of a file that holds several (a set of demonstrations).
#[derive(Clone, Debug, PartialEq)]
pub struct Episode {
    pub name: String,
    pub trace: Trace,
}

impl Episode {
    /// Load the episodes of a demonstration file.
    ///
    /// CSV: an optional `episode` column labels each row; consecutive rows with the same label form
    /// one episode (no column: one episode named after the file). JSON: either one trace
    /// ([`JsonTrace`]) or [`JsonEpisodes`].
    pub fn load_all(domain: &Domain, path: &Path) -> Result<Vec<Episode>, TraceError> {
        let text = crate::files::read_text(path)?;
        let name = path.display().to_string();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            Episode::from_json_str(domain, &name, &text)
        } else {
            Episode::from_csv_str(domain, &name, &text)
        }
    }

    pub fn from_csv_str(
        domain: &Domain,
        name: &str,
        text: &str,
    ) -> Result<Vec<Episode>, TraceError> {
        let episodes = csv_load::parse(domain, name, text, true)?;
        if episodes.is_empty() {
            return Err(TraceError::NoDemonstrations {
                name: name.to_string(),
            });
        }
        Ok(episodes)
    }

    pub fn from_json_str(
        domain: &Domain,
        name: &str,
        text: &str,
    ) -> Result<Vec<Episode>, TraceError> {
        let src = || NamedSource::new(name, text.to_string());
        let json_err = |e: serde_json::Error| TraceError::Json {
            message: e.to_string(),
            src: src(),
            span: line_col_span(text, e.line(), e.column()),
        };
        // Peek at the top-level keys, then parse again with the typed form so errors keep their
        // line and column.
        let value: serde_json::Value = serde_json::from_str(text).map_err(json_err)?;
        if value.get("episodes").is_none() {
            let doc: JsonTrace = serde_json::from_str(text).map_err(json_err)?;
            if doc.domain != domain.name {
                return Err(TraceError::DomainMismatch {
                    expected: domain.name.clone(),
                    found: doc.domain,
                });
            }
            if doc.points.is_empty() {
                return Err(TraceError::NoDemonstrations {
                    name: name.to_string(),
                });
            }
            return Ok(vec![Episode {
                name: name.to_string(),
                trace: Trace::from_json_points(domain, name, text, &doc.points, true)?,
            }]);
        }
        let many: JsonEpisodes = serde_json::from_str(text).map_err(json_err)?;
        if many.domain != domain.name {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: many.domain,
            });
        }
        if many.episodes.is_empty() {
            return Err(TraceError::NoDemonstrations {
                name: name.to_string(),
            });
        }
        // Where the n-th `"name": "NAME"` is in the text, for a label (serde keeps no positions).
        let name_span = |episode: &str, nth: usize| {
            let quoted = serde_json::to_string(episode).ok()?;
            let mut at = 0;
            let mut seen = 0;
            while let Some(i) = text[at..].find(&quoted) {
                let start = at + i;
                let before = text[..start].trim_end();
                if before.ends_with(':')
                    && before[..before.len() - 1].trim_end().ends_with("\"name\"")
                {
                    if seen == nth {
                        return Some(SourceSpan::new(start.into(), quoted.len()));
                    }
                    seen += 1;
                }
                at = start + quoted.len();
            }
            None
        };
        let mut seen: Vec<&str> = Vec::new();
        for e in &many.episodes {
            let nth = seen.iter().filter(|n| **n == e.name).count();
            if nth > 0 {
                return Err(TraceError::DuplicateEpisode {
                    episode: e.name.clone(),
                    src: src(),
                    span: name_span(&e.name, nth),
                });
            }
            if e.points.is_empty() {
                return Err(TraceError::EmptyEpisode {
                    episode: e.name.clone(),
                    src: src(),
                    span: name_span(&e.name, 0),
                });
            }
            seen.push(&e.name);
        }
        many.episodes
            .into_iter()
            .map(|e| {
                let ep_name = format!("{name} [{}]", e.name);
                let trace = Trace::from_json_points(domain, &ep_name, text, &e.points, true)?;
                Ok(Episode {
                    name: e.name,
                    trace,
                })
            })
            .collect()
    }

    /// Write episodes as one CSV with an `episode` column first.
    pub fn write_csv<W: std::io::Write>(
        domain: &Domain,
        episodes: &[Episode],
        w: W,
    ) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        let with_pose = episodes.iter().all(|e| e.trace.pose.is_some()) && !episodes.is_empty();
        let mut header = vec!["episode".to_string()];
        let mut h = episodes.first().map_or_else(
            || Trace::new(domain).csv_header(domain),
            |e| e.trace.csv_header(domain),
        );
        h.truncate(1 + domain.obs_dim() + domain.act_dim());
        header.extend(h);
        if with_pose {
            header.extend(["x", "y", "theta"].map(String::from));
        }
        out.write_record(&header)?;
        for e in episodes {
            let tr = &e.trace;
            for i in 0..tr.len() {
                let mut row = vec![e.name.clone(), fmt_num(tr.t[i])];
                row.extend(tr.z(i).iter().map(|v| fmt_num(*v)));
                row.extend(tr.a(i).iter().map(|v| fmt_num(*v)));
                if let (true, Some(p)) = (with_pose, &tr.pose) {
                    row.extend([p[i].x_m, p[i].y_m, p[i].theta_rad].map(fmt_num));
                }
                out.write_record(&row)?;
            }
        }
        out.flush()
    }

    /// The JSON form of several episodes.
    pub fn to_json(domain: &Domain, episodes: &[Episode]) -> JsonEpisodes {
        JsonEpisodes {
            domain: domain.name.clone(),
            episodes: episodes
                .iter()
                .map(|e| JsonEpisode {
                    name: e.name.clone(),
                    points: e.trace.to_json().points,
                })
                .collect(),
        }
    }
}

/// The JSON file format of several episodes:
/// `{"domain": "positioning", "episodes": [{"name": "demo-0", "points": [..]}]}`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonEpisodes {
    pub domain: String,
    pub episodes: Vec<JsonEpisode>,
}

/// One episode of [`JsonEpisodes`]; points as in [`JsonTrace`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonEpisode {
    pub name: String,
    pub points: Vec<JsonPoint>,
}

/// The JSON file format of a trace.
///
/// ```json
/// {"domain": "positioning",
///  "points": [{"t": 0.0, "z": [4.0, 0.1, 0.3], "a": [0.5, 0.0], "pose": [0.0, 0.0, 0.0]}]}
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonTrace {
    pub domain: String,
    pub points: Vec<JsonPoint>,
}

/// One point of a [`JsonTrace`]; `pose` is `[x_m, y_m, theta_rad]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonPoint {
    pub t: f64,
    pub z: Vec<f64>,
    pub a: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose: Option<[f64; 3]>,
}

/// A contiguous, half-open range `start..end` of point indices of one trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Chunk {
    pub start: usize,
    pub end: usize,
}

impl Chunk {
    /// A chunk of a trace of `len` points; errors when reversed or out of range.
    /// An empty chunk (`start == end`) is allowed: applying advice to it changes nothing.
    pub fn new(start: usize, end: usize, len: usize) -> Result<Chunk, ChunkError> {
        if start > end {
            return Err(ChunkError::Reversed { start, end });
        }
        if end > len {
            return Err(ChunkError::OutOfRange { start, end, len });
        }
        Ok(Chunk { start, end })
    }

    /// The whole of a trace of `len` points.
    pub fn all(len: usize) -> Chunk {
        Chunk { start: 0, end: len }
    }

    /// Points in the chunk. The fields are public (and deserialised), so a reversed chunk can
    /// exist; it holds no points, as its [`Chunk::range`] is empty.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    pub fn is_empty(&self) -> bool {
        self.start >= self.end
    }

    pub fn range(&self) -> Range<usize> {
        self.start..self.end
    }
}

impl std::fmt::Display for Chunk {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}..{}", self.start, self.end)
    }
}

/// A chunk that does not fit its trace.
#[derive(Debug, Error, Diagnostic, Clone, PartialEq, Eq)]
pub enum ChunkError {
    #[error("the range {start}..{end} is reversed")]
    #[diagnostic(
        code(advise::chunk::reversed),
        help("write the smaller index first: {end}..{start}")
    )]
    Reversed { start: usize, end: usize },
    #[error("the range {start}..{end} is outside the execution, which has {len} points")]
    #[diagnostic(
        code(advise::chunk::out_of_range),
        help("ranges are half-open and 0-based: the whole execution is 0..{len}")
    )]
    OutOfRange {
        start: usize,
        end: usize,
        len: usize,
    },
}

/// Everything that can be wrong with a trace file.
#[derive(Debug, Error, Diagnostic)]
pub enum TraceError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("the trace has no column `{column}`")]
    #[diagnostic(
        code(advise::trace::missing_column),
        help("the `{domain}` domain needs the columns: {expected}")
    )]
    MissingColumn {
        column: String,
        domain: String,
        expected: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("this header lacks `{column}`")]
        span: SourceSpan,
    },
    #[error("the trace has an unknown column `{column}`")]
    #[diagnostic(code(advise::trace::unknown_column), help("{help}"))]
    UnknownColumn {
        column: String,
        help: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("not a dimension of the `{domain}` domain")]
        span: SourceSpan,
        domain: String,
    },
    #[error("the column `{column}` appears twice")]
    #[diagnostic(code(advise::trace::duplicate_column), help("remove one of them"))]
    DuplicateColumn {
        column: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("second `{column}`")]
        span: SourceSpan,
    },
    #[error("line {line}: the row has {found} fields, the header has {expected}")]
    #[diagnostic(code(advise::trace::row_length))]
    RowLength {
        line: u64,
        found: usize,
        expected: usize,
        #[source_code]
        src: NamedSource<String>,
        #[label("this row")]
        span: SourceSpan,
    },
    #[error("line {line}, column `{column}`: `{value}` is not a number")]
    #[diagnostic(
        code(advise::trace::not_a_number),
        help("write a decimal number such as 0.25")
    )]
    NotANumber {
        line: u64,
        column: String,
        value: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("not a number")]
        span: SourceSpan,
    },
    #[error("line {line}, column `{column}`: the value is {value}, not a finite number")]
    #[diagnostic(
        code(advise::trace::not_finite),
        help("a NaN or infinity usually means a sensor dropout; remove or repair the row")
    )]
    NotFinite {
        line: u64,
        column: String,
        value: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("not finite")]
        span: SourceSpan,
    },
    #[error("line {line}: time goes backwards ({t} after {prev})")]
    #[diagnostic(
        code(advise::trace::time_backwards),
        help("rows must be in time order")
    )]
    TimeBackwards {
        line: u64,
        t: f64,
        prev: f64,
        #[source_code]
        src: NamedSource<String>,
        #[label("earlier than the row before")]
        span: SourceSpan,
    },
    #[error(
        "line {line}, column `{column}`: the action {value} is outside its limits [{lo}, {hi}]"
    )]
    #[diagnostic(
        code(advise::trace::action_out_of_limits),
        help(
            "a demonstration's actions are ones the robot can execute; clamp the value into [{lo}, {hi}]"
        )
    )]
    ActionOutOfLimits {
        line: u64,
        column: String,
        value: String,
        lo: String,
        hi: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("outside [{lo}, {hi}]")]
        span: SourceSpan,
    },
    #[error("line {line}: the time {t} repeats the row before")]
    #[diagnostic(
        code(advise::trace::time_repeated),
        help("each row is one control step, later than the one before; remove the repeated row")
    )]
    TimeRepeated {
        line: u64,
        t: f64,
        #[source_code]
        src: NamedSource<String>,
        #[label("same time as the row before")]
        span: SourceSpan,
    },
    #[error("line {line}: episode `{episode}` started before, on line {first_line}")]
    #[diagnostic(
        code(advise::trace::episode_split),
        help(
            "the rows of one episode are contiguous; move them together, or give this run of rows its own name"
        )
    )]
    EpisodeSplit {
        line: u64,
        first_line: u64,
        episode: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("`{episode}` again, after other episodes")]
        span: SourceSpan,
    },
    #[error("episode `{episode}` has no points")]
    #[diagnostic(
        code(advise::trace::empty_episode),
        help("remove the episode, or record its points")
    )]
    EmptyEpisode {
        episode: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("no points")]
        span: Option<SourceSpan>,
    },
    #[error("two episodes are named `{episode}`")]
    #[diagnostic(
        code(advise::trace::duplicate_episode),
        help("episode names tell demonstrations apart in provenance; rename one")
    )]
    DuplicateEpisode {
        episode: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("second `{episode}`")]
        span: Option<SourceSpan>,
    },
    #[error("`{name}` holds no demonstrations")]
    #[diagnostic(
        code(advise::trace::no_demonstrations),
        help(
            "a demonstrations file has at least one row after its header (CSV) or one episode (JSON)"
        )
    )]
    NoDemonstrations { name: String },
    #[error("the file is empty: it has no header")]
    #[diagnostic(
        code(advise::trace::empty),
        help("a trace starts with a header line such as `t,dist2,bearing,dheading,trans,rot`")
    )]
    Empty,
    #[error("the file holds {count} episodes where one trace was expected")]
    #[diagnostic(
        code(advise::trace::many_episodes),
        help(
            "load it as demonstrations (`load demos FILE`), pick one with `advise apply --episode K`, or keep one episode's rows"
        )
    )]
    ManyEpisodes { count: usize },
    #[error("the CSV is malformed: {message}")]
    #[diagnostic(code(advise::trace::csv))]
    Csv { message: String },
    #[error("the JSON trace is malformed: {message}")]
    #[diagnostic(
        code(advise::trace::json),
        help(r#"a JSON trace is {{"domain": NAME, "points": [{{"t": .., "z": [..], "a": [..], "pose": [x, y, theta]}}]}}"#)
    )]
    Json {
        message: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("here")]
        span: SourceSpan,
    },
    #[error("point {index} of the JSON trace: {what}")]
    #[diagnostic(code(advise::trace::json_point))]
    JsonPoint {
        index: usize,
        what: String,
        #[source_code]
        src: NamedSource<String>,
    },
    #[error("the trace is for the `{found}` domain, not `{expected}`")]
    #[diagnostic(
        code(advise::trace::domain_mismatch),
        help("switch the task first, or load a trace recorded for `{expected}`")
    )]
    DomainMismatch { expected: String, found: String },
}

/// Byte span of a (1-based) line and column in `text`, for serde_json positions.
pub fn line_col_span(text: &str, line: usize, column: usize) -> SourceSpan {
    let mut offset = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            // serde counts columns in bytes; step back to a character boundary and cover one
            // whole character.
            let mut col = column.saturating_sub(1).min(l.len());
            while !l.is_char_boundary(col) {
                col -= 1;
            }
            let width = l[col..].chars().next().map_or(0, char::len_utf8);
            return SourceSpan::new((offset + col).into(), width);
        }
        offset += l.len();
    }
    SourceSpan::new(text.len().into(), 0)
}

mod csv_load {
    use super::*;

    /// Where each CSV line starts, so rows can be labelled in the source.
    fn line_span(text: &str, byte: usize) -> SourceSpan {
        let end = text[byte..]
            .find(['\n', '\r'])
            .map_or(text.len(), |e| byte + e);
        SourceSpan::new(byte.into(), end - byte)
    }

    /// Span of field `field` in the line starting at `byte` (falls back to the whole line).
    fn field_span(text: &str, byte: usize, field: usize) -> SourceSpan {
        let line = line_span(text, byte);
        let s = &text[byte..byte + line.len()];
        let mut off = byte;
        for (i, f) in s.split(',').enumerate() {
            if i == field {
                return SourceSpan::new(off.into(), f.len());
            }
            off += f.len() + 1;
        }
        line
    }

    /// `demo`: the rows are demonstrations, whose actions must be within the domain's limits.
    pub fn parse(
        domain: &Domain,
        name: &str,
        text: &str,
        demo: bool,
    ) -> Result<Vec<Episode>, TraceError> {
        let src = || NamedSource::new(name, text.to_string());
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .trim(csv::Trim::All)
            .flexible(true)
            .from_reader(text.as_bytes());
        let mut records = rdr.records();
        let header = match records.next() {
            None => return Err(TraceError::Empty),
            Some(r) => r.map_err(|e| TraceError::Csv {
                message: e.to_string(),
            })?,
        };
        let header_byte = header.position().map_or(0, |p| p.byte() as usize);
        let header_span = line_span(text, header_byte);

        // Map each column to its slot: t, z[i], a[j], pose[k].
        #[derive(Clone, Copy)]
        enum Slot {
            Episode,
            T,
            Z(usize),
            A(usize),
            Pose(usize),
        }
        let mut slots = Vec::with_capacity(header.len());
        let mut seen: Vec<&str> = Vec::new();
        for (col, h) in header.iter().enumerate() {
            if seen.contains(&h) {
                return Err(TraceError::DuplicateColumn {
                    column: h.to_string(),
                    src: src(),
                    span: field_span(text, header_byte, col),
                });
            }
            seen.push(h);
            let slot = if h == "t" {
                Slot::T
            } else if h == "episode" {
                Slot::Episode
            } else if let Some(i) = domain.index_of(crate::domain::Space::Observation, h) {
                Slot::Z(i)
            } else if let Some(i) = domain.index_of(crate::domain::Space::Action, h) {
                Slot::A(i)
            } else if let Some(k) = ["x", "y", "theta"].iter().position(|p| *p == h) {
                Slot::Pose(k)
            } else {
                let known = known_columns(domain);
                let best = known
                    .iter()
                    .map(|k| (strsim::jaro_winkler(k, h), k))
                    .max_by(|a, b| a.0.total_cmp(&b.0));
                let help = match best {
                    Some((score, k)) if score > 0.8 => format!("did you mean `{k}`?"),
                    _ => format!("the known columns are: {}", known.join(", ")),
                };
                return Err(TraceError::UnknownColumn {
                    column: h.to_string(),
                    help,
                    src: src(),
                    span: field_span(text, header_byte, col),
                    domain: domain.name.clone(),
                });
            };
            slots.push(slot);
        }
        let required = std::iter::once("t".to_string())
            .chain(domain.observe.iter().map(|d| d.name.clone()))
            .chain(domain.act.iter().map(|d| d.name.clone()));
        for r in required {
            if !seen.contains(&r.as_str()) {
                return Err(TraceError::MissingColumn {
                    column: r,
                    domain: domain.name.clone(),
                    expected: known_columns(domain)[..1 + domain.obs_dim() + domain.act_dim()]
                        .join(","),
                    src: src(),
                    span: header_span,
                });
            }
        }
        let pose_cols = seen
            .iter()
            .filter(|h| ["x", "y", "theta"].contains(h))
            .count();
        if pose_cols != 0 && pose_cols != 3 {
            let missing = ["x", "y", "theta"]
                .into_iter()
                .find(|p| !seen.contains(p))
                .unwrap_or("x");
            return Err(TraceError::MissingColumn {
                column: missing.into(),
                domain: domain.name.clone(),
                expected: "x,y,theta (all three, or none)".into(),
                src: src(),
                span: header_span,
            });
        }

        let mut episodes: Vec<Episode> = Vec::new();
        // Each episode's label and first line: an episode's rows are contiguous.
        let mut starts: std::collections::HashMap<String, u64> = Default::default();
        let (mut z, mut a) = (vec![0.0; domain.obs_dim()], vec![0.0; domain.act_dim()]);
        let mut pose = [0.0; 3];
        for rec in records {
            let rec = rec.map_err(|e| TraceError::Csv {
                message: e.to_string(),
            })?;
            let byte = rec.position().map_or(0, |p| p.byte() as usize);
            let line = rec.position().map_or(0, |p| p.line());
            if rec.len() == 1 && rec.get(0) == Some("") {
                continue; // blank line
            }
            if rec.len() != slots.len() {
                return Err(TraceError::RowLength {
                    line,
                    found: rec.len(),
                    expected: slots.len(),
                    src: src(),
                    span: line_span(text, byte),
                });
            }
            let mut t = 0.0;
            let mut label = "";
            for (col, (field, slot)) in rec.iter().zip(&slots).enumerate() {
                if let Slot::Episode = slot {
                    label = field;
                    continue;
                }
                let column = || header.get(col).unwrap_or("?").to_string();
                let v: f64 = field.parse().map_err(|_| TraceError::NotANumber {
                    line,
                    column: column(),
                    value: field.to_string(),
                    src: src(),
                    span: field_span(text, byte, col),
                })?;
                if !v.is_finite() {
                    return Err(TraceError::NotFinite {
                        line,
                        column: column(),
                        value: field.to_string(),
                        src: src(),
                        span: field_span(text, byte, col),
                    });
                }
                if let (true, Slot::A(i)) = (demo, *slot)
                    && let Some(l) = domain.act[i].limits
                    && !l.contains(v)
                {
                    return Err(TraceError::ActionOutOfLimits {
                        line,
                        column: column(),
                        value: field.to_string(),
                        lo: fmt_num(l.lo),
                        hi: fmt_num(l.hi),
                        src: src(),
                        span: field_span(text, byte, col),
                    });
                }
                match *slot {
                    Slot::Episode => {}
                    Slot::T => t = v,
                    Slot::Z(i) => z[i] = v,
                    Slot::A(i) => a[i] = v,
                    Slot::Pose(k) => pose[k] = v,
                }
            }
            if episodes.last().is_none_or(|e| e.name != label) {
                if let Some(&first_line) = starts.get(label) {
                    let col = slots
                        .iter()
                        .position(|s| matches!(s, Slot::Episode))
                        .unwrap_or(0);
                    return Err(TraceError::EpisodeSplit {
                        line,
                        first_line,
                        episode: label.to_string(),
                        src: src(),
                        span: field_span(text, byte, col),
                    });
                }
                starts.insert(label.to_string(), line);
                episodes.push(Episode {
                    name: label.to_string(),
                    trace: Trace::new(domain),
                });
            }
            let Some(Episode { trace, .. }) = episodes.last_mut() else {
                unreachable!("an episode was pushed above")
            };
            if let Some(&prev) = trace.t.last()
                && t <= prev
            {
                let tcol = slots.iter().position(|s| matches!(s, Slot::T)).unwrap_or(0);
                let span = field_span(text, byte, tcol);
                return Err(if t == prev {
                    TraceError::TimeRepeated {
                        line,
                        t,
                        src: src(),
                        span,
                    }
                } else {
                    TraceError::TimeBackwards {
                        line,
                        t,
                        prev,
                        src: src(),
                        span,
                    }
                });
            }
            let p = (pose_cols == 3).then(|| Pose::new(pose[0], pose[1], pose[2]));
            trace.push(t, &z, &a, p);
        }
        Ok(episodes)
    }

    fn known_columns(domain: &Domain) -> Vec<String> {
        std::iter::once("t".to_string())
            .chain(domain.observe.iter().map(|d| d.name.clone()))
            .chain(domain.act.iter().map(|d| d.name.clone()))
            .chain(["x", "y", "theta", "episode"].map(String::from))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "t,dist2,bearing,dheading,trans,rot,x,y,theta\n\
                        0,4,0.1,0.2,0.5,0,0,0,0\n\
                        0.033,3.9,0.1,0.2,0.5,0.1,0.01,0,0\n";

    #[test]
    fn csv_round_trip() {
        let d = Domain::positioning();
        let tr = Trace::from_csv_str(&d, "t.csv", GOOD).unwrap();
        assert_eq!(tr.len(), 2);
        assert_eq!(tr.a(1), &[0.5, 0.1]);
        let mut out = Vec::new();
        tr.write_csv(&d, &mut out).unwrap();
        let back = Trace::from_csv_str(&d, "t.csv", std::str::from_utf8(&out).unwrap()).unwrap();
        assert_eq!(tr, back);
    }

    #[test]
    fn json_round_trip() {
        let d = Domain::positioning();
        let tr = Trace::from_csv_str(&d, "t.csv", GOOD).unwrap();
        let text = serde_json::to_string(&tr.to_json()).unwrap();
        assert_eq!(Trace::from_json_str(&d, "t.json", &text).unwrap(), tr);
    }

    #[test]
    fn csv_errors_name_the_problem() {
        let d = Domain::positioning();
        let missing = "t,dist2,bearing,trans,rot\n0,1,2,3,4\n";
        assert!(matches!(
            Trace::from_csv_str(&d, "m.csv", missing),
            Err(TraceError::MissingColumn { column, .. }) if column == "dheading"
        ));
        let nan = "t,dist2,bearing,dheading,trans,rot\n0,1,NaN,0,0,0\n";
        assert!(matches!(
            Trace::from_csv_str(&d, "n.csv", nan),
            Err(TraceError::NotFinite { line: 2, .. })
        ));
        let typo = "t,dist2,bearing,dheading,trans,rott\n";
        match Trace::from_csv_str(&d, "u.csv", typo) {
            Err(TraceError::UnknownColumn { help, .. }) => assert!(help.contains("`rot`")),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn episodes_round_trip_through_csv_and_json() {
        let d = Domain::positioning();
        let tr = Trace::from_csv_str(&d, "t.csv", GOOD).unwrap();
        let eps = vec![
            Episode {
                name: "a".into(),
                trace: tr.clone(),
            },
            Episode {
                name: "b".into(),
                trace: tr.slice(Chunk::new(1, 2, 2).unwrap()),
            },
        ];
        let mut out = Vec::new();
        Episode::write_csv(&d, &eps, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(Episode::from_csv_str(&d, "e.csv", &text).unwrap(), eps);
        assert!(matches!(
            Trace::from_csv_str(&d, "e.csv", &text),
            Err(TraceError::ManyEpisodes { count: 2 })
        ));
        let json = serde_json::to_string(&Episode::to_json(&d, &eps)).unwrap();
        assert_eq!(Episode::from_json_str(&d, "e.json", &json).unwrap(), eps);
    }

    #[test]
    fn chunks_are_validated() {
        assert!(Chunk::new(2, 5, 10).is_ok());
        assert_eq!(
            Chunk::new(5, 2, 10),
            Err(ChunkError::Reversed { start: 5, end: 2 })
        );
        assert!(matches!(
            Chunk::new(0, 11, 10),
            Err(ChunkError::OutOfRange { .. })
        ));
        assert!(Chunk::new(3, 3, 10).unwrap().is_empty());
    }

    #[test]
    fn a_reversed_chunk_built_by_hand_holds_no_points() {
        // The fields are public and deserialised: `Chunk::new` is not the only way in.
        let c: Chunk = serde_json::from_str(r#"{"start": 7, "end": 3}"#).unwrap();
        assert_eq!(c.len(), 0);
        assert!(c.is_empty());
        assert_eq!(c.range().count(), 0);
        assert_eq!(Chunk { start: 2, end: 5 }.len(), 3);
    }
}
