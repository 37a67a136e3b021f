//! Parse errors: [`ParseError`] and the conversion of pest's errors into words (what was
//! expected, the bracket a lost `}` left open, a hint for common slips).

use miette::Diagnostic;
use thiserror::Error;

use super::ast::Span;
use super::{MAX_NESTING, Rule, delims};
use crate::diag::{Loc, SourceId};

/// Text that does not parse.
#[derive(Debug, Error, Diagnostic, Clone)]
pub enum ParseError {
    #[error("{message}")]
    #[diagnostic(code(advise::parse::syntax))]
    Syntax {
        message: String,
        #[label("{label}")]
        span: Loc,
        label: String,
        #[help]
        help: Option<String>,
    },
    #[error("`{text}` is too large for a number")]
    #[diagnostic(
        code(advise::parse::number_too_large),
        help("numbers must be finite 64-bit floats (below about 1.8e308)")
    )]
    NumberTooLarge {
        text: String,
        #[label("overflows")]
        span: Loc,
    },
    #[error("{what} too deeply")]
    #[diagnostic(code(advise::parse::too_deep), help("{help}"))]
    TooDeep {
        what: String,
        help: String,
        #[label("too deep from here")]
        span: Loc,
    },
    #[error("`{word}` is not a command")]
    #[diagnostic(code(advise::parse::unknown_command), help("{help}"))]
    UnknownCommand {
        word: String,
        #[label("unknown command")]
        span: Loc,
        help: String,
    },
    #[error("`{command}` has no option `{option}`")]
    #[diagnostic(code(advise::parse::unknown_option), help("{help}"))]
    UnknownOption {
        command: String,
        option: String,
        #[label("unknown option")]
        span: Loc,
        help: String,
    },
    #[error("this `{open}` is never closed")]
    #[diagnostic(code(advise::parse::unclosed_delimiter))]
    Unclosed {
        open: char,
        #[label("unclosed `{open}`")]
        span: Loc,
        /// Where the parser expected the closing bracket.
        #[label("{expected_label}")]
        expected: Loc,
        expected_label: String,
        /// The parser stopped at the end of the input (more lines could close it).
        at_end: bool,
        #[help]
        help: String,
    },
}

/// Why brackets nested too deeply are refused, for [`ParseError::TooDeep`].
pub(super) fn nesting_too_deep(id: SourceId, at: usize) -> ParseError {
    ParseError::TooDeep {
        what: "brackets are nested".into(),
        help: format!(
            "brackets may nest at most {MAX_NESTING} deep; name a part of the computation as its own operator"
        ),
        span: id.at(at..at + 1),
    }
}

/// Turn a pest error into a diagnostic that names what was expected in words.
pub(super) fn convert(
    e: pest::error::Error<Rule>,
    id: SourceId,
    src: &str,
    brackets: &delims::Scan,
) -> ParseError {
    let pos = match e.location {
        pest::error::InputLocation::Pos(p) => p,
        pest::error::InputLocation::Span((s, _)) => s,
    }
    .min(src.len());
    let (mut found, mut span) = token_at(src, pos);
    // A zero-width label at the very end draws nothing; point at the last character written
    // instead, so the reader sees where the text stopped.
    let at_end = src[pos..].trim().is_empty();
    if at_end {
        let end = src[..pos].trim_end().len();
        if let Some(c) = src[..end].chars().next_back() {
            span = Span::new(end - c.len_utf8(), end);
        }
        found = "the end of the input".into();
    }
    let loc = |s: Span| id.at(s.start..s.end);
    match e.variant {
        pest::error::ErrorVariant::CustomError { message } => ParseError::TooDeep {
            what: "the input is nested".into(),
            help: message,
            span: loc(span),
        },
        pest::error::ErrorVariant::ParsingError { positives, .. } => {
            if let Some(blame) = unclosed_here(src, pos, at_end, &positives, brackets) {
                return unclosed(blame, id, src, span, at_end, &found);
            }
            let expected = expected_words(&positives);
            let message = if expected.is_empty() {
                format!("unexpected {found}")
            } else {
                format!("expected {}, found {found}", join_or(&expected))
            };
            ParseError::Syntax {
                message,
                span: loc(span),
                label: match (expected.is_empty(), at_end) {
                    (true, _) => "not allowed here".into(),
                    (false, false) => format!("expected {} here", join_or(&expected)),
                    (false, true) => "the input ends after this".into(),
                },
                help: help_for(&positives, src, pos),
            }
        }
    }
}

/// The bracket to blame for a parse error at `pos`, and where its closing bracket belonged (when
/// the text says), or `None` when the error is the parser's own. A lost `}` is noticed only at
/// the next item or at the end of the input, sometimes as something else entirely (`/// doc`
/// after a number reads as a division); the mistake is where the bracket was opened. So the
/// innermost bracket open at `pos` is blamed when the text never closes it and either the parser
/// would have accepted its closing bracket at `pos`, or the input ended inside it, or the parser
/// ran past the start of an item (a doc comment, `operator`, `domain`), which no bracket can hold:
/// the closing bracket belonged before it.
pub(super) fn unclosed_here(
    src: &str,
    pos: usize,
    at_end: bool,
    positives: &[Rule],
    brackets: &delims::Scan,
) -> Option<(delims::Open, Option<usize>)> {
    let open = delims::innermost_open(src, pos)?;
    if !brackets.unclosed.contains(&open) {
        return None;
    }
    let closer = match open.ch {
        '(' => Rule::rparen,
        '[' => Rule::rbracket,
        _ => Rule::rbrace,
    };
    let guess = close_guess(src, open.at, pos);
    (at_end || positives.contains(&closer) || guess.is_some()).then_some((open, guess))
}

/// The start of the first line after the bracket's own that begins an item, at or before `pos`.
pub(super) fn close_guess(src: &str, open_at: usize, pos: usize) -> Option<usize> {
    let starts_item = |t: &str| {
        t.starts_with("///")
            || ["operator", "domain"].iter().any(|kw| {
                t.strip_prefix(kw).is_some_and(|rest| {
                    !rest.starts_with(|c: char| c.is_alphanumeric() || c == '_')
                })
            })
    };
    let mut off = open_at + src[open_at..].find('\n')? + 1;
    for line in src[off..].split_inclusive('\n') {
        if off > pos {
            break;
        }
        let t = line.trim_start();
        if starts_item(t) {
            return Some(off + line.len() - t.len());
        }
        off += line.len();
    }
    None
}

pub(super) fn unclosed(
    (open, guess): (delims::Open, Option<usize>),
    id: SourceId,
    src: &str,
    stop: Span,
    at_end: bool,
    found: &str,
) -> ParseError {
    let close = open.closer();
    let line = |byte: usize| src[..byte].matches('\n').count() + 1;
    let what = match open.ch {
        '{' => "the body",
        '(' => "the list",
        _ => "the offset",
    };
    let opened = line(open.at);
    let (expected, expected_label, help) = match guess {
        Some(at) => {
            let (desc, span) = token_at(src, at);
            (
                span,
                format!("expected `{close}` before {desc}"),
                format!(
                    "close {what} opened on line {opened} with `{close}` before line {}",
                    line(at)
                ),
            )
        }
        None if at_end => (
            stop,
            format!("the input ends here, still expecting `{close}`"),
            format!("close {what} opened on line {opened} with `{close}`"),
        ),
        None => (
            stop,
            format!("expected `{close}` before {found}"),
            format!(
                "close {what} opened on line {opened} with `{close}` before line {}",
                line(stop.start)
            ),
        ),
    };
    ParseError::Unclosed {
        open: open.ch,
        span: id.at(open.at..open.at + 1),
        expected: id.at(expected.start..expected.end),
        expected_label,
        at_end: at_end && guess.is_none(),
        help,
    }
}

/// The token at `pos`, described for a message, and its span.
pub(super) fn token_at(src: &str, pos: usize) -> (String, Span) {
    let rest = &src[pos..];
    let Some(c) = rest.chars().next() else {
        return ("the end of the input".into(), Span::new(pos, pos));
    };
    let len = if c.is_alphanumeric() || c == '_' {
        rest.find(|ch: char| !(ch.is_alphanumeric() || ch == '_' || ch == '.'))
            .unwrap_or(rest.len())
    } else if ["==", "!=", "<=", ">=", "+=", "-=", "*=", "/=", "///"]
        .iter()
        .any(|t| rest.starts_with(t))
    {
        if rest.starts_with("///") { 3 } else { 2 }
    } else {
        c.len_utf8()
    };
    let text = &rest[..len];
    let shown = if c == '\n' || c == '\r' {
        "the end of the line".to_string()
    } else {
        format!("`{text}`")
    };
    (shown, Span::new(pos, pos + len))
}

pub(super) fn join_or(words: &[String]) -> String {
    match words {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// Words for what the parser would have accepted, in a stable order, without duplicates.
pub(super) fn expected_words(positives: &[Rule]) -> Vec<String> {
    let has = |r: Rule| positives.contains(&r);
    let mut words: Vec<String> = Vec::new();
    let mut push = |w: &str| {
        if !words.iter().any(|x| x == w) {
            words.push(w.to_string());
        }
    };
    let infix = [
        Rule::kw_or,
        Rule::kw_and,
        Rule::op_eq,
        Rule::op_ne,
        Rule::op_le,
        Rule::op_ge,
        Rule::op_lt,
        Rule::op_gt,
        Rule::op_add,
        Rule::op_sub,
        Rule::op_mul,
        Rule::op_div,
    ];
    let value = [
        Rule::number,
        Rule::paren,
        Rule::call_expr,
        Rule::at_expr,
        Rule::op_neg,
        Rule::kw_not,
        Rule::expr,
        Rule::signed_number,
    ];
    for r in positives {
        let w: &str = match r {
            r if infix.contains(r) => "an operator like `+`",
            r if value.contains(r) => "a value",
            Rule::name if has(Rule::number) || has(Rule::expr) => "a value",
            Rule::name if has(Rule::rbrace) => "a statement such as `rot = 0`",
            Rule::name => "a name",
            Rule::doc | Rule::domain | Rule::operator | Rule::kw_domain => {
                push("`domain`");
                "`operator`"
            }
            Rule::kw_operator => "`operator`",
            Rule::kw_observe | Rule::kw_act | Rule::dim_group => {
                push("`observe`");
                "`act`"
            }
            Rule::kw_observation | Rule::kw_action | Rule::space => {
                push("`observation`");
                "`action`"
            }
            Rule::kw_for => "`for`",
            Rule::kw_on => "`on`",
            Rule::kw_where | Rule::guard => "`where`",
            Rule::kw_then => "`then`",
            Rule::kw_in | Rule::limits => "`in [lo, hi]`",
            Rule::unit | Rule::quote => "a unit in quotes",
            Rule::lbrace | Rule::block_body => "`{`",
            Rule::rbrace => "`}`",
            Rule::lparen if has(Rule::number) => "a value",
            Rule::lparen | Rule::params | Rule::call_args | Rule::inv_args => "`(`",
            Rule::rparen => "`)`",
            Rule::lbracket => "`[`",
            Rule::rbracket => "`]`",
            Rule::comma => "`,`",
            Rule::semicolon => continue,
            Rule::assign | Rule::pipeline_body => "`=`",
            Rule::assign_op => {
                for w in ["`=`", "`+=`", "`-=`", "`*=`"] {
                    push(w);
                }
                "`/=`"
            }
            Rule::stmt => "a statement such as `rot = 0`",
            Rule::EOI => "the end of the input",
            Rule::uint | Rule::range => "a whole number such as `40..70`",
            Rule::path | Rule::bare_path | Rule::quoted_path => "a file path",
            Rule::backend_spec => "a backend such as `sim`, `rmp:HOST:PORT` or `ros2`",
            Rule::inv_body => "an operator such as `speed_up(0.5)`",
            Rule::dotdot => "`..`",
            r if format!("{r:?}").starts_with("cw_") => {
                let w = format!("`{}`", &format!("{r:?}")[3..]);
                push(&w);
                continue;
            }
            Rule::c_task | Rule::c_backend | Rule::c_run_goal | Rule::c_select | Rule::c_advise => {
                "a command (try `help`)"
            }
            _ => continue,
        };
        push(w);
    }
    // The end of a block is the likelier intent than yet another statement.
    words.sort_by_key(|w| match w.as_str() {
        "the end of the input" => 9,
        w if w.starts_with("an operator") => 8,
        "`}`" => 7,
        _ => 0,
    });
    words
}

/// A hint for the usual mistakes, keyed on what the parser wanted next.
pub(super) fn help_for(positives: &[Rule], src: &str, pos: usize) -> Option<String> {
    let has = |r: Rule| positives.contains(&r);
    let rest = &src[pos..];
    let word: String = rest
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    let keywords = [
        "domain",
        "observe",
        "act",
        "operator",
        "for",
        "on",
        "observation",
        "action",
        "where",
        "then",
        "and",
        "or",
        "not",
        "in",
    ];
    if has(Rule::name) && keywords.contains(&word.as_str()) {
        return Some(format!(
            "`{word}` is a reserved word; choose another name such as `{word}_`"
        ));
    }
    if has(Rule::kw_for) {
        return Some(
            "an operator names its domain and target: `operator NAME for DOMAIN on action { ... }`"
                .into(),
        );
    }
    if has(Rule::kw_on) {
        return Some("after the domain comes the target: `on action` or `on observation`".into());
    }
    if has(Rule::space) || has(Rule::kw_action) {
        return Some("an operator modifies either `observation`s or `action`s".into());
    }
    if (has(Rule::assign_op) || has(Rule::assign)) && rest.starts_with("==") {
        return Some("`==` compares; to assign write `=`".into());
    }
    if has(Rule::assign_op) {
        return Some("a statement assigns to a dimension: `trans *= 1.5`".into());
    }
    if has(Rule::kw_domain) && rest.starts_with('}') {
        return Some("this `}` closes nothing; remove it".into());
    }
    if has(Rule::kw_domain) {
        return Some("a file holds `domain` and `operator` items".into());
    }
    if has(Rule::rbrace) && rest.is_empty() {
        return Some("a `{` is not closed".into());
    }
    if has(Rule::rparen) && rest.is_empty() {
        return Some("a `(` is not closed".into());
    }
    if has(Rule::quote) || (has(Rule::unit) && rest.starts_with('\n')) {
        return Some("a unit is written in double quotes on one line: \"m/s\"".into());
    }
    None
}
