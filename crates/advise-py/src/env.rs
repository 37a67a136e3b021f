//! `advise._advise.SimEnv`: one simulated episode of a task, stepped from Python; the Gymnasium
//! environments of `advise/gym.py` wrap it.
//!
//! A step is one step of the library's [`Stepper`], the loop of [`advise::task::run_episode`]:
//! the same order, clamping, time limit and ending, so an episode stepped from Python is the
//! episode `advise demo` records. Episode `index` of `seed` starts from the task's
//! practice start `index` of `seed` on a simulator seeded with `episode_seed(seed, index)`: the
//! episode `advise demo --seed SEED` records as `demo-INDEX`.

use std::sync::{Mutex, MutexGuard, TryLockError};

use advise::backend::sim::{SimBackend, SimParams};
use advise::domain::Domain;
use advise::task::{Ending, Stepper, Task, TaskKind, episode_seed};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::matrix;
use crate::error::simple;

/// The simulator of a task (`positioning`, `interception`, or one declared in a file), stepped
/// from Python. Any thread may step it, one call at a time: the episode is behind a lock, and a
/// call while another thread's holds it is refused (`advise::py::busy`).
#[pyclass(module = "advise")]
pub struct SimEnv {
    kind: TaskKind,
    domain: Domain,
    params: SimParams,
    episode: Mutex<Option<Episode>>,
}

/// What `step` returns: observation, reward, terminated, truncated, info (Gymnasium's order).
type Transition<'py> = (
    Bound<'py, PyArray1<f64>>,
    f64,
    bool,
    bool,
    Bound<'py, PyDict>,
);

/// The episode under way.
struct Episode {
    backend: SimBackend,
    task: Box<dyn Task>,
    /// The library's stepper, the loop of `run_episode`; `None` once the episode is over.
    stepper: Option<Stepper>,
}

#[pymethods]
impl SimEnv {
    /// `SimEnv(task, tasks=None)`: a built-in task, or one declared in the files `tasks`
    /// (checked on top of the standard operators, as `advise run --tasks FILE` checks them).
    #[new]
    #[pyo3(signature = (task, tasks=None))]
    fn new(py: Python<'_>, task: &str, tasks: Option<Vec<String>>) -> PyResult<SimEnv> {
        let kind = crate::named::task_kind(py, task, tasks)?;
        Ok(SimEnv {
            domain: kind.domain(),
            kind,
            params: SimParams::default(),
            episode: Mutex::new(None),
        })
    }

    /// The observation's dimension.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.domain.obs_dim()
    }

    /// Each action dimension's (low, high) limits.
    fn action_limits(&self) -> Vec<(f64, f64)> {
        self.domain
            .act
            .iter()
            .map(|d| d.limits.map_or((f64::MIN, f64::MAX), |l| (l.lo, l.hi)))
            .collect()
    }

    /// Each observation's declared (low, high) range; unbounded where the task declares none.
    fn observation_limits(&self) -> Vec<(f64, f64)> {
        self.domain
            .observe
            .iter()
            .map(|d| {
                d.limits
                    .map_or((f64::NEG_INFINITY, f64::INFINITY), |l| (l.lo, l.hi))
            })
            .collect()
    }

    /// The control period, seconds.
    #[getter]
    fn period_s(&self) -> f64 {
        self.params.period_s()
    }

    /// reset(seed, index) -> observation: start episode `index` of `seed`.
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: u64,
        index: u64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let start = self
            .kind
            .practice_start(seed, index)
            .map_err(|e| crate::error::from_diag(py, &advise::diag::SourceMap::new(), &e))?;
        let mut backend = SimBackend::new(self.params.clone(), episode_seed(seed, index));
        let mut task = start.task();
        let stepper = Stepper::begin(&mut backend, task.as_mut())
            .map_err(|i| crate::error::from_diag(py, &advise::diag::SourceMap::new(), &i.error))?;
        let z = stepper.observation().to_vec();
        // An observation that is not a number ends the episode before anything acts on it.
        let stepper = (!stepper.is_over()).then_some(stepper);
        *self.episode(py)? = Some(Episode {
            backend,
            task,
            stepper,
        });
        Ok(z.into_pyarray(py))
    }

    /// step(action) -> (observation, reward, terminated, truncated, info)
    ///
    /// The reward is 1 at the end of a successful episode, else 0.
    fn step<'py>(&self, py: Python<'py>, action: &Bound<'py, PyAny>) -> PyResult<Transition<'py>> {
        let np = py.import("numpy")?;
        let row = np.call_method1("reshape", (action, (1, -1)))?;
        let (a, _) = matrix(py, &row, "action", Some(self.domain.act_dim()))?;
        let mut episode = self.episode(py)?;
        let Some(Episode {
            backend,
            task,
            stepper: Some(stepper),
        }) = episode.as_mut()
        else {
            return Err(simple(
                py,
                "advise::py::not_reset",
                "the episode is over or was never started".into(),
                "call `reset()` first",
            ));
        };
        let ending = stepper
            .step(backend, task.as_mut(), &a)
            .map_err(|e| crate::error::from_diag(py, &Default::default(), &e))?;
        let z = stepper.observation().to_vec();
        let info = PyDict::new(py);
        let mut reward = 0.0;
        let truncated = ending == Some(Ending::TimeLimit);
        if ending.is_some()
            && let Some(ep) = episode.as_mut()
            && let Some(stepper) = ep.stepper.take()
        {
            // The episode as `run_episode` ends one: the base stopped, the score and the rule.
            let outcome = match stepper.finish(&mut ep.backend, ep.task.as_ref()) {
                Ok(exec) => exec.outcome,
                Err(i) => {
                    return Err(crate::error::from_diag(py, &Default::default(), &i.error));
                }
            };
            reward = if outcome.success { 1.0 } else { 0.0 };
            info.set_item("ending", format!("{:?}", outcome.ending))?;
            // Which `end when` rule ended it, as a run's reply names it.
            if let Some(rule) = &outcome.end_rule {
                info.set_item("end_rule", rule.clone())?;
            }
            info.set_item("success", outcome.success)?;
            info.set_item("position_error_m", outcome.position_error_m)?;
        }
        Ok((
            z.into_pyarray(py),
            reward,
            ending.is_some() && !truncated,
            truncated,
            info,
        ))
    }
}

impl SimEnv {
    /// The episode, unless another thread is stepping or resetting it.
    fn episode(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, Option<Episode>>> {
        match self.episode.try_lock() {
            Ok(g) => Ok(g),
            // A panic mid-step left the episode as it found it: it is used on.
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(TryLockError::WouldBlock) => Err(simple(
                py,
                "advise::py::busy",
                "the environment is being stepped in another thread".into(),
                "an environment runs one episode one step at a time: step it from one thread \
                 at a time, or give each thread an environment of its own",
            )),
        }
    }
}
