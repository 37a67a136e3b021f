//! Experiments: the paper's two studies, end to end, with automated teachers.
//!
//! [`bc`] reproduces the Binary Critiquing study (ball interception, BC 1-NN learner, Table 1 and
//! Figure 5) with the [`critic`]; [`aopi`] reproduces the A-OPI study (spatial positioning, LWR
//! learner, Figures 8, 9 and 11) with the [`advisor`], which speaks only through the standard
//! advice operators. [`plot`] draws their figures as SVG. Every random choice is seeded from the
//! experiment's seed (demonstration and practice starts, simulator noise, LWR tuning), so a run is
//! reproducible bit for bit; the fixed test sets are never critiqued or advised.
//!
//! This module computes and summarises; it prints nothing except the progress bar (only on a
//! terminal, only when asked) and writes files only when asked to plot.

use std::path::Path;

use miette::Diagnostic;
use rayon::prelude::*;
use thiserror::Error;

use crate::backend::sim::SimParams;
use crate::eval::{ControllerBox, Report};
use crate::task::{InterceptionRules, Outcome, Start, TaskKind, episode_seed, run_sim_in};
use crate::trace;

pub mod ablation;
pub mod advisor;
pub mod aopi;
pub mod bc;
pub mod calibrate;
pub mod critic;
pub mod pilot;
pub mod plot;
pub mod protocol;
pub mod study;
pub mod summary;
pub mod takeover_arm;

/// Salts that keep the seed's streams apart: test-set noise, practice-execution noise.
const EVAL_SALT: u64 = 0x7E57_0000_0000_0001;
const PRACTICE_SALT: u64 = 0x9AC7_0000_0000_0002;

/// The simulator of an experiment: the parameters file `path` (read into `map`, where its
/// diagnostics point), or the defaults. `--sim-params FILE` and the Python studies' `sim_params=`.
pub fn sim_params(
    map: &mut crate::diag::SourceMap,
    path: Option<&Path>,
) -> Result<SimParams, crate::backend::sim::SimError> {
    match path {
        Some(p) => SimParams::load(map, p),
        None => Ok(SimParams::default()),
    }
}

/// The largest chunk either study's automated teacher flags or advises, points: the middle of
/// the paper's "typical sizes in this work are 20-30 points" (the second protocol, S4).
pub const CHUNK_POINTS: usize = 25;

/// The one chunk rule of both studies' automated teachers (the second protocol, S4,
/// docs/protocol.md): a chunk begins where the flaw begins, where the run began to "go wrong",
/// and holds at most [`CHUNK_POINTS`] points, fewer when the flawed `stretch` ends sooner. What
/// follows is left to the next execution, which shows it again if the correction did not reach
/// it.
pub fn chunk_rule(stretch: trace::Chunk) -> trace::Chunk {
    trace::Chunk {
        start: stretch.start,
        end: stretch.end.min(stretch.start.saturating_add(CHUNK_POINTS)),
    }
}

/// The simulator seed of test episode `i` of an experiment seeded with `seed`. Every policy of an
/// experiment (initial, final, teacher, each arm) meets the same noise on the same test start, so
/// their differences are the policies' own.
pub fn eval_seed(seed: u64) -> u64 {
    seed ^ EVAL_SALT
}

/// The simulator seed of practice execution `i` (critique round, advice cycle).
pub fn practice_seed(seed: u64, i: u64) -> u64 {
    episode_seed(seed ^ PRACTICE_SALT, i)
}

/// Why an experiment's output could not be written.
#[derive(Debug, Error, Diagnostic)]
pub enum ExperimentError {
    #[error("cannot create the plot folder `{path}`")]
    #[diagnostic(
        code(advise::experiment::plot_dir),
        help("check that the parent folder exists and is writable")
    )]
    PlotDir {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot draw `{path}`: {message}")]
    #[diagnostic(
        code(advise::experiment::plot),
        help("check that the folder is writable")
    )]
    Plot { path: String, message: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
}

/// Create the plot folder if needed.
pub fn ensure_dir(dir: &Path) -> Result<(), ExperimentError> {
    std::fs::create_dir_all(dir).map_err(|source| ExperimentError::PlotDir {
        path: dir.display().to_string(),
        source,
    })
}

/// A study's progress bar ([`crate::progress`]), drawn only when asked and a front end draws.
pub struct Progress {
    bar: Box<dyn crate::progress::Bar>,
}

impl Progress {
    pub fn new(show: bool, len: u64, message: &str) -> Progress {
        Progress {
            bar: crate::progress::bar(show, len, crate::progress::Unit::Items, message),
        }
    }

    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
    }

    pub fn set_message(&self, message: &str) {
        self.bar.set_message(message);
    }

    pub fn finish(&self) {
        self.bar.finish();
    }
}

/// Run controllers made by `make` from each of `starts` in parallel (episode `i` on a simulator
/// seeded with `episode_seed(eval_seed, i)`) and summarise. The same harness as
/// [`crate::eval::evaluate_with`], over any list of starts, so reduced experiments can use part
/// of a test set.
pub fn evaluate_starts<C, F>(
    kind: TaskKind,
    starts: &[Start],
    make: F,
    params: &SimParams,
    eval_seed: u64,
) -> Report
where
    C: ControllerBox,
    F: Fn() -> C + Sync,
{
    evaluate_starts_in(
        &InterceptionRules::default(),
        kind,
        starts,
        make,
        params,
        eval_seed,
    )
}

/// [`evaluate_starts`] with interception starts played in `world`.
pub fn evaluate_starts_in<C, F>(
    world: &InterceptionRules,
    kind: TaskKind,
    starts: &[Start],
    make: F,
    params: &SimParams,
    eval_seed: u64,
) -> Report
where
    C: ControllerBox,
    F: Fn() -> C + Sync,
{
    let outcomes: Vec<Outcome> = starts
        .par_iter()
        .enumerate()
        .map(|(i, start)| {
            let mut c = make();
            run_sim_in(
                start,
                world,
                c.controller(),
                params,
                episode_seed(eval_seed, i as u64),
            )
            .outcome
        })
        .collect();
    Report::from_outcomes(kind, eval_seed, outcomes)
}

/// Mean and sample standard deviation (0 for fewer than two values).
pub fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (0.0, 0.0);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
    (mean, var.sqrt())
}

fn pct(rate: f64) -> String {
    format!("{:.0}%", 100.0 * rate)
}

fn opt_m(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.2}"))
}
