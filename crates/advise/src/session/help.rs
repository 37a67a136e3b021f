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
        if let Some(why) = self.not_carried_over(name) {
            return Ok(why);
        }
        let mut known: Vec<&str> = COMMANDS.iter().map(|c| c.name).collect();
        known.extend(self.ops.operator_names(&self.domain.name));
        Err(SessionError::UnknownHelp {
            topic: name.to_string(),
            help: did_you_mean(name, &known)
                .unwrap_or_else(|| "`help` lists every command and operator".into()),
        })
    }

    /// On a declared task, why a standard operator of a built-in task (`name`) is not among its
    /// operators: an observation-side one names positioning's observations, an action-side one
    /// carries over only to a task whose actions drive speed and turn directly, and
    /// interception's work on its own actions (changes of the command).
    fn not_carried_over(&self, name: &str) -> Option<String> {
        let task = self.task.name().to_string();
        if crate::task::TaskKind::builtin(&task).is_some() {
            return None;
        }
        let (home, op) = ["positioning", "interception"]
            .into_iter()
            .find_map(|d| Some((d, self.ops.operator(d, name).filter(|o| o.is_standard())?)))?;
        let write_one = format!(
            "write one for it: `operator {name} for {task} on {} {{ ... }}` (`help` lists the operators {task} has)",
            match op.space() {
                crate::domain::Space::Observation => "observation",
                crate::domain::Space::Action => "action",
            }
        );
        let why = match (home, op.space()) {
            ("positioning", crate::domain::Space::Observation) => format!(
                "it works on positioning's observations ({}), and {task}'s observations are its own: no standard operator on observations carries over to a declared task",
                self.ops
                    .domains()
                    .iter()
                    .find(|d| d.name == "positioning")
                    .map(|d| d
                        .observe
                        .iter()
                        .map(|o| o.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "))
                    .unwrap_or_default()
            ),
            ("positioning", crate::domain::Space::Action) => format!(
                "positioning's operators on actions carry over by role only to a task whose actions drive the base's speed and turn directly (`act NAME ... drives speed`, `act NAME ... drives turn`); {task}'s do not"
            ),
            _ => format!(
                "it works on interception's actions (changes of the command each step); {task} is another domain"
            ),
        };
        Some(format!(
            "`{name}` is a standard operator for {home}, not for {task}: {why}; {write_one}"
        ))
    }
}
