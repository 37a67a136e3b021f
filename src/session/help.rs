//! `help`: the commands by the steps of the teacher's workflow, and each command's and operator's
//! own help.

use std::fmt::Write as _;

use super::{Session, SessionError};
use crate::diag::did_you_mean;
use crate::syntax::ast::Ident;
use crate::syntax::command::{COMMANDS, command_spec};

impl Session {
    pub(super) fn help(&self, topic: Option<&Ident>) -> Result<String, SessionError> {
        let Some(topic) = topic else {
            let mut out = String::from("commands, by the steps of the teacher's workflow:\n");
            for (step, words) in WORKFLOW {
                let _ = writeln!(out, "  {step}");
                for w in *words {
                    if let Some(c) = command_spec(w) {
                        let _ = writeln!(out, "    {:<34} {}", c.signature, c.doc);
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
        if let Some(c) = command_spec(name) {
            return Ok(format!("{}\n  {}", c.signature, c.doc));
        }
        if let Some(op) = self.ops.operator(&self.domain.name, name) {
            return Ok(format!(
                "{}  (on {})\n{}",
                op.signature(),
                op.space(),
                op.doc()
            ));
        }
        let mut known: Vec<&str> = COMMANDS.iter().map(|c| c.name).collect();
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

#[cfg(test)]
mod tests {
    use super::WORKFLOW;
    use crate::syntax::command::{COMMANDS, command_spec};

    #[test]
    fn help_lists_every_command_once_under_one_step() {
        let listed: Vec<&str> = WORKFLOW
            .iter()
            .flat_map(|(_, w)| w.iter().copied())
            .collect();
        for c in COMMANDS {
            let n = listed.iter().filter(|w| **w == c.name).count();
            assert_eq!(n, 1, "`{}` is listed {n} times by `help`", c.name);
            assert!(c.signature.starts_with(c.name), "{c:?}");
            assert!(!c.doc.is_empty(), "{c:?}");
        }
        for w in listed {
            assert!(
                command_spec(w).is_some(),
                "`help` lists `{w}`, which is no command"
            );
        }
    }
}
