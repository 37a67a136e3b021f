//! Text to spanned AST: the only module that knows pest.
//!
//! [`parse`] reads a whole file of items, [`parse_item`] exactly one item (a REPL line), and
//! [`parse_invocation`] the way a teacher names an operator (`speed_up`, `speed_up(0.5)`,
//! `speed_up(rate = 0.5)`). Parse errors are [`ParseError`] diagnostics that say what was expected
//! in words, converted from pest's byte offsets. This module does not resolve names or check
//! meaning; that is [`crate::check`]. The grammar is `grammar/advice.pest`.

pub mod ast;
mod build;
pub mod command;
pub mod delims;
mod error;
pub mod fmt;
pub mod print;
pub mod script;
mod split;

use pest::Parser;
use pest::iterators::{Pair, Pairs};

use crate::diag::{SourceId, SourceMap, Sourced, Src};
use ast::*;

use build::Builder;
pub use error::ParseError;
use error::{convert, nesting_too_deep};
pub use split::each_item;

#[derive(pest_derive::Parser)]
#[grammar = "../../../grammar/advice.pest"]
#[grammar = "../../../grammar/session.pest"]
struct AdviceParser;

pub use delims::MAX_NESTING;

/// How deep an expression's tree may be: every operand, operator, prefix and function call is one
/// level, so a chain `a + b + c ...` may have 128 terms. Far beyond any operator a person writes, and
/// it keeps every recursive pass over the tree (check, print, compile, drop) well inside a
/// thread's stack. Brackets are limited separately, before parsing ([`MAX_NESTING`]).
pub const MAX_DEPTH: usize = 128;

/// Parse a whole file, a source of a [`SourceMap`](crate::diag::SourceMap) whose errors point
/// into it: [`items`] collected.
pub fn parse(source: Src<'_>) -> Result<File, ParseError> {
    Ok(File {
        items: items(source).collect::<Result<_, _>>()?,
    })
}

/// [`parse`], with every comment of the text (doc comments too, in source order) as the scan that
/// runs before pest found them: what `fmt` puts back, since the grammar skips comments.
pub fn parse_with_comments(source: Src<'_>) -> Result<(File, Vec<delims::Comment>), ParseError> {
    let mut items = items(source);
    let parsed = items.by_ref().collect::<Result<_, _>>()?;
    let comments = std::mem::take(&mut items.brackets.comments);
    Ok((File { items: parsed }, comments))
}

/// The items of a file, each parsed when it is asked for; after an error, nothing more.
///
/// The file is parsed one item at a time (`next_item`), each from where the one before ended, so
/// pest's token queue (about 80 bytes per token, 40 times the text) holds one item, never the
/// whole file, and a reader that is done with an item (the checker, once it has compiled an
/// operator) need not hold its tree while the rest is read. A mistake is reported as a whole-file
/// parse reports it: the text is parsed again with `file`, from the start of the item before the
/// one that failed (whose continuation pest also tries where the next item starts), and the
/// error's place shifted back.
pub fn items(source: Src<'_>) -> Items<'_> {
    // pest recurses once per bracket; refuse deep nesting before it can exhaust the stack.
    let brackets = delims::scan(source.text);
    let failed = brackets.too_deep.map(|at| nesting_too_deep(source.id, at));
    let mut items = Items::within(source, brackets, 0..source.text.len(), 0);
    items.failed = failed;
    items
}

/// The iterator of [`items`].
pub struct Items<'s> {
    id: SourceId,
    src: &'s str,
    brackets: delims::Scan,
    /// Where the next item is looked for, and where the last one read started.
    pos: usize,
    last_start: usize,
    /// Where the text read ends: the source's end, or the end of a batch ([`split`]).
    end: usize,
    /// An error found before the first item (nesting too deep), reported first.
    failed: Option<ParseError>,
    done: bool,
}

impl<'s> Items<'s> {
    /// The items of `source.text[range]`, read as if the items before `range.start` had been
    /// (the last of them starting at `last_start`); `brackets` is the scan of the whole text.
    fn within(
        source: Src<'s>,
        brackets: delims::Scan,
        range: std::ops::Range<usize>,
        last_start: usize,
    ) -> Items<'s> {
        Items {
            id: source.id,
            src: source.text,
            brackets,
            pos: range.start,
            last_start,
            end: range.end,
            failed: None,
            done: false,
        }
    }
}

impl Iterator for Items<'_> {
    type Item = Result<Item, ParseError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        if let Some(e) = self.failed.take() {
            self.done = true;
            return Some(Err(e));
        }
        let (id, src, pos) = (self.id, self.src, self.pos);
        let step = match AdviceParser::parse(Rule::next_item, &src[pos..self.end]) {
            Ok(mut pairs) => pairs.next().expect("next_item always yields one pair"),
            Err(e) => {
                self.done = true;
                let e = match AdviceParser::parse(Rule::file, &src[self.last_start..self.end]) {
                    Err(whole) => shifted(whole, self.last_start),
                    // Cannot happen (the item before parsed the same way); the step's own error.
                    Ok(_) => shifted(e, pos),
                };
                return Some(Err(convert(e, id, src, &self.brackets)));
            }
        };
        let Some(p) = step.into_inner().find(|p| p.as_rule() != Rule::EOI) else {
            self.done = true;
            return None;
        };
        let b = Builder { id, base: pos };
        let span = b.span(&p);
        (self.last_start, self.pos) = (span.start, span.end);
        let item = b.item(p);
        self.done = item.is_err();
        Some(item)
    }
}

/// A pest error of text that starts at byte `base` of the source, placed in the source.
fn shifted(mut e: pest::error::Error<Rule>, base: usize) -> pest::error::Error<Rule> {
    use pest::error::InputLocation;
    e.location = match e.location {
        InputLocation::Pos(p) => InputLocation::Pos(base + p),
        InputLocation::Span((s, t)) => InputLocation::Span((base + s, base + t)),
    };
    e
}

/// Parse exactly one item, e.g. an operator typed on one REPL line.
pub fn parse_item(source: Src<'_>) -> Result<Item, ParseError> {
    let (id, src) = (source.id, source.text);
    let mut pairs = run(Rule::single_item, id, src)?;
    let whole = pairs.next().expect("single_item always yields one pair");
    let b = Builder::new(id);
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

/// Parse an invocation such as `speed_up(rate = 0.5)` typed on its own (a command-line argument,
/// a script of the automatic teacher); an error brings the text with it, named `invocation`.
pub fn parse_invocation(text: &str) -> Result<Invocation, Sourced<ParseError>> {
    let (mut map, id) = SourceMap::single("invocation", text);
    let parsed = run(Rule::invocation, id, text).and_then(|mut pairs| {
        let b = Builder::new(id);
        b.invocation(pairs.next().expect("invocation yields one pair"))
    });
    parsed.map_err(|e| map.attach(e))
}

impl Builder {
    /// An invocation from its pair (`invocation` or a command's `inv_body`: a name and maybe
    /// arguments). Its spans are made relative to its own text, which binding diagnostics show;
    /// its errors point into the builder's source.
    pub(crate) fn invocation(&self, p: Pair<'_, Rule>) -> Result<Invocation, ParseError> {
        let base = self.span(&p).start;
        let own = |s: Span| Span::new(s.start - base, s.end - base);
        let text = p.as_str().to_string();
        let mut inner = p.into_inner();
        let mut op = self.ident(inner.next().expect("an invocation starts with a name"));
        op.span = own(op.span);
        let mut args = Vec::new();
        if let Some(list) = inner.next().filter(|p| p.as_rule() == Rule::inv_args) {
            for a in list.into_inner().filter(|p| p.as_rule() == Rule::inv_arg) {
                args.push(self.inv_arg(a, own)?);
            }
        }
        Ok(Invocation {
            text,
            name: op,
            args,
        })
    }
}

impl Builder {
    /// One literal argument, positional or named (`rate = 0.5`), its spans passed through `own`
    /// (an invocation's are relative to its own text; `run goal`'s stay the statement's).
    pub(crate) fn inv_arg(
        &self,
        a: Pair<'_, Rule>,
        own: impl Fn(Span) -> Span,
    ) -> Result<InvArg, ParseError> {
        let span = own(self.span(&a));
        let mut name = None;
        let mut value = 0.0;
        for part in a.into_inner() {
            match part.as_rule() {
                Rule::name => {
                    let mut n = self.ident(part);
                    n.span = own(n.span);
                    name = Some(n);
                }
                Rule::signed_number => {
                    let text: String = part.as_str().chars().filter(|c| *c != '+').collect();
                    value = self.number_text(&text, self.span(&part))?;
                }
                _ => {}
            }
        }
        Ok(InvArg { name, value, span })
    }
}

fn run<'i>(rule: Rule, id: SourceId, src: &'i str) -> Result<Pairs<'i, Rule>, ParseError> {
    // pest recurses once per bracket; refuse deep nesting before it can exhaust the stack.
    let brackets = delims::scan(src);
    if let Some(at) = brackets.too_deep {
        return Err(nesting_too_deep(id, at));
    }
    AdviceParser::parse(rule, src).map_err(|e| convert(e, id, src, &brackets))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parse `text` as a file of its own (the errors' places are only compared, never drawn).
    fn parse(name: &str, text: &str) -> Result<File, ParseError> {
        let (map, id) = SourceMap::single(name, text);
        super::parse(map.src(id))
    }

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
