//! Text to spanned AST: the only module that knows pest.
//!
//! [`parse`] reads a whole file of items, [`parse_item`] exactly one item (a REPL line), and
//! [`parse_invocation`] the way a teacher names an operator (`speed_up`, `speed_up(0.5)`,
//! `speed_up(rate = 0.5)`). Parse errors are [`ParseError`] diagnostics that say what was expected
//! in words, converted from pest's byte offsets. This module does not resolve names or check
//! meaning; that is [`crate::check`]. The grammar is `grammar/advice.pest`.

pub mod ast;
pub mod command;
pub mod delims;
pub mod print;
pub mod source;

use miette::{Diagnostic, NamedSource, SourceSpan};
use pest::Parser;
use pest::iterators::{Pair, Pairs};
use thiserror::Error;

use crate::domain::Space;
use ast::*;
pub use source::SourceText;

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/advice.pest"]
#[grammar = "../grammar/session.pest"]
struct AdviceParser;

pub use delims::MAX_NESTING;

/// How deep an expression's tree may be: every operand, operator, prefix and function call is one
/// level, so a chain `a + b + c ...` may have 128 terms. Far beyond any operator a person writes, and
/// it keeps every recursive pass over the tree (check, print, compile, drop) well inside a
/// thread's stack. Brackets are limited separately, before parsing ([`MAX_NESTING`]).
pub const MAX_DEPTH: usize = 128;

/// Text that does not parse.
#[derive(Debug, Error, Diagnostic, Clone)]
pub enum ParseError {
    #[error("{message}")]
    #[diagnostic(code(advise::parse::syntax))]
    Syntax {
        message: String,
        #[source_code]
        src: NamedSource<SourceText>,
        #[label("{label}")]
        span: SourceSpan,
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
        #[source_code]
        src: NamedSource<SourceText>,
        #[label("overflows")]
        span: SourceSpan,
    },
    #[error("{what} too deeply")]
    #[diagnostic(code(advise::parse::too_deep), help("{help}"))]
    TooDeep {
        what: String,
        help: String,
        #[source_code]
        src: NamedSource<SourceText>,
        #[label("too deep from here")]
        span: SourceSpan,
    },
    #[error("`{word}` is not a command")]
    #[diagnostic(code(advise::parse::unknown_command), help("{help}"))]
    UnknownCommand {
        word: String,
        #[source_code]
        src: NamedSource<SourceText>,
        #[label("unknown command")]
        span: SourceSpan,
        help: String,
    },
    #[error("this `{open}` is never closed")]
    #[diagnostic(code(advise::parse::unclosed_delimiter))]
    Unclosed {
        open: char,
        #[source_code]
        src: NamedSource<SourceText>,
        #[label("unclosed `{open}`")]
        span: SourceSpan,
        /// Where the parser expected the closing bracket.
        #[label("{expected_label}")]
        expected: SourceSpan,
        expected_label: String,
        /// The parser stopped at the end of the input (more lines could close it).
        at_end: bool,
        #[help]
        help: String,
    },
}

/// Why brackets nested too deeply are refused, for [`ParseError::TooDeep`].
fn nesting_too_deep(name: &str, src: &str, at: usize) -> ParseError {
    ParseError::TooDeep {
        what: "brackets are nested".into(),
        help: format!(
            "brackets may nest at most {MAX_NESTING} deep; name a part of the computation as its own operator"
        ),
        src: NamedSource::new(name, SourceText::from(src)),
        span: Span::new(at, at + 1).into(),
    }
}

/// Parse a whole file. `name` is used in diagnostics, usually the path.
pub fn parse(name: &str, src: &str) -> Result<File, ParseError> {
    let mut pairs = run(Rule::file, name, src)?;
    let file = pairs.next().expect("the file rule always yields one pair");
    let b = Builder { name, src };
    let mut items = Vec::new();
    for p in file.into_inner() {
        if p.as_rule() != Rule::EOI {
            items.push(b.item(p)?);
        }
    }
    Ok(File { items })
}

/// Parse exactly one item, e.g. an operator typed on one REPL line.
pub fn parse_item(name: &str, src: &str) -> Result<Item, ParseError> {
    let mut pairs = run(Rule::single_item, name, src)?;
    let whole = pairs.next().expect("single_item always yields one pair");
    let b = Builder { name, src };
    let item = whole
        .into_inner()
        .find(|p| p.as_rule() != Rule::EOI)
        .expect("single_item holds one item");
    b.item(item)
}

/// An operator as a teacher names it: `speed_up`, `speed_up(0.5)`, `speed_up(rate = 0.5)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Invocation {
    /// The text it was parsed from; spans point into it.
    pub text: String,
    pub name: Ident,
    pub args: Vec<InvArg>,
}

/// One literal argument of an [`Invocation`].
#[derive(Clone, Debug, PartialEq)]
pub struct InvArg {
    pub name: Option<Ident>,
    pub value: f64,
    pub span: Span,
}

impl Invocation {
    /// An invocation without arguments (every parameter takes its default).
    pub fn bare(name: &str) -> Invocation {
        Invocation {
            text: name.to_string(),
            name: Ident {
                name: name.to_string(),
                span: Span::new(0, name.len()),
            },
            args: Vec::new(),
        }
    }
}

impl std::fmt::Display for Invocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name.name)?;
        if !self.args.is_empty() {
            f.write_str("(")?;
            for (i, a) in self.args.iter().enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                if let Some(n) = &a.name {
                    write!(f, "{} = ", n.name)?;
                }
                f.write_str(&print::number(a.value))?;
            }
            f.write_str(")")?;
        }
        Ok(())
    }
}

/// Parse an invocation such as `speed_up(rate = 0.5)`.
pub fn parse_invocation(src: &str) -> Result<Invocation, ParseError> {
    let name = "invocation";
    let mut pairs = run(Rule::invocation, name, src)?;
    let b = Builder { name, src };
    let mut inner = pairs
        .next()
        .expect("invocation yields one pair")
        .into_inner();
    let op = b.ident(inner.next().expect("an invocation starts with a name"));
    let mut args = Vec::new();
    if let Some(list) = inner.next().filter(|p| p.as_rule() == Rule::inv_args) {
        for a in list.into_inner().filter(|p| p.as_rule() == Rule::inv_arg) {
            let span = b.span(&a);
            let mut name = None;
            let mut value = 0.0;
            for part in a.into_inner() {
                match part.as_rule() {
                    Rule::name => name = Some(b.ident(part)),
                    Rule::signed_number => {
                        let text: String = part.as_str().chars().filter(|c| *c != '+').collect();
                        value = b.number_text(&text, b.span(&part))?;
                    }
                    _ => {}
                }
            }
            args.push(InvArg { name, value, span });
        }
    }
    Ok(Invocation {
        text: src.to_string(),
        name: op,
        args,
    })
}

fn run<'i>(rule: Rule, name: &str, src: &'i str) -> Result<Pairs<'i, Rule>, ParseError> {
    // pest recurses once per bracket; refuse deep nesting before it can exhaust the stack.
    let brackets = delims::scan(src);
    if let Some(at) = brackets.too_deep {
        return Err(nesting_too_deep(name, src, at));
    }
    AdviceParser::parse(rule, src).map_err(|e| convert(e, name, src, &brackets))
}

/// Turn a pest error into a diagnostic that names what was expected in words.
fn convert(
    e: pest::error::Error<Rule>,
    name: &str,
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
    let src_named = || NamedSource::new(name, SourceText::from(src));
    match e.variant {
        pest::error::ErrorVariant::CustomError { message } => ParseError::TooDeep {
            what: "the input is nested".into(),
            help: message,
            src: src_named(),
            span: span.into(),
        },
        pest::error::ErrorVariant::ParsingError { positives, .. } => {
            if let Some(blame) = unclosed_here(src, pos, at_end, &positives, brackets) {
                return unclosed(blame, name, src, span, at_end, &found);
            }
            let expected = expected_words(&positives);
            let message = if expected.is_empty() {
                format!("unexpected {found}")
            } else {
                format!("expected {}, found {found}", join_or(&expected))
            };
            ParseError::Syntax {
                message,
                src: src_named(),
                span: span.into(),
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
fn unclosed_here(
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
fn close_guess(src: &str, open_at: usize, pos: usize) -> Option<usize> {
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

fn unclosed(
    (open, guess): (delims::Open, Option<usize>),
    name: &str,
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
        src: NamedSource::new(name, SourceText::from(src)),
        span: Span::new(open.at, open.at + 1).into(),
        expected: expected.into(),
        expected_label,
        at_end: at_end && guess.is_none(),
        help,
    }
}

/// The token at `pos`, described for a message, and its span.
fn token_at(src: &str, pos: usize) -> (String, Span) {
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

fn join_or(words: &[String]) -> String {
    match words {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// Words for what the parser would have accepted, in a stable order, without duplicates.
fn expected_words(positives: &[Rule]) -> Vec<String> {
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
            Rule::backend_spec => "`sim` or `rmp:HOST:PORT`",
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
fn help_for(positives: &[Rule], src: &str, pos: usize) -> Option<String> {
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

/// Builds AST nodes from pest pairs.
struct Builder<'a> {
    name: &'a str,
    src: &'a str,
}

/// The flat token stream of an `expr` pair, consumed by precedence climbing.
enum Tok<'i> {
    Prefix(UnOp, Span),
    Infix(BinOp, Span),
    Operand(Pair<'i, Rule>),
}

impl<'a> Builder<'a> {
    fn span(&self, p: &Pair<'_, Rule>) -> Span {
        let s = p.as_span();
        Span::new(s.start(), s.end())
    }

    fn src(&self) -> NamedSource<SourceText> {
        NamedSource::new(self.name, SourceText::from(self.src))
    }

    fn ident(&self, p: Pair<'_, Rule>) -> Ident {
        Ident {
            name: p.as_str().to_string(),
            span: self.span(&p),
        }
    }

    fn number_text(&self, text: &str, span: Span) -> Result<f64, ParseError> {
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.too_large(text, span)),
        }
    }

    /// `text` does not fit a number; a number of a million digits is named by its first few.
    fn too_large(&self, text: &str, span: Span) -> ParseError {
        const SHOWN: usize = 24;
        let (text, span) = match text.get(..SHOWN) {
            Some(head) if text.len() > SHOWN => (
                format!("{head}... ({} digits)", text.len()),
                Span::new(span.start, span.start + SHOWN.min(span.len())),
            ),
            _ => (text.to_string(), span),
        };
        ParseError::NumberTooLarge {
            text,
            src: self.src(),
            span: span.into(),
        }
    }

    fn item(&self, p: Pair<'_, Rule>) -> Result<Item, ParseError> {
        match p.as_rule() {
            Rule::domain => Ok(Item::Domain(self.domain(p)?)),
            Rule::operator => Ok(Item::Operator(self.operator(p)?)),
            r => unreachable!("the grammar has no item {r:?}"),
        }
    }

    fn doc_line(&self, p: Pair<'_, Rule>) -> String {
        let text = p.into_inner().next().map_or("", |t| t.as_str());
        let text = text.strip_suffix('\r').unwrap_or(text);
        text.strip_prefix(' ').unwrap_or(text).to_string()
    }

    fn domain(&self, p: Pair<'_, Rule>) -> Result<DomainDecl, ParseError> {
        let span = self.span(&p);
        let mut doc = Vec::new();
        let mut name = None;
        let mut dims = Vec::new();
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::doc => doc.push(self.doc_line(part)),
                Rule::name => name = Some(self.ident(part)),
                Rule::dim_group => {
                    let mut inner = part.into_inner();
                    let kw = inner.next().expect("a group starts with its keyword");
                    let space = if kw.as_rule() == Rule::kw_observe {
                        Space::Observation
                    } else {
                        Space::Action
                    };
                    for d in inner.filter(|d| d.as_rule() == Rule::dim) {
                        dims.push(self.dim(space, d)?);
                    }
                }
                _ => {}
            }
        }
        Ok(DomainDecl {
            doc,
            name: name.expect("a domain has a name"),
            dims,
            span,
        })
    }

    fn dim(&self, space: Space, p: Pair<'_, Rule>) -> Result<DimDecl, ParseError> {
        let span = self.span(&p);
        let mut name = None;
        let mut unit = None;
        let mut limits = None;
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::name => name = Some(self.ident(part)),
                Rule::unit => {
                    unit = Some(
                        part.into_inner()
                            .find(|u| u.as_rule() == Rule::unit_text)
                            .map_or(String::new(), |u| u.as_str().to_string()),
                    )
                }
                Rule::limits => limits = Some(self.limits(part)?),
                _ => {}
            }
        }
        Ok(DimDecl {
            space,
            name: name.expect("a dimension has a name"),
            unit,
            limits,
            span,
        })
    }

    fn limits(&self, p: Pair<'_, Rule>) -> Result<LimitsExpr, ParseError> {
        let span = self.span(&p);
        let mut exprs = p.into_inner().filter(|e| e.as_rule() == Rule::expr);
        let lo = self.expr(exprs.next().expect("limits have a low end"), 0)?;
        let hi = self.expr(exprs.next().expect("limits have a high end"), 0)?;
        Ok(LimitsExpr { lo, hi, span })
    }

    fn operator(&self, p: Pair<'_, Rule>) -> Result<OperatorDecl, ParseError> {
        let span = self.span(&p);
        let mut doc = Vec::new();
        let mut names = Vec::new();
        let mut params = Vec::new();
        let mut space = None;
        let mut body = None;
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::doc => doc.push(self.doc_line(part)),
                Rule::name => names.push(self.ident(part)),
                Rule::params => {
                    for q in part.into_inner().filter(|q| q.as_rule() == Rule::param) {
                        params.push(self.param(q)?);
                    }
                }
                Rule::space => {
                    let s = self.span(&part);
                    let kw = part.into_inner().next().expect("a space is one keyword");
                    let sp = if kw.as_rule() == Rule::kw_action {
                        Space::Action
                    } else {
                        Space::Observation
                    };
                    space = Some((sp, s));
                }
                Rule::block_body => body = Some(self.block(part)?),
                Rule::pipeline_body => {
                    let mut calls = Vec::new();
                    for c in part.into_inner().filter(|c| c.as_rule() == Rule::call) {
                        calls.push(self.call(c)?);
                    }
                    body = Some(Body::Pipeline(calls));
                }
                _ => {}
            }
        }
        let mut names = names.into_iter();
        let (space, space_span) = space.expect("an operator names its space");
        Ok(OperatorDecl {
            doc,
            name: names.next().expect("an operator has a name"),
            params,
            domain: names.next().expect("an operator names its domain"),
            space,
            space_span,
            body: body.expect("an operator has a body"),
            span,
        })
    }

    fn param(&self, p: Pair<'_, Rule>) -> Result<ParamDecl, ParseError> {
        let span = self.span(&p);
        let mut name = None;
        let mut default = None;
        let mut limits = None;
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::name => name = Some(self.ident(part)),
                Rule::expr => default = Some(self.expr(part, 0)?),
                Rule::limits => limits = Some(self.limits(part)?),
                _ => {}
            }
        }
        Ok(ParamDecl {
            name: name.expect("a parameter has a name"),
            default,
            limits,
            span,
        })
    }

    fn block(&self, p: Pair<'_, Rule>) -> Result<Body, ParseError> {
        let mut guard = None;
        let mut stmts = Vec::new();
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::guard => {
                    let e = part
                        .into_inner()
                        .find(|e| e.as_rule() == Rule::expr)
                        .expect("a guard holds an expression");
                    guard = Some(self.expr(e, 0)?);
                }
                Rule::stmt => {
                    let span = self.span(&part);
                    let mut inner = part.into_inner();
                    let target = self.ident(inner.next().expect("a statement has a target"));
                    let op = match inner.next().expect("a statement has an operator").as_str() {
                        "+=" => AssignOp::Add,
                        "-=" => AssignOp::Sub,
                        "*=" => AssignOp::Mul,
                        "/=" => AssignOp::Div,
                        _ => AssignOp::Set,
                    };
                    let value = self.expr(inner.next().expect("a statement has a value"), 0)?;
                    stmts.push(Stmt {
                        target,
                        op,
                        value,
                        span,
                    });
                }
                _ => {}
            }
        }
        Ok(Body::Block { guard, stmts })
    }

    fn call(&self, p: Pair<'_, Rule>) -> Result<Call, ParseError> {
        let span = self.span(&p);
        let mut inner = p.into_inner();
        let name = self.ident(inner.next().expect("a call has a name"));
        let mut args = Vec::new();
        if let Some(list) = inner.next() {
            for a in list.into_inner().filter(|a| a.as_rule() == Rule::arg) {
                let aspan = self.span(&a);
                let mut aname = None;
                let mut value = None;
                for part in a.into_inner() {
                    match part.as_rule() {
                        Rule::name => aname = Some(self.ident(part)),
                        Rule::expr => value = Some(self.expr(part, 0)?),
                        _ => {}
                    }
                }
                args.push(Arg {
                    name: aname,
                    value: value.expect("an argument has a value"),
                    span: aspan,
                });
            }
        }
        Ok(Call { name, args, span })
    }

    fn too_deep(&self, span: Span) -> ParseError {
        ParseError::TooDeep {
            what: "the expression is nested".into(),
            help: format!(
                "an expression may be at most {MAX_DEPTH} levels deep, and every term of a chain `a + b + c` is one more; split it into several operators or statements"
            ),
            src: self.src(),
            span: span.into(),
        }
    }

    /// Build an `expr` pair; `depth` tree levels are already above it.
    fn expr(&self, p: Pair<'_, Rule>, depth: usize) -> Result<Expr, ParseError> {
        self.expr_height(p, depth).map(|(e, _)| e)
    }

    /// Build an `expr` pair by precedence climbing over its flat token stream; also returns the
    /// height of the tree built, which with `depth` stays within [`MAX_DEPTH`].
    fn expr_height(&self, p: Pair<'_, Rule>, depth: usize) -> Result<(Expr, usize), ParseError> {
        if depth >= MAX_DEPTH {
            return Err(self.too_deep(self.span(&p)));
        }
        let toks: Vec<Tok<'_>> = p
            .into_inner()
            .map(|t| {
                let infix = |op| Tok::Infix(op, self.span(&t));
                match t.as_rule() {
                    Rule::op_neg => Tok::Prefix(UnOp::Neg, self.span(&t)),
                    Rule::kw_not => Tok::Prefix(UnOp::Not, self.span(&t)),
                    Rule::kw_or => infix(BinOp::Or),
                    Rule::kw_and => infix(BinOp::And),
                    Rule::op_eq => infix(BinOp::Eq),
                    Rule::op_ne => infix(BinOp::Ne),
                    Rule::op_le => infix(BinOp::Le),
                    Rule::op_ge => infix(BinOp::Ge),
                    Rule::op_lt => infix(BinOp::Lt),
                    Rule::op_gt => infix(BinOp::Gt),
                    Rule::op_add => infix(BinOp::Add),
                    Rule::op_sub => infix(BinOp::Sub),
                    Rule::op_mul => infix(BinOp::Mul),
                    Rule::op_div => infix(BinOp::Div),
                    _ => Tok::Operand(t),
                }
            })
            .collect();
        let mut climb = Climb {
            b: self,
            toks,
            at: 0,
            depth,
        };
        climb.expr(0)
    }

    /// An operand and its height; `depth` levels are above it.
    fn operand(&self, p: Pair<'_, Rule>, depth: usize) -> Result<(Expr, usize), ParseError> {
        let span = self.span(&p);
        match p.as_rule() {
            Rule::number => Ok((
                Expr::new(ExprKind::Num(self.number_text(p.as_str(), span)?), span),
                1,
            )),
            Rule::name => Ok((Expr::new(ExprKind::Var(p.as_str().to_string()), span), 1)),
            Rule::paren => {
                let e = p
                    .into_inner()
                    .find(|e| e.as_rule() == Rule::expr)
                    .expect("parentheses hold an expression");
                // Parentheses group; they add no level to the tree.
                self.expr_height(e, depth)
            }
            Rule::call_expr => {
                let mut inner = p.into_inner();
                let func = self.ident(inner.next().expect("a call has a name"));
                let mut args = Vec::new();
                let mut height = 0;
                for e in inner.filter(|e| e.as_rule() == Rule::expr) {
                    let (a, h) = self.expr_height(e, depth + 1)?;
                    height = height.max(h);
                    args.push(a);
                }
                Ok((Expr::new(ExprKind::Call { func, args }, span), height + 1))
            }
            Rule::at_expr => {
                let mut inner = p.into_inner();
                let dim = self.ident(inner.next().expect("an offset read names a dimension"));
                let e = inner
                    .find(|e| e.as_rule() == Rule::expr)
                    .expect("an offset read has an offset");
                let (offset, h) = self.expr_height(e, depth + 1)?;
                let offset = Box::new(offset);
                Ok((Expr::new(ExprKind::At { dim, offset }, span), h + 1))
            }
            r => unreachable!("the grammar has no operand {r:?}"),
        }
    }
}

/// Precedence climbing over one expression's tokens. `depth` counts the tree levels above the
/// subtree being built; every node is refused once its level would pass [`MAX_DEPTH`], before
/// anything recurses deeper, so a hostile chain stops at the operator that passed the limit.
struct Climb<'b, 'a, 'i> {
    b: &'b Builder<'a>,
    toks: Vec<Tok<'i>>,
    at: usize,
    depth: usize,
}

impl Climb<'_, '_, '_> {
    fn expr(&mut self, min: u8) -> Result<(Expr, usize), ParseError> {
        let (mut lhs, mut height) = self.unary()?;
        while let Some(Tok::Infix(op, op_span)) = self.toks.get(self.at) {
            let (op, op_span) = (*op, *op_span);
            if op.precedence() < min {
                break;
            }
            // The new node sits where `lhs` was; `lhs` moves one level down.
            if self.depth + height + 1 > MAX_DEPTH {
                return Err(self.b.too_deep(op_span));
            }
            self.at += 1;
            self.depth += 1;
            let rhs = self.expr(op.precedence() + 1);
            self.depth -= 1;
            let (rhs, rh) = rhs?;
            height = height.max(rh) + 1;
            if self.depth + height > MAX_DEPTH {
                return Err(self.b.too_deep(op_span));
            }
            let span = lhs.span.join(rhs.span);
            lhs = Expr::new(ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)), span);
        }
        Ok((lhs, height))
    }

    fn unary(&mut self) -> Result<(Expr, usize), ParseError> {
        let at = self.at;
        self.at += 1;
        match self.toks.get(at) {
            Some(Tok::Prefix(op, span)) => {
                let (op, span) = (*op, *span);
                if self.depth + 1 >= MAX_DEPTH {
                    return Err(self.b.too_deep(span));
                }
                self.depth += 1;
                let e = self.expr(op.precedence());
                self.depth -= 1;
                let (e, h) = e?;
                let span = span.join(e.span);
                Ok((Expr::new(ExprKind::Unary(op, Box::new(e)), span), h + 1))
            }
            Some(Tok::Operand(p)) => {
                let p = p.clone();
                self.b.operand(p, self.depth)
            }
            _ => unreachable!("the grammar puts an operand after every operator"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expr(src: &str) -> String {
        let f = parse("t", &format!("operator o for d on action {{ u = {src} }}")).unwrap();
        let Item::Operator(o) = &f.items[0] else {
            panic!()
        };
        let Body::Block { stmts, .. } = &o.body else {
            panic!()
        };
        stmts[0].value.to_string()
    }

    #[test]
    fn precedence_is_conventional() {
        assert_eq!(expr("1 + 2 * 3"), "1 + 2 * 3");
        assert_eq!(expr("(1 + 2) * 3"), "(1 + 2) * 3");
        assert_eq!(expr("1 - (2 - 3)"), "1 - (2 - 3)");
        assert_eq!(expr("(1 - 2) - 3"), "1 - 2 - 3");
        assert_eq!(expr("-a * b"), "-a * b");
        assert_eq!(expr("-(a * b)"), "-(a * b)");
        assert_eq!(expr("not a < b and c"), "not a < b and c");
        assert_eq!(expr("(not a) < b"), "(not a) < b");
    }

    #[test]
    fn invocations() {
        let i = parse_invocation("speed_up(rate = 0.5)").unwrap();
        assert_eq!(i.name.name, "speed_up");
        assert_eq!(i.args[0].name.as_ref().unwrap().name, "rate");
        assert_eq!(i.args[0].value, 0.5);
        let i = parse_invocation("speed_up(-1.5)").unwrap();
        assert_eq!(i.args[0].value, -1.5);
        assert!(parse_invocation("speed_up").unwrap().args.is_empty());
        assert!(parse_invocation("speed_up(").is_err());
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let deep = format!("{}1{}", "(".repeat(500), ")".repeat(500));
        assert!(matches!(
            parse("t", &format!("operator o for d on action {{ u = {deep} }}")),
            Err(ParseError::TooDeep { .. })
        ));
        let negs = "-".repeat(5000);
        assert!(
            parse(
                "t",
                &format!("operator o for d on action {{ u = {negs}1 }}")
            )
            .is_err()
        );
    }
}
