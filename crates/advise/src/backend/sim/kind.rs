//! The simulator as the registry knows it: the `sim` kind and its spec, which connect a
//! [`SimBackend`]. Beside the simulator, not in it, so that the simulator's parameters (which
//! every spec's connection carries) do not reach back for the registry (issue 50).

use super::SimBackend;
use crate::backend::registry::BackendKind;
use crate::backend::spec::{BackendSpecError, Connect, Spec};
use crate::backend::{BackendError, Base};

/// The registry's `sim` kind: the in-process simulator.
pub struct SimKind;

impl BackendKind for SimKind {
    fn name(&self) -> &'static str {
        "sim"
    }

    fn syntax(&self) -> &'static str {
        "sim"
    }

    fn about(&self) -> &'static str {
        "the simulator"
    }

    fn claims(&self, spec: &str) -> bool {
        spec == "sim"
    }

    fn parse(&self, _spec: &str) -> Result<Box<dyn Spec>, BackendSpecError> {
        Ok(Box::new(SimSpec))
    }
}

/// `sim`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimSpec;

impl std::fmt::Display for SimSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("sim")
    }
}

impl Spec for SimSpec {
    fn connect(&self, with: &Connect<'_>) -> Result<Box<dyn Base>, BackendError> {
        Ok(Box::new(SimBackend::new(with.sim.clone(), with.seed)))
    }

    fn is_simulator(&self) -> bool {
        true
    }
}
