//! The table of session commands: each command once, with its forms (sub-words), their arguments
//! and options, its signature and its help. `help`, the REPL's hints and completion, the LSP's
//! command completion and the parser's diagnostics for unknown words and options read it; the
//! grammar (`grammar/session.pest`) cannot be generated from it (pest grammars are compiled), so
//! the tests below read the grammar's text and fail when a command, a sub-word or an option is in
//! one and not the other. A form's [`Form::rule`] is its dispatch key: [`super::Command::rule`]
//! names the form each parsed command came from, and the session's dispatch matches on
//! [`super::Command`] (exhaustively, so the compiler asks for a new command's arm).
//!
//! This module knows words and shapes only: which backends, learners or tasks exist is for the
//! layers after it (the REPL's completer asks them for an argument's words by its [`ArgKind`]).

use crate::syntax::Rule;

/// A session command as `help`, completion and hints know it: its word, its forms, its signature
/// and its one-line help.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandSpec {
    pub name: &'static str,
    /// Other words for the command (`exit` for `quit`): parsed, not listed.
    pub aliases: &'static [&'static str],
    /// What follows the command's word, one entry per grammar rule (`load demos`, `load trace`).
    pub forms: &'static [Form],
    pub signature: &'static str,
    pub doc: &'static str,
    /// Where `help` lists it.
    pub step: Step,
    /// A statement that uses it (the LSP's tests use it; each form has its own too).
    pub example: &'static str,
}

/// One shape of a command: an optional sub-word, then arguments, then options in any order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Form {
    /// The grammar rule that parses it, and the key [`super::Command::rule`] answers.
    pub rule: Rule,
    /// The word after the command's: `demos` in `load demos FILE`.
    pub sub: Option<&'static str>,
    /// Positional arguments, in order (the optional ones last).
    pub args: &'static [Arg],
    /// Keyword options and flags: `cmd TOPIC`, `--detail`, `in N`.
    pub options: &'static [Opt],
    /// A statement of this form (parsed by a test to the command whose rule is this one).
    pub example: &'static str,
}

/// One argument: what it is (for completion) and how signatures and hints name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Arg {
    pub kind: ArgKind,
    pub name: &'static str,
    pub optional: bool,
}

/// A keyword option and its arguments: `cmd TOPIC`; a flag has none: `--detail`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Opt {
    pub word: &'static str,
    pub args: &'static [Arg],
}

/// What an argument is, which decides what completes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArgKind {
    /// A file or directory (completed from the file system).
    Path,
    /// A signed decimal number.
    Number,
    /// A non-negative whole number (an execution, a point, a start).
    Count,
    /// A half-open range of points: `40..70`.
    Range,
    /// An operator with arguments (completed from the task's operators).
    Invocation,
    /// A backend spec (completed from the backends).
    Backend,
    /// A task's name (completed from the session's tasks).
    Task,
    /// A learner's name (completed from the learners).
    Learner,
    /// A command or an operator, for `help`.
    Topic,
    /// A ROS 2 topic name.
    RosTopic,
}

impl Form {
    /// The form as a hint shows it after its words: `FILE [cmd TOPIC] [odom TOPIC]`.
    pub fn rest(&self) -> String {
        let args = |args: &[Arg]| {
            args.iter()
                .map(|a| {
                    if a.optional {
                        format!("[{}]", a.name)
                    } else {
                        a.name.to_string()
                    }
                })
                .collect::<Vec<_>>()
        };
        let mut parts = args(self.args);
        for o in self.options {
            let mut words = vec![o.word.to_string()];
            words.extend(args(o.args));
            parts.push(format!("[{}]", words.join(" ")));
        }
        parts.join(" ")
    }

    /// The option spelt `word`, if this form takes it.
    pub fn option(&self, word: &str) -> Option<&'static Opt> {
        self.options.iter().find(|o| o.word == word)
    }

    /// How many positional arguments it needs.
    pub fn required(&self) -> usize {
        self.args.iter().filter(|a| !a.optional).count()
    }
}

impl CommandSpec {
    /// The form whose sub-word is `word`, else the form without one (`plot FILE`), if any.
    pub fn form_for(&self, word: Option<&str>) -> Option<&'static Form> {
        let forms = self.forms;
        word.and_then(|w| forms.iter().find(|f| f.sub == Some(w)))
            .or_else(|| forms.iter().find(|f| f.sub.is_none()))
    }

    /// The sub-words of its forms: `demos`, `trace` for `load`.
    pub fn subs(&self) -> impl Iterator<Item = &'static str> {
        self.forms.iter().filter_map(|f| f.sub)
    }

    /// Every word a statement of this command may hold: its name, aliases, sub-words, options.
    pub fn words(&self) -> Vec<&'static str> {
        let mut out = vec![self.name];
        out.extend(self.aliases);
        for f in self.forms {
            out.extend(f.sub);
            out.extend(f.options.iter().map(|o| o.word));
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// The teacher's workflow, in order: `help` lists the commands under these steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    Demonstrate,
    Run,
    Select,
    Correct,
    TakeBack,
    Measure,
    Keep,
    Session,
}

impl Step {
    pub const ALL: [Step; 8] = [
        Step::Demonstrate,
        Step::Run,
        Step::Select,
        Step::Correct,
        Step::TakeBack,
        Step::Measure,
        Step::Keep,
        Step::Session,
    ];

    /// The step's heading in `help`.
    pub fn label(self) -> &'static str {
        match self {
            Step::Demonstrate => "demonstrate",
            Step::Run => "run",
            Step::Select => "select",
            Step::Correct => "correct",
            Step::TakeBack => "take back",
            Step::Measure => "measure",
            Step::Keep => "keep",
            Step::Session => "session",
        }
    }
}

const fn arg(kind: ArgKind, name: &'static str) -> Arg {
    Arg {
        kind,
        name,
        optional: false,
    }
}

const fn optional(kind: ArgKind, name: &'static str) -> Arg {
    Arg {
        kind,
        name,
        optional: true,
    }
}

/// A form with only arguments.
const fn form(rule: Rule, args: &'static [Arg], example: &'static str) -> Form {
    Form {
        rule,
        sub: None,
        args,
        options: &[],
        example,
    }
}

/// A form with a sub-word and arguments.
const fn sub(rule: Rule, word: &'static str, args: &'static [Arg], example: &'static str) -> Form {
    Form {
        rule,
        sub: Some(word),
        args,
        options: &[],
        example,
    }
}

/// A form without arguments.
const fn bare(rule: Rule, example: &'static str) -> Form {
    form(rule, &[], example)
}

use ArgKind::{Count, Number, Path, RosTopic};

const TOPIC: &[Arg] = &[arg(RosTopic, "TOPIC")];
const POSE: &[Arg] = &[arg(Number, "X"), arg(Number, "Y"), arg(Number, "THETA")];
/// A goal's values, in the task's order or named: `2 -1 0.5`, `px=2 py=1`.
const GOAL: &[Arg] = &[arg(Number, "V...")];
const SECONDS: &[Arg] = &[arg(Number, "S")];
/// `takeover A..B`: the teacher drives from A to B seconds into a run.
const TAKEOVER: &[Opt] = &[Opt {
    word: "takeover",
    args: &[arg(ArgKind::Range, "A..B")],
}];

/// Every command, in the order hints try them and `help` lists them within a step. A command is
/// this entry, its rules in `grammar/session.pest` (`command`), its [`super::Command`] variant
/// with its arm in [`super::Command::rule`] and in the builder, and its arm in `Session::command`;
/// the tests below fail when they disagree, and the compiler asks for the arms.
pub const COMMANDS: &[CommandSpec] = &[
    CommandSpec {
        name: "task",
        aliases: &[],
        forms: &[form(
            Rule::c_task,
            &[arg(ArgKind::Task, "NAME")],
            "task interception",
        )],
        signature: "task positioning|interception|NAME",
        doc: "Switch task (positioning: A-OPI with LWR; interception: BC with 1-NN; a task loaded with `tasks FILE`: LWR). Each task keeps its own dataset, executions and history.",
        step: Step::Demonstrate,
        example: "task interception",
    },
    CommandSpec {
        name: "tasks",
        aliases: &[],
        forms: &[form(
            Rule::c_tasks,
            &[arg(Path, "FILE.adv")],
            "tasks examples/tasks/standoff.adv",
        )],
        signature: "tasks FILE.adv",
        doc: "Check a file of task declarations (`domain NAME { goal ... success when ... }`) and add its tasks and operators; `task NAME` switches to one.",
        step: Step::Demonstrate,
        example: "tasks examples/tasks/standoff.adv",
    },
    CommandSpec {
        name: "backend",
        aliases: &[],
        forms: &[form(
            Rule::c_backend,
            &[arg(ArgKind::Backend, "SPEC")],
            "backend ros2:/robot1?domain=3",
        )],
        signature: "backend sim|rmp:HOST:PORT|ros2",
        doc: "Choose the robot: the simulator, a Segway RMP at an address, or a ROS 2 base on `cmd_vel` and `odom` (`ros2:/NS` under a namespace).",
        step: Step::Run,
        example: "backend sim",
    },
    CommandSpec {
        name: "load",
        aliases: &[],
        forms: &[
            Form {
                rule: Rule::c_load_demos,
                sub: Some("demos"),
                args: &[arg(Path, "FILE")],
                options: &[
                    Opt {
                        word: "cmd",
                        args: TOPIC,
                    },
                    Opt {
                        word: "odom",
                        args: TOPIC,
                    },
                ],
                example: "load demos bags/run1 odom /robot1/odom cmd /robot1/cmd_vel",
            },
            sub(
                Rule::c_load_trace,
                "trace",
                &[arg(Path, "FILE")],
                "load trace run3.csv",
            ),
        ],
        signature: "load demos FILE | load trace FILE",
        doc: "Load demonstrations (a file; a ROS 2 bag or CSV log, `cmd TOPIC` and `odom TOPIC` naming a bag's topics; or `teacher:N` to record N teacher runs in the simulator) or a trace to advise.",
        step: Step::Demonstrate,
        example: "load demos teacher:5",
    },
    CommandSpec {
        name: "operators",
        aliases: &[],
        forms: &[form(
            Rule::c_operators,
            &[arg(Path, "FILE.adv")],
            "operators mine.adv",
        )],
        signature: "operators FILE.adv",
        doc: "Check an operator file and add its operators on top of the standard ones.",
        step: Step::Demonstrate,
        example: "operators mine.adv",
    },
    CommandSpec {
        name: "run",
        aliases: &[],
        forms: &[
            Form {
                rule: Rule::c_run_goal,
                sub: Some("goal"),
                args: GOAL,
                options: TAKEOVER,
                example: "run goal 2 -1 0.5 takeover 2..4",
            },
            Form {
                rule: Rule::c_run_start,
                sub: Some("start"),
                args: &[arg(Count, "N")],
                options: TAKEOVER,
                example: "run start 3",
            },
        ],
        signature: "run goal V... | run start N",
        doc: "Run the current policy to a goal, its values in the task's order or by name (`run goal 2 -1 0.5`, `run goal px=2 py=1`), or from the N-th practice start, and record it; the reply names the goal. With `takeover A..B` the task's teacher drives from A to B seconds into the run, and what it drove joins the data as a demonstration linked to the run (`why` names it, `undo` takes it back).",
        step: Step::Run,
        example: "run goal 2 -1 0",
    },
    CommandSpec {
        name: "show",
        aliases: &[],
        forms: &[form(Rule::c_show, &[optional(Count, "N")], "show 0")],
        signature: "show [N]",
        doc: "Summarise the selected execution (or execution N), with a small plot.",
        step: Step::Run,
        example: "show 0",
    },
    CommandSpec {
        name: "select",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_select,
            sub: None,
            args: &[arg(ArgKind::Range, "A..B")],
            options: &[Opt {
                word: "in",
                args: &[arg(Count, "N")],
            }],
            example: "select 10..40 in 0",
        }],
        signature: "select A..B [in N]",
        doc: "Select points A (inclusive) to B (exclusive) of the latest execution, or of execution N with `in N`; `A..end` (or `A..`) runs to the last point and `-N..end` is the last N points. Advise, critique, preview, why and plot act on it.",
        step: Step::Select,
        example: "select 10..40 in 0",
    },
    CommandSpec {
        name: "advise",
        aliases: &[],
        forms: &[form(
            Rule::c_advise,
            &[arg(ArgKind::Invocation, "OP[(ARGS)]")],
            "advise speed_up(0.5)",
        )],
        signature: "advise OP[(ARGS)]",
        doc: "Correct the selection with an advice operator: its points are synthesized and added (A-OPI).",
        step: Step::Correct,
        example: "advise speed_up(0.5)",
    },
    CommandSpec {
        name: "preview",
        aliases: &[],
        forms: &[form(
            Rule::c_preview,
            &[arg(ArgKind::Invocation, "OP[(ARGS)]")],
            "preview slow_down(rate = 0.3)",
        )],
        signature: "preview OP[(ARGS)]",
        doc: "Show what `advise` would add, without adding it.",
        step: Step::Correct,
        example: "preview slow_down(rate = 0.3)",
    },
    CommandSpec {
        name: "suggest",
        aliases: &[],
        forms: &[form(Rule::c_suggest, &[optional(Count, "N")], "suggest 0")],
        signature: "suggest [N]",
        doc: "Find the chunks of the latest execution (or execution N) where the task's `flaw` clauses hold, each with candidate advice (operators at a little, more, much more) and, on the simulator, what a re-run of the same start with the same noise shows with it, ranked. Nothing is added: `accept K` applies one.",
        step: Step::Correct,
        example: "suggest 0",
    },
    CommandSpec {
        name: "accept",
        aliases: &[],
        forms: &[form(Rule::c_accept, &[arg(Count, "K")], "accept 1")],
        signature: "accept K",
        doc: "Apply suggestion K of the last `suggest`: `select` its chunk, then `advise` its operator (journalled as those two).",
        step: Step::Correct,
        example: "accept 1",
    },
    CommandSpec {
        name: "critique",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_critique,
            sub: None,
            args: &[optional(Number, "KAPPA")],
            options: &[Opt {
                word: "--directional",
                args: &[],
            }],
            example: "critique 2 --directional",
        }],
        signature: "critique [--directional] [KAPPA]",
        doc: "Flag the selection as poor: the data points that recommended its actions are pushed away (BC); `--directional` penalises each only for observations on the flagged side of it (the paper's proposed improvement).",
        step: Step::Correct,
        example: "critique 2",
    },
    CommandSpec {
        name: "undo",
        aliases: &[],
        forms: &[bare(Rule::c_undo, "undo")],
        signature: "undo",
        doc: "Take back the last advice or critique, exactly.",
        step: Step::TakeBack,
        example: "undo",
    },
    CommandSpec {
        name: "redo",
        aliases: &[],
        forms: &[bare(Rule::c_redo, "redo")],
        signature: "redo",
        doc: "Put back what `undo` took.",
        step: Step::TakeBack,
        example: "redo",
    },
    CommandSpec {
        name: "history",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_history,
            sub: None,
            args: &[],
            options: &[Opt {
                word: "--conflicts",
                args: &[],
            }],
            example: "history --conflicts",
        }],
        signature: "history [--conflicts]",
        doc: "List the advice and critiques given so far; `--conflicts` lists only the advice that contradicts earlier advice or demonstrations where the learner treats the observations as one.",
        step: Step::TakeBack,
        example: "history",
    },
    CommandSpec {
        name: "eval",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_eval,
            sub: None,
            args: &[],
            options: &[Opt {
                word: "--detail",
                args: &[],
            }],
            example: "eval --detail",
        }],
        signature: "eval [--detail]",
        doc: "Evaluate the policy on the task's fixed test set (never advised) and say what changed since the last eval; `--detail` lists the tests that changed outcome.",
        step: Step::Measure,
        example: "eval --detail",
    },
    CommandSpec {
        name: "rederive",
        aliases: &[],
        forms: &[bare(Rule::c_rederive, "rederive")],
        signature: "rederive",
        doc: "Re-derive the policy from scratch (LWR is re-tuned by cross-validation).",
        step: Step::Measure,
        example: "rederive",
    },
    CommandSpec {
        name: "learner",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_learner,
            sub: None,
            args: &[arg(ArgKind::Learner, "bc|lwr")],
            options: &[Opt {
                word: "k",
                args: &[arg(Count, "N")],
            }],
            example: "learner lwr k 64",
        }],
        signature: "learner bc|lwr [k N]",
        doc: "Switch the running learner: `bc` (1-NN with critique weights) or `lwr` (locally weighted regression); the dataset is shared. `k N` limits LWR's kernel to its N nearest points (without it: no limit up to 20,000 points, beyond them the tuned kernel's mean neighbours, docs/protocol.md).",
        step: Step::Measure,
        example: "learner bc",
    },
    CommandSpec {
        name: "why",
        aliases: &[],
        forms: &[form(Rule::c_why, &[arg(Count, "T")], "why 12")],
        signature: "why T",
        doc: "Show which data points supported the action at point T, with their provenance.",
        step: Step::Correct,
        example: "why 12",
    },
    CommandSpec {
        name: "plot",
        aliases: &[],
        forms: &[
            form(Rule::c_plot, &[arg(Path, "FILE.svg")], "plot run.svg"),
            sub(
                Rule::plot_actions,
                "actions",
                &[arg(Path, "FILE.svg")],
                "plot actions a.svg",
            ),
            sub(
                Rule::plot_compare,
                "compare",
                &[arg(Path, "FILE.svg"), arg(Count, "N"), arg(Count, "M")],
                "plot compare c.svg 0 1",
            ),
        ],
        signature: "plot [actions|compare] FILE [N M]",
        doc: "Write the selected execution's path as SVG, `plot actions FILE` its actions against point index, `plot compare FILE N M` executions N and M overlaid; selection, advice and critiques marked.",
        step: Step::Run,
        example: "plot actions path.svg",
    },
    CommandSpec {
        name: "save",
        aliases: &[],
        forms: &[form(
            Rule::c_save,
            &[arg(Path, "FILE.json|FILE.csv")],
            "save session.json",
        )],
        signature: "save FILE.json|FILE.csv",
        doc: "Save the dataset with provenance (.json), or its points only (.csv). A .json also holds every execution's points and goal and the history of edits, which `open` brings back; a run's label and outcome, the selection and evaluations are not saved (the journal keeps them: `advise resume`).",
        step: Step::Keep,
        example: "save session.json",
    },
    CommandSpec {
        name: "open",
        aliases: &[],
        forms: &[form(
            Rule::c_open,
            &[arg(Path, "FILE.json")],
            "open session.json",
        )],
        signature: "open FILE.json",
        doc: "Open a dataset saved with `save`: its points with their provenance, its executions and its history of edits (what `history` lists and `undo` walks) replace this task's. The reply counts what it restored and what it replaced, and warns of what a file does not hold: a run's label and outcome, the selection, undone edits and the last evaluation.",
        step: Step::Keep,
        example: "open session.json",
    },
    CommandSpec {
        name: "export",
        aliases: &[],
        forms: &[
            sub(
                Rule::c_export_advice,
                "advice",
                &[arg(Path, "FILE.csv")],
                "export advice advice.csv",
            ),
            sub(
                Rule::c_export_mcap,
                "mcap",
                &[arg(Path, "FILE.mcap")],
                "export mcap session.mcap",
            ),
            sub(
                Rule::c_export_lerobot,
                "lerobot",
                &[arg(Path, "DIR")],
                "export lerobot out/",
            ),
        ],
        signature: "export advice|mcap|lerobot PATH",
        doc: "`advice FILE.csv`: every advised point with its provenance; `mcap FILE.mcap`: the executions, advice and critiques for Foxglove and ROS 2 tools; `lerobot DIR`: the points as a LeRobot v3.0 dataset.",
        step: Step::Keep,
        example: "export advice advice.csv",
    },
    CommandSpec {
        name: "help",
        aliases: &[],
        forms: &[form(
            Rule::c_help,
            &[optional(ArgKind::Topic, "COMMAND|OPERATOR")],
            "help advise",
        )],
        signature: "help [COMMAND|OPERATOR]",
        doc: "Help on commands and operators.",
        step: Step::Session,
        example: "help advise",
    },
    CommandSpec {
        name: "record",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_record_demo,
            sub: Some("demo"),
            args: &[],
            options: &[
                Opt {
                    word: "from",
                    args: TOPIC,
                },
                Opt {
                    word: "goal",
                    args: POSE,
                },
                Opt {
                    word: "for",
                    args: SECONDS,
                },
                Opt {
                    word: "--keep-idle",
                    args: &[],
                },
            ],
            example: "record demo from teleop/cmd_vel goal 2 -1 0 for 60",
        }],
        signature: "record demo [from TOPIC] [for S]",
        doc: "Record a person driving the ROS 2 base with their own teleoperation (Twist or TwistStamped commands on TOPIC, default `cmd_vel`) until Enter or Ctrl-C, S seconds, or 3 s without a moving command with the base at rest; added as a demonstration whose goal is where the base stopped (`goal X Y THETA` gives one), without the standing still after it came to rest (`--keep-idle` keeps it).",
        step: Step::Demonstrate,
        example: "record demo from teleop/cmd_vel goal 2 -1 0 for 60",
    },
    CommandSpec {
        name: "teleop",
        aliases: &[],
        forms: &[Form {
            rule: Rule::c_teleop,
            sub: None,
            args: &[],
            options: &[
                Opt {
                    word: "goal",
                    args: POSE,
                },
                Opt {
                    word: "for",
                    args: SECONDS,
                },
            ],
            example: "teleop goal 2 -1 0 for 60",
        }],
        signature: "teleop [for S]",
        doc: "Drive the base (any backend) from this terminal's keys: up/w and down/s speed, left/a and right/d turn, space stops, +/- scale the steps, Enter or q ends; kept as a demonstration whose goal is where the base stopped (`goal X Y THETA` gives one).",
        step: Step::Demonstrate,
        example: "teleop goal 2 -1 0 for 60",
    },
    CommandSpec {
        name: "quit",
        aliases: &["exit"],
        forms: &[bare(Rule::c_quit, "exit")],
        signature: "quit",
        doc: "Leave the session (the journal keeps everything).",
        step: Step::Session,
        example: "quit",
    },
];

/// The command called `name` (or one of its aliases), if any.
pub fn command_spec(name: &str) -> Option<&'static CommandSpec> {
    COMMANDS
        .iter()
        .find(|c| c.name == name || c.aliases.contains(&name))
}

/// The command and form whose grammar rule is `rule`, if any.
pub fn form_of(rule: Rule) -> Option<(&'static CommandSpec, &'static Form)> {
    COMMANDS
        .iter()
        .find_map(|c| c.forms.iter().find(|f| f.rule == rule).map(|f| (c, f)))
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, BTreeSet};

    use super::*;
    use crate::syntax::command::{Statement, parse_statement};

    /// A token of a grammar rule's body that the tests look at.
    #[derive(Clone, Debug, PartialEq)]
    enum Token {
        /// Another rule (or a builtin such as `ANY`).
        Rule(String),
        /// A string literal, unquoted.
        Literal(String),
    }

    /// The rules of a pest grammar: each name with its body's rule names and string literals, in
    /// order. Enough of pest's syntax for `session.pest`: doc and line comments, `name = {...}`
    /// with a modifier, string and character literals, repetition braces.
    fn rules_of(grammar: &str) -> BTreeMap<String, Vec<Token>> {
        #[derive(Debug, PartialEq)]
        enum Lex {
            Ident(String),
            Str(String),
            Punct(char),
        }
        let text: String = grammar
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        let mut lexed = Vec::new();
        let mut chars = text.chars().peekable();
        while let Some(c) = chars.next() {
            match c {
                c if c.is_whitespace() => {}
                '"' | '\'' => {
                    let mut s = String::new();
                    while let Some(d) = chars.next() {
                        match d {
                            // An escape stays visible, so `"\t"` is not the word `t`.
                            '\\' => s.extend(['\\'].into_iter().chain(chars.next())),
                            d if d == c => break,
                            d => s.push(d),
                        }
                    }
                    lexed.push(Lex::Str(s));
                }
                c if c.is_alphanumeric() || c == '_' => {
                    let mut s = String::from(c);
                    while let Some(&d) = chars.peek().filter(|d| d.is_alphanumeric() || **d == '_')
                    {
                        s.push(d);
                        chars.next();
                    }
                    lexed.push(Lex::Ident(s));
                }
                c => lexed.push(Lex::Punct(c)),
            }
        }
        let mut rules = BTreeMap::new();
        let mut i = 0;
        while i + 2 < lexed.len() {
            let (Lex::Ident(name), Lex::Punct('=')) = (&lexed[i], &lexed[i + 1]) else {
                i += 1;
                continue;
            };
            let mut j = i + 2;
            // A modifier: `@`, `$`, `!`, or `_` (read as a name).
            while matches!(lexed.get(j), Some(Lex::Punct('@' | '$' | '!')))
                || matches!(lexed.get(j), Some(Lex::Ident(m)) if m == "_")
            {
                j += 1;
            }
            assert_eq!(lexed.get(j), Some(&Lex::Punct('{')), "rule `{name}`");
            let (mut depth, mut body) = (1, Vec::new());
            j += 1;
            while depth > 0 {
                match &lexed[j] {
                    Lex::Punct('{') => depth += 1,
                    Lex::Punct('}') => depth -= 1,
                    Lex::Ident(s) if !s.starts_with(|c: char| c.is_ascii_digit()) => {
                        body.push(Token::Rule(s.clone()))
                    }
                    Lex::Str(s) => body.push(Token::Literal(s.clone())),
                    _ => {}
                }
                j += 1;
            }
            rules.insert(name.clone(), body);
            i = j;
        }
        rules
    }

    /// The grammar of session statements, as text.
    fn session_rules() -> BTreeMap<String, Vec<Token>> {
        rules_of(include_str!("../../../../../grammar/session.pest"))
    }

    /// A keyword rule: `cw_load = @{ "load" ~ !ident_char }`, `kw_actions`, `detail_flag`.
    fn is_keyword(rule: &str) -> bool {
        rule.starts_with("cw_") || rule.starts_with("kw_") || rule.ends_with("_flag")
    }

    /// The words a keyword rule matches: `load`; `quit` and `exit`; `--detail`.
    fn keyword_words(body: &[Token]) -> Vec<String> {
        body.iter()
            .filter_map(|t| match t {
                Token::Literal(s)
                    if !s.is_empty()
                        && s.chars()
                            .all(|c| c.is_alphanumeric() || c == '-' || c == '_') =>
                {
                    Some(s.clone())
                }
                _ => None,
            })
            .collect()
    }

    /// Every keyword reachable from `rule` through the rules of `rules` (a keyword rule is not
    /// entered further; rules of the other grammar, `name` or `inv_args`, hold no command words).
    fn words_of(rules: &BTreeMap<String, Vec<Token>>, rule: &str) -> BTreeSet<String> {
        let (mut out, mut seen, mut todo) = (BTreeSet::new(), BTreeSet::new(), vec![rule]);
        while let Some(r) = todo.pop() {
            let Some(body) = rules.get(r).filter(|_| seen.insert(r)) else {
                continue;
            };
            if is_keyword(r) {
                out.extend(keyword_words(body));
                continue;
            }
            todo.extend(body.iter().filter_map(|t| match t {
                Token::Rule(n) => Some(n.as_str()),
                Token::Literal(_) => None,
            }));
        }
        out
    }

    fn rule_name(rule: Rule) -> String {
        format!("{rule:?}")
    }

    /// The grammar's `command` alternation and the table name the same rules, and every `c_`
    /// rule the grammar defines is in the alternation.
    #[test]
    fn the_grammar_and_the_table_have_the_same_commands() {
        let rules = session_rules();
        let alternation: BTreeSet<String> = rules["command"]
            .iter()
            .filter_map(|t| match t {
                Token::Rule(n) => Some(n.clone()),
                Token::Literal(_) => None,
            })
            .collect();
        let defined: BTreeSet<String> = rules
            .keys()
            .filter(|n| n.starts_with("c_"))
            .cloned()
            .collect();
        assert_eq!(alternation, defined, "a `c_` rule outside `command`");
        let mut tabled = BTreeSet::new();
        for c in COMMANDS {
            for f in c.forms {
                let rule = rule_name(f.rule);
                assert!(
                    rules.contains_key(&rule),
                    "`{}`'s rule {rule} is not in session.pest",
                    c.name
                );
                // A form inside another (`plot actions`) is reached from its command's rule.
                if !alternation.contains(&rule) {
                    let reached = c.forms.iter().any(|top| {
                        let top = rule_name(top.rule);
                        alternation.contains(&top) && reaches(&rules, &top, &rule)
                    });
                    assert!(reached, "`{}`: {rule} is in no rule of `command`", c.name);
                }
                tabled.insert(rule);
            }
        }
        let missing: Vec<_> = alternation.difference(&tabled).collect();
        assert!(
            missing.is_empty(),
            "in the grammar, not the table: {missing:?}"
        );
    }

    fn reaches(rules: &BTreeMap<String, Vec<Token>>, from: &str, to: &str) -> bool {
        let (mut seen, mut todo) = (BTreeSet::new(), vec![from.to_string()]);
        while let Some(r) = todo.pop() {
            if r == to {
                return true;
            }
            if let Some(body) = rules.get(&r).filter(|_| seen.insert(r.clone())) {
                todo.extend(body.iter().filter_map(|t| match t {
                    Token::Rule(n) => Some(n.clone()),
                    Token::Literal(_) => None,
                }));
            }
        }
        false
    }

    /// Each command's words (its name and aliases, sub-words and options) are the keywords its
    /// grammar rules match, no more and no fewer; each rule of `command` starts with the
    /// command's word, and each form's rule holds its sub-word and options.
    #[test]
    fn the_grammar_and_the_table_have_the_same_words() {
        let rules = session_rules();
        for c in COMMANDS {
            let mut grammar = BTreeSet::new();
            for f in c.forms {
                let rule = rule_name(f.rule);
                let words = words_of(&rules, &rule);
                let own: Vec<&str> = f
                    .sub
                    .into_iter()
                    .chain(f.options.iter().map(|o| o.word))
                    .collect();
                for w in own {
                    assert!(
                        words.contains(w),
                        "`{}`: {rule} does not match `{w}`",
                        c.name
                    );
                }
                if rule.starts_with("c_") {
                    let first = match rules[&rule].first() {
                        Some(Token::Rule(r)) if is_keyword(r) => keyword_words(&rules[r]),
                        other => panic!("{rule} starts with {other:?}, not a keyword"),
                    };
                    let mut expected: Vec<String> = std::iter::once(c.name)
                        .chain(c.aliases.iter().copied())
                        .map(String::from)
                        .collect();
                    expected.sort();
                    let mut first = first;
                    first.sort();
                    assert_eq!(first, expected, "the word of {rule}");
                }
                grammar.extend(words);
            }
            let table: BTreeSet<String> = c.words().into_iter().map(String::from).collect();
            assert_eq!(
                grammar, table,
                "the words of `{}`: grammar, then table",
                c.name
            );
        }
    }

    /// Each form's example parses to a command of that form (so the builder knows the rule and
    /// [`super::super::Command::rule`] answers it); names are unique; each step has a command;
    /// the signature shows each sub-word and the signature or help each option.
    #[test]
    fn every_form_parses_to_its_command_and_help_shows_its_words() {
        let mut names = BTreeSet::new();
        for c in COMMANDS {
            for w in std::iter::once(c.name).chain(c.aliases.iter().copied()) {
                assert!(names.insert(w), "`{w}` twice");
            }
            assert!(c.signature.starts_with(c.name), "{c:?}");
            assert!(!c.doc.is_empty(), "{c:?}");
            assert!(!c.forms.is_empty(), "{c:?}");
            let bare = c.forms.iter().filter(|f| f.sub.is_none()).count();
            assert!(bare <= 1, "`{}`: which form without a sub-word?", c.name);
            let mut examples = vec![c.example];
            for f in c.forms {
                let words = std::iter::once(c.name).chain(c.aliases.iter().copied());
                let lead: Vec<String> = words
                    .map(|w| f.sub.map_or(w.to_string(), |s| format!("{w} {s}")))
                    .collect();
                assert!(
                    lead.iter().any(|l| f.example.starts_with(l.as_str())),
                    "{:?} does not start with {lead:?}",
                    f.example
                );
                examples.push(f.example);
                let parsed = parse(f.example);
                assert_eq!(parsed.rule(), f.rule, "{:?}", f.example);
                if let Some(s) = f.sub {
                    assert!(
                        c.signature.contains(s),
                        "`{}`'s signature lacks `{s}`",
                        c.name
                    );
                }
                for o in f.options {
                    assert!(
                        c.signature.contains(o.word) || c.doc.contains(o.word),
                        "`{}` says nothing of `{}`",
                        c.name,
                        o.word
                    );
                }
                let required = f
                    .args
                    .iter()
                    .position(|a| a.optional)
                    .unwrap_or(f.args.len());
                assert_eq!(
                    required,
                    f.required(),
                    "optional arguments come last: {f:?}"
                );
            }
            for e in examples {
                let parsed = parse(e);
                assert_eq!(parsed.name(), c.name, "{e}");
                assert_eq!(parsed.spec(), c);
            }
        }
        for step in Step::ALL {
            assert!(
                COMMANDS.iter().any(|c| c.step == step),
                "no command under {step:?}"
            );
        }
    }

    fn parse(text: &str) -> crate::syntax::command::Command {
        let (map, id) = crate::diag::SourceMap::single("<example>", text);
        match parse_statement(map.src(id)) {
            Ok(Statement::Command(command, _)) => command,
            other => panic!("the example {text:?} does not parse: {other:?}"),
        }
    }

    /// The reader above sees what the tests rely on, so they can fail.
    #[test]
    fn the_grammar_reader_finds_rules_and_keywords() {
        let rules = rules_of(
            "/// doc `x = { y }`\na = { cw_b ~ (c | \"}\")* ~ d{2} }\ncw_b = @{ (\"b\" | \"bb\") ~ !(ident_char | \"\\t\") }\nc = { cw_b ~ \" \" }",
        );
        assert_eq!(rules.keys().collect::<Vec<_>>(), ["a", "c", "cw_b"]);
        assert_eq!(
            rules["a"],
            [
                Token::Rule("cw_b".into()),
                Token::Rule("c".into()),
                Token::Literal("}".into()),
                Token::Rule("d".into())
            ]
        );
        assert_eq!(
            words_of(&rules, "a"),
            BTreeSet::from(["b".into(), "bb".into()])
        );
        assert!(reaches(&rules, "a", "c") && !reaches(&rules, "c", "a"));
        assert!(session_rules()["command"].len() > 20);
    }
}
