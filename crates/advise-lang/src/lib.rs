//! `advise-lang`: the language of advice operators, from text to running a bound call on a chunk.
//!
//! The phases, in order (see ARCHITECTURE.md): [`syntax`] (pest grammars to spanned ASTs, the
//! formatter, the session's command table), [`check`] (AST to a checked [`program`], invocations
//! bound to calls), [`interp`] (run a bound call on a chunk), and [`doctest`] (the examples in
//! operators' docs, run). The shared data types are [`domain`], [`trace`] and [`geometry`] (poses
//! and frames); every file is read and written through [`files`], and every diagnostic is drawn by
//! [`diag::render`] from one [`diag::SourceMap`].
//!
//! No network, no terminal, no robot: the crate reads and writes only the files it is given, so the
//! language server and the fuzz target build on it alone. Each module uses only the modules before
//! it in this list (`tests/architecture.rs`).
#![forbid(unsafe_code)]

pub mod check;
pub mod diag;
pub mod doctest;
pub mod domain;
pub mod files;
pub mod geometry;
pub mod interp;
pub mod number;
pub mod program;
pub mod syntax;
pub mod trace;
