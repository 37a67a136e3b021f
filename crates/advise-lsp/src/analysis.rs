//! What the language server knows about one version of a document, in byte offsets:
//! diagnostics, hover, completion, definitions and symbols.
//!
//! An [`Analysis`] is built once per version of a text (the server builds one on each open and
//! change): the text's [`LineIndex`], its operators checked on top of the standard ones, its
//! diagnostics, and its syntax tree (parsed at the first request that needs it). Every request after that reads it: hover and definition
//! find the node under the cursor from the tree's spans ([`Node`]) and resolve its name in the
//! checked set, so no request parses or checks the document again (completion on a line being
//! typed, when the document does not parse, parses it once more with that line blanked).
//! [`super`] converts to and from the protocol's positions. The free functions ([`hover`],
//! [`completion`], ...) analyse a text and answer one question, for tests and benches.

use std::ops::Range;
use std::sync::OnceLock;

use miette::Diagnostic;

use advise_lang::check::{self, Checked, OperatorSet};
use advise_lang::diag::lines::floor;
use advise_lang::diag::{LineIndex, SourceId, SourceMap};
use advise_lang::domain::Space;
use advise_lang::program::Operator;
use advise_lang::program::ir::Func;
use advise_lang::syntax::ast::{
    Body, Call, Clause, DimDecl, DimMeaning, DomainDecl, Expr, ExprKind, File, Ident, Item,
    OperatorDecl, ParamDecl, Span,
};
use advise_lang::syntax::command::{self, COMMANDS};

/// One version of a document, analysed once (see the module docs).
#[derive(Clone, Debug)]
pub struct Analysis {
    text: String,
    lines: LineIndex,
    /// A session script rather than an operator file ([`is_script`]).
    script: bool,
    /// The syntax tree of an operator file that parses: parsed at the first request that needs
    /// it (the checker parses on its own, so a change that no request follows costs one check).
    file: OnceLock<Option<File>>,
    /// The standard operators with the document's own: an operator file's when it checks (the
    /// standard set alone when it does not), a script's definitions that check, in order.
    set: OperatorSet,
    diagnostics: Vec<Diag>,
}

thread_local! {
    /// How many documents this thread checked and parsed ([`work_on_this_thread`]).
    static WORK: std::cell::Cell<(usize, usize)> = const { std::cell::Cell::new((0, 0)) };
}

/// How many times this thread checked a document ([`Analysis::new`]) and parsed one (its tree,
/// or a line being typed blanked): what a test counts to show requests reuse an analysis.
pub fn work_on_this_thread() -> (usize, usize) {
    WORK.with(|w| w.get())
}

fn count(checks: usize, parses: usize) {
    WORK.with(|w| {
        let (c, p) = w.get();
        w.set((c + checks, p + parses));
    });
}

impl Analysis {
    /// Parse and check `text` (its diagnostics name it `name`).
    pub fn new(name: &str, text: String) -> Analysis {
        count(1, 0);
        let lines = LineIndex::new(&text);
        if is_script(&text) {
            let (diagnostics, set) = script_diagnostics(&text);
            return Analysis {
                text,
                lines,
                script: true,
                file: OnceLock::from(None),
                set,
                diagnostics,
            };
        }
        let mut map = SourceMap::new();
        let id = map.add(name, text.as_str());
        let (set, diagnostics) = match OperatorSet::standard().merge_in(&map, &[id]) {
            Ok(Checked { set, warnings }) => {
                let d = warnings
                    .iter()
                    .map(|w| diag(w, id, text.len(), 0, true))
                    .collect();
                (set, d)
            }
            Err(errors) => {
                let d = errors
                    .errors
                    .iter()
                    .map(|e| diag(e, id, text.len(), 0, false))
                    .collect();
                (OperatorSet::standard(), d)
            }
        };
        Analysis {
            text,
            lines,
            script: false,
            file: OnceLock::new(),
            set,
            diagnostics,
        }
    }

    /// `text` held without its analysis (when analysing it failed): no tree, no diagnostics, the
    /// standard operators.
    pub(super) fn unanalysed(text: String) -> Analysis {
        Analysis {
            lines: LineIndex::new(&text),
            text,
            script: false,
            file: OnceLock::from(None),
            set: OperatorSet::standard(),
            diagnostics: Vec::new(),
        }
    }

    /// The syntax tree, when the document is an operator file that parses.
    fn file(&self) -> Option<&File> {
        self.file.get_or_init(|| parsed(&self.text)).as_ref()
    }

    pub fn text(&self) -> &str {
        &self.text
    }

    /// The text back, to edit it (the analysis is of the text as it was).
    pub fn into_text(self) -> String {
        self.text
    }

    pub fn lines(&self) -> &LineIndex {
        &self.lines
    }

    /// The errors and warnings `advise check FILE` reports (a script's: its bad lines).
    pub fn diagnostics(&self) -> &[Diag] {
        &self.diagnostics
    }

    /// The node under `offset` (clamped to a character boundary), when the document parses.
    fn node(&self, offset: usize) -> Option<Node<'_>> {
        let offset = floor(&self.text, offset);
        node_at(self.file()?, offset)
    }
}

/// The document's diagnostics: an operator file checked on top of the standard operators (the
/// errors and warnings `advise check FILE` reports), or a session script's lines that are not
/// statements.
pub fn diagnostics(name: &str, text: &str) -> Vec<Diag> {
    Analysis::new(name, text.to_string()).diagnostics
}

/// Hover at `offset` of `text`, analysed for this one question.
pub fn hover(text: &str, offset: usize) -> Option<(Range<usize>, String)> {
    Analysis::new("document", text.to_string()).hover(offset)
}

/// Completion at `offset` of `text`, analysed for this one question.
pub fn completion(text: &str, offset: usize) -> Vec<Completion> {
    Analysis::new("document", text.to_string()).completion(offset)
}

/// Go to definition at `offset` of `text`, analysed for this one question.
pub fn definition(text: &str, offset: usize) -> Option<Target> {
    Analysis::new("document", text.to_string()).definition(offset)
}

/// The symbols of `text`.
pub fn symbols(text: &str) -> Vec<Symbol> {
    parsed(text).map_or_else(Vec::new, |f| file_symbols(&f))
}
/// One diagnostic: where, how bad, the code, the message with its help, and the other labels.
#[derive(Clone, Debug, PartialEq)]
pub struct Diag {
    pub range: Range<usize>,
    pub warning: bool,
    pub code: Option<String>,
    pub message: String,
    pub related: Vec<(Range<usize>, String)>,
}

/// Whether the document is a session script (REPL commands) rather than an operator file: the
/// answer of `advise fmt`'s [`advise_lang::syntax::fmt::is_script`], asked only when some line starts
/// with a command's word. Every command does, so the answer is the same; but that function
/// parses each line as a statement, which took half the time of re-checking a 1,000-operator file
/// whose body lines (`trans *= f`, `}`) never start with one.
pub fn is_script(text: &str) -> bool {
    let starts_a_command = |line: &str| {
        let word = line
            .trim_start()
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .next()
            .unwrap_or("");
        COMMANDS.iter().any(|c| c.name == word)
    };
    text.lines().any(starts_a_command) && advise_lang::syntax::fmt::is_script(text)
}

/// A script's statements as the session splits them (an operator definition may span lines),
/// each parsed as a statement; a definition is checked as the session checks it, merged into the
/// standard operators and the script's definitions before it. With the set they make.
fn script_diagnostics(text: &str) -> (Vec<Diag>, OperatorSet) {
    let lines = LineIndex::new(text);
    let mut out = Vec::new();
    let mut set = OperatorSet::standard();
    let mut definitions = SourceMap::new();
    for st in advise_lang::syntax::script::statements(text) {
        let trimmed = st.text.trim();
        if trimmed.is_empty() || (trimmed.starts_with("//") && !trimmed.contains('\n')) {
            continue;
        }
        let start = lines
            .line_span(st.line.saturating_sub(1))
            .map_or(text.len(), |l| l.start);
        let len = st.text.len();
        let (map, id) = SourceMap::single("statement", st.text.as_str());
        match command::parse_statement(map.src(id)) {
            Err(e) => out.push(diag(&e, id, len, start, false)),
            Ok(command::Statement::Item(_)) => {
                let id = definitions.add(format!("line {}", st.line), st.text.as_str());
                match set.merge_in(&definitions, &[id]) {
                    Ok(Checked {
                        set: merged,
                        warnings,
                    }) => {
                        out.extend(warnings.iter().map(|w| diag(w, id, len, start, true)));
                        set = merged;
                    }
                    Err(errors) => {
                        out.extend(errors.errors.iter().map(|e| diag(e, id, len, start, false)))
                    }
                }
            }
            Ok(_) => {}
        }
    }
    (out, set)
}

/// A miette diagnostic of source `id` (`len` bytes, at byte `shift` of the document) as a
/// [`Diag`]: its first label is the range, the others related information.
fn diag(d: &dyn Diagnostic, id: SourceId, len: usize, shift: usize, warning: bool) -> Diag {
    let base = miette::SourceSpan::from(id.at(0..0)).offset();
    let mut labels: Vec<(Range<usize>, String)> = d
        .labels()
        .into_iter()
        .flatten()
        .filter(|l| l.offset() >= base && l.offset() <= base + len)
        .map(|l| {
            let start = l.offset() - base;
            let end = (start + l.len()).min(len);
            (
                shift + start..shift + end,
                l.label().unwrap_or("here").to_string(),
            )
        })
        .collect();
    let range = if labels.is_empty() {
        shift..shift
    } else {
        labels.remove(0).0
    };
    let mut message = d.to_string();
    if let Some(help) = d.help() {
        message.push_str(&format!("\nhelp: {help}"));
    }
    Diag {
        range,
        warning,
        code: d.code().map(|c| c.to_string()),
        message,
        related: labels,
    }
}

/// What the cursor is on, found from the syntax tree's spans.
#[derive(Clone, Copy, Debug)]
enum Node<'f> {
    /// An operator's own name, in its declaration.
    OperatorName(&'f OperatorDecl),
    /// A parameter's name, in its operator's declaration.
    ParamName(&'f OperatorDecl, &'f ParamDecl),
    /// The domain an operator is for (`for positioning`).
    DomainRef(&'f OperatorDecl),
    /// A name in an operator (assigned, read, read at an offset): a parameter or a dimension.
    InOperator(&'f OperatorDecl, &'f str, Span),
    /// A name read in a domain's clauses: its dimension, or a name the domain binds.
    InDomain(&'f DomainDecl, &'f str, Span),
    /// A step of a composition: an operator.
    Step(&'f OperatorDecl, &'f Call),
    /// A named argument of a step: the callee's parameter.
    NamedArg(&'f OperatorDecl, &'f Call, &'f Ident),
    /// A built-in function's name.
    Func(&'f Ident),
    /// A domain's name, in its declaration.
    DomainName(&'f DomainDecl),
    /// A dimension's name, in its domain's declaration.
    DimName(&'f DomainDecl, &'f DimDecl),
}

/// Whether `offset` is in `span` (its end included: a cursor just after a name is on it).
fn on(span: Span, offset: usize) -> bool {
    span.start <= offset && offset <= span.end
}

/// The node of `file` under `offset`. (A span may run over the blanks after it, so the one
/// before a node may hold its start too: each candidate is asked in turn.)
fn node_at(file: &File, offset: usize) -> Option<Node<'_>> {
    file.items
        .iter()
        .filter(|i| on(i.span(), offset))
        .find_map(|item| match item {
            Item::Operator(op) => operator_node(op, offset),
            Item::Domain(d) => domain_node(d, offset),
        })
}

fn operator_node<'f>(op: &'f OperatorDecl, offset: usize) -> Option<Node<'f>> {
    if on(op.name.span, offset) {
        return Some(Node::OperatorName(op));
    }
    if on(op.domain.span, offset) {
        return Some(Node::DomainRef(op));
    }
    let in_op = |name: &'f str, span: Span| Node::InOperator(op, name, span);
    for p in &op.params {
        if on(p.name.span, offset) {
            return Some(Node::ParamName(op, p));
        }
        let exprs = p
            .default
            .iter()
            .chain(p.limits.iter().flat_map(|l| [&l.lo, &l.hi]));
        if let Some(n) = exprs.filter_map(|e| expr_node(e, offset, &in_op)).next() {
            return Some(n);
        }
    }
    match &op.body {
        Body::Block { guard, stmts } => {
            if let Some(n) = guard.as_ref().and_then(|g| expr_node(g, offset, &in_op)) {
                return Some(n);
            }
            stmts.iter().filter(|s| on(s.span, offset)).find_map(|s| {
                if on(s.target.span, offset) {
                    return Some(in_op(&s.target.name, s.target.span));
                }
                expr_node(&s.value, offset, &in_op)
            })
        }
        Body::Pipeline(calls) => calls
            .iter()
            .filter(|c| on(c.span, offset))
            .find_map(|call| {
                if on(call.name.span, offset) {
                    return Some(Node::Step(op, call));
                }
                call.args.iter().find_map(|a| match &a.name {
                    Some(name) if on(name.span, offset) => Some(Node::NamedArg(op, call, name)),
                    _ => expr_node(&a.value, offset, &in_op),
                })
            }),
    }
}

fn domain_node<'f>(d: &'f DomainDecl, offset: usize) -> Option<Node<'f>> {
    if on(d.name.span, offset) {
        return Some(Node::DomainName(d));
    }
    let in_domain = |name: &'f str, span: Span| Node::InDomain(d, name, span);
    for x in &d.dims {
        if on(x.name.span, offset) {
            return Some(Node::DimName(d, x));
        }
        if let Some(n) = dim_exprs(x).find_map(|e| expr_node(e, offset, &in_domain)) {
            return Some(n);
        }
    }
    for clause in &d.clauses {
        let found = match clause {
            Clause::Goal(dims) => dims
                .iter()
                .flat_map(dim_exprs)
                .find_map(|e| expr_node(e, offset, &in_domain)),
            Clause::Let(bs) | Clause::Score(bs) | Clause::Recorded(bs) => bs
                .iter()
                .find_map(|b| expr_node(&b.value, offset, &in_domain)),
            Clause::Success { cond, .. } => expr_node(cond, offset, &in_domain),
            Clause::EndWhen { cond, hold, .. } => expr_node(cond, offset, &in_domain)
                .or_else(|| hold.as_ref().and_then(|h| expr_node(h, offset, &in_domain))),
            Clause::EndAfter { limit, .. } => expr_node(limit, offset, &in_domain),
            Clause::Flaw { cond, hold, .. } => expr_node(cond, offset, &in_domain)
                .or_else(|| hold.as_ref().and_then(|h| expr_node(h, offset, &in_domain))),
            Clause::Draw(ds) => ds
                .iter()
                .flat_map(|d| &d.args)
                .find_map(|e| expr_node(e, offset, &in_domain)),
            Clause::Test { .. } => None,
            Clause::Teacher { stmts, .. } => stmts
                .iter()
                .find_map(|s| expr_node(&s.binding.value, offset, &in_domain)),
        };
        if found.is_some() {
            return found;
        }
    }
    None
}

/// The expressions of a dimension's declaration: its limits and what it means in a task.
fn dim_exprs(x: &DimDecl) -> impl Iterator<Item = &Expr> {
    let limits = x.limits.iter().flat_map(|l| [&l.lo, &l.hi]);
    let meaning = x.meaning.iter().flat_map(|m| match m {
        DimMeaning::Def(e) => vec![e],
        DimMeaning::Drives(_) => vec![],
        DimMeaning::Changes(_, l) => vec![&l.lo, &l.hi],
    });
    limits.chain(meaning)
}

/// The name in `e` under `offset`, made a node by `name` (a built-in function's is its own).
fn expr_node<'f>(
    e: &'f Expr,
    offset: usize,
    name: &impl Fn(&'f str, Span) -> Node<'f>,
) -> Option<Node<'f>> {
    if !on(e.span, offset) {
        return None;
    }
    match &e.kind {
        ExprKind::Num(_) => None,
        ExprKind::Var(v) => Some(name(v, e.span)),
        ExprKind::At { dim, offset: at } => {
            if on(dim.span, offset) {
                Some(name(&dim.name, dim.span))
            } else {
                expr_node(at, offset, name)
            }
        }
        ExprKind::Call { func, args } => {
            if on(func.span, offset) {
                Some(Node::Func(func))
            } else {
                args.iter().find_map(|a| expr_node(a, offset, name))
            }
        }
        ExprKind::Unary(_, x) => expr_node(x, offset, name),
        ExprKind::Binary(_, a, b) => {
            expr_node(a, offset, name).or_else(|| expr_node(b, offset, name))
        }
    }
}

/// The word (a name) at byte `offset`, and its range: only for a text without a syntax tree (a
/// session script, or an operator file that does not parse).
fn word_at(text: &str, offset: usize) -> Option<(&str, Range<usize>)> {
    let offset = floor(text, offset);
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let start = text[..offset]
        .char_indices()
        .rev()
        .take_while(|(_, c)| is_word(*c))
        .last()
        .map_or(offset, |(i, _)| i);
    let end = offset
        + text[offset..]
            .char_indices()
            .find(|(_, c)| !is_word(*c))
            .map_or(text.len() - offset, |(i, _)| i);
    (start < end).then(|| (&text[start..end], start..end))
}

/// The parsed document, when it parses.
fn parsed(text: &str) -> Option<File> {
    count(0, 1);
    let (map, id) = SourceMap::single("document", text);
    advise_lang::syntax::parse(map.src(id)).ok()
}

/// The standard library's files, parsed once per process (for go to definition).
fn standard_files() -> &'static [(&'static str, File)] {
    static FILES: OnceLock<Vec<(&'static str, File)>> = OnceLock::new();
    FILES.get_or_init(|| {
        check::STANDARD_SOURCES
            .iter()
            .filter_map(|&(name, text)| Some((name, parsed(text)?)))
            .collect()
    })
}

/// The operator declaration whose text holds `offset`.
fn enclosing(file: &File, offset: usize) -> Option<&OperatorDecl> {
    file.items.iter().find_map(|i| match i {
        Item::Operator(o) if on(o.span, offset) => Some(o),
        _ => None,
    })
}

/// An operator's hover: the session's `help NAME` text (its first line, the signature and
/// space, as code), with the domain.
pub fn operator_help(op: &Operator) -> String {
    let help = op.help();
    let (head, doc) = help.split_once('\n').unwrap_or((&help, ""));
    let mut s = format!("```advise\n{head}\n```\nan operator for `{}`", op.domain());
    if !doc.trim().is_empty() {
        s.push_str("\n\n");
        s.push_str(doc);
    }
    s
}

/// A built-in function's arguments (a match, so a new function cannot be added without them).
fn func_args(f: Func) -> &'static str {
    match f {
        Func::Min | Func::Max => "a, b",
        Func::Abs | Func::Sign | Func::Sqrt => "x",
        Func::Cos | Func::Sin | Func::Wrap => "a",
        Func::Hypot => "dx, dy",
        Func::Atan2 => "y, x",
        Func::Clamp => "x, lo, hi",
        Func::If => "cond, a, b",
    }
}

impl Analysis {
    /// Hover: the operator, parameter, dimension, domain or function under `offset`.
    pub fn hover(&self, offset: usize) -> Option<(Range<usize>, String)> {
        let Some(node) = self.node(offset) else {
            // No tree: a name of an operator or a domain, as the text has it.
            if self.file().is_some() {
                return None;
            }
            let (word, range) = word_at(&self.text, offset)?;
            return Some((range, self.describe(word, None, &[])?));
        };
        let (span, text) = match node {
            Node::OperatorName(op) => (
                op.name.span,
                self.describe(&op.name.name, Some(&op.domain.name), &op.params),
            ),
            Node::ParamName(op, p) => (
                p.name.span,
                self.describe(&p.name.name, Some(&op.domain.name), &op.params),
            ),
            Node::DomainRef(op) => (op.domain.span, self.describe(&op.domain.name, None, &[])),
            Node::InOperator(op, name, span) => {
                (span, self.describe(name, Some(&op.domain.name), &op.params))
            }
            Node::Step(op, call) => (
                call.name.span,
                self.describe(&call.name.name, Some(&op.domain.name), &op.params),
            ),
            Node::NamedArg(op, call, name) => (
                name.span,
                self.callee_param(&op.domain.name, &call.name.name, &name.name)
                    .or_else(|| self.describe(&name.name, Some(&op.domain.name), &op.params)),
            ),
            Node::Func(f) => (
                f.span,
                Func::ALL
                    .iter()
                    .find(|x| x.name() == f.name)
                    .map(|&x| format!("function `{}({})`", x.name(), func_args(x))),
            ),
            Node::DomainName(d) => (d.name.span, self.describe(&d.name.name, None, &[])),
            Node::DimName(d, x) => (
                x.name.span,
                self.describe(&x.name.name, Some(&d.name.name), &[]),
            ),
            Node::InDomain(d, name, span) => (span, self.describe(name, Some(&d.name.name), &[])),
        };
        Some((span.start..span.end, text?))
    }

    /// What `name` is, read in an operator of `domain` with `params` (or outside any): a
    /// parameter, a dimension of the domain, an operator (of the domain first, then of any), a
    /// domain.
    fn describe(&self, name: &str, domain: Option<&str>, params: &[ParamDecl]) -> Option<String> {
        if let Some(p) = params.iter().find(|p| p.name.name == name) {
            return Some(format!("parameter `{p}`"));
        }
        if let Some(domain) = domain.and_then(|d| self.set.domain(d))
            && let Some((space, i)) = domain.find(name)
        {
            let d = &domain.dims(space)[i];
            let mut s = format!(
                "{} dimension `{}` of `{}`",
                match space {
                    Space::Observation => "observation",
                    Space::Action => "action",
                },
                d.name,
                domain.name
            );
            if !d.unit.is_empty() {
                s.push_str(&format!(", in {}", d.unit));
            }
            if let Some(l) = d.limits {
                s.push_str(&format!(
                    ", limits [{}, {}]",
                    advise_lang::number::fmt_num(l.lo),
                    advise_lang::number::fmt_num(l.hi)
                ));
            }
            return Some(s);
        }
        let domains = domain
            .into_iter()
            .chain(self.set.domains().iter().map(|d| d.name.as_str()));
        for domain in domains {
            if let Some(op) = self.set.operator(domain, name) {
                return Some(operator_help(op));
            }
        }
        let d = self.set.domain(name)?;
        let dims = |space| {
            d.dims(space)
                .iter()
                .map(|x| x.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        Some(format!(
            "domain `{}`: observe {}; act {}",
            d.name,
            dims(Space::Observation),
            dims(Space::Action)
        ))
    }

    /// The hover of parameter `param` of operator `callee` (of `domain` first, then of any).
    fn callee_param(&self, domain: &str, callee: &str, param: &str) -> Option<String> {
        let domains =
            std::iter::once(domain).chain(self.set.domains().iter().map(|d| d.name.as_str()));
        for domain in domains {
            if let Some(op) = self.set.operator(domain, callee)
                && let Some(p) = op.params().iter().find(|p| p.name == param)
            {
                return Some(format!("parameter `{p}` of `{}`", op.name()));
            }
        }
        None
    }
}

/// What a completion offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompletionKind {
    Keyword,
    Operator,
    Parameter,
    Dimension,
    Function,
    Command,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Completion {
    pub label: String,
    pub kind: CompletionKind,
    pub detail: String,
}

/// The language's keywords (`grammar/advice.pest`) and its reserved names `k`, `n` and `pi`.
pub const KEYWORDS: &[&str] = &[
    "operator",
    "domain",
    "for",
    "on",
    "action",
    "observation",
    "where",
    "then",
    "in",
    "observe",
    "act",
    "and",
    "or",
    "not",
    "k",
    "n",
    "pi",
    // A task's clauses and names (`operators/README.md`, Tasks).
    "goal",
    "let",
    "drives",
    "changes",
    "success",
    "when",
    "end",
    "after",
    "flaw",
    "total",
    "change",
    "score",
    "recorded",
    "draw",
    "pose",
    "point",
    "circle",
    "test",
    "seed",
    "teacher",
    "speed",
    "turn",
    "prev",
    "x",
    "y",
    "theta",
    "v",
    "w",
    "t",
];

/// Completion at `offset`: in a session script, the commands; in an operator file, the
/// keywords, functions, every operator, and inside an operator its parameters and its domain's
/// dimensions.
impl Analysis {
    /// Completion at `offset`: in a session script, the commands; in an operator file, the
    /// keywords, functions, every operator, and inside an operator its parameters and its
    /// domain's dimensions.
    pub fn completion(&self, offset: usize) -> Vec<Completion> {
        let text = self.text.as_str();
        let offset = floor(text, offset);
        if self.script {
            return self.script_completion(offset);
        }
        let mut out: Vec<Completion> = KEYWORDS
            .iter()
            .map(|k| Completion {
                label: k.to_string(),
                kind: CompletionKind::Keyword,
                detail: "keyword".into(),
            })
            .chain(Func::ALL.iter().map(|&f| Completion {
                label: f.name().to_string(),
                kind: CompletionKind::Function,
                detail: format!("{}({})", f.name(), func_args(f)),
            }))
            .collect();
        let set = &self.set;
        // A line being typed need not parse: the operator around it still counts.
        let typing;
        let file = match self.file() {
            Some(f) => Some(f),
            None => {
                typing = parsed(&without_line(text, offset));
                typing.as_ref()
            }
        };
        let here = file.and_then(|f| enclosing(f, offset));
        // Inside a step's parentheses (`slow_down(ra|`): the callee's parameters first. The
        // tree has the step when the text parses; a call being typed is found in the line.
        let callee = here
            .and_then(|op| step_args_at(op, offset))
            .or_else(|| open_call(text, offset));
        if let Some(callee) = callee {
            let domains: Vec<&str> = here
                .map(|d| d.domain.name.as_str())
                .into_iter()
                .chain(set.domains().iter().map(|d| d.name.as_str()))
                .collect();
            if let Some(op) = domains.iter().find_map(|d| set.operator(d, callee)) {
                for p in op.params() {
                    out.insert(
                        0,
                        Completion {
                            label: p.name.clone(),
                            kind: CompletionKind::Parameter,
                            detail: format!("parameter {p} of {}", op.name()),
                        },
                    );
                }
            }
        }
        if let Some(decl) = here {
            for p in &decl.params {
                out.push(Completion {
                    label: p.name.name.clone(),
                    kind: CompletionKind::Parameter,
                    detail: format!("parameter {p}"),
                });
            }
            if let Some(domain) = set.domain(&decl.domain.name) {
                for space in [Space::Observation, Space::Action] {
                    for d in domain.dims(space) {
                        out.push(Completion {
                            label: d.name.clone(),
                            kind: CompletionKind::Dimension,
                            detail: format!("{} {}", domain.name, d.unit).trim().to_string(),
                        });
                    }
                }
            }
        }
        for domain in set.domains() {
            if here.is_some_and(|d| d.domain.name != domain.name) {
                continue;
            }
            for op in set.operators(&domain.name) {
                out.push(Completion {
                    label: op.name().to_string(),
                    kind: CompletionKind::Operator,
                    detail: format!("{} ({})", op.signature(), domain.name),
                });
            }
        }
        out.dedup_by(|a, b| a.label == b.label && a.kind == b.kind);
        out
    }

    /// Completion in a session script: after `advise`, `preview` or `help`, the operators of the
    /// task (the last `task NAME` above, `positioning` before any), the script's own among them;
    /// the commands otherwise (and after `help`).
    fn script_completion(&self, offset: usize) -> Vec<Completion> {
        let text = self.text.as_str();
        let line_start = self
            .lines
            .line_span(self.lines.line(offset))
            .map_or(0, |l| l.start);
        let before = text[line_start..offset].trim_start();
        let first = before.split_whitespace().next().unwrap_or("");
        let commands = COMMANDS.iter().map(|c| Completion {
            label: c.name.to_string(),
            kind: CompletionKind::Command,
            detail: c.signature.to_string(),
        });
        let takes_operator =
            matches!(first, "advise" | "preview" | "help") && before.len() > first.len();
        if !takes_operator {
            return commands.collect();
        }
        let domain = text[..line_start]
            .lines()
            .rev()
            .find_map(|l| l.trim().strip_prefix("task "))
            .map_or("positioning", str::trim);
        // The script's definitions that check, on top of the standard operators.
        let mut out: Vec<Completion> = self
            .set
            .operators(domain)
            .map(|op| Completion {
                label: op.name().to_string(),
                kind: CompletionKind::Operator,
                detail: format!("{} ({domain})", op.signature()),
            })
            .collect();
        if first == "help" {
            out.extend(commands);
        }
        out
    }
}

/// The step of `op`'s composition whose parentheses hold `offset`: its callee's name.
fn step_args_at(op: &OperatorDecl, offset: usize) -> Option<&str> {
    let Body::Pipeline(calls) = &op.body else {
        return None;
    };
    calls
        .iter()
        .find(|c| c.name.span.end < offset && offset < c.span.end)
        .map(|c| c.name.name.as_str())
}

/// The name before the innermost `(` still open at `offset` on its line, if any.
fn open_call(text: &str, offset: usize) -> Option<&str> {
    let offset = floor(text, offset);
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let mut depth = 0i32;
    for (i, c) in text[line_start..offset].char_indices().rev() {
        match c {
            ')' => depth += 1,
            '(' if depth > 0 => depth -= 1,
            '(' => {
                let before = &text[line_start..line_start + i];
                let name_start = before
                    .char_indices()
                    .rev()
                    .take_while(|(_, c)| c.is_ascii_alphanumeric() || *c == '_')
                    .last()
                    .map_or(before.len(), |(j, _)| j);
                let name = &before[name_start..];
                return (!name.is_empty()).then_some(name);
            }
            _ => {}
        }
    }
    None
}

/// `text` with the line holding `offset` blanked: a half-typed line should not hide the
/// operator around it.
fn without_line(text: &str, offset: usize) -> String {
    let offset = floor(text, offset);
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let mut s = text[..start].to_string();
    // As many spaces as the line has bytes, so every span after it keeps its offset.
    s.push_str(&" ".repeat(end - start));
    s.push_str(&text[end..]);
    s
}

/// Where a name is defined.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// In the document itself.
    Here(Range<usize>),
    /// In a standard library file (`check::STANDARD_SOURCES`' name and its text's range).
    Standard {
        file: &'static str,
        range: Range<usize>,
    },
}

impl Analysis {
    /// Go to definition: the operator, domain or dimension named at `offset`, in the document or
    /// the standard library (inside an operator, of its domain: `speed_up` in an interception
    /// operator is interception's); a parameter to its declaration, a named argument to the
    /// callee's parameter.
    pub fn definition(&self, offset: usize) -> Option<Target> {
        let here = |s: Span| Some(Target::Here(s.start..s.end));
        let (word, domain): (&str, Option<&str>) = match self.node(offset) {
            None if self.file().is_none() => (word_at(&self.text, offset)?.0, None),
            None | Some(Node::Func(_)) => return None,
            Some(Node::ParamName(_, p)) => return here(p.name.span),
            Some(Node::DomainName(d)) => return here(d.name.span),
            Some(Node::DimName(_, x)) => return here(x.name.span),
            Some(Node::InOperator(op, name, _)) => {
                if let Some(p) = op.params.iter().find(|p| p.name.name == name) {
                    return here(p.name.span);
                }
                (name, Some(&op.domain.name))
            }
            Some(Node::OperatorName(op)) => (&op.name.name, Some(&op.domain.name)),
            Some(Node::DomainRef(op)) => (&op.domain.name, Some(&op.domain.name)),
            Some(Node::Step(op, call)) => (&call.name.name, Some(&op.domain.name)),
            Some(Node::InDomain(d, name, _)) => (name, Some(&d.name.name)),
            Some(Node::NamedArg(op, call, name)) => {
                let domain = Some(op.domain.name.as_str());
                return self.locate(|items| {
                    let callee = operator_decl(items, &call.name.name, domain)?;
                    let p = callee.params.iter().find(|p| p.name.name == name.name)?;
                    Some(p.name.span.start..p.name.span.end)
                });
            }
        };
        self.locate(|items| declared(items, word, domain))
    }

    /// The first range `find` gives in the document, then in the standard files.
    fn locate(&self, find: impl Fn(&[Item]) -> Option<Range<usize>>) -> Option<Target> {
        if let Some(range) = self.file().and_then(|f| find(&f.items)) {
            return Some(Target::Here(range));
        }
        standard_files().iter().find_map(|(file, parsed)| {
            find(&parsed.items).map(|range| Target::Standard { file, range })
        })
    }

    /// The document's symbols (none when it does not parse).
    pub fn symbols(&self) -> Vec<Symbol> {
        self.file().map_or_else(Vec::new, file_symbols)
    }
}

/// The declaration of operator `name` (of `domain`, when one is in scope) among `items`.
fn operator_decl<'a>(
    items: &'a [Item],
    name: &str,
    domain: Option<&str>,
) -> Option<&'a OperatorDecl> {
    items.iter().find_map(|item| match item {
        Item::Operator(o) if o.name.name == name && domain.is_none_or(|d| d == o.domain.name) => {
            Some(o)
        }
        _ => None,
    })
}

/// Where `items` declare `word`: an operator (of `domain`, when one is in scope), a domain, or a
/// dimension of `domain`.
fn declared(items: &[Item], word: &str, domain: Option<&str>) -> Option<Range<usize>> {
    items.iter().find_map(|item| match item {
        Item::Operator(o) if o.name.name == word && domain.is_none_or(|d| d == o.domain.name) => {
            Some(o.name.span.start..o.name.span.end)
        }
        Item::Domain(d) if d.name.name == word => Some(d.name.span.start..d.name.span.end),
        Item::Domain(d) if domain == Some(d.name.name.as_str()) => d
            .dims
            .iter()
            .find(|x| x.name.name == word)
            .map(|x| x.name.span.start..x.name.span.end),
        _ => None,
    })
}

/// A document symbol: a domain with its dimensions, an operator with its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Symbol {
    pub name: String,
    pub detail: String,
    pub kind: SymbolKind,
    pub range: Range<usize>,
    pub selection: Range<usize>,
    pub children: Vec<Symbol>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SymbolKind {
    Domain,
    Dimension,
    Operator,
    Parameter,
}

/// The symbols of a parsed document.
fn file_symbols(file: &File) -> Vec<Symbol> {
    file.items
        .iter()
        .map(|item| match item {
            Item::Domain(d) => Symbol {
                name: d.name.name.clone(),
                detail: "domain".into(),
                kind: SymbolKind::Domain,
                range: d.span.start..d.span.end,
                selection: d.name.span.start..d.name.span.end,
                children: d
                    .dims
                    .iter()
                    .map(|x| Symbol {
                        name: x.name.name.clone(),
                        detail: x.to_string(),
                        kind: SymbolKind::Dimension,
                        range: x.span.start..x.span.end,
                        selection: x.name.span.start..x.name.span.end,
                        children: Vec::new(),
                    })
                    .collect(),
            },
            Item::Operator(o) => Symbol {
                name: o.name.name.clone(),
                detail: format!("for {} on {}", o.domain.name, o.space),
                kind: SymbolKind::Operator,
                range: o.span.start..o.span.end,
                selection: o.name.span.start..o.name.span.end,
                children: o
                    .params
                    .iter()
                    .map(|p| Symbol {
                        name: p.name.name.clone(),
                        detail: p.to_string(),
                        kind: SymbolKind::Parameter,
                        range: p.span.start..p.span.end,
                        selection: p.name.span.start..p.name.span.end,
                        children: Vec::new(),
                    })
                    .collect(),
            },
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "// café: a comment with non-ASCII text\n\
        /// Creep along.\n\
        operator creep(f = 0.5 in [0, 1]) for positioning on action where trans != 0 {\n  trans *= f\n  rott = 0\n}\n\
        operator twice for positioning on action = creep then speed_up\n";

    #[test]
    fn diagnostics_are_the_checkers_with_codes_ranges_and_help() {
        let d = diagnostics("doc.adv", DOC);
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(
            d[0].code.as_deref(),
            Some("advise::check::unknown_dimension")
        );
        assert_eq!(&DOC[d[0].range.clone()], "rott");
        assert!(
            d[0].message.contains("did you mean `rot`"),
            "{}",
            d[0].message
        );
        assert!(!d[0].warning);
        let parse = diagnostics(
            "p.adv",
            "operator x for positioning on action { trans = }\n",
        );
        assert_eq!(parse[0].code.as_deref(), Some("advise::parse::syntax"));
        assert!(
            diagnostics(
                "ok.adv",
                "operator halt for positioning on action { trans = 0 }\n"
            )
            .is_empty()
        );
    }

    #[test]
    fn is_script_answers_as_fmt_does() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/sessions");
        let mut texts: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| std::fs::read_to_string(e.ok()?.path()).ok())
            .collect();
        assert!(!texts.is_empty());
        texts.extend(check::STANDARD_SOURCES.iter().map(|(_, t)| t.to_string()));
        texts.push(DOC.into());
        for c in COMMANDS {
            texts.push(format!("{DOC}{}\n", c.example));
        }
        for t in &texts {
            assert_eq!(is_script(t), advise_lang::syntax::fmt::is_script(t), "{t}");
        }
        // The example sessions and the standard files are clean.
        for t in &texts[..texts.len() - 1 - COMMANDS.len()] {
            assert_eq!(diagnostics("t.adv", t), Vec::new(), "{t}");
        }
        assert!(!is_script(DOC));
        assert!(is_script(&format!("{DOC}run goal 1 2 3\n")));
    }

    #[test]
    fn a_session_script_gets_its_bad_lines() {
        let d = diagnostics(
            "s.adv",
            "task positioning\nload demos teacher:3\nrunn goal 1 2 3\n",
        );
        assert_eq!(d.len(), 1, "{d:?}");
        assert!(d[0].range.start >= "task positioning\nload demos teacher:3\n".len());
        // An operator defined over several lines among the commands is one statement.
        let script = "/// Creep.\noperator creep for positioning on action {\n  trans = 0.1\n}\nrun goal 2 -1 0\nselec 0..3\n";
        let d = diagnostics("s.adv", script);
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(&script[d[0].range.clone()], "selec");
        // A definition is checked on top of the standard operators and the ones before it.
        let script = "operator creep for positioning on action {\n  trans = 0.1\n}\noperator crawl for positioning on action = creep then slow_down\noperator bad for positioning on action {\n  rott = 0\n}\nrun goal 2 -1 0\n";
        let d = diagnostics("s.adv", script);
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(&script[d[0].range.clone()], "rott");
        assert_eq!(
            d[0].code.as_deref(),
            Some("advise::check::unknown_dimension")
        );
        assert!(
            completion("task positioning\n", 17)
                .iter()
                .any(|c| c.label == "advise")
        );
        // After `advise`: the task's operators, the script's own among them.
        let script = "task interception\noperator lunge for interception on action {\n  trans_delta = 0.1\n}\nrun start 0\nadvise \n";
        let c = completion(script, script.len() - 1);
        let ops: Vec<&str> = c.iter().map(|c| c.label.as_str()).collect();
        assert!(ops.contains(&"lunge") && ops.contains(&"brake"), "{ops:?}");
        assert!(
            !ops.contains(&"no_turning") && !ops.contains(&"advise"),
            "{ops:?}"
        );
    }

    #[test]
    fn hover_names_operators_parameters_and_dimensions() {
        let at = |s: &str| DOC.find(s).unwrap() + 1;
        let (_, h) = hover(DOC, at("speed_up")).unwrap();
        assert!(
            h.starts_with("```advise\nspeed_up(rate = 0.2 in [0, 4])  (on action)\n```\nan operator for `positioning`\n\n"),
            "{h}"
        );
        assert!(h.contains("Move faster"), "{h}");
        let (_, h) = hover(DOC, at("f\n")).unwrap();
        assert_eq!(h, "parameter `f = 0.5 in [0, 1]`");
        let (r, h) = hover(DOC, at("trans *=")).unwrap();
        assert_eq!(&DOC[r], "trans");
        assert!(
            h.contains("action dimension `trans` of `positioning`, in m/s, limits [-1, 1]"),
            "{h}"
        );
    }

    #[test]
    fn completion_offers_the_operators_parameters_and_dimensions_in_scope() {
        let at = DOC.find("trans *=").unwrap();
        let c = completion(DOC, at);
        let has = |l: &str, k| c.iter().any(|x| x.label == l && x.kind == k);
        assert!(has("f", CompletionKind::Parameter));
        assert!(has("dist2", CompletionKind::Dimension));
        assert!(has("no_turning", CompletionKind::Operator));
        assert!(has("where", CompletionKind::Keyword));
        assert!(has("clamp", CompletionKind::Function));
        assert!(
            !has("hold_speed", CompletionKind::Operator),
            "interception's are out of scope"
        );
        // A half-typed line inside an operator still knows the operator.
        let typing = DOC.replace("  rott = 0\n", "  tra\n");
        let c = completion(&typing, typing.find("tra\n").unwrap() + 3);
        assert!(
            c.iter()
                .any(|x| x.label == "trans" && x.kind == CompletionKind::Dimension)
        );
    }

    #[test]
    fn completion_on_a_half_typed_line_with_non_ascii_text_keeps_the_operator() {
        // The blanked line must keep its byte length, or the operator's span would end before
        // the cursor.
        let typing = DOC.replace(
            "  rott = 0\n",
            &format!("  tra // {}\n", "\u{1F600}".repeat(8)),
        );
        let at = typing.find("\u{1F600}\n").unwrap() + 4;
        let c = completion(&typing, at);
        assert!(
            c.iter()
                .any(|x| x.label == "trans" && x.kind == CompletionKind::Dimension),
            "{c:?}"
        );
    }

    #[test]
    fn hover_on_a_named_argument_is_the_callees_parameter() {
        let text =
            "operator gentle for positioning on action = slow_down(rate = 0.3) then speed_up\n";
        let at = text.find("rate").unwrap() + 1;
        let (r, h) = hover(text, at).unwrap();
        assert_eq!(&text[r], "rate");
        assert!(h.starts_with("parameter `rate = "), "{h}");
        assert!(h.ends_with("of `slow_down`"), "{h}");
    }

    #[test]
    fn definitions_in_the_document_and_the_standard_library() {
        let at = DOC.rfind("creep").unwrap() + 1;
        assert_eq!(
            definition(DOC, at),
            Some(Target::Here(
                DOC.find("creep").unwrap()..DOC.find("creep").unwrap() + 5
            ))
        );
        let at = DOC.find("speed_up").unwrap() + 2;
        match definition(DOC, at) {
            Some(Target::Standard { file, range }) => {
                assert_eq!(file, "operators/positioning.adv");
                let text = check::STANDARD_SOURCES[0].1;
                assert_eq!(&text[range], "speed_up");
            }
            other => panic!("{other:?}"),
        }
        // A dimension: its declaration in the standard domain.
        let at = DOC.find("trans *=").unwrap() + 1;
        match definition(DOC, at) {
            Some(Target::Standard { file, range }) => {
                assert_eq!(file, "operators/positioning.adv");
                assert_eq!(&check::STANDARD_SOURCES[0].1[range], "trans");
            }
            other => panic!("{other:?}"),
        }
        // Inside an interception operator, `speed_up` is interception's.
        let text = "operator quick for interception on action = speed_up then brake\n";
        match definition(text, text.find("speed_up").unwrap()) {
            Some(Target::Standard { file, range }) => {
                assert_eq!(file, "operators/interception.adv");
                assert_eq!(&check::STANDARD_SOURCES[1].1[range], "speed_up");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn symbols_nest_parameters_and_dimensions() {
        let s = symbols(DOC);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].name, "creep");
        assert_eq!(s[0].children[0].name, "f");
        let d = symbols("domain rover {\n  observe range_m \"m\"\n  act v \"m/s\"\n}\n");
        assert_eq!(d[0].kind, SymbolKind::Domain);
        assert_eq!(d[0].children.len(), 2);
    }

    proptest::proptest! {
        #[test]
        fn nothing_panics_on_any_text_or_offset(
            text in "(operator |domain |for |on |action |where |then |[a-z_]{1,6}|[(){}=,.*+<>!-]| |\n|[0-9.]{1,3}|é|\u{1F600}|/// |// )*",
            offset in 0usize..400,
        ) {
            let _ = hover(&text, offset);
            let _ = completion(&text, offset);
            let _ = definition(&text, offset);
            let _ = diagnostics("p.adv", &text);
            let _ = symbols(&text);
        }
    }

    #[test]
    fn nothing_panics_on_any_offset() {
        for text in [DOC, "", "operator", "é\u{1F600}", "task positioning\n"] {
            for offset in 0..=text.len() + 2 {
                let offset = offset.min(text.len());
                if !text.is_char_boundary(offset) {
                    continue;
                }
                let _ = hover(text, offset);
                let _ = completion(text, offset);
                let _ = definition(text, offset);
            }
            let _ = diagnostics("t.adv", text);
            let _ = symbols(text);
        }
    }
}
