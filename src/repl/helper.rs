//! The rustyline helper: completion of commands, operator names and file paths; a hint with the
//! signature of what is being typed; multi-line input while an operator definition is unfinished.
//! What it knows of the session (operator names and signatures) it reads from [`Facts`], which the
//! REPL refreshes after every command.

use std::borrow::Cow;
use std::sync::{Arc, Mutex};

use rustyline::Context;
use rustyline::completion::{Completer, FilenameCompleter, Pair};
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::validate::Validator;

use crate::syntax::command::COMMANDS;

/// What the helper needs to know of the session.
#[derive(Clone, Debug, Default)]
pub struct Facts {
    /// Operators of the current domain: (name, signature).
    pub operators: Vec<(String, String)>,
    /// The task names the session knows.
    pub tasks: Vec<String>,
}

/// The REPL's rustyline helper.
pub struct AdviseHelper {
    pub facts: Arc<Mutex<Facts>>,
    files: FilenameCompleter,
    /// Dim hints with ANSI colour (off when the terminal does not want colour).
    pub colour: bool,
}

impl AdviseHelper {
    pub fn new(facts: Arc<Mutex<Facts>>) -> AdviseHelper {
        AdviseHelper {
            facts,
            files: FilenameCompleter::new(),
            colour: true,
        }
    }

    fn facts(&self) -> Facts {
        self.facts.lock().map(|f| f.clone()).unwrap_or_default()
    }

    /// Candidates for the word ending at `pos`, and where that word starts.
    pub fn candidates(&self, line: &str, pos: usize) -> (usize, Vec<String>) {
        let before = &line[..pos];
        let start = before.rfind([' ', '\t', '(']).map_or(0, |i| i + 1);
        let word = &before[start..];
        let words: Vec<&str> = before[..start].split_whitespace().collect();
        let facts = self.facts();
        let ops = || {
            facts
                .operators
                .iter()
                .map(|(n, _)| n.clone())
                .collect::<Vec<_>>()
        };
        let pool: Vec<String> = match words.as_slice() {
            [] => COMMANDS.iter().map(|c| c.name.to_string()).collect(),
            ["advise"] | ["preview"] => ops(),
            ["help"] => COMMANDS
                .iter()
                .map(|c| c.name.to_string())
                .chain(ops())
                .collect(),
            ["load"] => vec!["demos".into(), "trace".into()],
            ["export"] => vec!["advice".into()],
            ["run"] => vec!["goal".into(), "start".into()],
            ["task"] => facts.tasks.clone(),
            ["backend"] => vec!["sim".into(), "rmp:".into()],
            _ => Vec::new(),
        };
        let mut out: Vec<String> = pool.into_iter().filter(|c| c.starts_with(word)).collect();
        out.sort();
        out.dedup();
        (start, out)
    }

    /// Whether the word being typed is a file path argument.
    fn wants_path(line: &str, pos: usize) -> bool {
        let words: Vec<&str> = line[..pos].split_whitespace().collect();
        let typing_new = line[..pos].ends_with(' ');
        let head: &[&str] = if typing_new {
            &words
        } else {
            &words[..words.len().saturating_sub(1)]
        };
        matches!(
            head,
            ["load", "demos"]
                | ["load", "trace"]
                | ["operators"]
                | ["tasks"]
                | ["plot"]
                | ["save"]
                | ["open"]
                | ["export", "advice"]
        )
    }

    /// The hint for `line`: the rest of a command's signature, or an operator's signature.
    pub fn hint_for(&self, line: &str) -> Option<String> {
        if line.is_empty() || line.contains('\n') {
            return None;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        let first = *words.first()?;
        if let ["advise" | "preview", op] = words.as_slice()
            && !line.ends_with(' ')
        {
            let facts = self.facts();
            let (_, sig) = facts.operators.iter().find(|(n, _)| n == op)?;
            return sig
                .strip_prefix(op)
                .filter(|s| !s.is_empty())
                .map(|s| s.to_string());
        }
        if words.len() == 1 && !line.ends_with(' ') {
            // Complete the command word itself, then show its arguments.
            let c = COMMANDS.iter().find(|c| c.name.starts_with(first))?;
            return c
                .signature
                .strip_prefix(first)
                .map(|s| s.to_string())
                .filter(|s| !s.is_empty());
        }
        if words.len() == 1 && line.ends_with(' ') {
            let c = crate::syntax::command::command_spec(first)?;
            return c
                .signature
                .strip_prefix(c.name)
                .map(|s| s.trim_start().to_string())
                .filter(|s| !s.is_empty());
        }
        None
    }
}

impl Completer for AdviseHelper {
    type Candidate = Pair;

    fn complete(
        &self,
        line: &str,
        pos: usize,
        ctx: &Context<'_>,
    ) -> rustyline::Result<(usize, Vec<Pair>)> {
        if Self::wants_path(line, pos) {
            return self.files.complete(line, pos, ctx);
        }
        let (start, cands) = self.candidates(line, pos);
        let pairs = cands
            .into_iter()
            .map(|c| Pair {
                display: c.clone(),
                replacement: c,
            })
            .collect();
        Ok((start, pairs))
    }
}

impl Hinter for AdviseHelper {
    type Hint = String;

    fn hint(&self, line: &str, pos: usize, _ctx: &Context<'_>) -> Option<String> {
        if pos < line.len() {
            return None;
        }
        self.hint_for(line)
    }
}

impl Highlighter for AdviseHelper {
    fn highlight_hint<'h>(&self, hint: &'h str) -> Cow<'h, str> {
        if self.colour {
            Cow::Owned(format!("\x1b[2m{hint}\x1b[0m"))
        } else {
            Cow::Borrowed(hint)
        }
    }
}

/// Every line is handed on as typed: the REPL asks for the rest of an unfinished statement under
/// its own `...> ` prompt (rustyline's multi-line editing shows no prompt on later lines).
impl Validator for AdviseHelper {}

impl rustyline::Helper for AdviseHelper {}

#[cfg(test)]
mod tests {
    use super::*;

    fn helper() -> AdviseHelper {
        let facts = Facts {
            operators: vec![
                ("speed_up".into(), "speed_up(rate = 0.2)".into()),
                ("slow_down".into(), "slow_down(rate = 0.2)".into()),
                ("stop".into(), "stop".into()),
            ],
            tasks: vec!["positioning".into(), "interception".into()],
        };
        AdviseHelper::new(Arc::new(Mutex::new(facts)))
    }

    #[test]
    fn completes_commands_operators_and_words() {
        let h = helper();
        assert_eq!(h.candidates("cri", 3), (0, vec!["critique".into()]));
        assert_eq!(
            h.candidates("advise s", 8).1,
            vec!["slow_down", "speed_up", "stop"]
        );
        assert_eq!(h.candidates("advise sp", 9), (7, vec!["speed_up".into()]));
        assert_eq!(h.candidates("load ", 5).1, vec!["demos", "trace"]);
        assert_eq!(h.candidates("task i", 6).1, vec!["interception"]);
        assert!(AdviseHelper::wants_path("load demos ", 11));
        assert!(AdviseHelper::wants_path("plot ru", 7));
        assert!(!AdviseHelper::wants_path("advise sp", 9));
        assert!(AdviseHelper::wants_path("tasks ex", 8));
    }

    #[test]
    fn completes_the_tasks_a_file_declared() {
        let h = helper();
        h.facts.lock().unwrap().tasks.push("standoff".into());
        assert_eq!(h.candidates("task st", 7).1, vec!["standoff"]);
    }

    #[test]
    fn hints_show_signatures() {
        let h = helper();
        assert_eq!(h.hint_for("sel").as_deref(), Some("ect A..B [in N]"));
        assert_eq!(h.hint_for("select ").as_deref(), Some("A..B [in N]"));
        assert_eq!(
            h.hint_for("advise speed_up").as_deref(),
            Some("(rate = 0.2)")
        );
        assert_eq!(h.hint_for("advise stop"), None);
    }
}
