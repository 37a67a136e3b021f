//! `advise`: teach a robot's motion controller by critiquing and advising its executions.
//!
//! The library every front end stands on (see ARCHITECTURE.md): the command line, the REPL and
//! the web view (`advise-cli`) and the Python package (`advise-py`). It knows no terminal, no
//! argument parser and no web server: long work reports through [`progress`], a person's keys
//! reach a drive through [`backend::teleop::KeySource`], and what a front end shows is the
//! session's replies and state as data.
//!
//! The workspace's crates, in order: `advise-lang`, the language ([`syntax`], [`check`],
//! [`program`], [`interp`], [`doctest`], with the shared data types [`domain`], [`trace`],
//! [`geometry`], the file access of [`files`] and the diagnostics of [`diag`]); `advise-learn`,
//! the learners ([`policy`]: dataset with provenance, BC 1-NN, A-OPI LWR); and this crate:
//! [`backend`] (the bases a session drives: the simulator, a Segway RMP and a ROS 2 base behind
//! the `rmp` and `ros2` features; and teleop, a person driving any of them), [`task`], [`eval`],
//! [`recording`], [`experiment`] and [`session`]. The libraries are re-exported under their
//! module names, so `advise::check` and `crate::check` name the same module everywhere.

pub use advise_lang::{
    check, diag, doctest, domain, files, geometry, interp, number, program, syntax, trace,
};
pub use advise_learn as policy;

pub mod choice;
pub mod progress;

pub mod backend;
pub mod eval;
pub mod experiment;
pub mod recording;
pub mod session;
pub mod task;
