//! `advise-learn`: policies, mappings from observations to actions derived from a dataset. The
//! application re-exports this crate as `advise::policy`.
//!
//! This crate owns the [`Policy`] trait that tasks, the evaluation harness and backends run, the
//! [`dataset`] with provenance, the two learners of the paper ([`bc`]: weighted 1-NN for Binary
//! Critiquing; [`lwr`]: locally weighted regression for A-OPI), and the [`learner::Learner`] that
//! keeps a dataset and its derived policy in step. Only [`index`] touches kiddo. Policies do no IO
//! and print nothing; datasets load and save themselves.
//!
//! The one crate of the workspace allowed `unsafe`: the AVX2 range search in [`index`]. Every
//! unsafe operation sits in its own block with the reason it is sound (`// SAFETY:`), and the lints
//! below make that the compiler's rule, not a convention.
#![deny(unsafe_op_in_unsafe_fn, clippy::undocumented_unsafe_blocks)]

pub mod bc;
pub mod dataset;
pub mod exp;
pub mod index;
pub mod learner;
pub mod lwr;

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
