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

use serde::{Deserialize, Serialize};

use crate::diag::{Loc, SourceMap, Sourced, Src, locate};
use crate::domain::Domain;
use crate::interp::AppliedAdvice;
use crate::number::fmt_num;
use crate::trace::{Chunk, Episode, JsonPoint, Trace};

mod error;
mod file;

pub use error::DatasetError;
pub use file::{Demonstrations, SavedFormat, load_demonstrations};

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

    /// The executions advice or critique was given on, in the order they were added.
    pub fn executions(&self) -> &[ExecutionRecord] {
        &self.executions
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
