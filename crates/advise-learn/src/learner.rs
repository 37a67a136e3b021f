//! The learner a session (or an experiment) works with: a [`Dataset`] and the policy derived from
//! it, kept in step.
//!
//! Re-deriving from scratch ([`Learner::rederive`]) recomputes the observation scaling from the
//! data's ranges, rebuilds the index and re-tunes LWR by cross-validation. Advice is incremental:
//! its points are added to the existing index under the existing scaling and parameters, so the
//! policy is ready at once ([`Learner::add_advice`]). Undoing advice rebuilds the index under the
//! same scaling, which gives the policy that would exist had the advice never been given.

use std::fmt::Write as _;
use std::path::Path;

use miette::Diagnostic;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::Policy;
use crate::bc;
use crate::dataset::{
    Critique, CritiqueRule, Dataset, DatasetError, Provenance, SavedFormat, TakeoverLink,
};
use crate::index::{Index, MAX_DIM};
use crate::lwr::{self, LwrAnswer, LwrParams};
use advise_lang::domain::Domain;
use advise_lang::interp::Synthesized;
use advise_lang::trace::{Chunk, Episode, Trace};

pub use crate::dataset::{AdviceId, CritiqueId, DemoId, ExecutionId};

/// Which policy the learner runs: the one name of a learner for sessions (`learner bc`),
/// journals, `advise eval --policy` and `advise::eval::derive_policy`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LearnerKind {
    /// 1-nearest-neighbour (BC)
    Bc,
    /// Locally weighted regression (A-OPI)
    Lwr,
}

impl LearnerKind {
    /// Every learner, in the order help lists them.
    pub const ALL: [LearnerKind; 2] = [LearnerKind::Bc, LearnerKind::Lwr];

    /// The name a user types (`bc`, `lwr`), as in journals.
    pub fn name(self) -> &'static str {
        match self {
            LearnerKind::Bc => "bc",
            LearnerKind::Lwr => "lwr",
        }
    }

    /// The learner named `name`, if any.
    pub fn from_name(name: &str) -> Option<LearnerKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// What the learner is, in a few words (the command line's help beside [`Self::name`]).
    pub fn summary(self) -> &'static str {
        match self {
            LearnerKind::Bc => "1-nearest-neighbour (BC)",
            LearnerKind::Lwr => "Locally weighted regression (A-OPI)",
        }
    }
}

/// Why the learner could not do what was asked.
#[derive(Debug, Error, Diagnostic)]
pub enum LearnerError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    Dataset(#[from] DatasetError),
    #[error(
        "the `{domain}` domain has {dim} observation dimensions; the learners support 1 to {MAX_DIM}"
    )]
    #[diagnostic(code(advise::learner::dimension))]
    Dimension { domain: String, dim: usize },
    #[error("the dataset is for the `{found}` domain; this session's task is `{task}`")]
    #[diagnostic(code(advise::learner::other_task), help("{help}"))]
    OtherTask {
        found: String,
        /// The session's task, as the user names it.
        task: String,
        help: String,
    },
    #[error("the dataset's `{domain}` domain has other dimensions or limits than the task's")]
    #[diagnostic(
        code(advise::learner::domain_changed),
        help(
            "the file's `domain` was edited or comes from another version; save the dataset again from a session"
        )
    )]
    DomainChanged { domain: String },
    #[error("the dataset is empty: there is no policy to critique")]
    #[diagnostic(
        code(advise::learner::empty),
        help("load demonstrations first: `load demos FILE` or `load demos teacher:9`")
    )]
    Empty,
    #[error("the observation [{values}] is not finite: no data point is near it")]
    #[diagnostic(
        code(advise::learner::non_finite_query),
        help(
            "a NaN or infinite observation comes from a base's bad odometry or a task's observation expression; the policy commands zero there"
        )
    )]
    NonFiniteQuery { values: String },
}

/// How many of the steps of a run (or of every run of an evaluation) found data in LWR's kernel;
/// the rest were answered with the nearest point's action, as 1-NN would.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KernelCoverage {
    pub steps: usize,
    pub covered: usize,
}

impl KernelCoverage {
    /// The share of steps whose kernel held data (1 with no steps).
    pub fn share(&self) -> f64 {
        if self.steps == 0 {
            1.0
        } else {
            self.covered as f64 / self.steps as f64
        }
    }

    /// Most steps found no data: the kernel is not what answers (`advise::learner::kernel_empty`).
    pub fn mostly_empty(&self) -> bool {
        2 * self.covered < self.steps
    }

    /// `LWR: 170 of 190 steps (89%) found data in the kernel`.
    pub fn line(&self, what: &str) -> String {
        format!(
            "LWR: {} of {} {what} ({:.0}%) found data in the kernel",
            self.covered,
            self.steps,
            100.0 * self.share()
        )
    }
}

/// The warning when most steps found no data in LWR's kernel: there, "LWR" answered as 1-NN.
#[derive(Debug, Error, Diagnostic)]
#[error(
    "LWR's kernel held no data at {empty} of {steps} {what} ({share:.0}%): there the policy answered with the nearest point's action, as 1-NN"
)]
#[diagnostic(code(advise::learner::kernel_empty), severity(Warning), help("{help}"))]
pub struct KernelEmpty {
    pub empty: usize,
    pub steps: usize,
    pub what: String,
    pub share: f64,
    pub help: String,
}

impl KernelEmpty {
    /// The warning for `coverage` of `what` ("steps of this run", "held-out points"), if most
    /// found no data; `help` says what to do in that place.
    pub fn of(coverage: KernelCoverage, what: &str, help: &str) -> Option<KernelEmpty> {
        coverage.mostly_empty().then(|| KernelEmpty {
            empty: coverage.steps - coverage.covered,
            steps: coverage.steps,
            what: what.to_string(),
            share: 100.0 * (1.0 - coverage.share()),
            help: help.to_string(),
        })
    }
}

/// The `advise::learner::kernel_empty` warning for `coverage` of `what`, rendered as a reply
/// shows it after a blank line; empty when most steps found data.
pub fn kernel_warning(coverage: KernelCoverage, what: &str, help: &str) -> String {
    KernelEmpty::of(coverage, what, help)
        .map(|w| {
            let sources = advise_lang::diag::SourceMap::new();
            format!(
                "\n\n{}",
                advise_lang::diag::render(&sources, &w, false).trim_end()
            )
        })
        .unwrap_or_default()
}

/// A policy that counts, as it answers, the steps whose LWR kernel held data: the evaluation
/// harness runs it on many threads, and the counts are sums, the same whatever the schedule.
pub struct CoverageCounter<'a> {
    learner: &'a Learner,
    steps: std::sync::atomic::AtomicUsize,
    covered: std::sync::atomic::AtomicUsize,
}

impl<'a> CoverageCounter<'a> {
    pub fn new(learner: &'a Learner) -> CoverageCounter<'a> {
        CoverageCounter {
            learner,
            steps: Default::default(),
            covered: Default::default(),
        }
    }

    /// What was counted; `None` for a BC learner.
    pub fn coverage(&self) -> Option<KernelCoverage> {
        use std::sync::atomic::Ordering::Relaxed;
        (self.learner.kind == LearnerKind::Lwr).then(|| KernelCoverage {
            steps: self.steps.load(Relaxed),
            covered: self.covered.load(Relaxed),
        })
    }
}

impl Policy for CoverageCounter<'_> {
    fn act(&self, z: &[f64], a: &mut [f64]) {
        use std::sync::atomic::Ordering::Relaxed;
        if self.learner.kind != LearnerKind::Lwr {
            return self.learner.act(z, a);
        }
        a.iter_mut().for_each(|v| *v = 0.0);
        let ans = self.learner.regress(z, a);
        self.steps.fetch_add(1, Relaxed);
        if ans.total_weight > 0.0 {
            self.covered.fetch_add(1, Relaxed);
        }
    }
}

/// The critique a teacher's flag would make ([`Learner::plan_critique`]), not made yet.
#[derive(Clone, Debug, PartialEq)]
pub struct CritiquePlan {
    /// The critique: its increments are (supporting point, increment of its m), in step order;
    /// under the directional rule it keeps the flagged observation (raw) of each.
    pub critique: Critique,
    /// Steps whose supporting point was removed since the run; `None` when the supporting points
    /// were not recorded and the nearest ones now were used.
    pub gone: Option<usize>,
}

/// What a critique did.
#[derive(Clone, Debug)]
pub struct CritiqueResult {
    pub id: CritiqueId,
    pub summary: String,
    /// The critique made (what a redo or the journal puts back).
    pub critique: Critique,
}

thread_local! {
    // Query buffers, one set per thread: a robot loop queries once per control step and the
    // evaluation harness queries from several rayon threads; neither should allocate per query.
    static BC_SCRATCH: std::cell::RefCell<bc::Scratch> = std::cell::RefCell::new(bc::Scratch::default());
    static LWR_SCRATCH: std::cell::RefCell<lwr::Scratch> = std::cell::RefCell::new(lwr::Scratch::default());
}

/// A dataset and its derived policy.
pub struct Learner {
    kind: LearnerKind,
    ds: Dataset,
    index: Index,
    lwr: LwrParams,
    /// LWR's own index, in the space its kernel measures (range scale times
    /// [`LwrParams::scales`]), so a query's radius search covers exactly the kernel's support
    /// instead of a box inflated by the smallest scale. `None` for a BC learner.
    lwr_index: Option<Index>,
    /// [`Learner::lwr`] with unit scales and its bandwidth times [`Learner::lwr_density`]: the
    /// parameters that query `lwr_index`.
    lwr_unit: LwrParams,
    /// [`lwr::density_factor`] of the last tuning: 1 unless it tuned on a sample. `lwr` keeps
    /// the tuned bandwidth, which a warm re-tuning starts from.
    lwr_density: f64,
    /// The teacher's limit on LWR's kernel, its k nearest points (`learner lwr k=N`); `None`:
    /// the protocol's ([`lwr::default_k`]).
    lwr_k: Option<usize>,
    seed: u64,
    /// Points added since the index was last brought up to date.
    indexed: usize,
    /// How [`Learner::rederive`] re-tunes LWR, and what it needs to know for that.
    retune: Retune,
    tuning: TuningState,
    /// What the last tuning found (`None` before LWR was first tuned).
    last_tuning: Option<lwr::Tuning>,
}

/// How a re-derivation re-tunes the LWR kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Retune {
    /// Every re-derivation tunes from scratch ([`lwr::tune`]): what a session does.
    Full,
    /// Re-derivations start from the last tuning ([`lwr::tune_from`]: the neighbouring
    /// bandwidths, scales kept), with a full tuning every `full_every`-th one and whenever the
    /// dataset has doubled since the last full tuning. For a learner re-derived after every
    /// advised execution (the studies' arms): three loss evaluations instead of about thirteen.
    Warm { full_every: u32 },
}

/// What the schedule of [`Retune::Warm`] keeps between re-derivations.
#[derive(Clone, Copy, Debug, Default)]
struct TuningState {
    /// Re-derivations since the last full tuning; `None` before the first.
    since_full: Option<u32>,
    /// Dataset size at the last full tuning.
    full_at_len: usize,
}

impl Learner {
    /// An empty learner of `kind` on `domain`.
    pub fn new(domain: &Domain, kind: LearnerKind, seed: u64) -> Learner {
        Learner::with_dataset(Dataset::new(domain), kind, seed)
    }

    /// A learner on an existing dataset (derived at once).
    pub fn with_dataset(ds: Dataset, kind: LearnerKind, seed: u64) -> Learner {
        let dim = ds.domain().obs_dim();
        let mut l = Learner {
            kind,
            index: Index::new(vec![1.0; dim.clamp(1, MAX_DIM)]).expect("1..=MAX_DIM is supported"),
            lwr: LwrParams::default_for(dim),
            lwr_index: None,
            lwr_unit: LwrParams::default_for(dim),
            lwr_density: 1.0,
            lwr_k: None,
            ds,
            seed,
            indexed: 0,
            retune: Retune::Full,
            tuning: TuningState::default(),
            last_tuning: None,
        };
        l.rederive();
        l
    }

    /// A learner on an existing dataset that re-tunes by `retune` (derived at once, with a full
    /// tuning).
    pub fn with_retune(ds: Dataset, kind: LearnerKind, seed: u64, retune: Retune) -> Learner {
        let mut l = Learner::with_dataset(ds, kind, seed);
        l.retune = retune;
        l
    }

    pub fn kind(&self) -> LearnerKind {
        self.kind
    }

    /// The number of points LWR's parameters were last fully tuned on; `None` while a BC
    /// learner has never run as LWR (its LWR parameters are the untuned defaults). After
    /// `learner bc`, LWR keeps the parameters tuned while it ran.
    pub fn lwr_tuned_at(&self) -> Option<usize> {
        self.tuning.since_full.map(|_| self.tuning.full_at_len)
    }

    pub fn set_kind(&mut self, kind: LearnerKind) {
        self.kind = kind;
    }

    /// The teacher's limit on LWR's kernel: at most its `k` nearest points (`None`: the
    /// protocol's rule, [`lwr::default_k`]). Takes effect at once (the kernel is not re-tuned).
    pub fn set_lwr_k(&mut self, k: Option<usize>) {
        self.lwr_k = k.map(|k| k.max(1));
        self.lwr_unit.k = self.lwr_query_k();
    }

    /// The teacher's limit on LWR's kernel (`None`: the protocol's rule).
    pub fn lwr_k(&self) -> Option<usize> {
        self.lwr_k
    }

    /// The most points an LWR query sums: the teacher's limit, else the protocol's for this
    /// many points and the last tuning; `None`: the whole truncated kernel.
    pub fn lwr_query_k(&self) -> Option<usize> {
        self.lwr_k
            .or_else(|| lwr::default_k(self.ds.len(), self.last_tuning.as_ref()))
    }

    pub fn kind_name(&self) -> &'static str {
        match self.kind {
            LearnerKind::Bc => "BC 1-NN",
            LearnerKind::Lwr => "LWR",
        }
    }

    pub fn dataset(&self) -> &Dataset {
        &self.ds
    }

    pub fn domain(&self) -> &Domain {
        self.ds.domain()
    }

    pub fn len(&self) -> usize {
        self.ds.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ds.is_empty()
    }

    /// The spatial index the policies query.
    pub fn index(&self) -> &Index {
        &self.index
    }

    /// The bytes the learner holds for its points: the dataset's arrays and bookkeeping and both
    /// indexes (records of executions, advice and critiques aside). What the scale benchmark
    /// reports per point.
    pub fn held_bytes(&self) -> usize {
        self.ds.held_bytes()
            + self.index.held_bytes()
            + self.lwr_index.as_ref().map_or(0, Index::held_bytes)
    }

    pub fn lwr_params(&self) -> &LwrParams {
        &self.lwr
    }

    /// What LWR's last tuning found: folds, loss and its standard error, held-out coverage.
    pub fn last_tuning(&self) -> Option<&lwr::Tuning> {
        self.last_tuning.as_ref()
    }

    /// The bandwidth LWR queries with: the tuned one, times the density factor beyond the
    /// tuning sample.
    pub fn lwr_query_bandwidth(&self) -> f64 {
        self.lwr_unit.bandwidth
    }

    /// The scored held-out points of the last tuning whose kernel held data of other sources
    /// (what the learner's next execution can expect); `None` before LWR was tuned.
    pub fn held_out_coverage(&self) -> Option<KernelCoverage> {
        let t = self.last_tuning.as_ref()?;
        Some(KernelCoverage {
            steps: t.scored,
            covered: t.covered,
        })
    }

    /// How many steps of `trace` find data in LWR's kernel, as the learner is now; `None` for a
    /// BC learner (whose policy has no kernel).
    pub fn kernel_coverage(&self, trace: &Trace) -> Option<KernelCoverage> {
        self.coverage_of((0..trace.len()).map(|t| trace.z(t)))
    }

    /// How many of the observations `zs` find data in LWR's kernel, as the learner is now;
    /// `None` for a BC learner. What a run's reply counts, for any rows (Python's `coverage`).
    pub fn coverage_of<'z>(&self, zs: impl Iterator<Item = &'z [f64]>) -> Option<KernelCoverage> {
        if self.kind != LearnerKind::Lwr || self.ds.is_empty() {
            return None;
        }
        let mut a = vec![0.0; self.ds.domain().act_dim()];
        let (mut steps, mut covered) = (0, 0);
        for z in zs {
            steps += 1;
            if self.regress(z, &mut a).total_weight > 0.0 {
                covered += 1;
            }
        }
        Some(KernelCoverage { steps, covered })
    }

    fn check_dim(&self) -> Result<(), LearnerError> {
        let dim = self.ds.domain().obs_dim();
        if dim == 0 || dim > MAX_DIM {
            return Err(LearnerError::Dimension {
                domain: self.ds.domain().name.clone(),
                dim,
            });
        }
        Ok(())
    }

    /// Add demonstrations and re-derive from scratch (new scaling, re-tuned LWR).
    pub fn add_demonstrations(
        &mut self,
        episodes: &[Episode],
    ) -> Result<Vec<DemoId>, LearnerError> {
        let points = episodes.iter().map(|e| e.trace.len()).sum();
        self.add_each(points, episodes)
    }

    /// [`Learner::add_demonstrations`], taking the episodes: each one is dropped as soon as its
    /// points are in the dataset, so a large load holds its points once, not twice, while the
    /// re-derivation builds the indexes.
    pub fn add_demonstrations_owned(
        &mut self,
        episodes: Vec<Episode>,
    ) -> Result<Vec<DemoId>, LearnerError> {
        let points = episodes.iter().map(|e| e.trace.len()).sum();
        self.add_each(points, episodes)
    }

    /// Add `episodes` (`points` in all, reserved at once) in order, then re-derive.
    fn add_each<E: std::borrow::Borrow<Episode>>(
        &mut self,
        points: usize,
        episodes: impl IntoIterator<Item = E>,
    ) -> Result<Vec<DemoId>, LearnerError> {
        self.check_dim()?;
        self.ds.reserve(points);
        let ids = episodes
            .into_iter()
            .map(|e| {
                let e = e.borrow();
                self.ds.add_demonstration(&e.name, &e.trace)
            })
            .collect::<Result<Vec<_>, _>>()?;
        self.rederive();
        Ok(ids)
    }

    pub fn add_execution(&mut self, trace: &Trace) -> ExecutionId {
        // The trace was recorded in this learner's domain; a mismatch is a programming error
        // upstream, and the id is still unique.
        self.ds.add_execution(trace).unwrap_or(u32::MAX)
    }

    /// [`Learner::add_execution`], refusing what the dataset refuses (another domain, no id
    /// left) instead of giving an id that refers to nothing: what a session records.
    pub fn try_add_execution(&mut self, trace: &Trace) -> Result<ExecutionId, LearnerError> {
        Ok(self.ds.add_execution(trace)?)
    }

    /// Record the goal execution `id` was run to ([`Dataset::set_execution_goal`]).
    pub fn set_execution_goal(
        &mut self,
        id: ExecutionId,
        goal: Vec<f64>,
    ) -> Result<(), LearnerError> {
        Ok(self.ds.set_execution_goal(id, goal)?)
    }

    /// Add synthesized advice points; the policy is updated incrementally.
    pub fn add_advice(
        &mut self,
        execution: ExecutionId,
        syn: &Synthesized,
    ) -> Result<AdviceId, LearnerError> {
        let id = self.ds.add_advice(
            execution,
            syn.advice.clone(),
            &syn.points,
            &syn.source_index,
        )?;
        self.ensure_derived();
        Ok(id)
    }

    /// Add the demonstration a teacher gave by taking over a run ([`Dataset::add_takeover`]);
    /// the policy is updated incrementally, as advice is (a `rederive` re-tunes).
    pub fn add_takeover(
        &mut self,
        name: &str,
        trace: &Trace,
        link: TakeoverLink,
    ) -> Result<DemoId, LearnerError> {
        self.check_dim()?;
        let id = self.ds.add_takeover(name, trace, link)?;
        self.ensure_derived();
        Ok(id)
    }

    /// Remove a demonstration and its points (an undone takeover).
    pub fn remove_demonstration(&mut self, id: DemoId) -> Result<(), LearnerError> {
        self.ds.remove_demonstration(id)?;
        self.reindex();
        Ok(())
    }

    pub fn remove_advice(&mut self, id: AdviceId) -> Result<(), LearnerError> {
        self.ds.remove_advice(id)?;
        self.reindex();
        Ok(())
    }

    /// Flag `chunk` of an execution under the paper's rule: each flagged point's supporting data
    /// point gets `m += kappa / max(d, MIN)` (see [`bc::MIN_CRITIQUE_DISTANCE`]). The supporting
    /// points are the nearest now, which is what acted only when nothing was added since the
    /// run; a session records what acted when it ran and uses [`Learner::plan_critique`] with it.
    pub fn critique(
        &mut self,
        execution: ExecutionId,
        trace: &Trace,
        chunk: Chunk,
        kappa: f64,
    ) -> Result<CritiqueResult, LearnerError> {
        self.critique_with(execution, trace, chunk, kappa, CritiqueRule::Paper)
    }

    /// [`Learner::critique`] under either rule.
    pub fn critique_with(
        &mut self,
        execution: ExecutionId,
        trace: &Trace,
        chunk: Chunk,
        kappa: f64,
        rule: CritiqueRule,
    ) -> Result<CritiqueResult, LearnerError> {
        let plan = self.plan_critique(trace, chunk, kappa, None, rule)?;
        let id = self.add_critique(execution, plan.critique.clone())?;
        Ok(CritiqueResult {
            id,
            summary: self.critique_summary(&plan),
            critique: plan.critique,
        })
    }

    /// The increments a critique of `chunk` makes under `rule`, without making them.
    ///
    /// With `support` (for each step, the provenance of the data point that recommended its action
    /// when it ran: [`Learner::support_provenance`]), the paper's rule holds exactly: the points
    /// that acted are penalised, never data added after the run; a supporting point removed since
    /// (undone advice) is skipped and counted. Without it (a trace loaded from a file), the
    /// points nearest now are penalised. The increments are the same under both rules; the
    /// directional rule also keeps each flagged observation.
    pub fn plan_critique(
        &mut self,
        trace: &Trace,
        chunk: Chunk,
        kappa: f64,
        support: Option<&[Option<Provenance>]>,
        rule: CritiqueRule,
    ) -> Result<CritiquePlan, LearnerError> {
        if self.ds.is_empty() {
            return Err(LearnerError::Empty);
        }
        self.ensure_derived();
        let directional = rule == CritiqueRule::Directional;
        let (increments, flagged, gone) = match support {
            None => {
                let zs = chunk.range().map(|t| trace.z(t).to_vec());
                let found = bc::critique_increments(&self.index, &self.ds, zs, kappa);
                let increments = found
                    .iter()
                    .map(|(i, inc, _)| (self.ds.provenance(*i), *inc))
                    .collect();
                let flagged = if directional {
                    found.into_iter().map(|(_, _, z)| z).collect()
                } else {
                    Vec::new()
                };
                (increments, flagged, None)
            }
            Some(support) => {
                let (increments, flagged, gone) =
                    self.supported_increments(trace, chunk, kappa, support, directional);
                (increments, flagged, Some(gone))
            }
        };
        Ok(CritiquePlan {
            critique: Critique {
                chunk,
                kappa,
                increments,
                directional,
                flagged,
            },
            gone,
        })
    }

    /// The paper's rule on recorded support: each step's supporting point penalised by `kappa`
    /// over its scaled distance from the step's observation; the flagged observations (directional
    /// rule) and how many supporting points were removed since.
    #[allow(clippy::type_complexity)]
    fn supported_increments(
        &self,
        trace: &Trace,
        chunk: Chunk,
        kappa: f64,
        support: &[Option<Provenance>],
        directional: bool,
    ) -> (Vec<(Provenance, f64)>, Vec<Vec<f64>>, usize) {
        let scale = self.index.scale();
        let mut gone = 0;
        let mut increments = Vec::with_capacity(chunk.len());
        let mut flagged = Vec::new();
        for t in chunk.range() {
            let Some(p) = support.get(t).copied().flatten() else {
                continue;
            };
            let Some(i) = self.ds.position(p) else {
                gone += 1;
                continue;
            };
            let d = trace
                .z(t)
                .iter()
                .zip(self.ds.z(i))
                .zip(scale)
                .map(|((zt, zi), s)| ((zt - zi) * s).powi(2))
                .sum::<f64>()
                .sqrt();
            increments.push((p, kappa / d.max(bc::MIN_CRITIQUE_DISTANCE)));
            if directional {
                flagged.push(trace.z(t).to_vec());
            }
        }
        (increments, flagged, gone)
    }

    /// What a planned critique did, in words (after [`Learner::add_critique`] made it).
    pub fn critique_summary(&self, plan: &CritiquePlan) -> String {
        let chunk = plan.critique.chunk;
        let mut points: Vec<usize> = plan
            .critique
            .increments
            .iter()
            .filter_map(|(p, _)| self.ds.position(*p))
            .collect();
        points.sort_unstable();
        points.dedup();
        let max_m = points
            .iter()
            .map(|&i| self.ds.max_weight(i))
            .fold(1.0, f64::max);
        let mut summary = if plan.critique.directional {
            format!(
                "critiqued {chunk} ({} points, directional rule): raised the weight of {} data points for queries from the flagged side (largest m now {max_m:.2}, from the flagged direction itself)",
                chunk.len(),
                points.len()
            )
        } else {
            format!(
                "critiqued {chunk} ({} points, paper's rule): raised the weight of {} data points (largest m now {max_m:.2})",
                chunk.len(),
                points.len()
            )
        };
        match plan.gone {
            None => summary.push_str(
                "; the points that drove this execution were not recorded (a loaded trace), so the points nearest now were penalised",
            ),
            Some(0) => {}
            Some(n) => {
                let _ = write!(
                    summary,
                    "; {n} steps were driven by data removed since (undone advice) and were skipped"
                );
            }
        }
        if self.kind == LearnerKind::Lwr {
            summary.push_str("; note: weights steer the BC 1-NN policy, the running policy is LWR");
        }
        summary
    }

    /// Make a critique of execution `execution` exactly (a new critique, a redo, or a journal
    /// being restored): its increments as recorded, under its rule.
    pub fn add_critique(
        &mut self,
        execution: ExecutionId,
        critique: Critique,
    ) -> Result<CritiqueId, LearnerError> {
        Ok(self.ds.add_critique(execution, critique)?)
    }

    /// For each observation of `trace`, the provenance of the data point the BC 1-NN picks now:
    /// recorded right after a run (the dataset does not change during one), it says which points
    /// acted, whatever is added or removed later.
    pub fn support_provenance(&mut self, trace: &Trace) -> Vec<Option<Provenance>> {
        self.ensure_derived();
        (0..trace.len())
            .map(|t| {
                self.support(trace.z(t))
                    .map(|s| self.ds.provenance(s.point))
            })
            .collect()
    }

    pub fn remove_critique(&mut self, id: CritiqueId) -> Result<(), LearnerError> {
        self.ds.remove_critique(id)?;
        Ok(())
    }

    /// Re-derive from scratch; returns a note on what was tuned.
    pub fn rederive(&mut self) -> String {
        let dim = self.ds.domain().obs_dim();
        if dim == 0 || dim > MAX_DIM {
            return String::new();
        }
        let n = self.ds.len();
        let scale: Vec<f64> = (0..dim)
            .map(|j| {
                let (lo, hi) = (0..n).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
                    (lo.min(self.ds.z(i)[j]), hi.max(self.ds.z(i)[j]))
                });
                if hi - lo > 1e-12 {
                    1.0 / (hi - lo)
                } else {
                    1.0
                }
            })
            .collect();
        self.index = Index::new(scale).expect("dimension checked above");
        self.indexed = 0;
        self.lwr_index = None;
        self.ensure_derived();
        if self.kind == LearnerKind::Lwr {
            let warm = match (self.retune, self.tuning.since_full) {
                (Retune::Warm { full_every }, Some(since)) => {
                    since + 1 < full_every.max(1) && n < 2 * self.tuning.full_at_len.max(1)
                }
                _ => false,
            };
            let start = if warm {
                self.tuning.since_full = self.tuning.since_full.map(|s| s + 1);
                Some(&self.lwr)
            } else {
                self.tuning = TuningState {
                    since_full: Some(0),
                    full_at_len: n,
                };
                None
            };
            let tuning = lwr::tune_report(&self.ds, self.index.scale(), 5, self.seed, start);
            let sample = tuning.sample;
            self.lwr = tuning.params.clone();
            self.lwr_density = lwr::density_factor(sample, n, dim);
            self.last_tuning = Some(tuning.clone());
            self.build_lwr_index();
            let scales: Vec<String> = self.lwr.scales.iter().map(|s| format!("{s}")).collect();
            let density = if self.lwr_density == 1.0 {
                String::new()
            } else {
                format!(
                    " on a sample of {sample} points, applied as {:.4} at {n} points",
                    self.lwr_unit.bandwidth
                )
            };
            let how = if tuning.folds == 0 {
                "left at its defaults (too few points to cross-validate)".to_string()
            } else {
                let verb = if warm {
                    "re-tuned from the last tuning"
                } else {
                    "tuned"
                };
                if tuning.sources == 1 {
                    format!(
                        "{verb} by cross-validation over {} stretches of its one demonstration",
                        tuning.folds
                    )
                } else {
                    format!(
                        "{verb} by cross-validation over {} held-out sources in {} folds",
                        tuning.sources, tuning.folds
                    )
                }
            };
            let coverage = self
                .held_out_coverage()
                .filter(|_| tuning.folds > 0)
                .map(|c| format!("; {}", c.line("held-out points")))
                .unwrap_or_default();
            let limit = match (self.lwr_unit.k, self.lwr_k) {
                (Some(k), Some(_)) => format!("; the kernel limited to its {k} nearest points"),
                (Some(k), None) => format!(
                    "; the kernel limited to its {k} nearest points (beyond the tuning sample of {} points: the tuned kernel's mean held-out neighbours, at least {})",
                    lwr::TUNE_POINTS,
                    lwr::MIN_K
                ),
                (None, _) => String::new(),
            };
            format!(
                "; LWR {how}: bandwidth {}{density}, scales [{}]{coverage}{limit}",
                self.lwr.bandwidth,
                scales.join(", ")
            )
        } else {
            String::new()
        }
    }

    /// Bring the index up to date with points added since (incremental).
    pub fn ensure_derived(&mut self) {
        if self.ds.obs_dim_supported() {
            if self.indexed == 0 {
                // A fresh index (a re-derivation): sized for every point at once.
                let (n, pts) = (self.ds.len(), self.ds.points());
                self.index.reserve(n, pts);
                if let Some(l) = &mut self.lwr_index {
                    l.reserve(n, pts);
                }
            }
            for i in self.indexed..self.ds.len() {
                self.index.add(i as u32, self.ds.points());
                if let Some(l) = &mut self.lwr_index {
                    l.add_with_action(i as u32, self.ds.points());
                }
            }
        }
        self.indexed = self.ds.len();
    }

    /// A copy that answers as this learner does: the same dataset, scaling, kernel and tuning,
    /// its indexes built afresh (an index is a cache of the dataset). What `suggest` advises to
    /// see an effect without touching the session's learner; never tuned, so it costs a copy of
    /// the dataset and an index build, not a cross-validation.
    pub fn copy(&self) -> Learner {
        let mut l = Learner {
            kind: self.kind,
            ds: self.ds.clone(),
            index: Index::new(self.index.scale().to_vec()).unwrap_or_else(|| {
                Index::new(vec![1.0; self.ds.domain().obs_dim().clamp(1, MAX_DIM)])
                    .expect("1..=MAX_DIM is supported")
            }),
            lwr: self.lwr.clone(),
            lwr_index: None,
            lwr_unit: self.lwr_unit.clone(),
            lwr_density: self.lwr_density,
            lwr_k: self.lwr_k,
            seed: self.seed,
            indexed: 0,
            retune: self.retune,
            tuning: self.tuning,
            last_tuning: self.last_tuning.clone(),
        };
        if self.lwr_index.is_some() {
            l.build_lwr_index();
        }
        l.ensure_derived();
        l
    }

    /// The data points in the learner's neighbourhood of observation `z`: within one kernel
    /// bandwidth in the space LWR measures (weight at least `exp(-1/2)` of a point at `z`; for a
    /// BC learner, the same radius in range-scaled units), each with its squared distance in
    /// bandwidths. Points added since the index was last brought up to date are not seen.
    pub fn neighbourhood(&self, z: &[f64], out: &mut Vec<(usize, f64)>) {
        out.clear();
        let idx = self.lwr_index.as_ref().unwrap_or(&self.index);
        let dim = self.ds.domain().obs_dim();
        if idx.is_empty() || dim == 0 || dim > MAX_DIM || z.len() != dim {
            return;
        }
        let bw = self.lwr_unit.bandwidth;
        if !(bw.is_finite() && bw > 0.0) {
            return;
        }
        let mut q = [0.0; MAX_DIM];
        idx.scaled(z, &mut q[..dim]);
        let mut hits = Vec::new();
        idx.within(&q[..dim], bw * bw, &mut hits, self.ds.points());
        for (d2, g) in hits {
            for &p in idx.group(g) {
                if (p as usize) < self.indexed {
                    out.push((p as usize, d2 / (bw * bw)));
                }
            }
        }
    }

    /// Rebuild the index under the current scaling and parameters (after points were removed).
    fn reindex(&mut self) {
        if let Some(idx) = Index::new(self.index.scale().to_vec()) {
            self.index = idx;
            self.indexed = 0;
            if self.lwr_index.is_some() {
                // Empty now; `ensure_derived` fills both indexes.
                self.build_lwr_index();
            }
            self.ensure_derived();
        }
    }

    /// LWR's index for the current range scale and tuned parameters, holding the points indexed
    /// so far (`ensure_derived` adds the rest).
    fn build_lwr_index(&mut self) {
        let scale: Vec<f64> = self
            .index
            .scale()
            .iter()
            .zip(&self.lwr.scales)
            .map(|(r, s)| r * s)
            .collect();
        self.lwr_unit = LwrParams {
            scales: vec![1.0; scale.len()],
            bandwidth: self.lwr.bandwidth * self.lwr_density,
            k: self.lwr_query_k(),
            ..self.lwr.clone()
        };
        let act_dim = self.ds.domain().act_dim();
        self.lwr_index = Index::with_action_sums(scale, act_dim).map(|mut idx| {
            idx.reserve(self.ds.len(), self.ds.points());
            for i in 0..self.indexed.min(self.ds.len()) {
                idx.add_with_action(i as u32, self.ds.points());
            }
            idx
        });
    }

    /// The policy to run.
    pub fn policy(&self) -> &dyn Policy {
        self
    }

    /// Bring the indexes up to date and build the trees a run queries: BC's, then LWR's. In
    /// that order, because a tree's build holds its points once more for a while, and LWR's
    /// tree, with its action sums, is the larger one to have beside it: built second, its
    /// sums are made after that copy is gone (at 20 million points, a peak some 500 MB lower).
    pub fn prepare(&mut self) {
        self.ensure_derived();
        self.index.build_bulk(self.ds.points());
        if let Some(idx) = &self.lwr_index {
            idx.build_bulk(self.ds.points());
        }
    }

    /// The BC answer for `z`: which point supported the action.
    pub fn support(&self, z: &[f64]) -> Option<bc::Support> {
        BC_SCRATCH.with_borrow_mut(|scratch| bc::query(&self.index, &self.ds, z, scratch))
    }

    /// The LWR answer for `z`.
    pub fn regress(&self, z: &[f64], a: &mut [f64]) -> LwrAnswer {
        LWR_SCRATCH.with_borrow_mut(|scratch| match &self.lwr_index {
            Some(idx) => lwr::query(idx, &self.ds, &self.lwr_unit, z, a, scratch),
            None => lwr::query(&self.index, &self.ds, &self.lwr, z, a, scratch),
        })
    }

    /// A readable account of which data points support the action at `z`. `advice_name` names
    /// a piece of advice as the teacher knows it (the session's history number).
    pub fn why(
        &self,
        z: &[f64],
        advice_name: &dyn Fn(AdviceId) -> String,
    ) -> Result<String, LearnerError> {
        self.why_named(z, advice_name, &|id| format!("takeover (dataset id {id})"))
    }

    /// [`Learner::why`], with `takeover_name` naming a demonstration given by taking over a run
    /// as the teacher knows it (the session's history number).
    pub fn why_named(
        &self,
        z: &[f64],
        advice_name: &dyn Fn(AdviceId) -> String,
        takeover_name: &dyn Fn(DemoId) -> String,
    ) -> Result<String, LearnerError> {
        if self.ds.is_empty() {
            return Err(LearnerError::Empty);
        }
        if !z.iter().all(|v| v.is_finite()) {
            return Err(LearnerError::NonFiniteQuery { values: fmt4(z) });
        }
        let mut out = String::new();
        if let Some(s) = self.support(z) {
            let _ = writeln!(
                out,
                "nearest (BC): point {} at scaled distance {:.4}, m = {:.4} (weighted {:.4}), a = [{}]\n  from {}",
                s.point,
                s.distance,
                s.m,
                s.weighted,
                fmt_named(&self.ds.domain().act, self.ds.a(s.point)),
                self.describe_named(s.point, advice_name, takeover_name)
            );
            let (incs, _) = self.ds.directional(s.point);
            if !incs.is_empty() {
                let _ = writeln!(
                    out,
                    "  m from this side: {:.4} (paper's rule) + {:.4} of its {:.4} directional penalty ({} directional increments)",
                    self.ds.m(s.point),
                    s.m - self.ds.m(s.point),
                    self.ds.max_weight(s.point) - self.ds.m(s.point),
                    incs.len()
                );
            }
        }
        let mut a = vec![0.0; self.ds.domain().act_dim()];
        let ans = self.regress(z, &mut a);
        if self.lwr_tuned_at().is_none() {
            // A BC learner that never ran as LWR: its LWR parameters are the untuned defaults,
            // whose answer says nothing about this data.
            let _ = writeln!(
                out,
                "LWR: not tuned on this data (the running learner is BC 1-NN; `learner lwr` tunes it)"
            );
        } else if ans.total_weight > 0.0 {
            let _ = writeln!(
                out,
                "LWR: {} neighbours, total kernel weight {:.4}, a = [{}]",
                ans.neighbours,
                ans.total_weight,
                fmt_named(&self.ds.domain().act, &a)
            );
        } else {
            let _ = writeln!(
                out,
                "LWR: no data point within the kernel: this observation is far from all data (the nearest point's action is used)"
            );
        }
        Ok(out)
    }

    /// Where point `i` came from, in words.
    pub fn describe(&self, i: usize, advice_name: &dyn Fn(AdviceId) -> String) -> String {
        self.describe_named(i, advice_name, &|id| format!("takeover (dataset id {id})"))
    }

    /// [`Learner::describe`], with `takeover_name` naming a takeover's demonstration.
    pub fn describe_named(
        &self,
        i: usize,
        advice_name: &dyn Fn(AdviceId) -> String,
        takeover_name: &dyn Fn(DemoId) -> String,
    ) -> String {
        match self.ds.provenance(i) {
            Provenance::Demonstration { demo, index } => {
                let record = self.ds.demos().iter().find(|d| d.id == demo);
                match record.and_then(|d| d.takeover) {
                    Some(link) => format!(
                        "{}: the teacher took over execution {} for steps {}, from execution point {} (demonstration point {index})",
                        takeover_name(demo),
                        self.ds
                            .execution_number(link.execution)
                            .map_or_else(|| "?".to_string(), |n| n.to_string()),
                        link.steps,
                        link.step(index)
                    ),
                    None => {
                        let name = record.map_or("?", |d| d.name.as_str());
                        format!("demonstration {demo} ({name}), point {index}")
                    }
                }
            }
            Provenance::Advice {
                advice,
                index,
                source,
            } => match self.ds.advice().iter().find(|r| r.id == advice) {
                Some(r) => format!(
                    "{}: {} on {} of execution {}, from execution point {source} (synthesized point {index})",
                    advice_name(advice),
                    r.applied.invocation(),
                    r.applied.chunk,
                    self.ds.execution_number(r.execution).unwrap_or(usize::MAX)
                ),
                None => format!("{}, point {index}", advice_name(advice)),
            },
        }
    }

    /// Save the dataset; `.json` or `.csv` ([`Dataset::save`]).
    pub fn save(&self, path: &Path) -> Result<SavedFormat, LearnerError> {
        Ok(self.ds.save(path)?)
    }

    /// Open a saved dataset for a task of `domain`: a dataset of another domain is refused with
    /// `other_domain(found)` (the caller knows the tasks and words the help), one of a domain with
    /// other dimensions or limits under the same name with [`LearnerError::DomainChanged`].
    pub fn open(
        sources: &mut advise_lang::diag::SourceMap,
        path: &Path,
        domain: &Domain,
        kind: LearnerKind,
        seed: u64,
        other_domain: impl FnOnce(&str) -> LearnerError,
    ) -> Result<Learner, LearnerError> {
        let ds = Dataset::load(sources, path)?;
        Learner::adopt(ds, domain, kind, seed, other_domain)
    }

    /// A learner on a dataset already read and validated whole (by `open`, or from a journal's
    /// copy of it), refused unless the dataset's domain is `domain`: the one rule for both.
    pub fn adopt(
        ds: Dataset,
        domain: &Domain,
        kind: LearnerKind,
        seed: u64,
        other_domain: impl FnOnce(&str) -> LearnerError,
    ) -> Result<Learner, LearnerError> {
        let found = ds.domain();
        if found.name != domain.name {
            return Err(other_domain(&found.name));
        }
        if found != domain {
            return Err(LearnerError::DomainChanged {
                domain: domain.name.clone(),
            });
        }
        let l = Learner::with_dataset(ds, kind, seed);
        l.check_dim()?;
        Ok(l)
    }

    /// Write the advised points with their provenance as CSV; returns how many.
    pub fn export_advice(&self, path: &Path) -> Result<usize, LearnerError> {
        let mut n = 0;
        advise_lang::files::write_atomic(path, |w| {
            n = self.ds.write_advice_csv(w)?;
            Ok(())
        })
        .map_err(DatasetError::from)?;
        Ok(n)
    }
}

impl Policy for Learner {
    fn act(&self, z: &[f64], a: &mut [f64]) {
        a.iter_mut().for_each(|v| *v = 0.0);
        match self.kind {
            LearnerKind::Bc => {
                if let Some(s) = self.support(z) {
                    a.copy_from_slice(self.ds.a(s.point));
                }
            }
            LearnerKind::Lwr => {
                self.regress(z, a);
            }
        }
    }
}

/// Numbers as the session prints them: 4 decimals.
/// Values with their dimensions' names, as `why` shows them: `trans=0.2000, rot=0.1000`.
fn fmt_named(dims: &[advise_lang::domain::Dim], v: &[f64]) -> String {
    dims.iter()
        .zip(v)
        .map(|(d, x)| format!("{}={x:.4}", d.name))
        .collect::<Vec<_>>()
        .join(", ")
}

fn fmt4(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.4}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Learner {
    /// Query this learner's data by locally weighted regression with other parameters than its
    /// own (for tests and tuning experiments).
    pub fn query_lwr_with(&self, params: &LwrParams, z: &[f64], a: &mut [f64]) -> LwrAnswer {
        let mut scratch = lwr::Scratch::default();
        lwr::query(self.index(), self.dataset(), params, z, a, &mut scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use advise_lang::domain::Dim;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `count` seeded positioning demonstrations of 1,000 points each, drifting towards the goal.
    fn drifting_episodes(d: &Domain, count: usize) -> Vec<Episode> {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        (0..count)
            .map(|e| {
                let mut t = Trace::new(d);
                let (mut r, mut b): (f64, f64) =
                    (rng.random_range(0.5..9.0), rng.random_range(-3.0..3.0));
                for i in 0..1000 {
                    r = (r - 0.01 + rng.random_range(-0.002..0.002)).max(0.0);
                    b += rng.random_range(-0.01..0.01);
                    let z = [r, b, 0.5 * b];
                    let a = [(0.3 * r).min(1.0), (0.8 * b).clamp(-1.0, 1.0)];
                    t.push(i as f64 * 0.02, &z, &a, None);
                }
                Episode {
                    name: format!("e{e}"),
                    trace: t,
                }
            })
            .collect()
    }

    /// A learner larger than LWR's tuning sample queries with the tuned bandwidth shrunk for its
    /// density ([`lwr::density_factor`]) and says so; one that was tuned on all its points
    /// queries with the tuned bandwidth itself, to the bit.
    #[test]
    fn the_bandwidth_follows_the_density_beyond_the_tuning_sample() {
        let d = Domain::positioning();
        let mut small = Learner::new(&d, LearnerKind::Lwr, 0);
        small
            .add_demonstrations_owned(drifting_episodes(&d, 12))
            .unwrap();
        assert_eq!(small.lwr_density, 1.0);
        assert_eq!(small.lwr_unit.bandwidth, small.lwr.bandwidth);
        let mut large = Learner::new(&d, LearnerKind::Lwr, 0);
        large
            .add_demonstrations_owned(drifting_episodes(&d, 60))
            .unwrap();
        let factor = lwr::density_factor(lwr::TUNE_POINTS, 60_000, 3);
        assert!((factor - (1.0f64 / 3.0).powf(1.0 / 7.0)).abs() < 1e-15);
        assert_eq!(large.lwr_density, factor);
        assert_eq!(large.lwr_unit.bandwidth, large.lwr.bandwidth * factor);
        let note = large.rederive();
        assert!(
            note.contains("on a sample of 20000 points, applied as"),
            "{note}"
        );
        assert!(!small.rederive().contains("sample"));
    }

    /// A ready learner (both trees built, as a run needs them) holds its points in under 160
    /// bytes each: the dataset's 40, the two group tables, BC's tree and LWR's with its action
    /// sums (150 here at 100,000 points, where the group tables are at their emptiest), besides
    /// the exact copies that trees of up to 2^18 groups keep for speed (`8 * D` bytes a group
    /// each, none in the trees of a larger dataset).
    /// Its answers are those of brute force over the points.
    #[test]
    fn a_ready_learner_holds_its_points_compactly() {
        let d = Domain::positioning();
        let episodes = drifting_episodes(&d, 100);
        let mut l = Learner::new(&d, LearnerKind::Lwr, 0);
        l.add_demonstrations_owned(episodes).unwrap();
        l.prepare();
        let copies =
            l.index.exact_copy_bytes() + l.lwr_index.as_ref().map_or(0, Index::exact_copy_bytes);
        assert!(
            copies <= 2 * 8 * 3 * l.len(),
            "{copies} bytes of exact copies"
        );
        let per_point = (l.held_bytes() - copies) as f64 / l.len() as f64;
        assert!(per_point < 160.0, "{per_point:.1} bytes per point");
        let q = [3.0, 0.1, 0.05];
        let s = l.support(&q).unwrap();
        let scale = l.index().scale().to_vec();
        let dist = |i: usize| -> f64 {
            l.ds.z(i)
                .iter()
                .zip(&q)
                .zip(&scale)
                .map(|((z, q), s)| (z * s - q * s).powi(2))
                .sum::<f64>()
        };
        let best = (0..l.len()).map(dist).fold(f64::INFINITY, f64::min);
        assert!((dist(s.point) - best).abs() <= 1e-12 * best.max(1.0));
    }

    /// A warm schedule re-tunes from the last tuning between full tunings every `full_every`-th
    /// re-derivation; a full schedule always tunes from scratch.
    #[test]
    fn a_warm_schedule_tunes_in_full_every_nth_rederivation() {
        let d = Domain {
            name: "test".into(),
            observe: vec![Dim::new("x", "", None), Dim::new("y", "", None)],
            act: vec![Dim::new("u", "", None)],
        };
        let mut ds = Dataset::new(&d);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for k in 0..8 {
            let mut t = Trace::new(&d);
            let (mut x, mut y): (f64, f64) =
                (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            for i in 0..50 {
                x += rng.random_range(-0.02..0.02);
                y += rng.random_range(-0.02..0.02);
                t.push(i as f64, &[x, y], &[(3.0 * x).sin() + y], None);
            }
            ds.add_demonstration(&format!("d{k}"), &t).unwrap();
        }
        let mut warm = Learner::with_retune(
            ds.clone(),
            LearnerKind::Lwr,
            1,
            Retune::Warm { full_every: 3 },
        );
        let notes: Vec<bool> = (0..5)
            .map(|_| warm.rederive().contains("re-tuned from the last tuning"))
            .collect();
        assert_eq!(notes, [true, true, false, true, true]);
        let mut full = Learner::with_dataset(ds, LearnerKind::Lwr, 1);
        assert!(!full.rederive().contains("re-tuned"));
    }

    /// A NaN or infinite observation (a base's bad odometry) has no support: both learners answer
    /// zero, `why` refuses it with a code, and recording the support of a run that holds one
    /// gives no provenance there instead of indexing with a NaN (it panicked in the index).
    #[test]
    fn a_non_finite_observation_is_answered_with_zero_and_refused_by_why() {
        let d = Domain {
            name: "test".into(),
            observe: vec![Dim::new("x", "", None), Dim::new("y", "", None)],
            act: vec![Dim::new("u", "", None)],
        };
        let mut t = Trace::new(&d);
        for i in 0..200 {
            let x = f64::from(i) / 50.0;
            t.push(f64::from(i), &[x, 1.0 - x], &[0.5 + x], None);
        }
        let mut ds = Dataset::new(&d);
        ds.add_demonstration("d", &t).unwrap();
        for kind in [LearnerKind::Bc, LearnerKind::Lwr] {
            let mut learner = Learner::with_dataset(ds.clone(), kind, 1);
            learner.ensure_derived();
            for bad in [
                [f64::NAN, 0.5],
                [0.5, f64::INFINITY],
                [f64::NEG_INFINITY, f64::NAN],
            ] {
                let mut a = [7.0];
                learner.policy().act(&bad, &mut a);
                assert_eq!(a, [0.0], "{kind:?} at {bad:?}");
                let err = learner.why(&bad, &|_| String::new()).unwrap_err();
                assert!(matches!(err, LearnerError::NonFiniteQuery { .. }), "{err}");
            }
            let mut run = Trace::new(&d);
            run.push(0.0, &[0.5, 0.5], &[0.0], None);
            run.push(1.0, &[f64::NAN, 0.5], &[0.0], None);
            let support = learner.support_provenance(&run);
            assert!(support[0].is_some() && support[1].is_none(), "{support:?}");
        }
    }
}
