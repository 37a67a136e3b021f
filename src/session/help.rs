//! `help`: the commands by the steps of the teacher's workflow, and each command's and operator's
//! own help.

use std::fmt::Write as _;

use super::{Session, SessionError};
use crate::diagnostic::did_you_mean;
use crate::syntax::ast::Ident;
use crate::syntax::command::COMMANDS;

impl Session {
    pub(super) fn help(&self, topic: Option<&Ident>) -> Result<String, SessionError> {
        let Some(topic) = topic else {
            let mut out = String::from("commands, by the steps of the teacher's workflow:\n");
            for (step, words) in WORKFLOW {
                let _ = writeln!(out, "  {step}");
                for w in *words {
                    if let Some((_, sig)) = COMMANDS.iter().find(|(c, _)| c == w) {
                        let _ = writeln!(out, "    {sig:<34} {}", command_doc(w));
                    }
                }
            }
            let names = self.ops.operator_names(&self.domain.name);
            let _ = writeln!(
                out,
                "operators for {}: {}\n`help NAME` explains a command or an operator; an operator may be defined on the spot:\n  operator creep for {} on action {{ {} = 0.1 }}",
                self.domain.name,
                names.join(", "),
                self.domain.name,
                self.domain.act.first().map_or("a", |d| d.name.as_str()),
            );
            return Ok(out);
        };
        let name = topic.name.as_str();
        if let Some((_, sig)) = COMMANDS.iter().find(|(c, _)| *c == name) {
            return Ok(format!("{sig}\n  {}", command_doc(name)));
        }
        if let Some(op) = self.ops.operator(&self.domain.name, name) {
            return Ok(format!(
                "{}  (on {})\n{}",
                op.signature(),
                op.space(),
                op.doc()
            ));
        }
        let mut known: Vec<&str> = COMMANDS.iter().map(|(c, _)| *c).collect();
        known.extend(self.ops.operator_names(&self.domain.name));
        Err(SessionError::UnknownHelp {
            topic: name.to_string(),
            help: did_you_mean(name, &known)
                .unwrap_or_else(|| "`help` lists every command and operator".into()),
        })
    }
}

/// The commands grouped by the steps of the teacher's workflow, in `help`'s order.
const WORKFLOW: &[(&str, &[&str])] = &[
    ("demonstrate", &["task", "load", "operators"]),
    ("run", &["backend", "run", "show", "plot"]),
    ("select", &["select"]),
    ("correct", &["advise", "preview", "critique", "why"]),
    ("take back", &["undo", "redo", "history"]),
    ("measure", &["eval", "rederive", "learner"]),
    ("keep", &["save", "open", "export"]),
    ("session", &["help", "quit"]),
];

fn command_doc(name: &str) -> &'static str {
    match name {
        "task" => {
            "Switch task (positioning: A-OPI with LWR; interception: BC with 1-NN). Each task keeps its own dataset, executions and history."
        }
        "backend" => "Choose the robot: the simulator, or a Segway RMP at an address.",
        "load" => {
            "Load demonstrations (a file, or `teacher:N` to record N teacher runs in the simulator) or a trace to advise."
        }
        "operators" => "Check an operator file and add its operators on top of the standard ones.",
        "run" => {
            "Run the current policy to a goal (positioning) or from the N-th practice start, and record it."
        }
        "show" => "Summarise the selected execution (or execution N), with a small plot.",
        "select" => {
            "Select points A (inclusive) to B (exclusive) of the latest execution, or of execution N with `in N`; advise, critique, preview, why and plot act on it."
        }
        "critique" => {
            "Flag the selection as poor: the data points that recommended its actions are pushed away (BC)."
        }
        "advise" => {
            "Correct the selection with an advice operator: its points are synthesized and added (A-OPI)."
        }
        "preview" => "Show what `advise` would add, without adding it.",
        "undo" => "Take back the last advice or critique, exactly.",
        "redo" => "Put back what `undo` took.",
        "history" => "List the advice and critiques given so far.",
        "rederive" => "Re-derive the policy from scratch (LWR is re-tuned by cross-validation).",
        "eval" => {
            "Evaluate the policy on the task's fixed test set (never advised) and say what changed since the last eval; `--detail` lists the tests that changed outcome."
        }
        "learner" => {
            "Switch the running learner: `bc` (1-NN with critique weights) or `lwr` (locally weighted regression); the dataset is shared."
        }
        "why" => "Show which data points supported the action at point T, with their provenance.",
        "plot" => {
            "Write the selected execution's path as SVG, `plot actions FILE` its actions against point index, `plot compare FILE N M` executions N and M overlaid; selection, advice and critiques marked."
        }
        "save" => "Save the dataset with provenance (.json), or its points only (.csv).",
        "open" => "Open a dataset saved with `save`.",
        "export" => "Write every advised point with its provenance as CSV.",
        "help" => "Help on commands and operators.",
        "quit" => "Leave the session (the journal keeps everything).",
        _ => "",
    }
}
