//! Policies: mappings from observations to actions derived from a dataset.
//!
//! This module owns the [`Policy`] trait that tasks, the evaluation harness and backends run.
//! Policies do no IO and print nothing.

/// A controller: observation in, action out.
///
/// `Sync` so that evaluation can run one policy on many starts in parallel.
pub trait Policy: Sync {
    /// Write the action for observation `z` into `a` (`a.len()` is the domain's action dimension).
    fn act(&self, z: &[f64], a: &mut [f64]);
}

impl<F: Fn(&[f64], &mut [f64]) + Sync> Policy for F {
    fn act(&self, z: &[f64], a: &mut [f64]) {
        self(z, a)
    }
}
