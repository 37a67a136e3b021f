//! Session statements: commands and items, one at a time, as typed at the REPL or read from a
//! script. Built from the `session_line` rule of `grammar/session.pest`. What the commands do is
//! [`crate::session`]'s business; this module only gives them shape and spans.

use super::ast::{Ident, Item, Span};
use super::{Builder, InvArg, Invocation, ParseError, Rule, delims, run};
use crate::diag::{SourceId, Src};
use pest::iterators::Pair;

mod table;
pub use table::{Arg, ArgKind, COMMANDS, CommandSpec, Form, Opt, Step, command_spec, form_of};

/// One statement of a session.
#[derive(Clone, Debug, PartialEq)]
pub enum Statement {
    /// A blank or comment-only line.
    Empty,
    /// An operator or domain defined on the spot.
    Item(Item),
    /// A session command.
    Command(Command, Span),
}

/// What `plot` draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlotKind {
    /// The selected execution's path in the plane: `plot FILE.svg`.
    Path,
    /// The selected execution's actions against point index: `plot actions FILE.svg`.
    Actions,
    /// Two executions' paths overlaid: `plot compare FILE.svg N M`.
    Compare { before: usize, after: usize },
}

/// `takeover A..B` of a run: the task's teacher drives from `from_s` to `to_s` seconds into it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TakeoverSeconds {
    pub from_s: f64,
    pub to_s: f64,
    /// Where `A..B` was written.
    pub span: Span,
}

impl std::fmt::Display for TakeoverSeconds {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = |v: f64| crate::number::fmt_num(v);
        write!(f, "{}..{}", n(self.from_s), n(self.to_s))
    }
}

/// A session command, as the teacher wrote it.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    Task(Ident),
    /// `tasks FILE`: check a file and add the tasks it declares.
    Tasks(String),
    Backend(String),
    /// `load demos PATH [cmd TOPIC] [odom TOPIC]`: the topics apply to a bag.
    LoadDemos {
        path: String,
        cmd_topic: Option<String>,
        odom_topic: Option<String>,
    },
    LoadTrace(String),
    Operators(String),
    /// `run goal V...`: the goal's values, each in the task's order or named (`px=2`); which
    /// names and how many the task takes is the session's business.
    RunGoal {
        goal: Vec<InvArg>,
        takeover: Option<TakeoverSeconds>,
    },
    /// `run start N [takeover A..B]`.
    RunStart {
        start: usize,
        takeover: Option<TakeoverSeconds>,
    },
    /// `show` (the selected execution) or `show N`.
    Show(Option<usize>),
    /// `select A..B` (of the latest execution) or `select A..B in N`; `A..end`, `A..` and
    /// `-N..end` are resolved against the execution.
    Select {
        range: PointRange,
        span: Span,
        execution: Option<usize>,
    },
    /// `critique [--directional] [KAPPA]`.
    Critique {
        kappa: Option<f64>,
        /// `--directional`: the paper's proposed rule, the penalty depends on the query's
        /// direction from the point.
        directional: bool,
    },
    Advise(Invocation),
    Preview(Invocation),
    /// `suggest [N]`: flawed chunks of execution N (the latest) with candidate advice.
    Suggest(Option<usize>),
    /// `accept K`: suggestion K of the last `suggest`, applied as `select` + `advise`.
    Accept(usize),
    Undo,
    Redo,
    /// `history [--conflicts]`.
    History {
        conflicts: bool,
    },
    Rederive,
    Eval {
        detail: bool,
    },
    /// `learner NAME [k N]`: `k` limits LWR's kernel to its N nearest points.
    Learner {
        name: Ident,
        k: Option<usize>,
    },
    Why(usize),
    Plot {
        kind: PlotKind,
        path: String,
    },
    Save(String),
    Open(String),
    ExportAdvice(String),
    /// `export mcap FILE`: the dataset as MCAP (Foxglove, ROS 2 tools).
    ExportMcap(String),
    /// `export lerobot DIR`: the dataset as a LeRobot v3.0 dataset.
    ExportLeRobot(String),
    Help(Option<Ident>),
    Quit,
    /// `record demo [from TOPIC] [goal X Y THETA] [for SECONDS] [--keep-idle]`.
    RecordDemo {
        topic: Option<String>,
        goal: Option<[f64; 3]>,
        seconds: Option<f64>,
        keep_idle: bool,
    },
    /// `teleop [goal X Y THETA] [for SECONDS]`.
    Teleop {
        goal: Option<[f64; 3]>,
        seconds: Option<f64>,
    },
}

impl Command {
    /// The grammar rule it was parsed from: its form's key in [`COMMANDS`] (exhaustive, so a new
    /// variant must name its rule, and the table's tests then ask for its form).
    pub fn rule(&self) -> Rule {
        match self {
            Command::Task(_) => Rule::c_task,
            Command::Tasks(_) => Rule::c_tasks,
            Command::Backend(_) => Rule::c_backend,
            Command::LoadDemos { .. } => Rule::c_load_demos,
            Command::LoadTrace(_) => Rule::c_load_trace,
            Command::Operators(_) => Rule::c_operators,
            Command::RunGoal { .. } => Rule::c_run_goal,
            Command::RunStart { .. } => Rule::c_run_start,
            Command::Show(_) => Rule::c_show,
            Command::Select { .. } => Rule::c_select,
            Command::Critique { .. } => Rule::c_critique,
            Command::Advise(_) => Rule::c_advise,
            Command::Preview(_) => Rule::c_preview,
            Command::Undo => Rule::c_undo,
            Command::Redo => Rule::c_redo,
            Command::Suggest(_) => Rule::c_suggest,
            Command::Accept(_) => Rule::c_accept,
            Command::History { .. } => Rule::c_history,
            Command::Rederive => Rule::c_rederive,
            Command::Eval { .. } => Rule::c_eval,
            Command::Learner { .. } => Rule::c_learner,
            Command::Why(_) => Rule::c_why,
            Command::Plot { kind, .. } => match kind {
                PlotKind::Path => Rule::c_plot,
                PlotKind::Actions => Rule::plot_actions,
                PlotKind::Compare { .. } => Rule::plot_compare,
            },
            Command::Save(_) => Rule::c_save,
            Command::Open(_) => Rule::c_open,
            Command::ExportAdvice(_) => Rule::c_export_advice,
            Command::ExportMcap(_) => Rule::c_export_mcap,
            Command::ExportLeRobot(_) => Rule::c_export_lerobot,
            Command::Help(_) => Rule::c_help,
            Command::Quit => Rule::c_quit,
            Command::RecordDemo { .. } => Rule::c_record_demo,
            Command::Teleop { .. } => Rule::c_teleop,
        }
    }

    /// Its form in the table.
    pub fn form(&self) -> &'static Form {
        self.entry().1
    }

    /// The command's word: its [`CommandSpec`]'s `name`.
    pub fn name(&self) -> &'static str {
        self.spec().name
    }

    /// What `help` and hints know of it.
    pub fn spec(&self) -> &'static CommandSpec {
        self.entry().0
    }

    fn entry(&self) -> (&'static CommandSpec, &'static Form) {
        form_of(self.rule()).expect("every command's rule has a form in the table (tested)")
    }
}

/// Parse one statement, a source of the session's map (named `<repl>`, or `script.adv:12`).
pub fn parse_statement(source: Src<'_>) -> Result<Statement, ParseError> {
    statement(source.id, source.text)
}

/// Whether `src` parses as a statement (only the answer is kept).
pub fn is_statement(src: &str) -> bool {
    statement(SourceId::UNMAPPED, src).is_ok()
}

fn statement(id: SourceId, src: &str) -> Result<Statement, ParseError> {
    let mut pairs = run(Rule::session_line, id, src).map_err(|e| {
        unknown_command(id, src)
            .or_else(|| unknown_option(id, src))
            .unwrap_or(e)
    })?;
    let line = pairs.next().expect("session_line always yields one pair");
    let b = Builder::new(id);
    let Some(p) = line.into_inner().find(|p| p.as_rule() != Rule::EOI) else {
        return Ok(Statement::Empty);
    };
    let span = b.span(&p);
    let rule = p.as_rule();
    if matches!(rule, Rule::domain | Rule::operator) {
        return b.item(p).map(Statement::Item);
    }
    let mut args = p
        .into_inner()
        .filter(|a| !format!("{:?}", a.as_rule()).starts_with("cw_"));
    let mut next = || args.next();
    let cmd = match rule {
        Rule::c_task => Command::Task(b.ident(req(next()))),
        Rule::c_tasks => Command::Tasks(path(req(next()))),
        Rule::c_backend => Command::Backend(req(next()).as_str().to_string()),
        Rule::c_load_demos => load_demos(path(req(next())), &mut next),
        Rule::c_load_trace => Command::LoadTrace(path(req(next()))),
        Rule::c_operators => Command::Operators(path(req(next()))),
        Rule::c_run_goal => {
            let (mut goal, mut takeover) = (Vec::new(), None);
            while let Some(a) = next() {
                if a.as_rule() == Rule::run_takeover {
                    takeover = Some(takeover_seconds(&b, a)?);
                } else {
                    goal.push(b.inv_arg(a, |s| s)?);
                }
            }
            Command::RunGoal { goal, takeover }
        }
        Rule::c_run_start => Command::RunStart {
            start: b.uint(req(next()))?,
            takeover: next().map(|t| takeover_seconds(&b, t)).transpose()?,
        },
        Rule::c_show => Command::Show(next().map(|n| b.uint(n)).transpose()?),
        Rule::c_select => {
            let range = req(next());
            let rspan = b.span(&range);
            Command::Select {
                range: b.point_range(range)?,
                span: rspan,
                execution: next().map(|n| b.uint(n)).transpose()?,
            }
        }
        Rule::c_record_demo | Rule::c_teleop => record_or_teleop(&b, rule, &mut next)?,
        Rule::c_critique => {
            let mut directional = false;
            let mut kappa = None;
            while let Some(p) = next() {
                match p.as_rule() {
                    Rule::directional_flag => directional = true,
                    _ => kappa = Some(b.signed(p)?),
                }
            }
            Command::Critique { kappa, directional }
        }
        Rule::c_advise => Command::Advise(b.invocation(req(next()))?),
        Rule::c_preview => Command::Preview(b.invocation(req(next()))?),
        Rule::c_undo => Command::Undo,
        Rule::c_redo => Command::Redo,
        Rule::c_suggest => Command::Suggest(next().map(|n| b.uint(n)).transpose()?),
        Rule::c_accept => Command::Accept(b.uint(req(next()))?),
        Rule::c_history => Command::History {
            conflicts: next().is_some(),
        },
        Rule::c_rederive => Command::Rederive,
        Rule::c_eval => Command::Eval {
            detail: next().is_some(),
        },
        Rule::c_learner => Command::Learner {
            name: b.ident(req(next())),
            k: next().map(|n| b.uint(n)).transpose()?,
        },
        Rule::c_why => Command::Why(b.uint(req(next()))?),
        Rule::c_plot => plot(&b, req(next()))?,
        Rule::c_save => Command::Save(path(req(next()))),
        Rule::c_open => Command::Open(path(req(next()))),
        Rule::c_export_advice => Command::ExportAdvice(path(req(next()))),
        Rule::c_export_mcap => Command::ExportMcap(path(req(next()))),
        Rule::c_export_lerobot => Command::ExportLeRobot(path(req(next()))),
        Rule::c_help => Command::Help(next().map(|n| b.ident(n))),
        Rule::c_quit => Command::Quit,
        other => unreachable!("session_line yields no {other:?}"),
    };
    Ok(Statement::Command(cmd, span))
}

/// `load demos FILE [cmd TOPIC] [odom TOPIC]`, after its file.
fn load_demos<'i>(file: String, next: &mut impl FnMut() -> Option<Pair<'i, Rule>>) -> Command {
    let (mut cmd_topic, mut odom_topic) = (None, None);
    while let Some(part) = next() {
        let rule = part.as_rule();
        let topic = part
            .into_inner()
            .find(|t| t.as_rule() == Rule::topic_name)
            .map(|t| t.as_str().to_string());
        if rule == Rule::load_cmd_topic {
            cmd_topic = topic;
        } else {
            odom_topic = topic;
        }
    }
    Command::LoadDemos {
        path: file,
        cmd_topic,
        odom_topic,
    }
}

/// `record demo` or `teleop` (`rule`), with their options: a topic, a goal, a time limit.
fn record_or_teleop<'i>(
    b: &Builder,
    rule: Rule,
    next: &mut impl FnMut() -> Option<Pair<'i, Rule>>,
) -> Result<Command, ParseError> {
    let (mut topic, mut goal, mut seconds) = (None, None, None);
    let mut keep_idle = false;
    while let Some(opt) = next() {
        let opt_rule = opt.as_rule();
        if opt_rule == Rule::keep_idle_flag {
            keep_idle = true;
            continue;
        }
        let mut parts = opt
            .into_inner()
            .filter(|a| !format!("{:?}", a.as_rule()).starts_with("cw_"));
        match opt_rule {
            Rule::record_from => topic = parts.next().map(|t| t.as_str().to_string()),
            Rule::record_goal => {
                let mut v = [0.0; 3];
                for slot in &mut v {
                    *slot = b.signed(req(parts.next()))?;
                }
                goal = Some(v);
            }
            _ => seconds = parts.next().map(|n| b.signed(n)).transpose()?,
        }
    }
    Ok(if rule == Rule::c_teleop {
        Command::Teleop { goal, seconds }
    } else {
        Command::RecordDemo {
            topic,
            goal,
            seconds,
            keep_idle,
        }
    })
}

/// `takeover A..B`, from its rule.
fn takeover_seconds(b: &Builder, p: Pair<'_, Rule>) -> Result<TakeoverSeconds, ParseError> {
    let range = req(p.into_inner().find(|q| q.as_rule() == Rule::seconds_range));
    let span = b.span(&range);
    let mut ends = range.into_inner().filter(|q| q.as_rule() == Rule::seconds);
    let mut secs = || -> Result<f64, ParseError> { b.signed(req(ends.next())) };
    let (from_s, to_s) = (secs()?, secs()?);
    Ok(TakeoverSeconds { from_s, to_s, span })
}

/// `plot FILE`, `plot actions FILE` or `plot compare FILE A B`, from the part after `plot`.
fn plot(b: &Builder, p: Pair<'_, Rule>) -> Result<Command, ParseError> {
    Ok(match p.as_rule() {
        Rule::plot_actions => Command::Plot {
            kind: PlotKind::Actions,
            path: path(req(p.into_inner().find(|q| q.as_rule() == Rule::path))),
        },
        Rule::plot_compare => {
            let mut inner = p.into_inner().filter(|q| q.as_rule() != Rule::kw_compare);
            let file = path(req(inner.next()));
            let before = b.uint(req(inner.next()))?;
            let after = b.uint(req(inner.next()))?;
            Command::Plot {
                kind: PlotKind::Compare { before, after },
                path: file,
            }
        }
        _ => Command::Plot {
            kind: PlotKind::Path,
            path: path(p),
        },
    })
}

/// The first word of a statement, and where it starts.
fn first_word(src: &str) -> Option<(usize, &str)> {
    let start = src.len() - src.trim_start().len();
    let rest = &src[start..];
    let end = rest
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    (end > 0).then(|| (start, &rest[..end]))
}

/// Whether `src` starts with a command word. A command is one line: a line that starts with one
/// never continues on the next (an unclosed `(` in it is an error at once, not a wait for more).
pub fn starts_command(src: &str) -> bool {
    first_word(src).is_some_and(|(_, w)| command_spec(w).is_some())
}

/// A statement that failed to parse and starts with a word that is neither a command nor an
/// item's keyword: say so, with the closest command.
fn unknown_command(id: SourceId, src: &str) -> Option<ParseError> {
    let (at, word) = first_word(src)?;
    if starts_command(src) || matches!(word, "operator" | "domain") {
        return None;
    }
    let words: Vec<&str> = COMMANDS.iter().map(|c| c.name).collect();
    Some(ParseError::UnknownCommand {
        word: word.to_string(),
        span: id.span(at, word.len()),
        // Command words are short (`run`, `why`): a slip of one letter or a swap finds its word.
        help: crate::diag::suggest::closest_short(word, words)
            .map(|w| format!("did you mean `{w}`?"))
            .unwrap_or_else(|| "`help` lists the commands".into()),
    })
}

/// A command statement that failed to parse and holds a `--word` its command does not take (the
/// flags of its forms in the table): say so, with the closest option.
fn unknown_option(id: SourceId, src: &str) -> Option<ParseError> {
    let (_, word) = first_word(src)?;
    let spec = command_spec(word)?;
    let not_in_option = |c: char| !(c.is_alphanumeric() || c == '-' || c == '_');
    let mut options: Vec<&str> = spec
        .forms
        .iter()
        .flat_map(|f| f.options.iter().map(|o| o.word))
        .filter(|w| w.starts_with("--"))
        .collect();
    options.dedup();
    let mut at = 0;
    for token in src.split_whitespace() {
        at += src[at..].find(token)?;
        let option = token.split(not_in_option).next().unwrap_or(token);
        if option.starts_with("--") && !options.contains(&option) {
            let help = match options.as_slice() {
                [] => format!("`{word}` takes no options: `{}`", spec.signature),
                _ => crate::diag::hint(option, &format!("options of `{word}`"), &options),
            };
            return Some(ParseError::UnknownOption {
                command: word.to_string(),
                option: option.to_string(),
                span: id.span(at, option.len()),
                help,
            });
        }
        at += token.len();
    }
    None
}

/// Whether `src` is an unfinished statement that more lines could complete (an open `{` or `(`,
/// a composition ending in `then`, a doc comment waiting for its item): the REPL asks for another
/// line, and a script reader joins the next line, instead of reporting an error.
pub fn is_incomplete(src: &str) -> bool {
    if starts_command(src) {
        return false;
    }
    let last = src.trim_end().lines().last().unwrap_or("");
    if !(delims::any_open(src) || ends_open(last)) {
        return false;
    }
    match statement(SourceId::UNMAPPED, src) {
        Ok(_) => false,
        Err(ParseError::Unclosed { at_end, .. }) => at_end,
        Err(ParseError::Syntax { message, .. }) => message.ends_with("found the end of the input"),
        Err(_) => false,
    }
}

/// Whether a line leaves its statement open for the next: a doc comment waiting for its item, or
/// code ending in `then`, `=` or `,`.
pub fn ends_open(line: &str) -> bool {
    let line = line.trim();
    if line.starts_with("///") {
        return true;
    }
    let code = line.split("//").next().unwrap_or("").trim_end();
    let ends_with_then = code
        .strip_suffix("then")
        .is_some_and(|rest| !rest.ends_with(|c: char| c.is_alphanumeric() || c == '_'));
    ends_with_then || code.ends_with('=') || code.ends_with(',')
}

fn req(p: Option<Pair<'_, Rule>>) -> Pair<'_, Rule> {
    p.expect("the grammar guarantees this argument")
}

fn path(p: Pair<'_, Rule>) -> String {
    match p.clone().into_inner().next() {
        Some(inner) if inner.as_rule() == Rule::quoted_path => inner
            .into_inner()
            .find(|q| q.as_rule() == Rule::path_text)
            .map_or(String::new(), |q| q.as_str().to_string()),
        _ => p.as_str().to_string(),
    }
}

impl Builder {
    fn signed(&self, p: Pair<'_, Rule>) -> Result<f64, ParseError> {
        let text: String = p.as_str().chars().filter(|c| *c != '+').collect();
        self.number_text(&text, self.span(&p))
    }

    /// A `range`: `40..70`, `125..end`, `125..`, `-30..end`.
    fn point_range(&self, p: Pair<'_, Rule>) -> Result<PointRange, ParseError> {
        let (mut start, mut end) = (RangeStart::At(0), None);
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::range_from => {
                    let from_end = part
                        .clone()
                        .into_inner()
                        .any(|q| q.as_rule() == Rule::from_end);
                    let n =
                        self.uint(req(part.into_inner().find(|q| q.as_rule() == Rule::uint)))?;
                    start = if from_end {
                        RangeStart::FromEnd(n)
                    } else {
                        RangeStart::At(n)
                    };
                }
                Rule::range_to => {
                    end = part
                        .into_inner()
                        .find(|q| q.as_rule() == Rule::uint)
                        .map(|n| self.uint(n))
                        .transpose()?;
                }
                _ => {}
            }
        }
        Ok(PointRange { start, end })
    }

    fn uint(&self, p: Pair<'_, Rule>) -> Result<usize, ParseError> {
        let span = self.span(&p);
        p.as_str()
            .parse::<usize>()
            .map_err(|_| self.too_large(p.as_str(), span))
    }
}

/// A range of points as a teacher writes it, before the execution it selects from is known:
/// `40..70`, `125..end` (or `125..`) to the last point, `-30..end` the last 30 points. A range
/// copied from a transcript keeps meaning the same stretch when the run is a point shorter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PointRange {
    pub start: RangeStart,
    /// The point after the last, or `None` for the execution's end.
    pub end: Option<usize>,
}

/// Where a [`PointRange`] starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangeStart {
    /// Point `A`.
    At(usize),
    /// `N` points before the end: `-N`.
    FromEnd(usize),
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parse `text` as a statement of its own (the errors' places are only compared).
    fn parse_statement(name: &str, text: &str) -> Result<Statement, ParseError> {
        let (map, id) = crate::diag::SourceMap::single(name, text);
        super::parse_statement(map.src(id))
    }

    fn cmd(src: &str) -> Command {
        match parse_statement("<test>", src) {
            Ok(Statement::Command(c, _)) => c,
            other => panic!("{src}: {other:?}"),
        }
    }

    #[test]
    fn plot_forms_parse_and_keywords_are_not_file_names() {
        let plot = |kind, path: &str| Command::Plot {
            kind,
            path: path.to_string(),
        };
        assert_eq!(cmd("plot run.svg"), plot(PlotKind::Path, "run.svg"));
        assert_eq!(cmd("plot actions a.svg"), plot(PlotKind::Actions, "a.svg"));
        assert_eq!(
            cmd("plot compare \"my runs/c.svg\" 0 3"),
            plot(
                PlotKind::Compare {
                    before: 0,
                    after: 3
                },
                "my runs/c.svg"
            )
        );
        // A file that merely starts with a keyword is a file.
        assert_eq!(cmd("plot actions.svg"), plot(PlotKind::Path, "actions.svg"));
        assert_eq!(cmd("plot compare.svg"), plot(PlotKind::Path, "compare.svg"));
        // A keyword without its file is an error, not a file named after the keyword.
        for src in ["plot actions", "plot compare c.svg 1", "plot compare"] {
            assert!(parse_statement("<test>", src).is_err(), "{src}");
        }
    }

    #[test]
    fn commands_parse() {
        let goal = |line: &str| match cmd(line) {
            Command::RunGoal { goal: values, .. } => values
                .iter()
                .map(|a| (a.name.as_ref().map(|n| n.name.clone()), a.value))
                .collect::<Vec<_>>(),
            c => panic!("{c:?}"),
        };
        assert_eq!(
            goal("run goal 2 -1 0.5"),
            [(None, 2.0), (None, -1.0), (None, 0.5)]
        );
        assert_eq!(
            goal("run goal gx=2 gy = 1 1.5"),
            [
                (Some("gx".into()), 2.0),
                (Some("gy".into()), 1.0),
                (None, 1.5)
            ]
        );
        assert!(parse_statement("<t>", "run goal").is_err());
        let range = |line: &str| match cmd(line) {
            Command::Select { range, .. } => range.to_string(),
            c => panic!("{c:?}"),
        };
        assert_eq!(range("select 40..70"), "40..70");
        assert_eq!(range("select 125..end"), "125..end");
        assert_eq!(range("select 125.. in 2"), "125..end");
        assert_eq!(range("select -30..end"), "-30..end");
        assert_eq!(range("select -30..5"), "-30..5");
        for bad in [
            "select 1..-2",
            "select 1..ends",
            "select --1..end",
            "select ..5",
        ] {
            assert!(parse_statement("<t>", bad).is_err(), "{bad}");
        }
        assert_eq!(
            cmd("critique"),
            Command::Critique {
                kappa: None,
                directional: false
            }
        );
        assert_eq!(
            cmd("critique 0.5"),
            Command::Critique {
                kappa: Some(0.5),
                directional: false
            }
        );
        assert_eq!(
            cmd("critique --directional"),
            Command::Critique {
                kappa: None,
                directional: true
            }
        );
        for line in ["critique --directional 0.5", "critique 0.5 --directional"] {
            assert_eq!(
                cmd(line),
                Command::Critique {
                    kappa: Some(0.5),
                    directional: true
                }
            );
        }
        assert_eq!(
            cmd("load demos \"my runs/d.csv\""),
            Command::LoadDemos {
                path: "my runs/d.csv".into(),
                cmd_topic: None,
                odom_topic: None,
            }
        );
        assert_eq!(
            cmd("load demos bags/run1 odom /robot1/odom cmd /robot1/cmd_vel"),
            Command::LoadDemos {
                path: "bags/run1".into(),
                cmd_topic: Some("/robot1/cmd_vel".into()),
                odom_topic: Some("/robot1/odom".into()),
            }
        );
        assert_eq!(
            cmd("backend rmp:127.0.0.1:9000"),
            Command::Backend("rmp:127.0.0.1:9000".into())
        );
        assert_eq!(
            cmd("export advice a.csv"),
            Command::ExportAdvice("a.csv".into())
        );
        match cmd("advise speed_up(rate = 0.5)") {
            Command::Advise(inv) => assert_eq!(inv.to_string(), "speed_up(rate = 0.5)"),
            c => panic!("{c:?}"),
        }
        assert!(matches!(cmd("help advise"), Command::Help(Some(_))));
        assert_eq!(cmd("exit"), Command::Quit);
    }

    #[test]
    fn items_and_blank_lines() {
        assert_eq!(
            parse_statement("<t>", "  // nothing").unwrap(),
            Statement::Empty
        );
        let op = "operator creep for positioning on action { trans = 0.1 }";
        assert!(matches!(
            parse_statement("<t>", op).unwrap(),
            Statement::Item(_)
        ));
    }

    #[test]
    fn unfinished_statements_are_recognised() {
        assert!(is_incomplete("operator creep for positioning on action {"));
        assert!(is_incomplete(
            "operator b for positioning on action = slow_down then"
        ));
        assert!(is_incomplete("/// Creep forward."));
        // However the body is indented, and whatever comes after a number.
        assert!(is_incomplete(
            "operator creep for positioning on action {\ntrans = 0.1\n"
        ));
        assert!(is_incomplete(
            "operator creep for positioning on action {\n  trans = 0.1 / 2 // half\n"
        ));
        // An item where the body should have ended is a mistake, not more to come.
        assert!(!is_incomplete(
            "operator a for positioning on action {\n  trans = 0\noperator b for positioning on action {"
        ));
        assert!(!is_incomplete("select 1..x"));
        assert!(!is_incomplete("selec 1..2"));
        assert!(!is_incomplete(
            "operator creep for positioning on action { trans = 0.1 }"
        ));
    }

    #[test]
    fn errors_say_what_was_expected() {
        let e = parse_statement("<t>", "select 5").unwrap_err();
        assert!(e.to_string().contains("expected"), "{e}");
    }
}
