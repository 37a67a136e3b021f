//! `advise`: teach a robot's motion controller by critiquing and advising its executions.
//!
//! The workspace's crates, in order (see ARCHITECTURE.md): `advise-lang`, the language
//! ([`syntax`], [`check`], [`program`], [`interp`], [`doctest`], with the shared data types
//! [`domain`], [`trace`], [`geometry`], the file access of [`files`] and the diagnostics of
//! [`diag`]); `advise-learn`, the learners ([`policy`]: dataset with provenance, BC 1-NN, A-OPI
//! LWR); `advise-lsp`, the language server on `advise-lang` alone ([`lsp`]); and this crate, the
//! application: [`backend`] (the bases a session drives: the simulator, a Segway RMP, a ROS 2
//! base; and teleop, a person driving any of them from the keyboard), [`task`], [`eval`],
//! [`recording`], [`experiment`], [`session`], [`repl`] and [`cli`]. The libraries are
//! re-exported under their module names, so `advise::check` and `crate::check` name the same
//! module everywhere.

pub use advise_lang::{
    check, diag, doctest, domain, files, geometry, interp, number, program, syntax, trace,
};
pub use advise_learn as policy;
pub use advise_lsp as lsp;

// First, so that its printing macros (`outln!`, `errln!`, `err!`) reach the modules below.
#[macro_use]
pub mod repl;
pub mod backend;
pub mod cli;
pub mod eval;
pub mod experiment;
pub mod recording;
pub mod session;
pub mod task;
pub mod web;
