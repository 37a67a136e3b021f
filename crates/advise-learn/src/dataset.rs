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
//! and [`Dataset::load`], both through [`advise_lang::files`]; a loaded file is validated whole.

use std::collections::HashMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use advise_lang::diag::{Loc, SourceMap, Sourced, Src, locate};
use advise_lang::domain::Domain;
use advise_lang::interp::AppliedAdvice;
use advise_lang::number::fmt_num;
use advise_lang::trace::{Chunk, Episode, JsonPoint, Trace};

mod error;
mod file;

pub use error::DatasetError;
pub use file::{
    Demonstrations, MAX_STREAM_POINTS, STREAM_CSV_BYTES, SavedFormat, load_demonstrations,
    load_demonstrations_with,
};

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
    /// The time between points, s, for a demonstration recorded at a steady rate (a teacher's
    /// in the simulator: 1/15 s for positioning). Absent in files written before datasets kept
    /// times, and when `times_s` holds the times instead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f64>,
    /// Each point's time since the first, s, for a demonstration whose points are not evenly
    /// spaced (a recording's log times). Absent with `period_s`, and in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub times_s: Option<Vec<f64>>,
    /// For a demonstration a teacher gave by taking over a run: which execution and which of its
    /// steps. Absent for every other demonstration, and in files written before takeovers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub takeover: Option<TakeoverLink>,
}

/// Where a demonstration given by taking over a run came from: the teacher drove steps
/// `steps` of execution `execution`, and the demonstration keeps every `every`-th of them from
/// the first (its point `k` is the execution's step `steps.start + k * every`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TakeoverLink {
    pub execution: ExecutionId,
    pub steps: Chunk,
    pub every: u32,
}

impl TakeoverLink {
    /// The execution step demonstration point `k` was recorded at.
    pub fn step(&self, k: u32) -> u64 {
        self.steps.start as u64 + u64::from(k) * u64::from(self.every.max(1))
    }

    /// How many points a demonstration of these steps holds.
    pub fn points(&self) -> usize {
        self.steps.len().div_ceil(self.every.max(1) as usize)
    }
}

/// When a demonstration's points were recorded, relative to its first point: what
/// [`DemoRecord`] keeps (`period_s` or `times_s`), found from a trace's times by
/// [`DemoTimes::of`]. A trace whose times do not advance, or are its points' numbers (0, 1, 2, ...
/// s: how a file without times is read, older saved datasets among them), has none.
#[derive(Clone, Debug, PartialEq)]
pub enum DemoTimes {
    /// Evenly spaced, this far apart, s.
    Period(f64),
    /// Each point's time since the first, s (non-decreasing, the first 0).
    Each(Vec<f64>),
}

impl DemoTimes {
    /// The times of a trace's points `t`: a period when every point is within a microsecond of
    /// an even spacing, else each time; `None` when they do not advance, are not finite, or are
    /// the points' numbers ([`DemoTimes::trace_times`] of none).
    pub fn of(t: &[f64]) -> Option<DemoTimes> {
        let (&first, &last) = (t.first()?, t.last()?);
        let span = last - first;
        let steady = t.windows(2).all(|w| w[1] >= w[0]);
        let numbered = t.iter().enumerate().all(|(k, &v)| v == k as f64);
        if t.len() < 2 || !span.is_finite() || span <= 0.0 || !steady || numbered {
            return None;
        }
        let period = span / (t.len() - 1) as f64;
        let even = t
            .iter()
            .enumerate()
            .all(|(k, &v)| (v - first - k as f64 * period).abs() <= 1e-6);
        Some(if even {
            DemoTimes::Period(period)
        } else {
            DemoTimes::Each(t.iter().map(|v| v - first).collect())
        })
    }

    /// Point `k`'s time since the first, s.
    pub fn time_s(&self, k: usize) -> f64 {
        match self {
            DemoTimes::Period(p) => k as f64 * p,
            DemoTimes::Each(t) => t.get(k).or(t.last()).copied().unwrap_or(0.0),
        }
    }

    /// The rate, Hz: the period's, or for uneven times that of the median spacing (a
    /// recording's jitter does not move it).
    pub fn rate_hz(&self) -> f64 {
        match self {
            DemoTimes::Period(p) => 1.0 / p,
            DemoTimes::Each(t) => {
                let mut gaps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
                gaps.sort_unstable_by(f64::total_cmp);
                let median = gaps.get(gaps.len() / 2).copied().unwrap_or(0.0);
                if median > 0.0 {
                    1.0 / median
                } else {
                    (t.len().saturating_sub(1)) as f64 / t.last().copied().unwrap_or(1.0)
                }
            }
        }
    }

    /// `(period_s, times_s)` as a [`DemoRecord`] keeps them.
    pub fn fields(times: Option<DemoTimes>) -> (Option<f64>, Option<Vec<f64>>) {
        match times {
            Some(DemoTimes::Period(p)) => (Some(p), None),
            Some(DemoTimes::Each(t)) => (None, Some(t)),
            None => (None, None),
        }
    }

    /// The times kept as `(period_s, times_s)`, if any.
    pub fn from_fields(period_s: Option<f64>, times_s: Option<&Vec<f64>>) -> Option<DemoTimes> {
        match (period_s, times_s) {
            (Some(p), _) => Some(DemoTimes::Period(p)),
            (None, Some(t)) => Some(DemoTimes::Each(t.clone())),
            (None, None) => None,
        }
    }

    /// `n` points' times, from 0, for a trace: without times, the points' numbers (0, 1, 2, ...
    /// s), which [`DemoTimes::of`] reads back as none.
    pub fn trace_times(times: Option<&DemoTimes>, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| times.map_or(k as f64, |t| t.time_s(k)))
            .collect()
    }
}

impl DemoRecord {
    /// When its points were recorded, if the dataset knows ([`DemoTimes`]).
    pub fn times(&self) -> Option<DemoTimes> {
        DemoTimes::from_fields(self.period_s, self.times_s.as_ref())
    }
}

/// An execution that advice or critique was given on, kept whole so advice can be re-synthesized.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutionRecord {
    pub id: ExecutionId,
    /// The goal the run was given, a value for each of the task's goal parameters (x, y, theta
    /// for positioning), so that an opened dataset's runs keep their goals (plots draw them).
    /// Absent for a trace loaded from a file, an interception run, and in files written before
    /// goals were kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<Vec<f64>>,
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

/// A critique: the flagged chunk, kappa, the weight increments it made and the rule they follow.
///
/// The one shape of a critique: the session's journal effect and undo edit carry it, the learner
/// makes it ([`crate::learner::Learner::add_critique`]) and the dataset keeps it in a
/// [`CritiqueRecord`]. Its JSON fields are those of the journal's `critique` line and of a dataset
/// file's critique (both flatten it beside their own fields).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Critique {
    pub chunk: Chunk,
    pub kappa: f64,
    /// (point, increment of its m), in the order they were applied.
    pub increments: Vec<(Provenance, f64)>,
    /// The directional rule ([`CritiqueRule::Directional`]): each increment penalises its point
    /// only for queries from the side of the observation that was flagged. Absent in files and
    /// journals written before the rule existed (the paper's rule).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub directional: bool,
    /// With `directional`, the flagged observation (raw, unscaled) of each increment, in the same
    /// order: the direction is recomputed under the current range scaling after a `rederive`.
    /// Without it, ignored (and kept empty by [`Dataset::add_critique`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flagged: Vec<Vec<f64>>,
}

impl Critique {
    /// A critique under the paper's rule.
    pub fn paper(chunk: Chunk, kappa: f64, increments: Vec<(Provenance, f64)>) -> Self {
        Critique {
            chunk,
            kappa,
            increments,
            directional: false,
            flagged: Vec::new(),
        }
    }

    /// A critique under the directional rule: `flagged` holds the flagged observation (raw) of
    /// each increment, in order.
    pub fn directional(
        chunk: Chunk,
        kappa: f64,
        increments: Vec<(Provenance, f64)>,
        flagged: Vec<Vec<f64>>,
    ) -> Self {
        Critique {
            chunk,
            kappa,
            increments,
            directional: true,
            flagged,
        }
    }
}

/// A critique as the dataset keeps it: its id and the execution it flagged, beside the critique.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CritiqueRecord {
    pub id: CritiqueId,
    pub execution: ExecutionId,
    #[serde(flatten)]
    pub critique: Critique,
}

/// How a critique's increments weigh a data point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CritiqueRule {
    /// The paper's: `m_i += kappa / d` whatever direction the point is later queried from.
    #[default]
    Paper,
    /// The paper's proposed improvement: the increment counts in full for queries from the
    /// flagged observation's side, scaled by the cosine of the angle between the query's and the
    /// flagged observation's directions from the point, and not at all from the other half-space
    /// ([`crate::bc`] has the rule).
    Directional,
}

impl CritiqueRule {
    /// The rule's name as the session and the experiment print it.
    pub fn name(self) -> &'static str {
        match self {
            CritiqueRule::Paper => "paper",
            CritiqueRule::Directional => "directional",
        }
    }

    /// The rule as a reply, a figure or a progress message names it: "paper's rule".
    pub fn label(self) -> &'static str {
        match self {
            CritiqueRule::Paper => "paper's rule",
            CritiqueRule::Directional => "directional rule",
        }
    }
}

/// The directional penalties of every point, laid out for the BC query: point `i`'s are entries
/// `start[i]..start[i + 1]`, each an increment and the flagged observation it came from (raw, a
/// row of `z`). Most points have none, which costs the query one comparison.
#[derive(Clone, Debug, PartialEq)]
struct DirectionalPenalties {
    /// `len + 1` offsets into `inc`; empty while no point has a directional increment (what
    /// costs nothing per point).
    start: Vec<u32>,
    inc: Vec<f64>,
    /// Flagged observations, `inc.len() * obs_dim`, row after row.
    z: Vec<f64>,
}

impl DirectionalPenalties {
    fn new() -> DirectionalPenalties {
        DirectionalPenalties {
            start: Vec::new(),
            inc: Vec::new(),
            z: Vec::new(),
        }
    }
}

/// Consecutive points from one source: from point `start` up to the next run's start (or the
/// end), points `first_index`, `first_index + 1`, ... of demonstration or advice `id`. An
/// advice's points keep their source points in [`Dataset::sources`] from `source_at` on. A
/// session's dataset holds one run per demonstration and per piece of advice, whatever their
/// size; a dataset file's points may come in any order, and then take more runs.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Run {
    start: u32,
    id: u32,
    first_index: u32,
    advice: bool,
    source_at: u32,
}

/// Points with provenance and weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    domain: Domain,
    /// Observations, `len * obs_dim`, row after row.
    z: Vec<f64>,
    /// Actions, `len * act_dim`.
    a: Vec<f64>,
    /// How many points.
    len: usize,
    /// The points' provenance, as runs in point order.
    runs: Vec<Run>,
    /// The source point of each advice point, run after run.
    sources: Vec<u32>,
    /// BC weight `m_i >= 1` of each point: 1 plus the paper's (isotropic) increments; empty
    /// while every weight is 1 (no critique under the paper's rule reaches a point), which costs
    /// nothing per point.
    m: Vec<f64>,
    /// The directional critiques' increments by point (derived from the records, like `m`).
    directional: DirectionalPenalties,
    demos: Vec<DemoRecord>,
    executions: Vec<ExecutionRecord>,
    advice: Vec<AdviceRecord>,
    critiques: Vec<CritiqueRecord>,
    next_id: u32,
}

impl Dataset {
    pub fn new(domain: &Domain) -> Dataset {
        Dataset {
            domain: domain.clone(),
            z: Vec::new(),
            a: Vec::new(),
            len: 0,
            runs: Vec::new(),
            sources: Vec::new(),
            m: Vec::new(),
            directional: DirectionalPenalties::new(),
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
        (1..=crate::index::MAX_DIM).contains(&self.domain.obs_dim())
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Room for `points` more points without growing the arrays again (exactly: a large load
    /// reserves once, so the arrays hold no doubling slack).
    pub fn reserve(&mut self, points: usize) {
        self.z.reserve_exact(points * self.domain.obs_dim());
        self.a.reserve_exact(points * self.domain.act_dim());
    }

    /// The bytes the dataset's points and their bookkeeping hold (records of advice, critiques
    /// and executions aside): what the scale benchmark reports.
    pub fn held_bytes(&self) -> usize {
        (self.z.capacity() + self.a.capacity() + self.m.capacity()) * 8
            + self.runs.capacity() * std::mem::size_of::<Run>()
            + self.sources.capacity() * 4
            + (self.directional.start.capacity() + self.directional.inc.capacity() * 2) * 8
            + self.directional.z.capacity() * 8
    }

    /// Every point's observation and action, as the index refers to them.
    #[inline]
    pub fn points(&self) -> crate::index::Points<'_> {
        crate::index::Points {
            z: &self.z,
            a: &self.a,
        }
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
        if self.m.is_empty() { 1.0 } else { self.m[i] }
    }

    /// The isotropic weights `m_i` (the paper's rule) of every point, in a vector of their own
    /// (the dataset keeps none while all are 1); directional increments are apart
    /// ([`Dataset::directional`]).
    pub fn weights(&self) -> Vec<f64> {
        (0..self.len).map(|i| self.m(i)).collect()
    }

    /// Point `i`'s directional increments and, row after row, the flagged observation (raw) each
    /// came from; empty for most points.
    #[inline]
    pub fn directional(&self, i: usize) -> (&[f64], &[f64]) {
        let d = self.domain.obs_dim();
        let p = &self.directional;
        if p.start.is_empty() {
            return (&[], &[]);
        }
        let (a, b) = (p.start[i] as usize, p.start[i + 1] as usize);
        (&p.inc[a..b], &p.z[a * d..b * d])
    }

    /// Whether any point has a directional increment.
    pub fn has_directional(&self) -> bool {
        !self.directional.inc.is_empty()
    }

    /// The largest weight point `i` can have: `m_i` plus all its directional increments (what a
    /// query from exactly a flagged direction meets).
    pub fn max_weight(&self, i: usize) -> f64 {
        self.directional(i)
            .0
            .iter()
            .fold(self.m(i), |m, inc| m + inc)
    }

    pub fn provenance(&self, i: usize) -> Provenance {
        let r = self.runs.partition_point(|r| r.start as usize <= i) - 1;
        let run = &self.runs[r];
        let k = (i - run.start as usize) as u32;
        if run.advice {
            Provenance::Advice {
                advice: run.id,
                index: run.first_index + k,
                source: self.sources[(run.source_at + k) as usize],
            }
        } else {
            Provenance::Demonstration {
                demo: run.id,
                index: run.first_index + k,
            }
        }
    }

    /// Where the point of provenance `p` is, if it is still in the dataset (provenance survives
    /// removals; positions do not). The runs of a session's dataset are in the order of their
    /// ids, so this is a binary search; a file's points in another order are searched run by run.
    pub fn position(&self, p: Provenance) -> Option<usize> {
        self.position_in(p, self.runs_in_id_order())
    }

    /// [`Dataset::position`], told whether the runs are in id order.
    fn position_in(&self, p: Provenance, in_id_order: bool) -> Option<usize> {
        let (id, index, advice) = match p {
            Provenance::Demonstration { demo, index } => (demo, index, false),
            Provenance::Advice { advice, index, .. } => (advice, index, true),
        };
        let found = |r: usize| -> Option<usize> {
            let run = &self.runs[r];
            let len = self.run_len(r) as u32;
            if run.id != id || run.advice != advice || index < run.first_index {
                return None;
            }
            let k = index - run.first_index;
            (k < len).then_some(run.start as usize + k as usize)
        };
        let at = if in_id_order {
            let r = self
                .runs
                .partition_point(|r| (r.id, r.first_index) <= (id, index));
            r.checked_sub(1).and_then(found)
        } else {
            (0..self.runs.len()).find_map(found)
        };
        at.filter(|&i| self.provenance(i) == p)
    }

    /// Whether each run's (id, first index) is after the one before: a binary search finds a
    /// provenance.
    fn runs_in_id_order(&self) -> bool {
        self.runs
            .windows(2)
            .all(|w| (w[0].id, w[0].first_index) < (w[1].id, w[1].first_index))
    }

    /// The number of points of run `r`.
    fn run_len(&self, r: usize) -> usize {
        let end = self.runs.get(r + 1).map_or(self.len, |n| n.start as usize);
        end - self.runs[r].start as usize
    }

    /// Append point `(z, a)` of provenance `p`, continuing the last run where it can.
    fn push_point(&mut self, z: &[f64], a: &[f64], p: Provenance) {
        self.z.extend_from_slice(z);
        self.a.extend_from_slice(a);
        let (id, index, advice, source) = match p {
            Provenance::Demonstration { demo, index } => (demo, index, false, None),
            Provenance::Advice {
                advice,
                index,
                source,
            } => (advice, index, true, Some(source)),
        };
        let last = self.runs.len().checked_sub(1);
        let continues = last.is_some_and(|r| {
            let run = &self.runs[r];
            run.id == id
                && run.advice == advice
                && u64::from(run.first_index) + self.run_len(r) as u64 == u64::from(index)
        });
        if !continues {
            self.runs.push(Run {
                start: self.len as u32,
                id,
                first_index: index,
                advice,
                source_at: self.sources.len() as u32,
            });
        }
        if let Some(s) = source {
            self.sources.push(s);
        }
        self.len += 1;
        // A new point weighs 1 and has no directional increment; only kept arrays grow.
        if !self.m.is_empty() {
            self.m.push(1.0);
        }
        if let Some(&last) = self.directional.start.last() {
            self.directional.start.push(last);
        }
    }

    pub fn demos(&self) -> &[DemoRecord] {
        &self.demos
    }

    pub fn advice(&self) -> &[AdviceRecord] {
        &self.advice
    }

    /// The executions advice or critique was given on, in the order they were added.
    pub fn executions(&self) -> &[ExecutionRecord] {
        &self.executions
    }

    pub fn critiques(&self) -> &[CritiqueRecord] {
        &self.critiques
    }

    /// The next id, or an error when the id space is used up (a file's `next_id` edited to the
    /// top of the range): ids never wrap, as a reused id would make `undo` remove other points.
    fn fresh_id(&mut self) -> Result<u32, DatasetError> {
        self.next_id = next_id_after(self.next_id)?;
        Ok(self.next_id)
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

    /// Add a demonstration; its points are appended in order.
    pub fn add_demonstration(&mut self, name: &str, trace: &Trace) -> Result<DemoId, DatasetError> {
        self.add_demonstration_linked(name, trace, None)
    }

    /// Add the demonstration a teacher gave by taking over execution `link.execution` (its steps
    /// `link.steps`, every `link.every`-th kept): refused unless the execution is held, the steps
    /// are within it and the trace holds as many points as the link says.
    pub fn add_takeover(
        &mut self,
        name: &str,
        trace: &Trace,
        link: TakeoverLink,
    ) -> Result<DemoId, DatasetError> {
        check_takeover(
            &link,
            self.execution_len(link.execution)?,
            trace.len(),
            || "takeover".into(),
        )?;
        self.add_demonstration_linked(name, trace, Some(link))
    }

    /// Remove demonstration `id` and exactly its points (a takeover's, undone).
    pub fn remove_demonstration(&mut self, id: DemoId) -> Result<DemoRecord, DatasetError> {
        let pos = self
            .demos
            .iter()
            .position(|r| r.id == id)
            .ok_or(DatasetError::UnknownDemonstration(id))?;
        let record = self.demos.remove(pos);
        self.remove_points_of(id, false);
        self.recompute_weights();
        Ok(record)
    }

    fn add_demonstration_linked(
        &mut self,
        name: &str,
        trace: &Trace,
        takeover: Option<TakeoverLink>,
    ) -> Result<DemoId, DatasetError> {
        self.check(trace)?;
        check_finite(trace, || format!("demonstration `{name}`"))?;
        for i in 0..trace.len() {
            check_point(&self.domain, trace.z(i), trace.a(i), |s, k| {
                format!("demonstration {name}, point {i}, {s}[{k}]")
            })?;
        }
        let id = self.fresh_id()?;
        for i in 0..trace.len() {
            self.push_point(
                trace.z(i),
                trace.a(i),
                Provenance::Demonstration {
                    demo: id,
                    index: i as u32,
                },
            );
        }
        let (period_s, times_s) = DemoTimes::fields(DemoTimes::of(&trace.t));
        self.demos.push(DemoRecord {
            id,
            name: name.to_string(),
            points: trace.len() as u32,
            period_s,
            times_s,
            takeover,
        });
        Ok(id)
    }

    /// Keep an execution that advice or critique may refer to (its points are not training data).
    pub fn add_execution(&mut self, trace: &Trace) -> Result<ExecutionId, DatasetError> {
        self.check(trace)?;
        let id = self.fresh_id()?;
        self.executions.push(ExecutionRecord {
            id,
            goal: None,
            points: trace.to_json().points,
        });
        Ok(id)
    }

    /// Record the goal execution `id` was run to (see [`ExecutionRecord::goal`]); values that
    /// are not all finite are refused.
    pub fn set_execution_goal(
        &mut self,
        id: ExecutionId,
        goal: Vec<f64>,
    ) -> Result<(), DatasetError> {
        for &v in &goal {
            check_finite_value(v, || format!("the goal of execution {id}"))?;
        }
        let rec = self
            .executions
            .iter_mut()
            .find(|e| e.id == id)
            .ok_or(DatasetError::UnknownExecution(id))?;
        rec.goal = Some(goal);
        Ok(())
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
                p.pose
                    .map(|[x, y, th]| advise_lang::trace::Pose::new(x, y, th))
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
        let len = self.execution_len(execution)?;
        check_advice(&self.domain, &applied, execution, len, "advice")?;
        check_finite(points, || format!("advice `{}`", applied.operator))?;
        for j in 0..points.len() {
            check_point(&self.domain, points.z(j), points.a(j), |s, k| {
                format!("advice {}, point {j}, {s}[{k}]", applied.invocation())
            })?;
        }
        if source.len() != points.len() || source.iter().any(|i| !applied.chunk.range().contains(i))
        {
            return Err(DatasetError::Record {
                at: "advice.source_index".into(),
                what: format!(
                    "{} source points for {} synthesized points, each within the chunk {}",
                    source.len(),
                    points.len(),
                    applied.chunk
                ),
            });
        }
        let id = self.fresh_id()?;
        for j in 0..points.len() {
            self.push_point(
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
        self.remove_points_of(id, true);
        self.recompute_weights();
        Ok(record)
    }

    /// Remove every point of demonstration or advice `id` (its runs) and their rows.
    fn remove_points_of(&mut self, id: u32, advice: bool) {
        let (od, ad) = (self.domain.obs_dim(), self.domain.act_dim());
        let mut r = 0;
        while r < self.runs.len() {
            let run = self.runs[r];
            if run.id != id || run.advice != advice {
                r += 1;
                continue;
            }
            let (start, n) = (run.start as usize, self.run_len(r));
            self.z.drain(start * od..(start + n) * od);
            self.a.drain(start * ad..(start + n) * ad);
            let sources = if advice { n } else { 0 };
            let at = run.source_at as usize;
            self.sources.drain(at..at + sources);
            self.len -= n;
            self.runs.remove(r);
            for later in &mut self.runs[r..] {
                later.start -= n as u32;
                later.source_at -= sources as u32;
            }
        }
    }

    /// Record a critique of execution `execution` and make its increments: each applies to the
    /// point of that provenance if it is still in the dataset. The weights are recomputed from the
    /// records in critique order, so a critique made, redone or restored from the journal gives bit
    /// for bit the same weights. A critique under the paper's rule keeps no flagged observations.
    pub fn add_critique(
        &mut self,
        execution: ExecutionId,
        mut critique: Critique,
    ) -> Result<CritiqueId, DatasetError> {
        let len = self.execution_len(execution)?;
        check_chunk(critique.chunk, execution, len, || "critique.chunk".into())?;
        check_finite_value(critique.kappa, || "critique.kappa".into())?;
        if let Some((p, inc)) = critique
            .increments
            .iter()
            .find(|(_, inc)| !(inc.is_finite() && *inc >= 0.0))
        {
            return Err(DatasetError::NonFinite {
                what: format!("the critique's increment for {p:?} is {inc}"),
            });
        }
        if critique.directional {
            self.check_flagged(&critique.increments, &critique.flagged)?;
        } else {
            critique.flagged.clear();
        }
        let id = self.fresh_id()?;
        self.critiques.push(CritiqueRecord {
            id,
            execution,
            critique,
        });
        self.recompute_weights();
        // Finite increments can still sum to infinity; such a critique is taken back whole.
        if let Err(e) = self.check_weights() {
            self.critiques.pop();
            self.next_id -= 1;
            self.recompute_weights();
            return Err(e);
        }
        Ok(id)
    }

    /// The number of points of execution `id`.
    fn execution_len(&self, id: ExecutionId) -> Result<usize, DatasetError> {
        self.executions
            .iter()
            .find(|e| e.id == id)
            .map(|e| e.points.len())
            .ok_or(DatasetError::UnknownExecution(id))
    }

    /// Every weight a query can meet is finite and at least 1: `m_i`, and `m_i` plus the
    /// point's directional increments (what the BC search divides by).
    fn check_weights(&self) -> Result<(), DatasetError> {
        if self.m.is_empty() && !self.has_directional() {
            return Ok(());
        }
        for i in 0..self.len() {
            for m in [self.m(i), self.max_weight(i)] {
                check_weight(m, || match self.provenance(i) {
                    Provenance::Demonstration { demo, index } => {
                        format!("demonstration {demo}, point {index}")
                    }
                    Provenance::Advice { advice, index, .. } => {
                        format!("advice {advice}, point {index}")
                    }
                })?;
            }
        }
        Ok(())
    }

    /// A directional critique's flagged observations: one per increment, each of the domain's
    /// observation dimension and finite.
    fn check_flagged(
        &self,
        increments: &[(Provenance, f64)],
        flagged: &[Vec<f64>],
    ) -> Result<(), DatasetError> {
        if flagged.len() != increments.len() {
            return Err(DatasetError::Inconsistent {
                what: format!(
                    "a directional critique has {} increments and {} flagged observations",
                    increments.len(),
                    flagged.len()
                ),
            });
        }
        let dim = self.domain.obs_dim();
        for (k, z) in flagged.iter().enumerate() {
            if z.len() != dim {
                return Err(DatasetError::Inconsistent {
                    what: format!(
                        "flagged observation {k} of a directional critique has {} values; the `{}` domain observes {dim}",
                        z.len(),
                        self.domain.name
                    ),
                });
            }
            if let Some(v) = z.iter().find(|v| !v.is_finite()) {
                return Err(DatasetError::NonFinite {
                    what: format!("flagged observation {k} of a directional critique has {v}"),
                });
            }
        }
        Ok(())
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

    /// `m_i = 1 + increments` of the paper's rule, summed in critique order, and the directional
    /// increments of each point in critique order, so the result depends only on the records.
    fn recompute_weights(&mut self) {
        self.m.clear();
        let n = self.len;
        let mut dir = DirectionalPenalties::new();
        if self.critiques.is_empty() {
            self.directional = dir;
            return;
        }
        let mut m = vec![1.0; n];
        let in_id_order = self.runs_in_id_order();
        // Directional increments: (point, critique, increment), gathered in critique order and
        // then grouped by point with a stable sort, so each point's stay in critique order.
        let mut by_point: Vec<(usize, usize, usize)> = Vec::new();
        for (c_at, c) in self.critiques.iter().enumerate() {
            for (k, (p, inc)) in c.critique.increments.iter().enumerate() {
                let Some(i) = self.position_in(*p, in_id_order) else {
                    continue;
                };
                if c.critique.directional {
                    by_point.push((i, c_at, k));
                } else {
                    m[i] += inc;
                }
            }
        }
        by_point.sort_by_key(|&(i, _, _)| i);
        let mut counts = vec![0u32; n + 1];
        for &(i, c, k) in &by_point {
            let rec = &self.critiques[c];
            counts[i + 1] += 1;
            dir.inc.push(rec.critique.increments[k].1);
            dir.z.extend_from_slice(&rec.critique.flagged[k]);
        }
        for i in 0..n {
            counts[i + 1] += counts[i];
        }
        // All ones and no directional increment: nothing kept per point.
        if m.iter().any(|m| *m != 1.0) {
            self.m = m;
        }
        dir.start = if by_point.is_empty() {
            Vec::new()
        } else {
            counts
        };
        self.directional = dir;
    }
}
/// The id after `last`, or [`DatasetError::IdsExhausted`] at the top of the range.
fn next_id_after(last: u32) -> Result<u32, DatasetError> {
    last.checked_add(1)
        .ok_or(DatasetError::IdsExhausted { next_id: last })
}

/// The rule every point of the training data obeys, wherever it enters (a demonstration, advice,
/// a dataset file, a journal): each value finite, each action within its dimension's limits.
/// Actions are clamped to their limits wherever a command makes them (recorded runs, operators,
/// demonstration files); observations are what the robot saw, and may lie beyond (a goal 20 m
/// away). The dimensions are the caller's to have checked; `at(space, k)` names a value.
fn check_point(
    domain: &Domain,
    z: &[f64],
    a: &[f64],
    at: impl Fn(&str, usize) -> String,
) -> Result<(), DatasetError> {
    use advise_lang::domain::Space;
    use advise_lang::trace::{ValueFault, demo_value_fault};
    for (space, side, vals, dims) in [
        ("z", Space::Observation, z, &domain.observe),
        ("a", Space::Action, a, &domain.act),
    ] {
        for (k, (v, dim)) in vals.iter().zip(dims.iter()).enumerate() {
            // The one rule for demonstration values (`trace::demo_value_fault`), named here as
            // a dataset's error.
            match demo_value_fault(domain, side, k, *v) {
                None => {}
                Some(ValueFault::NotFinite) => check_finite_value(*v, || at(space, k))?,
                Some(ValueFault::OutsideLimits(l)) => {
                    return Err(DatasetError::OutOfLimits {
                        at: at(space, k),
                        value: advise_lang::number::fmt_readable(*v),
                        dim: dim.name.clone(),
                        lo: fmt_num(l.lo),
                        hi: fmt_num(l.hi),
                    });
                }
            }
        }
    }
    Ok(())
}

/// A value that must be finite (`at` names it).
fn check_finite_value(v: f64, at: impl Fn() -> String) -> Result<(), DatasetError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(DatasetError::NotFinite {
            at: at(),
            value: v.to_string(),
        })
    }
}

/// A BC weight: finite and at least 1.
fn check_weight(m: f64, at: impl Fn() -> String) -> Result<(), DatasetError> {
    if m.is_finite() && m >= 1.0 {
        Ok(())
    } else {
        Err(DatasetError::Record {
            at: at(),
            what: format!("the weight is {m}; weights are finite and at least 1"),
        })
    }
}

/// A chunk of execution `execution` (`len` points) that advice or a critique was given on: in
/// order and within the execution.
fn check_chunk(
    chunk: Chunk,
    execution: ExecutionId,
    len: usize,
    at: impl Fn() -> String,
) -> Result<(), DatasetError> {
    if chunk.start > chunk.end || chunk.end > len {
        return Err(DatasetError::Record {
            at: at(),
            what: format!("the chunk {chunk} is not within execution {execution} ({len} points)"),
        });
    }
    Ok(())
}

/// What a takeover records of itself: steps within its execution (of `len` points), a step of at
/// least 1, and as many points as those steps keep.
fn check_takeover(
    link: &TakeoverLink,
    len: usize,
    points: usize,
    at: impl Fn() -> String,
) -> Result<(), DatasetError> {
    check_chunk(link.steps, link.execution, len, || {
        format!("{}.steps", at())
    })?;
    if link.every == 0 || link.steps.is_empty() || link.points() != points {
        return Err(DatasetError::Record {
            at: at(),
            what: format!(
                "steps {} kept every {} make {} points, not {points}",
                link.steps,
                link.every,
                link.points()
            ),
        });
    }
    Ok(())
}

/// What advice records of itself: a chunk within its execution, finite parameters, and the
/// dataset's domain. `at` is the record's name (`advice[3]` in a file).
fn check_advice(
    domain: &Domain,
    applied: &AppliedAdvice,
    execution: ExecutionId,
    len: usize,
    at: &str,
) -> Result<(), DatasetError> {
    check_chunk(applied.chunk, execution, len, || {
        format!("{at}.applied.chunk")
    })?;
    for (k, p) in applied.params.iter().enumerate() {
        check_finite_value(p.value, || format!("{at}.applied.params[{k}].value"))?;
    }
    if applied.domain != domain.name {
        return Err(DatasetError::Record {
            at: format!("{at}.applied.domain"),
            what: format!(
                "the advice is for the `{}` domain, the dataset is `{}`",
                applied.domain, domain.name
            ),
        });
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

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(d: &Domain, x: f64) -> Trace {
        let mut t = Trace::new(d);
        t.push(0.0, &[x, 0.0, 0.0], &[0.1, 0.0], None);
        t.push(0.1, &[x - 0.1, 0.0, 0.0], &[0.1, 0.0], None);
        t
    }

    /// Weights and directional offsets are kept per point only once a critique reaches one;
    /// points added after that weigh 1 and have no increment, and every point's provenance is
    /// found where it is.
    #[test]
    fn points_added_after_a_critique_weigh_one() {
        let d = Domain::positioning();
        let mut ds = Dataset::new(&d);
        ds.add_demonstration("a", &trace(&d, 1.0)).unwrap();
        assert_eq!(ds.weights(), [1.0, 1.0]);
        let e = ds.add_execution(&trace(&d, 0.5)).unwrap();
        let p = ds.provenance(0);
        let chunk = Chunk { start: 0, end: 1 };
        ds.add_critique(e, Critique::paper(chunk, 1.0, vec![(p, 2.0)]))
            .unwrap();
        let flagged = vec![vec![1.0, 0.1, 0.0]];
        ds.add_critique(
            e,
            Critique::directional(chunk, 1.0, vec![(p, 1.0)], flagged),
        )
        .unwrap();
        ds.add_demonstration("b", &trace(&d, 2.0)).unwrap();
        assert_eq!(ds.weights(), [3.0, 1.0, 1.0, 1.0]);
        assert_eq!(ds.directional(0).0, [1.0]);
        assert!(ds.directional(3).0.is_empty());
        assert_eq!(ds.max_weight(3), 1.0);
        for i in 0..ds.len() {
            assert_eq!(ds.position(ds.provenance(i)), Some(i));
        }
    }
}
