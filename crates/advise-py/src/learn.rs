//! `advise.BC` and `advise.LWR`: the learners of the paper on numpy arrays, derived exactly as a
//! session derives them (`load demos`: [`Learner::new`] then the demonstrations added), so that
//! their predictions equal the command line's to the bit.

use advise::check::OperatorSet;
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::policy::Policy as _;
use advise::policy::learner::{Learner, LearnerKind};
use advise::trace::Episode;
use std::sync::{RwLock, RwLockReadGuard, RwLockWriteGuard, TryLockError};

use numpy::PyArray2;
use pyo3::prelude::*;

use crate::arrays::{matrix, to_numpy};
use crate::error::{from_diag, simple};
use crate::ops::trace_of;

/// What BC and LWR share: the domain and, once fitted, the learner.
struct Fitted {
    kind: LearnerKind,
    domain: Domain,
    seed: u64,
    /// The task's definition (`task=`): how `fit_file` makes a recording of a base's drive into
    /// demonstrations.
    def: Option<std::sync::Arc<advise::program::task::TaskDef>>,
    /// The standard operators with the task files (`tasks=`): what `fit_file` tells a file of
    /// another task by.
    set: OperatorSet,
    learner: Option<Learner>,
    /// LWR's kernel limited to its k nearest points (`LWR(k=N)`); `None`: the protocol's rule.
    lwr_k: Option<usize>,
}

impl Fitted {
    fn new(
        py: Python<'_>,
        kind: LearnerKind,
        domain: Option<&str>,
        task: Option<&str>,
        tasks: Option<&Bound<'_, PyAny>>,
        seed: u64,
    ) -> PyResult<Fitted> {
        let files = crate::named::task_files(py, tasks)?;
        let named = crate::named::Named::new(py, domain, task, &files, None)?;
        Ok(Fitted {
            kind,
            domain: named.domain,
            seed,
            def: named.def,
            set: named.set,
            learner: None,
            lwr_k: None,
        })
    }

    /// Derive from `episodes` as a session's `load demos` does.
    fn derive(&mut self, py: Python<'_>, episodes: Vec<Episode>) -> PyResult<()> {
        let (domain, kind, seed, k) = (&self.domain, self.kind, self.seed, self.lwr_k);
        let learner = py
            .detach(|| {
                let mut l = Learner::new(domain, kind, seed);
                l.set_lwr_k(k);
                l.add_demonstrations_owned(episodes).map(|_| l)
            })
            .map_err(|e| from_diag(py, &SourceMap::new(), &e))?;
        self.learner = Some(learner);
        Ok(())
    }

    /// The demonstrations of arrays: rows with the same label in `episodes` (contiguous) form one
    /// episode, named after the label; no labels is one episode.
    fn fit(
        &mut self,
        py: Python<'_>,
        observations: &Bound<'_, PyAny>,
        actions: &Bound<'_, PyAny>,
        episodes: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let trace = trace_of(py, &self.domain, observations, actions, None)?;
        let labels: Vec<i64> = match episodes {
            None => vec![0; trace.len()],
            Some(e) => {
                let l: Vec<i64> = e.extract().map_err(|_| {
                    simple(
                        py,
                        "advise::py::bad_argument",
                        "`episodes` is not a sequence of integers".into(),
                        "one integer episode label per row",
                    )
                })?;
                if l.len() != trace.len() {
                    return Err(simple(
                        py,
                        "advise::py::shape",
                        format!("{} episode labels for {} rows", l.len(), trace.len()),
                        "one integer episode label per row",
                    ));
                }
                l
            }
        };
        let mut eps: Vec<Episode> = Vec::new();
        let mut start = 0;
        for end in 1..=labels.len() {
            if end == labels.len() || labels[end] != labels[start] {
                eps.push(Episode {
                    name: format!("episode-{}", labels[start]),
                    trace: trace.slice(
                        advise::trace::Chunk::new(start, end, trace.len())
                            .expect("start < end <= len"),
                    ),
                });
                start = end;
            }
        }
        if eps.is_empty() {
            return Err(simple(
                py,
                "advise::trace::no_demonstrations",
                "no rows to fit".into(),
                "pass at least one demonstrated point",
            ));
        }
        self.derive(py, eps)
    }

    /// The demonstrations of a file, read as `load demos FILE` reads it (see
    /// [`advise::session::read_demos_file`]).
    fn fit_file(&mut self, py: Python<'_>, path: &str) -> PyResult<()> {
        let mut files = SourceMap::new();
        let read = advise::session::read_demos_file(
            &mut files,
            &self.set,
            &self.domain,
            self.def.as_ref(),
            path,
            &Default::default(),
        )
        .map_err(|e| from_diag(py, &files, &e))?;
        self.derive(py, read.episodes)
    }

    /// The learner, once fitted (`advise::py::not_fitted` before), and the domain.
    fn fitted(&mut self, py: Python<'_>) -> PyResult<(&mut Learner, &Domain)> {
        let kind = self.kind;
        match &mut self.learner {
            Some(l) => Ok((l, &self.domain)),
            None => Err(not_fitted(py, kind)),
        }
    }

    /// The action for each row of `observations`, computed without the GIL.
    fn predict<'py>(
        &self,
        py: Python<'py>,
        observations: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let Some(learner) = &self.learner else {
            return Err(not_fitted(py, self.kind));
        };
        let (od, ad) = (self.domain.obs_dim(), self.domain.act_dim());
        let (z, n) = matrix(py, observations, "observations", Some(od))?;
        let a = py.detach(|| {
            let mut a = vec![0.0; n * ad];
            for (zi, ai) in z.chunks_exact(od).zip(a.chunks_exact_mut(ad)) {
                learner.act(zi, ai);
            }
            a
        });
        to_numpy(py, a, n, ad)
    }
}

/// A learner behind a lock any Python thread may take: predictions share it (the GIL is
/// released while they compute), a fit or a critique holds it alone. A call that finds it
/// held the other way is refused with `advise::py::busy`, never made to wait (it would wait
/// holding the GIL the other thread needs to finish).
struct Shared(RwLock<Fitted>);

impl Shared {
    fn read(&self, py: Python<'_>) -> PyResult<RwLockReadGuard<'_, Fitted>> {
        match self.0.try_read() {
            Ok(g) => Ok(g),
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(TryLockError::WouldBlock) => Err(busy(py)),
        }
    }

    fn write(&self, py: Python<'_>) -> PyResult<RwLockWriteGuard<'_, Fitted>> {
        match self.0.try_write() {
            Ok(g) => Ok(g),
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(TryLockError::WouldBlock) => Err(busy(py)),
        }
    }
}

/// `advise::py::busy`: a learner another thread is fitting, critiquing or predicting with.
fn busy(py: Python<'_>) -> PyErr {
    simple(
        py,
        "advise::py::busy",
        "the learner is in use by another thread (a fit or critique holds it alone)".into(),
        "predictions may run in several threads at once; fit and critique one thread at a \
         time: wait for that thread (`join` it), or give each thread a learner of its own",
    )
}

/// `advise::py::not_fitted`: a learner of `kind` asked to act before it has data.
fn not_fitted(py: Python<'_>, kind: LearnerKind) -> PyErr {
    simple(
        py,
        "advise::py::not_fitted",
        format!("this {} learner has no data", kind.name()),
        "call `fit(observations, actions)` or `fit_file(path)` first",
    )
}

/// One learner class per kind: the same methods over [`Fitted`].
macro_rules! learner_class {
    ($name:ident, $kind:expr, $doc:literal) => {
        #[doc = $doc]
        // The Python names of the paper's learners (`advise.BC`, `advise.LWR`).
        #[allow(clippy::upper_case_acronyms)]
        #[pyclass(module = "advise")]
        pub struct $name(Shared);

        #[pymethods]
        impl $name {
            #[new]
            /// `task` (built in, or declared in `tasks`: a task file or a list of them, as
            /// `advise.Session` takes them) or `domain` says what the observations and actions
            /// are. `k` (LWR): its kernel limited to the k nearest points (default: no limit up
            /// to 20,000 points, beyond them the tuned kernel's mean neighbours).
            #[pyo3(signature = (*, task=None, domain=None, tasks=None, seed=0, k=None))]
            fn new(
                py: Python<'_>,
                task: Option<&str>,
                domain: Option<&str>,
                tasks: Option<&Bound<'_, PyAny>>,
                seed: u64,
                k: Option<usize>,
            ) -> PyResult<Self> {
                let mut fitted = Fitted::new(py, $kind, domain, task, tasks, seed)?;
                if k.is_some() && $kind != LearnerKind::Lwr {
                    return Err(simple(
                        py,
                        "advise::py::bad_argument",
                        "`k` limits LWR's kernel; BC has none".into(),
                        "leave `k` out, or use advise.LWR(k=...)",
                    ));
                }
                fitted.lwr_k = k.map(|k| k.max(1));
                Ok($name(Shared(RwLock::new(fitted))))
            }

            /// fit(observations, actions, episodes=None) -> self
            ///
            /// Derive the policy from demonstrations: `observations` (n, obs_dim) and `actions`
            /// (n, act_dim); `episodes` labels each row's episode (contiguous), default one.
            #[pyo3(signature = (observations, actions, episodes=None))]
            fn fit<'py>(
                slf: PyRef<'py, Self>,
                observations: &Bound<'py, PyAny>,
                actions: &Bound<'py, PyAny>,
                episodes: Option<&Bound<'py, PyAny>>,
            ) -> PyResult<PyRef<'py, Self>> {
                let py = slf.py();
                slf.0.write(py)?.fit(py, observations, actions, episodes)?;
                Ok(slf)
            }

            /// fit_file(path) -> self
            ///
            /// Derive the policy from a demonstrations file, read as `load demos FILE` reads
            /// it: CSV, JSON, a saved dataset, Parquet, or (with `task=`) a ROS 2 bag or CSV
            /// log of a base's drive.
            fn fit_file<'py>(
                slf: PyRef<'py, Self>,
                path: &str,
            ) -> PyResult<PyRef<'py, Self>> {
                let py = slf.py();
                slf.0.write(py)?.fit_file(py, path)?;
                Ok(slf)
            }

            /// predict(observations) -> actions
            ///
            /// The policy's action for each row of `observations` (n, obs_dim), as an
            /// (n, act_dim) array; the GIL is released while it computes.
            fn predict<'py>(
                &self,
                py: Python<'py>,
                observations: &Bound<'py, PyAny>,
            ) -> PyResult<Bound<'py, PyArray2<f64>>> {
                self.0.read(py)?.predict(py, observations)
            }

            /// critique(observations, *, chunk=None, kappa=1.0, rule="paper", actions=None)
            /// -> Critique
            ///
            /// The REPL's `critique KAPPA` on `chunk` ((start, end), default all) of a trace
            /// of `observations` (n, obs_dim): the data points that supported those steps
            /// get their weight m raised by kappa over their scaled distance (`rule=
            /// "directional"`: only for queries from the flagged side). The trace, with
            /// `actions` (default the learner's own), is recorded in the dataset as the
            /// critiqued execution. Returns what was raised, by how much, and the REPL's reply.
            #[pyo3(signature = (observations, *, chunk=None, kappa=advise::session::DEFAULT_KAPPA, rule="paper", actions=None))]
            fn critique(
                &self,
                py: Python<'_>,
                observations: &Bound<'_, PyAny>,
                chunk: Option<(usize, usize)>,
                kappa: f64,
                rule: &str,
                actions: Option<&Bound<'_, PyAny>>,
            ) -> PyResult<crate::explain::Critique> {
                let args = crate::explain::CritiqueArgs {
                    observations,
                    actions,
                    chunk,
                    kappa,
                    rule,
                };
                let mut fitted = self.0.write(py)?;
                let (learner, domain) = fitted.fitted(py)?;
                crate::explain::critique(py, learner, domain, args)
            }

            /// why(observation) -> Why
            ///
            /// The REPL's `why` at one observation: the BC nearest point with its distance,
            /// weight and provenance, LWR's neighbourhood, each one's action, and the REPL's
            /// text.
            fn why(
                &self,
                py: Python<'_>,
                observation: &Bound<'_, PyAny>,
            ) -> PyResult<crate::explain::Why> {
                let mut fitted = self.0.write(py)?;
                let (learner, domain) = fitted.fitted(py)?;
                crate::explain::why(py, learner, domain, observation)
            }

            /// weights() -> array
            ///
            /// Every data point's weight m (the paper's rule), in dataset order.
            fn weights<'py>(
                &self,
                py: Python<'py>,
            ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
                let mut fitted = self.0.write(py)?;
                let (learner, _) = fitted.fitted(py)?;
                Ok(crate::explain::weights(py, learner))
            }

            /// dataset() -> dict
            ///
            /// The data points with their provenance, in dataset order (as `save` writes
            /// them): `observations` (n, obs_dim), `actions` (n, act_dim), `weights` (n,) m,
            /// `source` (n,) `"demonstration"` or `"advice"`, `source_id` (n,) the
            /// demonstration's or the advice's id, `index` (n,) the point's index in it,
            /// `execution_index` (n,) the execution point an advice point was synthesized from
            /// (-1 for a demonstration); `demonstrations` and `advice` (a dict each: id, name or
            /// operator, invocation, chunk), `domain`, `observation_names`, `action_names`.
            /// `advise.to_arrow` makes it a pyarrow table.
            fn dataset<'py>(
                &self,
                py: Python<'py>,
            ) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
                let mut fitted = self.0.write(py)?;
                let (learner, _) = fitted.fitted(py)?;
                crate::dataset::dataset_dict(py, learner.dataset())
            }

            /// kernel() -> dict | None
            ///
            /// LWR's kernel as its last tuning chose it (docs/protocol.md, issue 48):
            /// `bandwidth` (tuned), `query_bandwidth` (what queries use: times the density
            /// factor beyond the 20,000-point tuning sample), `scales` (per observation
            /// dimension, on top of range scaling), `folds` and `sources` (the held-out
            /// demonstrations and pieces of advice), `loss` and `standard_error` of the chosen
            /// kernel, `held_out_scored`, `held_out_covered` and `held_out_coverage` (the share
            /// of scored held-out points whose kernel held data of other sources),
            /// `mean_neighbours`. None before the learner tuned LWR (a BC learner).
            fn kernel<'py>(
                &self,
                py: Python<'py>,
            ) -> PyResult<Option<Bound<'py, pyo3::types::PyDict>>> {
                let fitted = self.0.read(py)?;
                let Some(learner) = &fitted.learner else {
                    return Err(not_fitted(py, fitted.kind));
                };
                let Some(t) = learner.last_tuning() else {
                    return Ok(None);
                };
                let d = pyo3::types::PyDict::new(py);
                d.set_item("bandwidth", t.params.bandwidth)?;
                d.set_item("query_bandwidth", learner.lwr_query_bandwidth())?;
                d.set_item("scales", t.params.scales.clone())?;
                d.set_item("folds", t.folds)?;
                d.set_item("sources", t.sources)?;
                d.set_item("loss", t.loss)?;
                d.set_item("standard_error", t.se)?;
                let held_out = learner.held_out_coverage().unwrap_or_default();
                d.set_item("held_out_scored", held_out.steps)?;
                d.set_item("held_out_covered", held_out.covered)?;
                d.set_item("held_out_coverage", held_out.share())?;
                d.set_item("mean_neighbours", t.mean_neighbours)?;
                Ok(Some(d))
            }

            /// coverage(observations) -> dict | None
            ///
            /// How many rows of `observations` (n, obs_dim) (a run's steps) find data in LWR's
            /// kernel, as a run's reply counts them: `steps`, `covered`, `share`. None for a
            /// BC learner, whose policy has no kernel.
            fn coverage<'py>(
                &self,
                py: Python<'py>,
                observations: &Bound<'py, PyAny>,
            ) -> PyResult<Option<Bound<'py, pyo3::types::PyDict>>> {
                let fitted = self.0.read(py)?;
                let Some(learner) = &fitted.learner else {
                    return Err(not_fitted(py, fitted.kind));
                };
                let od = fitted.domain.obs_dim();
                let (z, _) = matrix(py, observations, "observations", Some(od))?;
                let Some(c) = py.detach(|| learner.coverage_of(z.chunks_exact(od))) else {
                    return Ok(None);
                };
                let d = pyo3::types::PyDict::new(py);
                d.set_item("steps", c.steps)?;
                d.set_item("covered", c.covered)?;
                d.set_item("share", c.share())?;
                Ok(Some(d))
            }

            /// The number of data points the policy holds.
            fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
                Ok(self.0.read(py)?.learner.as_ref().map_or(0, Learner::len))
            }

            /// The domain's name.
            #[getter]
            fn domain(&self, py: Python<'_>) -> PyResult<String> {
                Ok(self.0.read(py)?.domain.name.clone())
            }
        }
    };
}

learner_class!(
    BC,
    LearnerKind::Bc,
    "Binary Critiquing's learner: weighted 1-nearest-neighbour over range-scaled observations."
);
learner_class!(
    LWR,
    LearnerKind::Lwr,
    "A-OPI's learner: locally weighted regression, its kernel tuned by cross-validation."
);
