//! The rustyline helper: completion of commands, their sub-words, options and arguments, operator
//! names and file paths; a hint with the signature of what is being typed; multi-line input while
//! an operator definition is unfinished. What a command takes it reads from the command table
//! ([`advise::syntax::command::COMMANDS`]); what it knows of the session (operator names and
//! signatures, tasks) from [`Facts`], which the REPL refreshes after every command.

use std::borrow::Cow;
use std::sync::{Arc, Mutex};

use rustyline::Context;
use rustyline::completion::{Completer, FilenameCompleter, Pair};
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::validate::Validator;

use advise::policy::learner::LearnerKind;
use advise::syntax::command::{Arg, ArgKind, COMMANDS, command_spec};

/// What the helper needs to know of the session.
#[derive(Clone, Debug, Default)]
pub struct Facts {
    /// Operators of the current domain: (name, signature).
    pub operators: Vec<(String, String)>,
    /// The task names the session knows.
    pub tasks: Vec<String>,
    /// The words `backend ` completes: the session's registry's (its kinds, a test's fake base
    /// among them).
    pub backends: Vec<String>,
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

    /// Candidates for the word ending at `pos`, and where that word starts (file paths aside:
    /// [`Completer::complete`] adds those where [`AdviseHelper::wants_path`]).
    pub fn candidates(&self, line: &str, pos: usize) -> (usize, Vec<String>) {
        let (start, word, expect) = expect_at(line, pos, &self.facts());
        let mut out: Vec<String> = expect
            .words
            .into_iter()
            .filter(|c| c.starts_with(word))
            .collect();
        // A range's end: `125..` completes to `125..end`.
        if expect.range
            && let Some((from, to)) = word.split_once("..")
            && !from.is_empty()
            && "end".starts_with(to)
        {
            out.push(format!("{from}..end"));
        }
        out.sort();
        out.dedup();
        (start, out)
    }

    /// Whether the word being typed may be a file path (`export mcap `, `plot `).
    pub fn wants_path(line: &str, pos: usize) -> bool {
        expect_at(line, pos, &Facts::default()).2.path
    }

    /// The hint for `line`: the rest of a command's signature, the rest of a sub-word and its
    /// form's arguments and options (from the command table), or an operator's signature.
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
        let spec = command_spec(first)?;
        match (words.as_slice(), line.ends_with(' ')) {
            ([_], true) => spec
                .signature
                .strip_prefix(spec.name)
                .map(|s| s.trim_start().to_string())
                .filter(|s| !s.is_empty()),
            // A sub-word being typed: its rest, then its form's arguments (`export m`: `cap FILE.mcap`).
            ([_, partial], false) => {
                let (form, rest) = spec
                    .forms
                    .iter()
                    .find_map(|f| Some((f, f.sub?.strip_prefix(partial)?)))?;
                Some(format!("{rest} {}", form.rest()).trim_end().to_string())
                    .filter(|s| !s.is_empty())
            }
            // A sub-word typed: its form's arguments (`load demos `: `FILE [cmd TOPIC] [odom TOPIC]`).
            ([_, word], true) => {
                let form = spec.forms.iter().find(|f| f.sub == Some(word))?;
                Some(form.rest()).filter(|s| !s.is_empty())
            }
            _ => None,
        }
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
        let (start, cands) = self.candidates(line, pos);
        let mut pairs: Vec<Pair> = cands
            .into_iter()
            .map(|c| Pair {
                display: c.clone(),
                replacement: c,
            })
            .collect();
        if Self::wants_path(line, pos) {
            let (from, files) = self.files.complete(line, pos, ctx)?;
            if pairs.is_empty() {
                return Ok((from, files));
            }
            // `plot ac`: a sub-word and files alike, when both replace the same word.
            if from == start {
                pairs.extend(files);
            }
        }
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

/// What may be typed at the cursor: some words, a file path, or both (`plot ` takes `actions`,
/// `compare` or a file).
#[derive(Debug, Default, PartialEq)]
struct Expect {
    words: Vec<String>,
    path: bool,
    /// A range of points (`A..B`, `A..end`, `-N..end`).
    range: bool,
}

/// Where the word ending at `pos` starts, that word, and what the command table says it may be.
fn expect_at<'l>(line: &'l str, pos: usize, facts: &Facts) -> (usize, &'l str, Expect) {
    let before = &line[..pos];
    let start = before.rfind([' ', '\t', '(']).map_or(0, |i| i + 1);
    let head: Vec<&str> = before[..start].split_whitespace().collect();
    (start, &before[start..], expect(&head, facts))
}

/// What may follow `head`, the whole words before the cursor's, by the command table: the
/// command's sub-words, then its form's arguments in order with its options among them (an
/// option takes its own arguments), each argument completed by its kind.
fn expect(head: &[&str], facts: &Facts) -> Expect {
    let mut out = Expect::default();
    let Some((first, rest)) = head.split_first() else {
        out.words = COMMANDS.iter().map(|c| c.name.to_string()).collect();
        return out;
    };
    let Some(spec) = command_spec(first) else {
        return out;
    };
    if rest.is_empty() {
        out.words.extend(spec.subs().map(String::from));
    }
    let Some(form) = spec.form_for(rest.first().copied()) else {
        return out;
    };
    let rest = if form.sub.is_some() { &rest[1..] } else { rest };
    let (mut positional, mut used, mut i) = (0, Vec::new(), 0);
    while i < rest.len() {
        if let Some(option) = form.option(rest[i]) {
            used.push(option.word);
            // The cursor is on one of the option's own arguments.
            if let Some(arg) = option.args.get(rest.len() - 1 - i) {
                expect_arg(arg, facts, &mut out);
                return out;
            }
            i += 1 + option.args.len();
        } else if form.args.get(positional).map(|a| a.kind) == Some(ArgKind::Invocation) {
            // An invocation runs to the end of the line.
            return out;
        } else {
            positional += 1;
            i += 1;
        }
    }
    if let Some(arg) = form.args.get(positional) {
        expect_arg(arg, facts, &mut out);
    }
    if positional >= form.required() {
        let unused = form.options.iter().filter(|o| !used.contains(&o.word));
        out.words.extend(unused.map(|o| o.word.to_string()));
    }
    out
}

/// What completes an argument of this kind.
fn expect_arg(arg: &Arg, facts: &Facts, out: &mut Expect) {
    let ops = facts.operators.iter().map(|(n, _)| n.clone());
    match arg.kind {
        ArgKind::Path => out.path = true,
        ArgKind::Invocation => out.words.extend(ops),
        ArgKind::Topic => {
            out.words
                .extend(COMMANDS.iter().map(|c| c.name.to_string()));
            out.words.extend(ops);
        }
        ArgKind::Task => out.words.extend(facts.tasks.iter().cloned()),
        ArgKind::Backend => out.words.extend(facts.backends.iter().cloned()),
        ArgKind::Learner => out
            .words
            .extend(LearnerKind::ALL.iter().map(|k| k.name().to_string())),
        ArgKind::Range => out.range = true,
        ArgKind::Number | ArgKind::Count | ArgKind::RosTopic => {}
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
            backends: advise::backend::Registry::standard().completions(""),
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

    /// After a command, its sub-words and arguments as the table gives them: every backend,
    /// every export, a path after `export mcap`, options after the arguments they follow.
    #[test]
    fn completes_sub_words_arguments_and_options() {
        let h = helper();
        let words = |line: &str| h.candidates(line, line.len()).1;
        assert_eq!(words("backend "), vec!["rmp:", "ros2", "ros2:", "sim"]);
        assert_eq!(words("backend r"), vec!["rmp:", "ros2", "ros2:"]);
        assert_eq!(words("export "), vec!["advice", "lerobot", "mcap"]);
        assert_eq!(words("export m"), vec!["mcap"]);
        for line in [
            "export mcap ",
            "export lerobot ",
            "export advice a",
            "plot compare ",
        ] {
            assert!(AdviseHelper::wants_path(line, line.len()), "{line}");
            assert_eq!(words(line), Vec::<String>::new(), "{line}");
        }
        assert!(!AdviseHelper::wants_path("export ", 7));
        assert!(!AdviseHelper::wants_path("plot compare c.svg ", 19));
        assert_eq!(words("learner "), vec!["bc", "lwr"]);
        assert_eq!(words("run "), vec!["goal", "start"]);
        // A range's open end.
        assert_eq!(words("select 125.."), vec!["125..end"]);
        assert_eq!(words("select -30..e"), vec!["-30..end"]);
        assert_eq!(words("select 125..1"), Vec::<String>::new());
        assert_eq!(words("load demos d.csv "), vec!["cmd", "odom"]);
        assert_eq!(words("load demos d.csv cmd /c "), vec!["odom"]);
        assert_eq!(words("load demos d.csv cmd "), Vec::<String>::new());
        assert_eq!(words("record "), vec!["demo"]);
        assert_eq!(
            words("record demo for 5 "),
            vec!["--keep-idle", "from", "goal"]
        );
        assert_eq!(words("record demo goal 1 "), Vec::<String>::new());
        assert_eq!(words("teleop "), vec!["for", "goal"]);
        assert_eq!(words("critique "), vec!["--directional"]);
        assert_eq!(words("critique 0.5 "), vec!["--directional"]);
        assert_eq!(words("eval "), vec!["--detail"]);
        assert_eq!(words("select 1..4 "), vec!["in"]);
        assert_eq!(words("select "), Vec::<String>::new());
        // `plot` takes a sub-word or a file; after the sub-word, a file.
        assert_eq!(words("plot "), vec!["actions", "compare"]);
        assert!(AdviseHelper::wants_path("plot ", 5));
        assert!(AdviseHelper::wants_path("plot actions ", 13));
        assert_eq!(words("help und"), vec!["undo"]);
        assert_eq!(words("help sp"), vec!["speed_up"]);
        assert_eq!(words("advise speed_up(ra"), Vec::<String>::new());
        assert_eq!(words("nonsense "), Vec::<String>::new());
    }

    /// Whatever the table holds completes: each command's word, each sub-word after it, a path
    /// for each form that starts with one, and each option once the form's arguments are typed.
    #[test]
    fn every_word_of_the_table_completes() {
        let h = helper();
        let words = |line: &str| h.candidates(line, line.len()).1;
        for c in COMMANDS {
            assert!(words("").contains(&c.name.to_string()), "{}", c.name);
            for f in c.forms {
                let mut line = format!("{} ", c.name);
                if let Some(s) = f.sub {
                    assert!(words(&line).contains(&s.to_string()), "{line}{s}");
                    line.push_str(s);
                    line.push(' ');
                }
                let first = f.args.first().map(|a| a.kind);
                assert_eq!(
                    AdviseHelper::wants_path(&line, line.len()),
                    first == Some(ArgKind::Path),
                    "{line}"
                );
                for a in f.args.iter().filter(|a| !a.optional) {
                    line.push_str(match a.kind {
                        ArgKind::Range => "1..2 ",
                        ArgKind::Number | ArgKind::Count => "1 ",
                        _ => "x ",
                    });
                }
                if f.args.iter().all(|a| a.kind != ArgKind::Invocation) {
                    for o in f.options {
                        assert!(
                            words(&line).contains(&o.word.to_string()),
                            "{line}{}",
                            o.word
                        );
                    }
                }
            }
        }
    }

    /// What Tab offers, through rustyline's own entry point: sub-words alone after `export`,
    /// files after `export mcap` and `export lerobot`, both after `plot`.
    #[test]
    fn tab_completes_paths_where_the_table_says_a_path() {
        let h = helper();
        let history = rustyline::history::DefaultHistory::new();
        let ctx = Context::new(&history);
        let tab = |line: &str| {
            let (start, pairs) = h.complete(line, line.len(), &ctx).unwrap();
            let words: Vec<String> = pairs.into_iter().map(|p| p.replacement).collect();
            (start, words)
        };
        assert_eq!(tab("export ").1, vec!["advice", "lerobot", "mcap"]);
        let dir = env!("CARGO_MANIFEST_DIR");
        for sub in ["mcap", "lerobot", "advice"] {
            let line = format!("export {sub} {dir}/Cargo.to");
            let (start, words) = tab(&line);
            assert_eq!(start, line.len() - dir.len() - "/Cargo.to".len(), "{line}");
            assert_eq!(words, vec![format!("{dir}/Cargo.toml")], "{line}");
        }
        let line = format!("plot {dir}/Cargo.to");
        assert_eq!(tab(&line).1, vec![format!("{dir}/Cargo.toml")]);
        let (start, words) = tab("plot ");
        assert_eq!(start, 5);
        assert!(words.iter().any(|w| w == "actions") && words.iter().any(|w| w == "compare"));
        assert_eq!(tab("backend ").1, vec!["rmp:", "ros2", "ros2:", "sim"]);
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
        // A sub-word: the rest of it, then its form's arguments and options.
        assert_eq!(h.hint_for("export m").as_deref(), Some("cap FILE.mcap"));
        assert_eq!(h.hint_for("export mcap").as_deref(), Some(" FILE.mcap"));
        assert_eq!(
            h.hint_for("load demos ").as_deref(),
            Some("FILE [cmd TOPIC] [odom TOPIC]")
        );
        assert_eq!(
            h.hint_for("record demo ").as_deref(),
            Some("[from TOPIC] [goal X Y THETA] [for S] [--keep-idle]")
        );
        assert_eq!(h.hint_for("task i"), None);
    }
}
