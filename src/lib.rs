//! `advise`: teach a robot's motion controller by critiquing and advising its executions.
//!
//! The phases, in order (see ARCHITECTURE.md): [`syntax`] (pest grammar to spanned AST),
//! [`check`] (AST to a checked operator set), [`interp`] (apply operators to chunks),
//! [`policy`] (dataset with provenance, BC 1-NN, A-OPI LWR), [`backend`] (sim and RMP bases).
//! The shared data types are [`domain`] and [`trace`]; every file is read and written through
//! [`files`], and every diagnostic is drawn by [`diagnostic::render`].

pub mod backend;
pub mod check;
pub mod diagnostic;
pub mod domain;
pub mod eval;
pub mod experiment;
pub mod files;
pub mod interp;
pub mod policy;
pub mod recording;
pub mod repl;
pub mod session;
pub mod syntax;
pub mod task;
pub mod trace;
