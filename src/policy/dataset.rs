//! The dataset: points `(z, a)` with their provenance and BC weights, and the records from which
//! advice and critiques can be undone exactly.
//!
//! Every point knows where it came from ([`Provenance`]): demonstration `d`, point `i`; or advice
//! `k`, synthesized point `j`. Advice is kept as an [`AdviceRecord`] (the interpreter's
//! [`AppliedAdvice`] plus the execution it was given on), so its points can be re-synthesized, and
//! removing it removes exactly its points. BC weights are never edited in place: each critique
//! keeps the increments it made (keyed by provenance, which survives removals), and the weights
//! are the sum `m_i = 1 + sum of increments` recomputed in critique order, so undoing a critique
//! gives bit for bit the weights that would exist without it. No IO here but [`Dataset::save`]
//! and [`Dataset::load`], both through [`crate::files`]; a loaded file is validated whole.

use std::collections::HashMap;
use std::path::Path;

use miette::Diagnostic;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::diag::{Loc, SourceMap, Sourced, Src, locate};
use crate::domain::Domain;
use crate::interp::AppliedAdvice;
use crate::number::fmt_num;
use crate::trace::{Chunk, Episode, JsonPoint, Trace};

/// Ids are small integers, unique within a dataset and never reused.
pub type DemoId = u32;
pub type ExecutionId = u32;
pub type AdviceId = u32;
pub type CritiqueId = u32;

/// Where a data point came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Provenance {
    /// Point `index` of demonstration `demo`.
    Demonstration { demo: DemoId, index: u32 },
    /// Synthesized point `index` of advice `advice` (from execution point `source`).
    Advice {
        advice: AdviceId,
        index: u32,
        source: u32,
    },
}

/// A demonstration as recorded in the dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemoRecord {
    pub id: DemoId,
    pub name: String,
    pub points: u32,
}

/// An execution that advice or critique was given on, kept whole so advice can be re-synthesized.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutionRecord {
    pub id: ExecutionId,
    pub points: Vec<JsonPoint>,
}

/// A piece of advice: what was applied, on which execution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdviceRecord {
    pub id: AdviceId,
    pub execution: ExecutionId,
    pub applied: AppliedAdvice,
}

/// A critique: the flagged chunk, kappa, and the weight increments it made.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CritiqueRecord {
    pub id: CritiqueId,
    pub execution: ExecutionId,
    pub chunk: Chunk,
    pub kappa: f64,
    /// (point, increment of its m), in the order they were applied.
    pub increments: Vec<(Provenance, f64)>,
}

/// Points with provenance and weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    domain: Domain,
    /// Observations, `len * obs_dim`, row after row.
    z: Vec<f64>,
    /// Actions, `len * act_dim`.
    a: Vec<f64>,
    provenance: Vec<Provenance>,
    /// BC weight `m_i >= 1` of each point.
    m: Vec<f64>,
    demos: Vec<DemoRecord>,
    executions: Vec<ExecutionRecord>,
    advice: Vec<AdviceRecord>,
    critiques: Vec<CritiqueRecord>,
    next_id: u32,
}

/// What can go wrong with a dataset.
#[derive(Debug, Error, Diagnostic)]
pub enum DatasetError {
    #[error("no advice with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_advice))]
    UnknownAdvice(AdviceId),
    #[error("no critique with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_critique))]
    UnknownCritique(CritiqueId),
    #[error("no execution with id {0}")]
    #[diagnostic(code(advise::dataset::unknown_execution))]
    UnknownExecution(ExecutionId),
    #[error("the points are for the `{found}` domain, the dataset is `{expected}`")]
    #[diagnostic(code(advise::dataset::domain_mismatch))]
    DomainMismatch { expected: String, found: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Trace(#[from] crate::trace::TraceError),
    #[error("`{path}`: a dataset is saved as `.json` (to open again) or `.csv` (points only)")]
    #[diagnostic(
        code(advise::dataset::unknown_format),
        help("name the file `{stem}.json`, or `{stem}.csv` for the points alone")
    )]
    UnknownFormat { path: String, stem: String },
    #[error("the dataset file is malformed: {message}")]
    #[diagnostic(
        code(advise::dataset::json),
        help("dataset files are written by `save FILE.json`; a CSV export cannot be opened again")
    )]
    Json {
        message: String,
        #[label("here")]
        at: Loc,
    },
    #[error("refused to add a value that is not finite: {what}")]
    #[diagnostic(
        code(advise::dataset::non_finite),
        help("every value in a dataset must be a finite number; nothing was added")
    )]
    NonFinite { what: String },
    #[error("the dataset file is inconsistent: {what}")]
    #[diagnostic(code(advise::dataset::inconsistent))]
    Inconsistent { what: String },
    #[error("`{at}`: {what}")]
    #[diagnostic(
        code(advise::dataset::dimension),
        help("every point has the domain's dimensions: {expected}")
    )]
    Dimension {
        at: String,
        what: String,
        expected: String,
    },
    #[error("a number of the dataset is `null`, not a finite number")]
    #[diagnostic(
        code(advise::dataset::null),
        help(
            "JSON writes NaN and infinity as `null`; a dataset holds finite numbers only, so the point must be repaired or removed"
        )
    )]
    Null {
        #[label("not a number")]
        at: Loc,
    },
    #[error("`{at}` is {value}, not a finite number")]
    #[diagnostic(
        code(advise::dataset::not_finite),
        help("a dataset holds finite numbers only (JSON writes NaN and infinity as `null`)")
    )]
    NotFinite { at: String, value: String },
    #[error("`{at}` is {value}, outside the `{dim}` limits [{lo}, {hi}]")]
    #[diagnostic(
        code(advise::dataset::out_of_limits),
        help(
            "the domain's limits hold for every point; the file was edited or is for another domain"
        )
    )]
    OutOfLimits {
        at: String,
        value: String,
        dim: String,
        lo: String,
        hi: String,
    },
    #[error("id {id} is used twice: by {first} and by {second}")]
    #[diagnostic(
        code(advise::dataset::duplicate_id),
        help("demonstrations, executions, advice and critiques share one sequence of ids")
    )]
    DuplicateId {
        id: u32,
        first: String,
        second: String,
    },
    #[error("`{at}` refers to {what} {id}, which the file does not hold")]
    #[diagnostic(code(advise::dataset::dangling))]
    Dangling {
        at: String,
        what: &'static str,
        id: u32,
    },
    #[error("`next_id` is {next_id}, but the file already uses id {max_id}")]
    #[diagnostic(
        code(advise::dataset::next_id),
        help(
            "`next_id` is the last id given out; it must be at least {max_id}, or new advice would reuse an id and `undo` would remove the wrong points"
        )
    )]
    NextId { next_id: u32, max_id: u32 },
    #[error("`{at}`: {what}")]
    #[diagnostic(code(advise::dataset::inconsistent_record))]
    Record { at: String, what: String },
}

impl Dataset {
    pub fn new(domain: &Domain) -> Dataset {
        Dataset {
            domain: domain.clone(),
            z: Vec::new(),
            a: Vec::new(),
            provenance: Vec::new(),
            m: Vec::new(),
            demos: Vec::new(),
            executions: Vec::new(),
            advice: Vec::new(),
            critiques: Vec::new(),
            next_id: 0,
        }
    }

    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Whether the learners' index supports this domain's observation dimension.
    pub fn obs_dim_supported(&self) -> bool {
        (1..=crate::policy::index::MAX_DIM).contains(&self.domain.obs_dim())
    }

    pub fn len(&self) -> usize {
        self.provenance.len()
    }

    pub fn is_empty(&self) -> bool {
        self.provenance.is_empty()
    }

    #[inline]
    pub fn z(&self, i: usize) -> &[f64] {
        let d = self.domain.obs_dim();
        &self.z[i * d..(i + 1) * d]
    }

    #[inline]
    pub fn a(&self, i: usize) -> &[f64] {
        let d = self.domain.act_dim();
        &self.a[i * d..(i + 1) * d]
    }

    #[inline]
    pub fn m(&self, i: usize) -> f64 {
        self.m[i]
    }

    pub fn weights(&self) -> &[f64] {
        &self.m
    }

    pub fn provenance(&self, i: usize) -> Provenance {
        self.provenance[i]
    }

    pub fn demos(&self) -> &[DemoRecord] {
        &self.demos
    }

    pub fn advice(&self) -> &[AdviceRecord] {
        &self.advice
    }

    pub fn critiques(&self) -> &[CritiqueRecord] {
        &self.critiques
    }

    fn fresh_id(&mut self) -> u32 {
        self.next_id += 1;
        self.next_id
    }

    fn check(&self, trace: &Trace) -> Result<(), DatasetError> {
        if trace.domain != self.domain.name
            || trace.obs_dim() != self.domain.obs_dim()
            || trace.act_dim() != self.domain.act_dim()
        {
            return Err(DatasetError::DomainMismatch {
                expected: self.domain.name.clone(),
                found: trace.domain.clone(),
            });
        }
        Ok(())
    }

    fn push(&mut self, z: &[f64], a: &[f64], p: Provenance) {
        self.z.extend_from_slice(z);
        self.a.extend_from_slice(a);
        self.provenance.push(p);
        self.m.push(1.0);
    }

    /// Add a demonstration; its points are appended in order.
    pub fn add_demonstration(&mut self, name: &str, trace: &Trace) -> Result<DemoId, DatasetError> {
        self.check(trace)?;
        check_finite(trace, || format!("demonstration `{name}`"))?;
        let id = self.fresh_id();
        for i in 0..trace.len() {
            self.push(
                trace.z(i),
                trace.a(i),
                Provenance::Demonstration {
                    demo: id,
                    index: i as u32,
                },
            );
        }
        self.demos.push(DemoRecord {
            id,
            name: name.to_string(),
            points: trace.len() as u32,
        });
        Ok(id)
    }

    /// Keep an execution that advice or critique may refer to (its points are not training data).
    pub fn add_execution(&mut self, trace: &Trace) -> Result<ExecutionId, DatasetError> {
        self.check(trace)?;
        let id = self.fresh_id();
        self.executions.push(ExecutionRecord {
            id,
            points: trace.to_json().points,
        });
        Ok(id)
    }

    /// The position of execution `id` among the dataset's executions (0 for the first recorded):
    /// the number a teacher sees.
    pub fn execution_number(&self, id: ExecutionId) -> Option<usize> {
        self.executions.iter().position(|e| e.id == id)
    }

    /// The execution with id `id`, as a trace.
    pub fn execution(&self, id: ExecutionId) -> Result<Trace, DatasetError> {
        let rec = self
            .executions
            .iter()
            .find(|e| e.id == id)
            .ok_or(DatasetError::UnknownExecution(id))?;
        let mut t = Trace::new(&self.domain);
        let with_pose = rec.points.first().is_some_and(|p| p.pose.is_some());
        for p in &rec.points {
            let pose = if with_pose {
                p.pose.map(|[x, y, th]| crate::trace::Pose::new(x, y, th))
            } else {
                None
            };
            t.push(p.t, &p.z, &p.a, pose);
        }
        Ok(t)
    }

    /// Add advice given on `execution`: `points` are the synthesized points, `source[j]` the
    /// execution index point `j` came from. Returns the new advice id and the index of its first
    /// point (points are appended).
    pub fn add_advice(
        &mut self,
        execution: ExecutionId,
        applied: AppliedAdvice,
        points: &Trace,
        source: &[usize],
    ) -> Result<AdviceId, DatasetError> {
        self.check(points)?;
        if !self.executions.iter().any(|e| e.id == execution) {
            return Err(DatasetError::UnknownExecution(execution));
        }
        check_finite(points, || format!("advice `{}`", applied.operator))?;
        let id = self.fresh_id();
        for j in 0..points.len() {
            self.push(
                points.z(j),
                points.a(j),
                Provenance::Advice {
                    advice: id,
                    index: j as u32,
                    source: source.get(j).copied().unwrap_or(0) as u32,
                },
            );
        }
        self.advice.push(AdviceRecord {
            id,
            execution,
            applied,
        });
        // New advice has a fresh id, so no critique record can refer to its points: their
        // weights start at 1 and nothing else changes.
        Ok(id)
    }

    /// Remove advice `id` and exactly its points.
    pub fn remove_advice(&mut self, id: AdviceId) -> Result<AdviceRecord, DatasetError> {
        let pos = self
            .advice
            .iter()
            .position(|r| r.id == id)
            .ok_or(DatasetError::UnknownAdvice(id))?;
        let record = self.advice.remove(pos);
        self.retain_points(|p| !matches!(p, Provenance::Advice { advice, .. } if *advice == id));
        self.recompute_weights();
        Ok(record)
    }

    fn retain_points(&mut self, keep: impl Fn(&Provenance) -> bool) {
        let (od, ad) = (self.domain.obs_dim(), self.domain.act_dim());
        let mut w = 0;
        for r in 0..self.provenance.len() {
            if keep(&self.provenance[r]) {
                if w != r {
                    self.provenance[w] = self.provenance[r];
                    self.m[w] = self.m[r];
                    self.z.copy_within(r * od..(r + 1) * od, w * od);
                    self.a.copy_within(r * ad..(r + 1) * ad, w * ad);
                }
                w += 1;
            }
        }
        self.provenance.truncate(w);
        self.m.truncate(w);
        self.z.truncate(w * od);
        self.a.truncate(w * ad);
    }

    /// Record a critique and make its increments: each applies to the point of that provenance if
    /// it is still in the dataset. The weights are recomputed from the records in critique order,
    /// so a critique made, redone or restored from the journal gives bit for bit the same weights.
    pub fn add_critique(
        &mut self,
        execution: ExecutionId,
        chunk: Chunk,
        kappa: f64,
        increments: Vec<(Provenance, f64)>,
    ) -> Result<CritiqueId, DatasetError> {
        if !self.executions.iter().any(|e| e.id == execution) {
            return Err(DatasetError::UnknownExecution(execution));
        }
        if let Some((p, inc)) = increments
            .iter()
            .find(|(_, inc)| !(inc.is_finite() && *inc >= 0.0))
        {
            return Err(DatasetError::NonFinite {
                what: format!("the critique's increment for {p:?} is {inc}"),
            });
        }
        let id = self.fresh_id();
        self.critiques.push(CritiqueRecord {
            id,
            execution,
            chunk,
            kappa,
            increments,
        });
        self.recompute_weights();
        Ok(id)
    }

    /// Where each point is, by provenance (provenance survives removals; positions do not).
    pub fn positions(&self) -> HashMap<Provenance, usize> {
        self.provenance
            .iter()
            .enumerate()
            .map(|(i, p)| (*p, i))
            .collect()
    }

    /// Remove critique `id`; the weights become those the remaining critiques give.
    pub fn remove_critique(&mut self, id: CritiqueId) -> Result<CritiqueRecord, DatasetError> {
        let pos = self
            .critiques
            .iter()
            .position(|c| c.id == id)
            .ok_or(DatasetError::UnknownCritique(id))?;
        let record = self.critiques.remove(pos);
        self.recompute_weights();
        Ok(record)
    }

    /// `m_i = 1 + increments`, summed in critique order, so the result depends only on the records.
    fn recompute_weights(&mut self) {
        self.m.iter_mut().for_each(|m| *m = 1.0);
        if self.critiques.is_empty() {
            return;
        }
        let index: HashMap<Provenance, usize> = self
            .provenance
            .iter()
            .enumerate()
            .map(|(i, p)| (*p, i))
            .collect();
        for c in &self.critiques {
            for (p, inc) in &c.increments {
                if let Some(&i) = index.get(p) {
                    self.m[i] += inc;
                }
            }
        }
    }

    /// Save the dataset atomically ([`crate::files::write_atomic`]): `.json` is the full record
    /// (what `open` reads back), `.csv` the points alone; any other extension is refused, as the
    /// file would not be what its name says. Returns what was written.
    pub fn save(&self, path: &Path) -> Result<SavedFormat, DatasetError> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let format = match ext.as_deref() {
            Some("json") => SavedFormat::Json,
            Some("csv") => SavedFormat::Csv,
            _ => {
                return Err(DatasetError::UnknownFormat {
                    path: path.display().to_string(),
                    stem: path.with_extension("").display().to_string(),
                });
            }
        };
        crate::files::write_atomic(path, |w| match format {
            SavedFormat::Json => serde_json::to_writer(w, &self.to_file()).map_err(Into::into),
            SavedFormat::Csv => self.write_csv(w),
        })?;
        Ok(format)
    }

    /// Points only, for other tools: `provenance`, observation and action columns, `m`.
    pub fn write_csv<W: std::io::Write>(&self, w: W) -> std::io::Result<()> {
        self.write_csv_filtered(w, |_| true)
    }

    /// Advised points only, with their provenance: operator, parameters, chunk, execution.
    pub fn write_advice_csv<W: std::io::Write>(&self, w: W) -> std::io::Result<usize> {
        let mut n = 0;
        self.write_csv_filtered(w, |p| {
            let keep = matches!(p, Provenance::Advice { .. });
            n += keep as usize;
            keep
        })?;
        Ok(n)
    }

    fn write_csv_filtered<W: std::io::Write>(
        &self,
        w: W,
        mut keep: impl FnMut(&Provenance) -> bool,
    ) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        let mut header = vec!["source".to_string(), "detail".to_string()];
        header.extend(self.domain.observe.iter().map(|d| d.name.clone()));
        header.extend(self.domain.act.iter().map(|d| d.name.clone()));
        header.push("m".into());
        out.write_record(&header)?;
        for i in 0..self.len() {
            let p = self.provenance[i];
            if !keep(&p) {
                continue;
            }
            let (source, detail) = match p {
                Provenance::Demonstration { demo, index } => {
                    let name = self
                        .demos
                        .iter()
                        .find(|d| d.id == demo)
                        .map_or("?", |d| d.name.as_str());
                    (format!("demo {demo}"), format!("{name} point {index}"))
                }
                Provenance::Advice {
                    advice,
                    index,
                    source,
                } => {
                    let detail = self.advice.iter().find(|r| r.id == advice).map_or_else(
                        || "?".to_string(),
                        |r| {
                            format!(
                                "{} on {} of execution {}, point {source} (synthesized {index})",
                                r.applied.invocation(),
                                r.applied.chunk,
                                self.execution_number(r.execution).unwrap_or(usize::MAX)
                            )
                        },
                    );
                    (format!("advice {advice}"), detail)
                }
            };
            let mut row = vec![source, detail];
            row.extend(self.z(i).iter().map(|v| fmt_num(*v)));
            row.extend(self.a(i).iter().map(|v| fmt_num(*v)));
            row.push(fmt_num(self.m[i]));
            out.write_record(&row)?;
        }
        out.flush()
    }

    fn to_file(&self) -> DatasetFile {
        DatasetFile {
            format: "advise-dataset-1".into(),
            domain: self.domain.clone(),
            points: (0..self.len())
                .map(|i| FilePoint {
                    z: self.z(i).to_vec(),
                    a: self.a(i).to_vec(),
                    m: self.m[i],
                    provenance: self.provenance[i],
                })
                .collect(),
            demos: self.demos.clone(),
            executions: self.executions.clone(),
            advice: self.advice.clone(),
            critiques: self.critiques.clone(),
            next_id: self.next_id,
        }
    }

    /// The dataset as the JSON text `save` writes.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string(&self.to_file())
            .expect("a dataset's values are finite and its keys strings")
    }

    /// Load a dataset saved as JSON, read into `sources` and validated whole
    /// ([`Dataset::parse`]).
    pub fn load(sources: &mut SourceMap, path: &Path) -> Result<Dataset, DatasetError> {
        crate::files::parse_file(sources, path, Dataset::parse)
    }

    /// [`Dataset::parse`] of a text outside any session (its error brings its own source map).
    pub fn from_json_str(name: &str, text: &str) -> Result<Dataset, Sourced<DatasetError>> {
        let mut sources = SourceMap::new();
        let id = sources.add(name, text);
        Dataset::parse(sources.src(id)).map_err(|e| sources.attach(e))
    }

    /// Whether JSON text is a saved dataset (rather than a trace or demonstrations): its top
    /// level has the `format` key. Malformed JSON counts as a dataset when it names the dataset
    /// format (`"advise-dataset-`), so that its error is the dataset's.
    pub fn is_dataset_json(text: &str) -> bool {
        #[derive(Deserialize)]
        struct Probe {
            format: Option<serde::de::IgnoredAny>,
        }
        match serde_json::from_str::<Probe>(text) {
            Ok(p) => p.format.is_some(),
            Err(_) => text.contains("\"advise-dataset-"),
        }
    }

    /// Parse and validate a saved dataset; the first problem found is the error. A dataset that
    /// loads is one the session could have built: every id unique and below `next_id`, every
    /// reference resolved, every point of the domain's shape and finite, every action within its
    /// limits, and
    /// the weights what the critiques say.
    pub fn parse(src: Src<'_>) -> Result<Dataset, DatasetError> {
        let text = src.text;
        let file: DatasetFile = serde_json::from_str(text).map_err(|e| {
            let span = locate::line_col(text, e.line(), e.column());
            let message = e.to_string();
            // NaN and infinity were saved as `null` by earlier versions.
            if message.starts_with("invalid type: null, expected f64") {
                // serde points after the value; cover the `null` itself.
                let end = span.start;
                let start = text[..end].rfind("null").filter(|s| s + 4 >= end);
                let span = start.map_or(span, |s| s..s + 4);
                DatasetError::Null { at: src.at(span) }
            } else {
                DatasetError::Json {
                    message,
                    at: src.at(span),
                }
            }
        })?;
        if file.format != "advise-dataset-1" {
            return Err(DatasetError::Inconsistent {
                what: format!("unknown format `{}`", file.format),
            });
        }
        validate(&file)?;
        let mut d = Dataset::new(&file.domain);
        for p in &file.points {
            d.z.extend_from_slice(&p.z);
            d.a.extend_from_slice(&p.a);
            d.provenance.push(p.provenance);
            d.m.push(p.m);
        }
        d.demos = file.demos;
        d.executions = file.executions;
        d.advice = file.advice;
        d.critiques = file.critiques;
        d.next_id = file.next_id;
        // The stored weights must be what the critique records say.
        let stored = d.m.clone();
        d.recompute_weights();
        if stored != d.m {
            return Err(DatasetError::Inconsistent {
                what: "the weights do not match the critique records".into(),
            });
        }
        Ok(d)
    }

    /// The training data as demonstrations: each demonstration, and each piece of advice's
    /// points, becomes one episode named after where it came from (`NAME demo 3 (teacher-0)`,
    /// `NAME advice 7 (slow_down on 40..70)`). Critique weights are not carried (a
    /// demonstration's points weigh 1); executions are not training data and are left out. Point
    /// times are their index in the episode, in seconds, as the dataset keeps no times.
    pub fn to_episodes(&self, name: &str) -> Vec<Episode> {
        let mut order: Vec<(Provenance, Vec<usize>)> = Vec::new();
        let mut slot: HashMap<(bool, u32), usize> = HashMap::new();
        for i in 0..self.len() {
            let key = match self.provenance[i] {
                Provenance::Demonstration { demo, .. } => (true, demo),
                Provenance::Advice { advice, .. } => (false, advice),
            };
            let k = *slot.entry(key).or_insert_with(|| {
                order.push((self.provenance[i], Vec::new()));
                order.len() - 1
            });
            order[k].1.push(i);
        }
        order
            .into_iter()
            .map(|(p, points)| {
                let label = match p {
                    Provenance::Demonstration { demo, .. } => {
                        let d = self.demos.iter().find(|d| d.id == demo);
                        format!(
                            "{name} demo {demo} ({})",
                            d.map_or("?", |d| d.name.as_str())
                        )
                    }
                    Provenance::Advice { advice, .. } => {
                        let r = self.advice.iter().find(|r| r.id == advice);
                        format!(
                            "{name} advice {advice} ({})",
                            r.map_or_else(
                                || "?".to_string(),
                                |r| format!("{} on {}", r.applied.invocation(), r.applied.chunk)
                            )
                        )
                    }
                };
                let mut trace = Trace::new(&self.domain);
                for (k, &i) in points.iter().enumerate() {
                    trace.push(k as f64, self.z(i), self.a(i), None);
                }
                Episode { name: label, trace }
            })
            .collect()
    }
}

/// Demonstrations read from a file, and whether the file was a saved dataset.
#[derive(Clone, Debug)]
pub struct Demonstrations {
    pub episodes: Vec<Episode>,
    /// For a saved dataset: how many of the episodes were its demonstrations and how many its
    /// advice.
    pub from_dataset: Option<(usize, usize)>,
}

/// Read demonstrations for `domain` from any file that holds them: a demonstrations file (CSV
/// or JSON, [`Episode`]) or a dataset saved by a session ([`Dataset::to_episodes`]).
pub fn load_demonstrations(
    sources: &mut SourceMap,
    domain: &Domain,
    path: &Path,
) -> Result<Demonstrations, DatasetError> {
    crate::files::parse_file(sources, path, |src| {
        let name = path.display().to_string();
        let is_json = crate::trace::is_json(path);
        if is_json && Dataset::is_dataset_json(src.text) {
            let ds = Dataset::parse(src)?;
            if ds.domain() != domain {
                return Err(crate::trace::TraceError::DomainMismatch {
                    expected: domain.name.clone(),
                    found: ds.domain().name.clone(),
                }
                .into());
            }
            let from = (ds.demos().len(), ds.advice().len());
            return Ok(Demonstrations {
                episodes: ds.to_episodes(&name),
                from_dataset: Some(from),
            });
        }
        let episodes = if is_json {
            Episode::parse_json(domain, src)?
        } else {
            Episode::parse_csv(domain, src)?
        };
        Ok(Demonstrations {
            episodes,
            from_dataset: None,
        })
    })
}

/// What [`Dataset::save`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SavedFormat {
    /// The full record, which `open` reads back.
    Json,
    /// The points alone, for other tools.
    Csv,
}

impl SavedFormat {
    /// In words, for the session's reply.
    pub fn describe(self) -> &'static str {
        match self {
            SavedFormat::Json => "JSON, with provenance; `open` reads it back",
            SavedFormat::Csv => "CSV, points only; it cannot be opened again",
        }
    }
}

/// Every check of a dataset file but the weights, in file order; the first problem is returned.
fn validate(file: &DatasetFile) -> Result<(), DatasetError> {
    let domain = &file.domain;
    let expected = || {
        let names = |dims: &[crate::domain::Dim]| {
            dims.iter()
                .map(|d| d.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        format!(
            "observation [{}], action [{}]",
            names(&domain.observe),
            names(&domain.act)
        )
    };
    if domain.observe.is_empty() || domain.act.is_empty() {
        return Err(DatasetError::Dimension {
            at: "domain".into(),
            what: "the domain needs at least one observation and one action dimension".into(),
            expected: expected(),
        });
    }
    let values = |at: &str, z: &[f64], a: &[f64]| -> Result<(), DatasetError> {
        for (space, vals, dims) in [("z", z, &domain.observe), ("a", a, &domain.act)] {
            if vals.len() != dims.len() {
                return Err(DatasetError::Dimension {
                    at: format!("{at}.{space}"),
                    what: format!("{} values where the domain has {}", vals.len(), dims.len()),
                    expected: expected(),
                });
            }
            for (k, (v, dim)) in vals.iter().zip(dims.iter()).enumerate() {
                let at = || format!("{at}.{space}[{k}]");
                if !v.is_finite() {
                    return Err(DatasetError::NotFinite {
                        at: at(),
                        value: v.to_string(),
                    });
                }
                // Actions are clamped to their limits wherever they enter a dataset (recorded
                // runs, operators, demonstration files); observations are what the robot saw,
                // and may lie beyond (a goal 20 m away).
                if let (true, Some(l)) = (space == "a", dim.limits)
                    && !l.contains(*v)
                {
                    return Err(DatasetError::OutOfLimits {
                        at: at(),
                        value: fmt_num(*v),
                        dim: dim.name.clone(),
                        lo: fmt_num(l.lo),
                        hi: fmt_num(l.hi),
                    });
                }
            }
        }
        Ok(())
    };
    let finite = |at: String, v: f64| {
        if v.is_finite() {
            Ok(())
        } else {
            Err(DatasetError::NotFinite {
                at,
                value: v.to_string(),
            })
        }
    };

    // One sequence of ids for every kind of record.
    let mut owner: HashMap<u32, String> = HashMap::new();
    let mut max_id = 0;
    let records = file
        .demos
        .iter()
        .enumerate()
        .map(|(i, r)| (r.id, format!("demos[{i}]")))
        .chain(
            file.executions
                .iter()
                .enumerate()
                .map(|(i, r)| (r.id, format!("executions[{i}]"))),
        )
        .chain(
            file.advice
                .iter()
                .enumerate()
                .map(|(i, r)| (r.id, format!("advice[{i}]"))),
        )
        .chain(
            file.critiques
                .iter()
                .enumerate()
                .map(|(i, r)| (r.id, format!("critiques[{i}]"))),
        );
    for (id, at) in records {
        if let Some(first) = owner.get(&id) {
            return Err(DatasetError::DuplicateId {
                id,
                first: first.clone(),
                second: at,
            });
        }
        max_id = max_id.max(id);
        owner.insert(id, at);
    }
    if file.next_id < max_id {
        return Err(DatasetError::NextId {
            next_id: file.next_id,
            max_id,
        });
    }

    let executions: HashMap<u32, &ExecutionRecord> =
        file.executions.iter().map(|e| (e.id, e)).collect();
    for (i, e) in file.executions.iter().enumerate() {
        for (j, p) in e.points.iter().enumerate() {
            let at = format!("executions[{i}].points[{j}]");
            // Executions are what the base recorded; they are checked for shape, not limits
            // (an observation beyond a limit is a fact of the run).
            for (space, vals, n) in [("z", &p.z, domain.obs_dim()), ("a", &p.a, domain.act_dim())] {
                if vals.len() != n {
                    return Err(DatasetError::Dimension {
                        at: format!("{at}.{space}"),
                        what: format!("{} values where the domain has {n}", vals.len()),
                        expected: expected(),
                    });
                }
            }
            let all = std::iter::once(p.t)
                .chain(p.z.iter().copied())
                .chain(p.a.iter().copied())
                .chain(p.pose.into_iter().flatten());
            for v in all {
                finite(at.clone(), v)?;
            }
            if (p.pose.is_some()) != e.points[0].pose.is_some() {
                return Err(DatasetError::Record {
                    at,
                    what: "some points of the execution have a `pose` and others do not".into(),
                });
            }
        }
    }
    let exec_len = |at: String, id: u32| -> Result<usize, DatasetError> {
        executions
            .get(&id)
            .map(|e| e.points.len())
            .ok_or(DatasetError::Dangling {
                at,
                what: "execution",
                id,
            })
    };
    let mut advice_points: HashMap<u32, u32> = HashMap::new();
    for (i, r) in file.advice.iter().enumerate() {
        let len = exec_len(format!("advice[{i}].execution"), r.execution)?;
        let c = r.applied.chunk;
        if c.start > c.end || c.end > len {
            return Err(DatasetError::Record {
                at: format!("advice[{i}].applied.chunk"),
                what: format!(
                    "the chunk {c} is not within execution {} ({len} points)",
                    r.execution
                ),
            });
        }
        for (k, p) in r.applied.params.iter().enumerate() {
            finite(format!("advice[{i}].applied.params[{k}].value"), p.value)?;
        }
        if r.applied.domain != domain.name {
            return Err(DatasetError::Record {
                at: format!("advice[{i}].applied.domain"),
                what: format!(
                    "the advice is for the `{}` domain, the dataset is `{}`",
                    r.applied.domain, domain.name
                ),
            });
        }
        advice_points.insert(r.id, 0);
    }
    for (i, c) in file.critiques.iter().enumerate() {
        let len = exec_len(format!("critiques[{i}].execution"), c.execution)?;
        if c.chunk.start > c.chunk.end || c.chunk.end > len {
            return Err(DatasetError::Record {
                at: format!("critiques[{i}].chunk"),
                what: format!(
                    "the chunk {} is not within execution {} ({len} points)",
                    c.chunk, c.execution
                ),
            });
        }
        finite(format!("critiques[{i}].kappa"), c.kappa)?;
        for (k, (_, inc)) in c.increments.iter().enumerate() {
            finite(format!("critiques[{i}].increments[{k}]"), *inc)?;
        }
    }

    let mut demo_points: HashMap<u32, u32> = file.demos.iter().map(|d| (d.id, 0)).collect();
    let mut seen: HashMap<Provenance, usize> = HashMap::new();
    for (i, p) in file.points.iter().enumerate() {
        let at = format!("points[{i}]");
        values(&at, &p.z, &p.a)?;
        if !(p.m.is_finite() && p.m >= 1.0) {
            return Err(DatasetError::Record {
                at: format!("{at}.m"),
                what: format!("the weight is {}; weights are finite and at least 1", p.m),
            });
        }
        let (count, what, id) = match p.provenance {
            Provenance::Demonstration { demo, .. } => {
                (demo_points.get_mut(&demo), "demonstration", demo)
            }
            Provenance::Advice { advice, .. } => (advice_points.get_mut(&advice), "advice", advice),
        };
        match count {
            Some(n) => *n += 1,
            None => {
                return Err(DatasetError::Dangling {
                    at: format!("{at}.provenance"),
                    what,
                    id,
                });
            }
        }
        if let Some(first) = seen.insert(p.provenance, i) {
            return Err(DatasetError::Record {
                at: format!("{at}.provenance"),
                what: format!("points {first} and {i} have the same provenance"),
            });
        }
    }
    for (i, d) in file.demos.iter().enumerate() {
        let n = demo_points.get(&d.id).copied().unwrap_or(0);
        if n != d.points {
            return Err(DatasetError::Record {
                at: format!("demos[{i}].points"),
                what: format!(
                    "demonstration {} says it has {} points; the file holds {n}",
                    d.id, d.points
                ),
            });
        }
    }
    Ok(())
}

/// Refuse a trace with a value that is not finite (a point that cannot be saved as JSON, and
/// that would poison every distance it enters).
fn check_finite(trace: &Trace, what: impl Fn() -> String) -> Result<(), DatasetError> {
    for i in 0..trace.len() {
        if let Some(v) = trace.z(i).iter().chain(trace.a(i)).find(|v| !v.is_finite()) {
            return Err(DatasetError::NonFinite {
                what: format!("{} has {v} at point {i}", what()),
            });
        }
    }
    Ok(())
}

/// The JSON file of a dataset.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DatasetFile {
    format: String,
    domain: Domain,
    points: Vec<FilePoint>,
    demos: Vec<DemoRecord>,
    executions: Vec<ExecutionRecord>,
    advice: Vec<AdviceRecord>,
    critiques: Vec<CritiqueRecord>,
    next_id: u32,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePoint {
    z: Vec<f64>,
    a: Vec<f64>,
    m: f64,
    provenance: Provenance,
}
