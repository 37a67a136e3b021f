//! One of the paper's studies for one seed or a range of seeds: the loop the command line runs,
//! written once for both studies. A single seed gives that run's figures; a range (even of one
//! seed) gives each figure's mean and spread beside the paper's.

use std::path::{Path, PathBuf};

use serde::Serialize;

use rayon::prelude::*;

use super::protocol::Revert;
pub use super::protocol::Study;
use super::{ExperimentError, Progress, aopi, bc, ensure_dir, plot, summary};
use crate::backend::sim::SimParams;

/// Which seeds to run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Seeds {
    /// One run, reported on its own.
    One(u64),
    /// Every seed of a half-open range, summarised.
    Range(std::ops::Range<u64>),
}

/// What a study produced: its figures as text and as pretty JSON (ending in a newline), and the
/// plots written.
#[derive(Clone, Debug)]
pub struct StudyOutput {
    pub text: String,
    pub json: String,
    pub plots: Vec<PathBuf>,
}

/// The BC study's own options (`advise experiment bc --critique RULE --teacher ARM`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BcChoices {
    pub critique: bc::Rules,
    pub teachers: bc::Teachers,
}

/// Run `study` for `seeds` on the simulator with `sim` (the BC study under the critique rules
/// and with the teachers' arms of `bc_choices`; with the protocol's choice `revert` reverted, for the ablation; the A-OPI arms
/// capped at `practice` practice goals when given), plotting each run into `plot_dir` (created
/// if needed, before anything runs) when given.
// Each argument is one of `advise experiment`'s options, as the command line and the Python
// package pass them.
#[allow(clippy::too_many_arguments)]
pub fn run(
    study: Study,
    seeds: &Seeds,
    sim: SimParams,
    bc_choices: BcChoices,
    revert: Option<Revert>,
    practice: Option<usize>,
    plot_dir: Option<&Path>,
    progress: bool,
) -> Result<StudyOutput, ExperimentError> {
    if let Some(dir) = plot_dir {
        ensure_dir(dir)?;
    }
    let out = match study {
        Study::Bc => {
            let params = bc::BcParams {
                sim,
                critique: bc_choices.critique,
                teachers: bc_choices.teachers,
                ..bc::BcParams::default()
            };
            let params = match revert {
                Some(choice) => choice.bc(params),
                None => params,
            };
            each_seed(
                seeds,
                plot_dir,
                progress,
                super::calibrate::shipped(study),
                |seed, bar| bc::run(seed, &params, bar),
                plot::bc,
                bc::BcResult::render,
                summary::bc,
                summary::BcSummary::render,
            )
        }
        Study::Aopi => {
            let defaults = aopi::AopiParams::default();
            let params = aopi::AopiParams {
                sim,
                max_practice: practice.unwrap_or(defaults.max_practice),
                ..defaults
            };
            let params = match revert {
                Some(choice) => choice.aopi(params),
                None => params,
            };
            each_seed(
                seeds,
                plot_dir,
                progress,
                super::calibrate::shipped(study),
                |seed, bar| aopi::run(seed, &params, bar),
                plot::aopi,
                aopi::AopiResult::render,
                summary::aopi,
                summary::AopiSummary::render,
            )
        }
    }?;
    Ok(match revert {
        // The text says what was reverted, so an ablation's output is never read as the
        // protocol's; the JSON says it at the top and in every run's parameters.
        Some(choice) => StudyOutput {
            text: format!(
                "ablation: protocol choice {} (`{}`) reverted alone; not the protocol's figures\n{}",
                choice.point(),
                choice.name(),
                out.text
            ),
            json: with_revert(&out.json, choice),
            ..out
        },
        None => out,
    })
}

/// A study's JSON (a pretty-printed object) with `"revert": CHOICE` as its first field, for the
/// ablation's files; the rest is unchanged, in its order.
fn with_revert(json: &str, choice: Revert) -> String {
    match json.strip_prefix("{\n") {
        Some(rest) => format!("{{\n  \"revert\": \"{}\",\n{rest}", choice.name()),
        None => json.to_string(),
    }
}

/// The seed loop of either study: run, plot, then report the one run or summarise them all.
/// A range's seeds run in parallel (each study also spreads its own evaluations over the
/// cores), with one progress bar counting seeds; results keep the seeds' order, so the output
/// is the same however the runs were scheduled.
#[allow(clippy::too_many_arguments)]
fn each_seed<R: Serialize + Send, S: Serialize>(
    seeds: &Seeds,
    plot_dir: Option<&Path>,
    progress: bool,
    calibration: Option<serde_json::Value>,
    run: impl Fn(u64, bool) -> R + Sync,
    draw: impl Fn(&R, &Path) -> Result<Vec<PathBuf>, ExperimentError>,
    render: impl Fn(&R) -> String,
    summarise: impl FnOnce(Vec<R>) -> S,
    render_summary: impl Fn(&S) -> String,
) -> Result<StudyOutput, ExperimentError> {
    let runs: Vec<R> = match seeds {
        Seeds::One(seed) => vec![run(*seed, progress)],
        Seeds::Range(range) => {
            let list: Vec<u64> = range.clone().collect();
            let bar = Progress::new(progress, list.len() as u64, "seeds");
            let runs = list
                .par_iter()
                .map(|&seed| {
                    let r = run(seed, false);
                    bar.inc(1);
                    r
                })
                .collect();
            bar.finish();
            runs
        }
    };
    let mut plots = Vec::new();
    if let Some(dir) = plot_dir {
        for r in &runs {
            plots.extend(draw(r, dir)?);
        }
    }
    let (text, json) = match seeds {
        Seeds::One(_) => {
            let r = &runs[0];
            (
                render(r),
                pretty(&WithCalibration {
                    result: r,
                    calibration,
                }),
            )
        }
        Seeds::Range(_) => {
            let s = summarise(runs);
            let json = pretty(&WithCalibration {
                result: &s,
                calibration,
            });
            (render_summary(&s), json)
        }
    };
    Ok(StudyOutput { text, json, plots })
}

/// A study's JSON with the shipped calibration's fit report (what the defaults were fitted to, and
/// how closely) under `calibration`.
#[derive(Serialize)]
struct WithCalibration<'a, T: Serialize> {
    #[serde(flatten)]
    result: &'a T,
    #[serde(skip_serializing_if = "Option::is_none")]
    calibration: Option<serde_json::Value>,
}

fn pretty(value: &impl Serialize) -> String {
    let mut t = serde_json::to_string_pretty(value).expect("a result is plain data");
    t.push('\n');
    t
}
