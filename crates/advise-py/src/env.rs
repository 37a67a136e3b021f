//! The simulator, one episode step by step (placeholder until the Gymnasium environment lands).

use pyo3::prelude::*;

/// The simulator of a task, stepped from Python.
#[pyclass(module = "advise")]
pub struct SimEnv {}
