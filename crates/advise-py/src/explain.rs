//! `critique` and `why` of `advise.BC` and `advise.LWR`: the REPL's `critique` and `why` on a
//! learner fitted from Python, through the same [`Learner`] calls the session makes, so the
//! increments, weights and texts are the REPL's.
//!
//! A session records, when it runs, which data point supported each step, and critiques those.
//! Python has no run: the critiqued observations' support is taken when `critique` is called
//! ([`Learner::support_provenance`]), which is what acted for actions predicted since the last
//! change of the learner's data: the REPL's critique of a run made on the same data.

use advise::domain::Domain;
use advise::policy::Policy as _;
use advise::policy::dataset::{CritiqueRule, Provenance as Prov};
use advise::policy::learner::Learner;
use advise::trace::{Chunk, Trace};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use crate::arrays::matrix;
use crate::error::{from_diag, simple};
use crate::ops::trace_of;

/// Where a data point came from: `kind` is `demonstration` (point `index` of demonstration `id`,
/// named `name`) or `advice` (synthesized point `index` of advice `id`, from execution point
/// `source`).
#[pyclass(module = "advise", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct Provenance {
    pub kind: String,
    pub id: u32,
    pub name: Option<String>,
    pub index: u32,
    pub source: Option<u32>,
}

#[pymethods]
impl Provenance {
    fn __repr__(&self) -> String {
        format!(
            "Provenance({} {}, point {})",
            self.kind, self.id, self.index
        )
    }
}

impl Provenance {
    pub(crate) fn of(learner: &Learner, p: Prov) -> Provenance {
        match p {
            Prov::Demonstration { demo, index } => Provenance {
                kind: "demonstration".into(),
                id: demo,
                name: learner
                    .dataset()
                    .demos()
                    .iter()
                    .find(|d| d.id == demo)
                    .map(|d| d.name.clone()),
                index,
                source: None,
            },
            Prov::Advice {
                advice,
                index,
                source,
            } => Provenance {
                kind: "advice".into(),
                id: advice,
                name: None,
                index,
                source: Some(source),
            },
        }
    }
}

/// What a critique did: the chunk, kappa and rule; for each increment the data point raised
/// (`points`, positions in the dataset, with `provenance`), by how much (`increments`) and its
/// weight after (`weights`: m plus any directional increments); `summary` is the REPL's reply.
#[pyclass(module = "advise", frozen)]
pub struct Critique {
    #[pyo3(get)]
    chunk: (usize, usize),
    #[pyo3(get)]
    kappa: f64,
    #[pyo3(get)]
    rule: String,
    #[pyo3(get)]
    summary: String,
    #[pyo3(get)]
    provenance: Vec<Provenance>,
    points: Vec<i64>,
    increments: Vec<f64>,
    weights: Vec<f64>,
}

#[pymethods]
impl Critique {
    /// The dataset position of each increment's point (-1 for a point no longer there).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.points.clone().into_pyarray(py)
    }

    /// Each increment of its point's m, in the order they were made.
    #[getter]
    fn increments<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.increments.clone().into_pyarray(py)
    }

    /// Each increment's point's weight after the critique.
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.weights.clone().into_pyarray(py)
    }

    fn __repr__(&self) -> String {
        self.summary.clone()
    }
}

/// Why the learner acts as it does at one observation: the BC 1-nearest point (`point`, its
/// scaled `distance`, weight `m`, `weighted` = m * distance, its `bc_action` and `provenance`),
/// LWR's `lwr_neighbours`, `lwr_total_weight` and `lwr_action` (`lwr_tuned` False for a BC learner
/// that never ran as LWR: those three then come from LWR's untuned default parameters), the
/// running learner's `action`, and `text`, what the REPL's `why` prints after its first line.
#[pyclass(module = "advise", frozen, get_all)]
pub struct Why {
    pub point: Option<usize>,
    pub distance: Option<f64>,
    pub m: Option<f64>,
    pub weighted: Option<f64>,
    pub bc_action: Option<Vec<f64>>,
    pub provenance: Option<Provenance>,
    pub lwr_neighbours: usize,
    pub lwr_total_weight: f64,
    pub lwr_action: Vec<f64>,
    pub lwr_tuned: bool,
    pub action: Vec<f64>,
    pub text: String,
}

#[pymethods]
impl Why {
    fn __repr__(&self) -> String {
        self.text.clone()
    }
}

/// Options of a critique, as given in Python.
pub struct CritiqueArgs<'a, 'py> {
    pub observations: &'a Bound<'py, PyAny>,
    pub actions: Option<&'a Bound<'py, PyAny>>,
    pub chunk: Option<(usize, usize)>,
    pub kappa: f64,
    pub rule: &'a str,
}

/// The REPL's `critique KAPPA` (`--directional` with `rule="directional"`) on `chunk` of the
/// trace of `observations` (and `actions`, by default the learner's own), recorded as an
/// execution of the learner's dataset.
pub fn critique(
    py: Python<'_>,
    learner: &mut Learner,
    domain: &Domain,
    args: CritiqueArgs<'_, '_>,
) -> PyResult<Critique> {
    let rule = match args.rule {
        "paper" => CritiqueRule::Paper,
        "directional" => CritiqueRule::Directional,
        other => {
            return Err(simple(
                py,
                "advise::py::bad_argument",
                format!("there is no critique rule `{other}`"),
                "`rule=\"paper\"` (the paper's) or `rule=\"directional\"`",
            ));
        }
    };
    advise::session::check_kappa(args.kappa)
        .map_err(|e| crate::error::from_diag(py, &advise::diag::SourceMap::new(), &e))?;
    let actions = match args.actions {
        Some(a) => a.clone(),
        None => {
            let (z, n) = matrix(
                py,
                args.observations,
                "observations",
                Some(domain.obs_dim()),
            )?;
            predicted(py, learner, domain, &z, n)?.into_any()
        }
    };
    let trace: Trace = trace_of(py, domain, args.observations, &actions, None)?;
    let (a, b) = args.chunk.unwrap_or((0, trace.len()));
    let chunk =
        Chunk::new(a, b, trace.len()).map_err(|e| from_diag(py, &Default::default(), &e))?;
    let learn_err =
        |e: advise::policy::learner::LearnerError| from_diag(py, &Default::default(), &e);
    let support = learner.support_provenance(&trace);
    let plan = learner
        .plan_critique(&trace, chunk, args.kappa, Some(&support), rule)
        .map_err(learn_err)?;
    let execution = learner.try_add_execution(&trace).map_err(learn_err)?;
    learner
        .add_critique(execution, plan.critique.clone())
        .map_err(learn_err)?;
    let ds = learner.dataset();
    let positions: Vec<Option<usize>> = plan
        .critique
        .increments
        .iter()
        .map(|(p, _)| ds.position(*p))
        .collect();
    Ok(Critique {
        chunk: (chunk.start, chunk.end),
        kappa: args.kappa,
        rule: rule.name().into(),
        summary: learner.critique_summary(&plan),
        provenance: plan
            .critique
            .increments
            .iter()
            .map(|(p, _)| Provenance::of(learner, *p))
            .collect(),
        points: positions
            .iter()
            .map(|p| p.map_or(-1, |i| i as i64))
            .collect(),
        increments: plan.critique.increments.iter().map(|(_, x)| *x).collect(),
        weights: positions
            .iter()
            .map(|p| p.map_or(f64::NAN, |i| ds.max_weight(i)))
            .collect(),
    })
}

/// The learner's actions at the `n` observations `z`, as a numpy array.
fn predicted<'py>(
    py: Python<'py>,
    learner: &Learner,
    domain: &Domain,
    z: &[f64],
    n: usize,
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let ad = domain.act_dim();
    let mut a = vec![0.0; n * ad];
    for (zi, ai) in z.chunks_exact(domain.obs_dim()).zip(a.chunks_exact_mut(ad)) {
        learner.act(zi, ai);
    }
    crate::arrays::to_numpy(py, a, n, ad)
}

/// The REPL's `why` at one observation (a row or a 1-D array).
pub fn why(
    py: Python<'_>,
    learner: &mut Learner,
    domain: &Domain,
    observation: &Bound<'_, PyAny>,
) -> PyResult<Why> {
    let np = py.import("numpy")?;
    let row = np.call_method1("reshape", (observation, (1, -1)))?;
    let (z, _) = matrix(py, &row, "observation", Some(domain.obs_dim()))?;
    learner.ensure_derived();
    let name = |id| format!("advice (dataset id {id})");
    let text = learner
        .why(&z, &name)
        .map_err(|e| from_diag(py, &Default::default(), &e))?;
    let support = learner.support(&z);
    let ds = learner.dataset();
    let mut lwr_action = vec![0.0; domain.act_dim()];
    let answer = learner.regress(&z, &mut lwr_action);
    let mut action = vec![0.0; domain.act_dim()];
    learner.act(&z, &mut action);
    Ok(Why {
        point: support.map(|s| s.point),
        distance: support.map(|s| s.distance),
        m: support.map(|s| s.m),
        weighted: support.map(|s| s.weighted),
        bc_action: support.map(|s| ds.a(s.point).to_vec()),
        provenance: support.map(|s| Provenance::of(learner, ds.provenance(s.point))),
        lwr_neighbours: answer.neighbours,
        lwr_total_weight: answer.total_weight,
        lwr_action,
        lwr_tuned: learner.lwr_tuned_at().is_some(),
        action,
        text,
    })
}

/// Every data point's weight m (the paper's rule; directional increments apart).
pub fn weights<'py>(py: Python<'py>, learner: &Learner) -> Bound<'py, PyArray1<f64>> {
    learner.dataset().weights().into_pyarray(py)
}
