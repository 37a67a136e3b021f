//! What a statement did to a session: the unit of the journal.
//!
//! A command does its work (drives the base, reads a file, synthesizes advice) and then hands the
//! session an [`Effect`]: the recorded execution, the points an advice added, the weights a
//! critique changed, the operator text a definition checked. Applying an effect is a pure state
//! change: it never reads a file, never connects to or drives a robot. The live session and
//! `advise resume` apply effects through the same code ([`crate::session::Session`]'s `apply`), so
//! a resumed session is the session that was journalled, not a re-run of its commands.
//!
//! Numbers are stored with serde_json's exact float round trip, so a restored dataset is bit for
//! bit the one that was saved.

use serde::{Deserialize, Serialize};

use crate::backend::sim::SimParams;
use crate::eval::Report;
use crate::interp::AppliedAdvice;
use crate::policy::dataset::{Critique, Provenance};
use crate::policy::learner::LearnerKind;
use crate::task::{Outcome, TaskKind};
use crate::trace::{Chunk, JsonTrace, Pose};

/// The first line of a journal: how the session started.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// Always [`JOURNAL_FORMAT`].
    pub format: String,
    /// The built-in task the session was made on; a declared task is reached by the entries.
    #[serde(deserialize_with = "header_task")]
    pub task: TaskKind,
    pub seed: u64,
    pub sim: SimParams,
    /// When the session started (seconds since the Unix epoch) and which process wrote it.
    pub started_unix_s: u64,
    pub pid: u32,
}

/// A header's task. Journals written before the header named the task a session was made on
/// (rather than the one it had reached when its journal started) may name a declared task: its
/// `tasks FILE` and `task NAME` entries follow, so the restore starts on positioning and reaches
/// it from them.
fn header_task<'de, D: serde::Deserializer<'de>>(d: D) -> Result<TaskKind, D::Error> {
    let name = String::deserialize(d)?;
    Ok(TaskKind::builtin(&name).unwrap_or(TaskKind::Positioning))
}

/// The journal's format name; a journal of another format is refused with a diagnostic.
pub const JOURNAL_FORMAT: &str = "advise-journal-1";

/// One line of a journal after the header: the statement as typed, where it came from, and what
/// it did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    pub statement: String,
    pub origin: String,
    pub effect: Effect,
}

/// What one statement changed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Effect {
    /// Operator or domain definitions, checked on top of the session's operators: typed at the
    /// prompt (`origin` is the REPL line) or read from a file by `operators FILE` (the file's
    /// text as it was then).
    Define {
        origin: String,
        text: String,
        /// For `tasks FILE` and `operators FILE`: the file's absolute path, so a resume can say
        /// whether the file still holds the text journalled (it restores the journalled text
        /// either way). Absent in journals written before it was recorded.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        file: Option<String>,
    },
    /// The session switched task (each task keeps its own dataset and executions): its name, a
    /// declared task's resolved against the definitions journalled before it.
    Task {
        task: String,
    },
    /// The session connected to a base. Restoring it does not connect: the session is on `sim`
    /// until the teacher connects again.
    Backend {
        spec: String,
    },
    /// Demonstrations added, with every point (a file may change, a teacher run is not re-run).
    Demos {
        source: String,
        episodes: Vec<DemoEpisode>,
    },
    /// Demonstrations added from a file in a journalled session: their points are in a sidecar
    /// beside the journal ([`super::sidecar`]), written before this line; the line names it and
    /// each demonstration's name and length, in order.
    DemosFile {
        source: String,
        sidecar: super::sidecar::SidecarRef,
        episodes: Vec<DemoSpan>,
    },
    /// An execution recorded: run on a base, interrupted, or loaded from a file.
    Execution(Box<ExecutionEntry>),
    /// The selection.
    Select {
        execution: usize,
        chunk: Chunk,
    },
    /// Advice: the synthesized points themselves, with the record they came from.
    Advice {
        execution: usize,
        applied: AppliedAdvice,
        points: JsonTrace,
        source_index: Vec<usize>,
    },
    /// The teacher took over execution `execution` for its steps `steps`: what it drove joins
    /// the data as a demonstration linked to the run, its points kept every `every`-th step
    /// from the first (the task's demonstration rate), named `name`. Restoring it adds the
    /// points; nothing is driven again.
    Takeover {
        execution: usize,
        steps: Chunk,
        every: u32,
        name: String,
        points: JsonTrace,
    },
    /// A critique of execution `execution`: the weight increments it made, by provenance, under
    /// its rule (`directional` is absent in journals written before `critique --directional`).
    Critique {
        execution: usize,
        #[serde(flatten)]
        critique: Critique,
    },
    Undo,
    Redo,
    /// The policy re-derived from scratch (deterministic for the session's seed).
    Rederive,
    /// The running learner switched (and re-derived).
    Learner {
        learner: LearnerKind,
        /// LWR's kernel limited to its k nearest points (`learner lwr k N`); absent: the
        /// protocol's rule.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        k: Option<usize>,
    },
    /// A test-set evaluation, kept so the next one can say what changed.
    Evaluated {
        report: Box<Report>,
    },
    /// A dataset opened from a file, whole.
    Open {
        path: String,
        dataset: String,
    },
}

/// A demonstration as journalled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemoEpisode {
    pub name: String,
    pub trace: JsonTrace,
}

/// A demonstration whose points are in a sidecar: its name and how many of the sidecar's rows
/// (following the previous demonstration's) are its points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemoSpan {
    pub name: String,
    pub points: u64,
    /// When its points were recorded (the sidecar holds points only): the time between them,
    /// s, or each point's time from the first ([`crate::policy::dataset::DemoTimes`]). Absent in
    /// journals written before datasets kept times, and for a file without times.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub times_s: Option<Vec<f64>>,
}

/// An execution as journalled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutionEntry {
    pub label: String,
    pub trace: JsonTrace,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<Pose>,
    /// A declared task's goal, a value per goal parameter in the declared order (what its
    /// pictures are drawn from); a positioning goal is `goal`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal_values: Option<Vec<f64>>,
    /// What the run measured (absent for a trace loaded from a file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub run: Option<RunEntry>,
}

/// The parts of an execution only a run has.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunEntry {
    /// The session's run counter for this run (it seeds the simulator of the next run).
    pub number: u64,
    pub outcome: Outcome,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub true_poses: Option<Vec<Pose>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ball: Option<Vec<[f64; 2]>>,
    /// For each step, the data point that recommended the action (BC 1-NN): what a critique
    /// penalises.
    pub support: Vec<Option<Provenance>>,
    /// The windows of steps the teacher drove (a takeover); every other step was the
    /// learner's. Absent when the learner drove the whole run, and in journals written before
    /// takeovers.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub teacher: Vec<Chunk>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A critique's fields stay flat beside `kind` and `execution` (the journal's shape before
    /// the one critique record), and a field no version wrote is refused.
    #[test]
    fn a_critique_line_is_flat_and_strict() {
        for line in [
            r#"{"kind":"critique","execution":0,"chunk":{"start":1,"end":3},"kappa":0.5,"increments":[]}"#,
            r#"{"kind":"critique","execution":2,"chunk":{"start":0,"end":1},"kappa":1.0,"increments":[],"directional":true,"flagged":[[0.1,-2.5]]}"#,
        ] {
            let e: Effect = serde_json::from_str(line).unwrap();
            assert!(matches!(&e, Effect::Critique { .. }));
            assert_eq!(serde_json::to_string(&e).unwrap(), line);
            let extra = line.replace(r#""kappa""#, r#""colour":1,"kappa""#);
            let err = serde_json::from_str::<Effect>(&extra).unwrap_err();
            assert!(err.to_string().contains("unknown field `colour`"), "{err}");
        }
    }
}
