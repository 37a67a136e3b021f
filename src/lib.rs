//! `advise`: teach a robot's motion controller by critiquing and advising its executions.
//!
//! The phases, in order (see ARCHITECTURE.md): [`syntax`] (pest grammar to spanned AST),
//! [`check`] (AST to a checked [`program`], invocations bound to calls), [`interp`] (run a bound
//! call on a chunk),
//! [`policy`] (dataset with provenance, BC 1-NN, A-OPI LWR), [`backend`] (the bases a session
//! drives: the simulator, a Segway RMP, a ROS 2 base; and teleop, a person driving any of them
//! from the keyboard).
//! The shared data types are [`domain`], [`trace`] and [`geometry`] (poses and frames); every
//! file is read and written through [`files`], and every diagnostic is drawn by [`diag::render`]
//! from one [`diag::SourceMap`].

pub mod backend;
pub mod check;
pub mod cli;
pub mod diag;
pub mod doctest;
pub mod domain;
pub mod eval;
pub mod experiment;
pub mod files;
pub mod geometry;
pub mod interp;
pub mod lsp;
pub mod number;
pub mod policy;
pub mod program;
pub mod recording;
pub mod repl;
pub mod session;
pub mod syntax;
pub mod task;
pub mod trace;
