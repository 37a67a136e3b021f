//! `help`: the commands by the steps of the teacher's workflow, and each command's and operator's
//! own help.

use std::fmt::Write as _;

use super::{Session, SessionError};
use crate::diag::did_you_mean;
use crate::syntax::ast::Ident;
use crate::syntax::command::{COMMANDS, Step, command_spec};

impl Session {
    pub(super) fn help(&self, topic: Option<&Ident>) -> Result<String, SessionError> {
        let Some(topic) = topic else {
            let mut out = String::from("commands, by the steps of the teacher's workflow:\n");
            for step in Step::ALL {
                let _ = writeln!(out, "  {}", step.label());
                for c in COMMANDS.iter().filter(|c| c.step == step) {
                    let _ = writeln!(out, "    {:<34} {}", c.signature, c.doc);
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
            return Ok(op.help());
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
