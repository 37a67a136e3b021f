//! AST to checked [`OperatorSet`]: names, dimensions, parameters, types, ranges.
//!
//! The checker reads every file it is given, reports every mistake of every file at once (each a
//! [`CheckError`] with a stable code, a label and a hint), and only when there are none builds an
//! [`OperatorSet`] whose operators are already compiled for the interpreter. A checked type cannot
//! hold an unchecked program: [`Operator`] has no public constructor. The standard library in
//! `operators/*.adv` goes through this same path ([`OperatorSet::standard`]); a user's file is
//! checked on top of it ([`OperatorSet::merge`]) so it may use the standard domains and compose the
//! standard operators. This module does no IO and applies nothing.

pub mod error;
pub mod ir;
mod trace_domain;

use std::collections::{HashMap, HashSet};
use std::ops::Deref;
use std::sync::OnceLock;

use miette::NamedSource;

use crate::domain::{Dim, Domain, Limits, Space};
use crate::interp::Program;
use crate::syntax::{self, SourceText, ast::*};
pub use error::{CheckError, CheckErrors, CheckWarning, FileError};
use ir::{BlockIr, Func, Ir};
pub use trace_domain::TraceDomainError;

/// A named source text: a file, a REPL line, an embedded standard file.
#[derive(Clone, Debug)]
pub struct Source {
    pub name: String,
    pub text: String,
}

impl Source {
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Source {
        Source {
            name: name.into(),
            text: text.into(),
        }
    }
}

/// The standard operator library, embedded so the binary works from any directory.
pub const STANDARD_SOURCES: [(&str, &str); 2] = [
    (
        "operators/positioning.adv",
        include_str!("../operators/positioning.adv"),
    ),
    (
        "operators/interception.adv",
        include_str!("../operators/interception.adv"),
    ),
];

/// How many per-point stages a composition may expand to (each stage runs over the whole chunk,
/// so this bounds an application's work; a composition that composes the one before it four times
/// reaches 4^k).
pub const MAX_STAGES: usize = 1024;

/// How many expression nodes an operator's body may hold: each becomes an instruction whose
/// register holds a batch of points, so this bounds an application's memory (a few MB).
pub const MAX_NODES: usize = 4096;

/// How many parameters an operator may declare (every composition stage binds them all).
pub const MAX_PARAMS: usize = 64;

/// How many errors one check reports before it stops looking: each costs work in proportion to
/// the text (hints compare names), so an input of many mistakes would otherwise cost its square.
pub const MAX_ERRORS: usize = 100;

/// A parameter of a checked operator.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: String,
    /// `None` when every invocation must give a value.
    pub default: Option<f64>,
    /// Allowed values, when declared.
    pub limits: Option<Limits>,
}

impl std::fmt::Display for Param {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name)?;
        if let Some(d) = self.default {
            write!(f, " = {}", syntax::print::number(d))?;
        }
        if let Some(l) = self.limits {
            write!(
                f,
                " in [{}, {}]",
                syntax::print::number(l.lo),
                syntax::print::number(l.hi)
            )?;
        }
        Ok(())
    }
}

/// A checked, compiled operator.
#[derive(Clone, Debug)]
pub struct Operator {
    name: String,
    domain: String,
    space: Space,
    doc: String,
    params: Vec<Param>,
    definition: String,
    /// Where it was defined: `operators/positioning.adv at line 12`.
    origin: String,
    /// Whether it comes from the standard library (`operators/*.adv`).
    standard: bool,
    /// The per-point stages it expands to (1 for a block), at most [`MAX_STAGES`].
    stages: u64,
    pub(crate) body: OpBody,
}

/// What applying an operator runs.
#[derive(Clone, Debug)]
pub(crate) enum OpBody {
    /// A per-point program.
    Block(Program),
    /// Operators applied in sequence on the same chunk.
    Pipeline(Vec<Stage>),
}

/// One step of a composition: the callee (an index into the set) and, per callee parameter, the
/// bound argument (an expression over the caller's parameters and `n`) or `None` for its default.
#[derive(Clone, Debug)]
pub(crate) struct Stage {
    pub op: usize,
    pub args: Vec<Option<Ir>>,
}

impl Operator {
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Name of the domain it belongs to.
    pub fn domain(&self) -> &str {
        &self.domain
    }

    /// The space it modifies.
    pub fn space(&self) -> Space {
        self.space
    }

    /// The doc comment, lines joined with `\n`.
    pub fn doc(&self) -> &str {
        &self.doc
    }

    /// The first line of the doc comment (for completion menus and tables).
    pub fn summary(&self) -> &str {
        self.doc.lines().next().unwrap_or("")
    }

    pub fn params(&self) -> &[Param] {
        &self.params
    }

    /// The definition in canonical form, without its doc comment (kept with provenance).
    pub fn definition(&self) -> &str {
        &self.definition
    }

    /// `speed_up(rate = 0.2 in [0, 1])`
    pub fn signature(&self) -> String {
        if self.params.is_empty() {
            return self.name.clone();
        }
        let ps: Vec<String> = self.params.iter().map(|p| p.to_string()).collect();
        format!("{}({})", self.name, ps.join(", "))
    }

    /// Invocations quoted on the doc comment's `Example:` lines, e.g. `speed_up(0.5)`.
    pub fn examples(&self) -> Vec<String> {
        self.doc
            .lines()
            .filter_map(|l| l.trim().strip_prefix("Example:"))
            .filter_map(|rest| rest.split('`').nth(1).map(str::to_string))
            .collect()
    }

    /// Where it was defined, e.g. `operators/positioning.adv at line 12`.
    pub fn origin(&self) -> &str {
        &self.origin
    }

    /// How many per-point stages applying it runs (1 unless it is a composition).
    pub fn stage_count(&self) -> u64 {
        self.stages
    }

    /// Whether this operator is a composition of others.
    pub fn is_composition(&self) -> bool {
        matches!(self.body, OpBody::Pipeline(_))
    }
}

/// Checked domains and operators, ready to apply.
#[derive(Clone, Debug, Default)]
pub struct OperatorSet {
    domains: Vec<Domain>,
    /// In definition order; a later operator with the same domain and name shadows an earlier one
    /// (a user's file over the standard library) while compositions keep what they were built on.
    ops: Vec<Operator>,
    /// `(domain, name)` to the index of the visible operator of that name.
    visible: HashMap<(String, String), usize>,
}

/// A checked set with what the check found worth saying but not refusing.
#[derive(Clone, Debug)]
pub struct Checked {
    pub set: OperatorSet,
    pub warnings: Vec<CheckWarning>,
}

impl OperatorSet {
    /// The standard library (`operators/*.adv`), checked once per process.
    pub fn standard() -> OperatorSet {
        static STANDARD: OnceLock<OperatorSet> = OnceLock::new();
        STANDARD
            .get_or_init(|| {
                let sources: Vec<Source> = STANDARD_SOURCES
                    .iter()
                    .map(|(n, t)| Source::new(*n, *t))
                    .collect();
                match check(&sources) {
                    Ok(set) => set,
                    // A test checks the embedded library; reaching this is a build defect.
                    Err(e) => panic!("the standard operators do not check:\n{}", render_all(&e)),
                }
            })
            .clone()
    }

    /// Check `sources` on top of this set: they may use its domains and operators, and their
    /// operators shadow same-named ones of this set.
    pub fn merge(&self, sources: &[Source]) -> Result<OperatorSet, CheckErrors> {
        check_with(Some(self), sources)
    }

    /// [`OperatorSet::merge`], with the warnings (a standard operator shadowed, say).
    pub fn merge_with_warnings(&self, sources: &[Source]) -> Result<Checked, CheckErrors> {
        check_with_warnings(Some(self), sources)
    }

    fn reindex(&mut self) {
        self.visible.clear();
        for (i, o) in self.ops.iter().enumerate() {
            self.visible.insert((o.domain.clone(), o.name.clone()), i);
        }
    }

    fn is_visible(&self, i: usize) -> bool {
        let o = &self.ops[i];
        self.find(&o.domain, &o.name) == Some(i)
    }

    pub fn domains(&self) -> &[Domain] {
        &self.domains
    }

    pub fn domain(&self, name: &str) -> Option<&Domain> {
        self.domains.iter().find(|d| d.name == name)
    }

    /// Index of the visible operator `name` of `domain`.
    pub(crate) fn find(&self, domain: &str, name: &str) -> Option<usize> {
        self.visible
            .get(&(domain.to_string(), name.to_string()))
            .copied()
    }

    pub(crate) fn op(&self, index: usize) -> &Operator {
        &self.ops[index]
    }

    /// The operator `name` of `domain`.
    pub fn operator(&self, domain: &str, name: &str) -> Option<&Operator> {
        self.find(domain, name).map(|i| &self.ops[i])
    }

    /// The visible operators of `domain`, in definition order.
    pub fn operators<'s>(&'s self, domain: &'s str) -> impl Iterator<Item = &'s Operator> + 's {
        self.ops
            .iter()
            .enumerate()
            .filter(move |(i, o)| o.domain == domain && self.is_visible(*i))
            .map(|(_, o)| o)
    }

    /// Names of the visible operators of `domain` (what a REPL completes).
    pub fn operator_names(&self, domain: &str) -> Vec<&str> {
        self.ops
            .iter()
            .enumerate()
            .filter(|(i, o)| o.domain == domain && self.is_visible(*i))
            .map(|(_, o)| o.name.as_str())
            .collect()
    }

    /// Number of visible operators over all domains.
    pub fn operator_count(&self) -> usize {
        self.visible.len()
    }

    /// Domains other than `domain` that define an operator called `name`.
    pub(crate) fn domains_with(&self, name: &str) -> Vec<&str> {
        let mut v: Vec<&str> = self
            .ops
            .iter()
            .filter(|o| o.name == name)
            .map(|o| o.domain.as_str())
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }
}

/// Parse and check `sources` on their own.
pub fn check(sources: &[Source]) -> Result<OperatorSet, CheckErrors> {
    check_with(None, sources)
}

/// Parse and check `sources` on top of `base` (see [`OperatorSet::merge`]).
pub fn check_with(
    base: Option<&OperatorSet>,
    sources: &[Source],
) -> Result<OperatorSet, CheckErrors> {
    check_with_warnings(base, sources).map(|c| c.set)
}

/// [`check_with`], keeping the warnings.
pub fn check_with_warnings(
    base: Option<&OperatorSet>,
    sources: &[Source],
) -> Result<Checked, CheckErrors> {
    let mut c = Checker {
        sources,
        texts: sources
            .iter()
            .map(|s| SourceText::from(s.text.as_str()))
            .collect(),
        newlines: sources
            .iter()
            .map(|s| s.text.match_indices('\n').map(|(i, _)| i).collect())
            .collect(),
        errors: Vec::new(),
        dropped: 0,
        warnings: Vec::new(),
    };
    let mut files = Vec::new();
    for (i, s) in sources.iter().enumerate() {
        match syntax::parse(&s.name, &s.text) {
            Ok(f) => files.push((i, f)),
            Err(e) => c.errors.push((i, 0, e.into())),
        }
    }
    let result = c.run(base, &files);
    let mut errors = c.errors;
    errors.sort_by_key(|(f, pos, _)| (*f, *pos));
    if errors.is_empty() {
        let mut warnings = c.warnings;
        warnings.sort_by_key(|(f, pos, _)| (*f, *pos));
        Ok(Checked {
            set: result,
            warnings: warnings.into_iter().map(|(_, _, w)| w).collect(),
        })
    } else {
        let mut errors: Vec<FileError> = errors.into_iter().map(|(_, _, e)| e).collect();
        if errors.len() >= MAX_ERRORS {
            errors.push(
                CheckError::TooManyErrors {
                    shown: errors.len(),
                }
                .into(),
            );
        }
        Err(CheckErrors { errors })
    }
}

/// Render every diagnostic without colour at a fixed width (for tests and logs).
pub fn render_all(errors: &CheckErrors) -> String {
    errors
        .errors
        .iter()
        .map(|e| render(e))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Render one diagnostic as the terminal shows it, without colour, 100 columns wide.
pub fn render(diag: &dyn miette::Diagnostic) -> String {
    crate::diagnostic::render(diag, false)
}

/// The best "did you mean" among `candidates`, if any is close.
pub(crate) fn suggest<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (strsim::jaro_winkler(name, c), c))
        .filter(|(score, _)| *score > 0.8)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// `did you mean `x`?` or a list of what exists.
pub(crate) fn hint(name: &str, what: &str, candidates: &[&str]) -> String {
    match suggest(name, candidates.iter().copied()) {
        Some(s) => format!("did you mean `{s}`?"),
        None if candidates.is_empty() => format!("there are no {what}"),
        None => format!("the {what} are: {}", listing(candidates)),
    }
}

/// Names for a help text: all of a few, or the first twenty and how many more.
fn listing(names: &[&str]) -> String {
    const SHOWN: usize = 20;
    let mut out = names
        .iter()
        .take(SHOWN)
        .map(|c| format!("`{c}`"))
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > SHOWN {
        out.push_str(&format!(" and {} more", names.len() - SHOWN));
    }
    out
}

const RESERVED: [(&str, &str); 3] = [
    ("k", "the index of the point in the chunk"),
    ("n", "the number of points in the chunk"),
    ("pi", "the constant 3.14159..."),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    Num,
    Bool,
    /// Already reported; compatible with everything so one mistake gives one diagnostic.
    Err,
}

impl Ty {
    fn word(self) -> &'static str {
        match self {
            Ty::Num => "a number",
            Ty::Bool => "a condition",
            Ty::Err => "an error",
        }
    }
}

/// What names mean where an expression is resolved.
#[derive(Clone, Copy)]
enum Scope<'a> {
    /// Limits and defaults: numbers, `pi` and arithmetic only.
    Const,
    /// An operator body: dimensions, parameters, `k`, `n`.
    Point {
        domain: &'a Dom<'a>,
        params: &'a [Param],
    },
    /// An argument in a composition: the caller's parameters and `n`.
    Arg {
        domain: &'a Dom<'a>,
        params: &'a [Param],
    },
}

/// A domain with its dimensions indexed by name, so that resolving a name does not scan them.
struct Dom<'d> {
    domain: &'d Domain,
    names: HashMap<&'d str, (Space, usize)>,
}

impl<'d> Dom<'d> {
    fn new(domain: &'d Domain) -> Dom<'d> {
        let mut names = HashMap::new();
        for space in [Space::Observation, Space::Action] {
            for (i, d) in domain.dims(space).iter().enumerate() {
                names.entry(d.name.as_str()).or_insert((space, i));
            }
        }
        Dom { domain, names }
    }

    /// The space and index of the dimension `name` (as [`Domain::find`], by hashing).
    fn find(&self, name: &str) -> Option<(Space, usize)> {
        self.names.get(name).copied()
    }
}

impl Deref for Dom<'_> {
    type Target = Domain;

    fn deref(&self) -> &Domain {
        self.domain
    }
}

/// The signature of an operator being checked, before its body is known to be good.
struct Sig<'f> {
    file: usize,
    decl: &'f OperatorDecl,
    domain: Option<usize>,
    params: Vec<Param>,
}

/// The operators a composition may call: those being checked and those of the base set.
struct Known<'k, 'f> {
    sigs: &'k [Sig<'f>],
    /// `(domain, name)` to the first signature of that name.
    first: &'k HashMap<(usize, &'f str), usize>,
    base: Option<&'k OperatorSet>,
    base_ops: usize,
}

/// What a composition needs to know about an operator it calls.
struct CalleeInfo<'x> {
    name: &'x str,
    space: Space,
    params: &'x [Param],
}

struct Checker<'s> {
    sources: &'s [Source],
    /// The texts, shared by every diagnostic instead of copied into each.
    texts: Vec<SourceText>,
    /// Byte offsets of each text's newlines, to turn offsets into lines without rescanning.
    newlines: Vec<Vec<usize>>,
    errors: Vec<(usize, usize, FileError)>,
    /// Errors found past [`MAX_ERRORS`], not reported.
    dropped: usize,
    warnings: Vec<(usize, usize, CheckWarning)>,
}

impl Checker<'_> {
    fn src(&self, file: usize) -> NamedSource<SourceText> {
        NamedSource::new(&self.sources[file].name, self.texts[file].clone())
    }

    fn err(&mut self, file: usize, span: Span, e: CheckError) {
        if self.full() {
            self.dropped += 1;
            return;
        }
        self.errors.push((file, span.start, e.into()));
    }

    /// 1-based line of a byte offset of file `file`.
    fn line(&self, file: usize, byte: usize) -> usize {
        self.newlines[file].partition_point(|&nl| nl < byte) + 1
    }

    fn error_count(&self) -> usize {
        self.errors.len() + self.dropped
    }

    /// Whether enough errors were found: the rest of the check skips work that only finds more.
    fn full(&self) -> bool {
        self.errors.len() >= MAX_ERRORS
    }

    fn run(&mut self, base: Option<&OperatorSet>, files: &[(usize, File)]) -> OperatorSet {
        let mut domains: Vec<Domain> = base.map(|b| b.domains.clone()).unwrap_or_default();
        let base_domains = domains.len();
        let mut by_name: HashMap<String, usize> = domains
            .iter()
            .enumerate()
            .map(|(i, d)| (d.name.clone(), i))
            .collect();
        let mut declared: HashMap<String, (usize, Span)> = HashMap::new();
        for (f, file) in files {
            for item in &file.items {
                if let Item::Domain(d) = item {
                    if self.full() {
                        continue;
                    }
                    let dom = self.domain(*f, d);
                    if let Some(&(ff, fs)) = declared.get(&dom.name) {
                        let first = format!(
                            "the first declaration is in {} at line {}",
                            self.sources[ff].name,
                            self.line(ff, fs.start)
                        );
                        self.err(
                            *f,
                            d.name.span,
                            CheckError::DuplicateDomain {
                                name: dom.name.clone(),
                                first,
                                src: self.src(*f),
                                span: d.name.span.into(),
                            },
                        );
                        continue;
                    }
                    declared.insert(dom.name.clone(), (*f, d.name.span));
                    if let Some(&existing) = by_name.get(&dom.name).filter(|&&i| i < base_domains) {
                        if let Some(difference) = domain_difference(&domains[existing], &dom) {
                            self.err(
                                *f,
                                d.name.span,
                                CheckError::ConflictingDomain {
                                    name: dom.name.clone(),
                                    difference,
                                    src: self.src(*f),
                                    span: d.name.span.into(),
                                },
                            );
                        }
                        continue;
                    }
                    by_name.insert(dom.name.clone(), domains.len());
                    domains.push(dom);
                }
            }
        }

        let base_ops = base.map_or(0, |b| b.ops.len());
        let (sigs, bodies) = {
            let doms: Vec<Dom<'_>> = domains.iter().map(Dom::new).collect();
            // Signatures first, so compositions may name operators defined later in any file.
            let mut sigs: Vec<Sig<'_>> = Vec::new();
            // `(domain, name)` to the first signature of that name.
            let mut first: HashMap<(usize, &str), usize> = HashMap::new();
            for (f, file) in files {
                for item in &file.items {
                    if let Item::Operator(o) = item {
                        let sig = self.signature(*f, o, &by_name, &doms);
                        if let Some(d) = sig.domain {
                            match first.get(&(d, o.name.name.as_str())) {
                                Some(&j) => {
                                    let first = &sigs[j];
                                    let msg = format!(
                                        "the first definition is in {} at line {}",
                                        self.sources[first.file].name,
                                        self.line(first.file, first.decl.name.span.start)
                                    );
                                    self.err(
                                        *f,
                                        o.name.span,
                                        CheckError::DuplicateOperator {
                                            name: o.name.name.clone(),
                                            domain: domains[d].name.clone(),
                                            first: msg,
                                            src: self.src(*f),
                                            span: o.name.span.into(),
                                        },
                                    );
                                }
                                None => {
                                    first.insert((d, o.name.name.as_str()), sigs.len());
                                }
                            }
                        }
                        sigs.push(sig);
                    }
                }
            }
            let known = Known {
                sigs: &sigs,
                first: &first,
                base,
                base_ops,
            };
            let mut bodies: Vec<Option<Body2>> = Vec::with_capacity(sigs.len());
            for (i, sig) in sigs.iter().enumerate() {
                let body = match sig.domain {
                    Some(d) if !self.full() => self.body(&known, i, &doms[d]),
                    _ => None,
                };
                bodies.push(body);
            }
            (sigs, bodies)
        };
        self.cycles(&sigs, &bodies, base_ops);
        let stages = if self.errors.is_empty() {
            self.expansions(&sigs, &bodies, base)
        } else {
            Vec::new()
        };

        let mut set = OperatorSet {
            domains,
            ops: base.map(|b| b.ops.clone()).unwrap_or_default(),
            visible: HashMap::new(),
        };
        if !self.errors.is_empty() {
            return set;
        }
        for ((sig, body), stages) in sigs.iter().zip(bodies).zip(stages) {
            let (Some(d), Some(body)) = (sig.domain, body) else {
                continue;
            };
            let domain = &set.domains[d];
            let body = match body {
                Body2::Block(b) => OpBody::Block(Program::compile(&b, domain)),
                Body2::Pipeline(stages) => OpBody::Pipeline(stages),
            };
            let mut def = sig.decl.clone();
            def.doc.clear();
            let definition = def.to_string();
            if let Some(shadowed) = base.and_then(|b| b.operator(&domain.name, &sig.decl.name.name))
                && shadowed.standard
                // The standard file itself, checked again, shadows nothing new.
                && shadowed.definition != definition
            {
                let span = sig.decl.name.span;
                self.warnings.push((
                    sig.file,
                    span.start,
                    CheckWarning::ShadowsStandard {
                        name: sig.decl.name.name.clone(),
                        domain: domain.name.clone(),
                        origin: shadowed.origin.clone(),
                        src: self.src(sig.file),
                        span: span.into(),
                    },
                ));
            }
            let source = &self.sources[sig.file];
            set.ops.push(Operator {
                name: sig.decl.name.name.clone(),
                domain: domain.name.clone(),
                space: sig.decl.space,
                doc: sig.decl.doc.join("\n"),
                params: sig.params.clone(),
                definition,
                origin: format!(
                    "{} at line {}",
                    source.name,
                    self.line(sig.file, sig.decl.name.span.start)
                ),
                standard: STANDARD_SOURCES.iter().any(|(n, _)| *n == source.name),
                stages,
                body,
            });
        }
        set.reindex();
        set
    }

    /// How many per-point stages each operator of `sigs` expands to; reports those past
    /// [`MAX_STAGES`] whose callees are all within it (the rest only inherit the excess). Needs
    /// bodies without cycles. Iterative: a chain of compositions may be as long as the file.
    fn expansions(
        &mut self,
        sigs: &[Sig<'_>],
        bodies: &[Option<Body2>],
        base: Option<&OperatorSet>,
    ) -> Vec<u64> {
        let base_ops = base.map_or(0, |b| b.ops.len());
        let mut count: Vec<Option<u64>> = vec![None; sigs.len()];
        let known = |count: &[Option<u64>], op: usize| {
            if op < base_ops {
                base.map(|b| b.ops[op].stages)
            } else {
                count[op - base_ops]
            }
        };
        for start in 0..sigs.len() {
            let mut stack = vec![start];
            while let Some(&i) = stack.last() {
                if count[i].is_some() {
                    stack.pop();
                    continue;
                }
                let pending: Vec<usize> = stages_of(&bodies[i])
                    .iter()
                    .filter(|st| known(&count, st.op).is_none())
                    .map(|st| st.op - base_ops)
                    .collect();
                if pending.is_empty() {
                    let n = match &bodies[i] {
                        Some(Body2::Pipeline(st)) => st
                            .iter()
                            .map(|st| known(&count, st.op).unwrap_or(1))
                            .fold(0u64, u64::saturating_add),
                        _ => 1,
                    };
                    count[i] = Some(n);
                    stack.pop();
                } else {
                    stack.extend(pending);
                }
            }
        }
        let count: Vec<u64> = count.into_iter().map(|c| c.unwrap_or(1)).collect();
        let name_of = |op: usize| -> &str {
            if op < base_ops {
                base.map_or("", |b| b.ops[op].name.as_str())
            } else {
                &sigs[op - base_ops].decl.name.name
            }
        };
        let stages_at = |op: usize| {
            if op < base_ops {
                base.map_or(1, |b| b.ops[op].stages)
            } else {
                count[op - base_ops]
            }
        };
        let limit = MAX_STAGES as u64;
        for (i, sig) in sigs.iter().enumerate() {
            let own = stages_of(&bodies[i]);
            if count[i] <= limit || own.iter().any(|st| stages_at(st.op) > limit) {
                continue;
            }
            // The chain that grows: from this operator down through its largest callee.
            let mut chain = vec![format!(
                "`{}` ({})",
                sig.decl.name.name,
                count_text(count[i])
            )];
            let mut at = own.iter().max_by_key(|st| stages_at(st.op)).map(|st| st.op);
            while let Some(op) = at {
                if chain.len() == 8 {
                    chain.push("...".into());
                    break;
                }
                chain.push(format!("`{}` ({})", name_of(op), count_text(stages_at(op))));
                at = if op < base_ops {
                    None
                } else {
                    stages_of(&bodies[op - base_ops])
                        .iter()
                        .max_by_key(|st| stages_at(st.op))
                        .map(|st| st.op)
                };
            }
            let f = sig.file;
            self.err(
                f,
                sig.decl.name.span,
                CheckError::CompositionTooLarge {
                    name: sig.decl.name.name.clone(),
                    stages: count_text(count[i]),
                    limit: MAX_STAGES,
                    chain: format!("stages per operator: {}", chain.join(" -> ")),
                    src: self.src(f),
                    span: sig.decl.name.span.into(),
                },
            );
        }
        count
    }

    fn domain(&mut self, f: usize, d: &DomainDecl) -> Domain {
        let mut dom = Domain {
            name: d.name.name.clone(),
            observe: Vec::new(),
            act: Vec::new(),
        };
        let mut seen: HashSet<&str> = HashSet::new();
        for dim in &d.dims {
            let name = dim.name.name.as_str();
            if let Some((_, meaning)) = RESERVED.iter().find(|(r, _)| *r == name) {
                self.err(
                    f,
                    dim.name.span,
                    CheckError::ReservedName {
                        name: name.into(),
                        meaning: (*meaning).into(),
                        src: self.src(f),
                        span: dim.name.span.into(),
                    },
                );
            }
            if !seen.insert(name) {
                self.err(
                    f,
                    dim.name.span,
                    CheckError::DuplicateDimension {
                        name: name.into(),
                        src: self.src(f),
                        span: dim.name.span.into(),
                    },
                );
                continue;
            }
            let limits = dim.limits.as_ref().and_then(|l| self.limits(f, l));
            let new = Dim {
                name: name.into(),
                unit: dim.unit.clone().unwrap_or_default(),
                limits,
            };
            match dim.space {
                Space::Observation => dom.observe.push(new),
                Space::Action => dom.act.push(new),
            }
        }
        dom
    }

    fn limits(&mut self, f: usize, l: &LimitsExpr) -> Option<Limits> {
        let lo = self.constant(f, &l.lo, "a limit");
        let hi = self.constant(f, &l.hi, "a limit");
        let (lo, hi) = (lo?, hi?);
        if lo > hi {
            self.err(
                f,
                l.span,
                CheckError::EmptyLimits {
                    lo,
                    hi,
                    src: self.src(f),
                    span: l.span.into(),
                },
            );
            return None;
        }
        Some(Limits::new(lo, hi))
    }

    /// Evaluate a constant expression, reporting why it is not one.
    fn constant(&mut self, f: usize, e: &Expr, what: &str) -> Option<f64> {
        let before = self.error_count();
        let (ir, ty) = self.resolve(f, Scope::Const, e, what);
        if self.error_count() > before {
            return None;
        }
        if !self.expect(f, e, ty, Ty::Num, None) {
            return None;
        }
        let v = ir.eval_uniform(&[], f64::NAN);
        if !v.is_finite() {
            self.err(
                f,
                e.span,
                CheckError::NotFinite {
                    value: v,
                    src: self.src(f),
                    span: e.span.into(),
                },
            );
            return None;
        }
        Some(v)
    }

    fn signature<'f>(
        &mut self,
        f: usize,
        o: &'f OperatorDecl,
        by_name: &HashMap<String, usize>,
        domains: &[Dom<'_>],
    ) -> Sig<'f> {
        let domain = by_name.get(&o.domain.name).copied();
        if domain.is_none() && !self.full() {
            let names: Vec<&str> = domains.iter().map(|d| d.name.as_str()).collect();
            let help = match suggest(&o.domain.name, names.iter().copied()) {
                Some(s) => format!("did you mean `{s}`?"),
                None => format!(
                    "declare it with `domain {} {{ observe ... act ... }}`{}",
                    o.domain.name,
                    if names.is_empty() {
                        String::new()
                    } else {
                        format!(", or use one of: {}", names.join(", "))
                    }
                ),
            };
            self.err(
                f,
                o.domain.span,
                CheckError::UnknownDomain {
                    name: o.domain.name.clone(),
                    help,
                    src: self.src(f),
                    span: o.domain.span.into(),
                },
            );
        }
        let mut params: Vec<Param> = Vec::new();
        if let Some(extra) = o.params.get(MAX_PARAMS) {
            self.err(
                f,
                extra.name.span,
                CheckError::TooManyParameters {
                    name: o.name.name.clone(),
                    count: o.params.len(),
                    limit: MAX_PARAMS,
                    src: self.src(f),
                    span: extra.name.span.into(),
                },
            );
        }
        for p in o.params.iter().take(MAX_PARAMS) {
            let name = p.name.name.as_str();
            if let Some((_, meaning)) = RESERVED.iter().find(|(r, _)| *r == name) {
                self.err(
                    f,
                    p.name.span,
                    CheckError::ReservedName {
                        name: name.into(),
                        meaning: (*meaning).into(),
                        src: self.src(f),
                        span: p.name.span.into(),
                    },
                );
            }
            if let Some(d) = domain
                && domains[d].find(name).is_some()
            {
                self.err(
                    f,
                    p.name.span,
                    CheckError::ParamShadowsDimension {
                        name: name.into(),
                        domain: domains[d].name.clone(),
                        src: self.src(f),
                        span: p.name.span.into(),
                    },
                );
            }
            if params.iter().any(|q| q.name == name) {
                self.err(
                    f,
                    p.name.span,
                    CheckError::DuplicateParameter {
                        name: name.into(),
                        src: self.src(f),
                        span: p.name.span.into(),
                    },
                );
            }
            let limits = p.limits.as_ref().and_then(|l| self.limits(f, l));
            let default = p
                .default
                .as_ref()
                .and_then(|e| self.constant(f, e, "a default"));
            if let (Some(v), Some(l), Some(e)) = (default, limits, &p.default)
                && !l.contains(v)
            {
                self.err(
                    f,
                    e.span,
                    CheckError::ParamOutOfRange {
                        what: "default".into(),
                        param: name.into(),
                        value: v,
                        lo: l.lo,
                        hi: l.hi,
                        src: self.src(f),
                        span: e.span.into(),
                    },
                );
            }
            params.push(Param {
                name: name.into(),
                default,
                limits,
            });
        }
        Sig {
            file: f,
            decl: o,
            domain,
            params,
        }
    }

    fn body(&mut self, known: &Known<'_, '_>, i: usize, domain: &Dom<'_>) -> Option<Body2> {
        let sig = &known.sigs[i];
        let f = sig.file;
        let o = sig.decl;
        let before = self.error_count();
        let scope = Scope::Point {
            domain,
            params: &sig.params,
        };
        let body = match &o.body {
            Body::Block { guard, stmts } => {
                let guard = guard.as_ref().map(|g| {
                    let (ir, ty) = self.resolve(f, scope, g, "");
                    self.expect(
                        f,
                        g,
                        ty,
                        Ty::Bool,
                        Some("a guard is a condition, e.g. `where rot != 0`"),
                    );
                    ir
                });
                if stmts.is_empty() {
                    self.err(
                        f,
                        o.name.span,
                        CheckError::EmptyOperator {
                            name: o.name.name.clone(),
                            src: self.src(f),
                            span: o.name.span.into(),
                        },
                    );
                }
                let mut writes: Vec<(usize, Ir)> = Vec::new();
                let mut assigned: HashSet<(Space, usize)> = HashSet::new();
                for s in stmts {
                    if self.full() {
                        break;
                    }
                    let (value, ty) = self.resolve(f, scope, &s.value, "");
                    self.expect(
                        f,
                        &s.value,
                        ty,
                        Ty::Num,
                        Some("a dimension holds a number; conditions belong in `where`"),
                    );
                    let Some((space, idx)) = self.target(f, &s.target, sig, domain) else {
                        continue;
                    };
                    if !assigned.insert((space, idx)) {
                        self.err(
                            f,
                            s.target.span,
                            CheckError::DuplicateAssignment {
                                name: s.target.name.clone(),
                                src: self.src(f),
                                span: s.target.span.into(),
                            },
                        );
                        continue;
                    }
                    let constant = (ty == Ty::Num && value.is_constant())
                        .then(|| value.eval_uniform(&[], f64::NAN));
                    if let Some(v) = constant.filter(|v| !v.is_finite()) {
                        self.err(
                            f,
                            s.value.span,
                            CheckError::NotFinite {
                                value: v,
                                src: self.src(f),
                                span: s.value.span.into(),
                            },
                        );
                    } else if s.op == AssignOp::Set
                        && let Some(v) = constant
                        && let Some(l) = domain.dims(space)[idx].limits
                        && !l.contains(v)
                    {
                        self.err(
                            f,
                            s.value.span,
                            CheckError::LiteralOutOfRange {
                                dim: s.target.name.clone(),
                                value: v,
                                lo: l.lo,
                                hi: l.hi,
                                clamped: l.clamp(v),
                                src: self.src(f),
                                span: s.value.span.into(),
                            },
                        );
                    }
                    let cur = Box::new(Ir::Dim(space, idx));
                    let v = Box::new(value);
                    let ir = match s.op {
                        AssignOp::Set => *v,
                        AssignOp::Add => Ir::Bin(BinOp::Add, cur, v),
                        AssignOp::Sub => Ir::Bin(BinOp::Sub, cur, v),
                        AssignOp::Mul => Ir::Bin(BinOp::Mul, cur, v),
                        AssignOp::Div => Ir::Bin(BinOp::Div, cur, v),
                    };
                    writes.push((idx, ir));
                }
                let nodes = guard.iter().map(Ir::size).sum::<usize>()
                    + writes.iter().map(|(_, ir)| ir.size()).sum::<usize>();
                if nodes > MAX_NODES {
                    self.err(
                        f,
                        o.name.span,
                        CheckError::OperatorTooLarge {
                            name: o.name.name.clone(),
                            nodes,
                            limit: MAX_NODES,
                            src: self.src(f),
                            span: o.name.span.into(),
                        },
                    );
                }
                Body2::Block(BlockIr {
                    space: o.space,
                    guard,
                    writes,
                })
            }
            Body::Pipeline(calls) => {
                let mut stages = Vec::new();
                for c in calls {
                    if self.full() {
                        break;
                    }
                    if let Some(st) = self.stage(known, i, c, domain) {
                        stages.push(st);
                    }
                }
                Body2::Pipeline(stages)
            }
        };
        (self.error_count() == before).then_some(body)
    }

    /// Resolve the dimension a statement assigns to.
    fn target(
        &mut self,
        f: usize,
        t: &Ident,
        sig: &Sig<'_>,
        domain: &Dom<'_>,
    ) -> Option<(Space, usize)> {
        let o = sig.decl;
        match domain.find(&t.name) {
            Some((space, idx)) => {
                if space != o.space {
                    self.err(
                        f,
                        t.span,
                        CheckError::MixedSpaces {
                            operator: o.name.name.clone(),
                            dim: t.name.clone(),
                            op_space: o.space.word().into(),
                            dim_space: space.word().into(),
                            src: self.src(f),
                            span: t.span.into(),
                        },
                    );
                    return None;
                }
                Some((space, idx))
            }
            None => {
                let names: Vec<&str> = domain
                    .dims(o.space)
                    .iter()
                    .map(|d| d.name.as_str())
                    .collect();
                let mut help = hint(&t.name, &format!("{} dimensions", o.space), &names);
                if sig.params.iter().any(|p| p.name == t.name) {
                    help = format!(
                        "`{}` is a parameter; only dimensions can be assigned. {help}",
                        t.name
                    );
                } else if let Some(other) = other_domain_with_dim(&t.name, &domain.name) {
                    help = format!(
                        "`{}` is a dimension of the `{other}` domain; {help}",
                        t.name
                    );
                }
                self.err(
                    f,
                    t.span,
                    CheckError::UnknownDimension {
                        name: t.name.clone(),
                        domain: domain.name.clone(),
                        help,
                        src: self.src(f),
                        span: t.span.into(),
                    },
                );
                None
            }
        }
    }

    fn callee<'x>(
        known: &Known<'x, '_>,
        domain: &Domain,
        d_idx: Option<usize>,
        name: &str,
    ) -> Option<(usize, CalleeInfo<'x>)> {
        let (sigs, base) = (known.sigs, known.base);
        if let Some(&j) = d_idx.and_then(|d| known.first.get(&(d, name))) {
            let s = &sigs[j];
            return Some((
                known.base_ops + j,
                CalleeInfo {
                    name: &s.decl.name.name,
                    space: s.decl.space,
                    params: &s.params,
                },
            ));
        }
        let b = base?;
        let j = b.find(&domain.name, name)?;
        let o = &b.ops[j];
        Some((
            j,
            CalleeInfo {
                name: &o.name,
                space: o.space,
                params: &o.params,
            },
        ))
    }

    fn stage(
        &mut self,
        known: &Known<'_, '_>,
        i: usize,
        c: &Call,
        domain: &Dom<'_>,
    ) -> Option<Stage> {
        let (sigs, base) = (known.sigs, known.base);
        let sig = &sigs[i];
        let f = sig.file;
        let o = sig.decl;
        let Some((idx, callee)) = Self::callee(known, domain, sig.domain, &c.name.name) else {
            let mut others: Vec<&str> = sigs
                .iter()
                .filter(|s| s.decl.name.name == c.name.name && s.domain != sig.domain)
                .filter_map(|s| s.domain.map(|_| s.decl.domain.name.as_str()))
                .collect();
            if let Some(b) = base {
                others.extend(b.domains_with(&c.name.name));
            }
            if let Some(other) = others.first() {
                self.err(
                    f,
                    c.name.span,
                    CheckError::WrongDomain {
                        name: c.name.name.clone(),
                        op_domain: (*other).into(),
                        domain: domain.name.clone(),
                        src: self.src(f),
                        span: c.name.span.into(),
                    },
                );
                return None;
            }
            let mut names: Vec<&str> = sigs
                .iter()
                .filter(|s| s.domain == sig.domain)
                .map(|s| s.decl.name.name.as_str())
                .collect();
            if let Some(b) = base {
                names.extend(b.operator_names(&domain.name));
            }
            let help = hint(
                &c.name.name,
                &format!("operators for `{}`", domain.name),
                &names,
            );
            self.err(
                f,
                c.name.span,
                CheckError::UnknownOperator {
                    name: c.name.name.clone(),
                    domain: domain.name.clone(),
                    help,
                    src: self.src(f),
                    span: c.name.span.into(),
                },
            );
            return None;
        };
        let mut ok = true;
        if callee.space != o.space {
            self.err(
                f,
                c.name.span,
                CheckError::MixedComposition {
                    operator: o.name.name.clone(),
                    callee: callee.name.into(),
                    op_space: o.space.word().into(),
                    callee_space: callee.space.word().into(),
                    src: self.src(f),
                    span: c.name.span.into(),
                },
            );
            ok = false;
        }
        let cparams = callee.params;
        let signature = if cparams.is_empty() {
            format!("`{}` takes no arguments", callee.name)
        } else {
            let ps: Vec<String> = cparams.iter().map(|p| p.to_string()).collect();
            format!("`{}({})`", callee.name, ps.join(", "))
        };
        let callee_name = callee.name.to_string();
        let mut args: Vec<Option<Ir>> = vec![None; cparams.len()];
        let mut given = vec![false; cparams.len()];
        for (pos, a) in c.args.iter().enumerate() {
            let slot = match &a.name {
                None if pos >= cparams.len() => {
                    self.err(
                        f,
                        a.span,
                        CheckError::TooManyArguments {
                            operator: callee_name.clone(),
                            expected: cparams.len(),
                            found: c.args.len(),
                            signature: signature.clone(),
                            src: self.src(f),
                            span: a.span.into(),
                        },
                    );
                    ok = false;
                    continue;
                }
                None => pos,
                Some(n) => match cparams.iter().position(|p| p.name == n.name) {
                    Some(s) => s,
                    None => {
                        let names: Vec<&str> = cparams.iter().map(|p| p.name.as_str()).collect();
                        let help = hint(&n.name, &format!("parameters of `{callee_name}`"), &names);
                        self.err(
                            f,
                            n.span,
                            CheckError::UnknownParameter {
                                name: n.name.clone(),
                                operator: callee_name.clone(),
                                help,
                                src: self.src(f),
                                span: n.span.into(),
                            },
                        );
                        ok = false;
                        continue;
                    }
                },
            };
            if given[slot] {
                self.err(
                    f,
                    a.span,
                    CheckError::DuplicateArgument {
                        name: cparams[slot].name.clone(),
                        src: self.src(f),
                        span: a.span.into(),
                    },
                );
                ok = false;
                continue;
            }
            given[slot] = true;
            let (ir, ty) = self.resolve(
                f,
                Scope::Arg {
                    domain,
                    params: &sig.params,
                },
                &a.value,
                "",
            );
            ok &= self.expect(f, &a.value, ty, Ty::Num, None);
            if ty == Ty::Num
                && ir.is_constant()
                && let Some(l) = cparams[slot].limits
            {
                let v = ir.eval_uniform(&[], f64::NAN);
                if !l.contains(v) {
                    self.err(
                        f,
                        a.value.span,
                        CheckError::ParamOutOfRange {
                            what: "argument".into(),
                            param: cparams[slot].name.clone(),
                            value: v,
                            lo: l.lo,
                            hi: l.hi,
                            src: self.src(f),
                            span: a.value.span.into(),
                        },
                    );
                    ok = false;
                }
            }
            args[slot] = Some(ir);
        }
        for (p, g) in cparams.iter().zip(&given) {
            if !g && p.default.is_none() {
                self.err(
                    f,
                    c.span,
                    CheckError::MissingArgument {
                        operator: callee_name.clone(),
                        param: p.name.clone(),
                        src: self.src(f),
                        span: c.span.into(),
                    },
                );
                ok = false;
            }
        }
        ok.then_some(Stage { op: idx, args })
    }

    /// Report compositions that lead back to themselves.
    fn cycles(&mut self, sigs: &[Sig<'_>], bodies: &[Option<Body2>], base_ops: usize) {
        // Edges between the operators being checked, with the span of the call.
        let edges: Vec<Vec<(usize, Span)>> = sigs
            .iter()
            .zip(bodies)
            .map(|(s, b)| match (&s.decl.body, b) {
                (Body::Pipeline(calls), Some(Body2::Pipeline(stages))) => {
                    let spans = calls.iter().map(|c| c.name.span);
                    stages
                        .iter()
                        .zip(spans)
                        .filter(|(st, _)| st.op >= base_ops)
                        .map(|(st, sp)| (st.op - base_ops, sp))
                        .collect()
                }
                _ => Vec::new(),
            })
            .collect();
        // 0 = unvisited, 1 = on the current path, 2 = done.
        let mut state = vec![0u8; sigs.len()];
        // Where each operator on the current path is on it.
        let mut on_path = vec![0usize; sigs.len()];
        for start in 0..sigs.len() {
            if state[start] != 0 {
                continue;
            }
            let mut path: Vec<(usize, usize)> = vec![(start, 0)];
            state[start] = 1;
            on_path[start] = 0;
            while let Some(&mut (node, ref mut next)) = path.last_mut() {
                if let Some(&(to, span)) = edges[node].get(*next) {
                    *next += 1;
                    match state[to] {
                        0 => {
                            state[to] = 1;
                            on_path[to] = path.len();
                            path.push((to, 0));
                        }
                        1 if self.full() => {}
                        1 => {
                            let from = on_path[to];
                            let mut names: Vec<String> = path[from..]
                                .iter()
                                .map(|(n, _)| format!("`{}`", sigs[*n].decl.name.name))
                                .collect();
                            // A long loop is named by its ends.
                            if names.len() > 8 {
                                let more = names.len() - 6;
                                names.drain(3..names.len() - 3);
                                names.insert(3, format!("({more} more)"));
                            }
                            names.push(format!("`{}`", sigs[to].decl.name.name));
                            let cycle = names.join(" -> ");
                            let f = sigs[node].file;
                            self.err(
                                f,
                                span,
                                CheckError::RecursiveOperator {
                                    name: sigs[to].decl.name.name.clone(),
                                    cycle,
                                    src: self.src(f),
                                    span: span.into(),
                                },
                            );
                        }
                        _ => {}
                    }
                } else {
                    state[node] = 2;
                    path.pop();
                }
            }
        }
    }

    /// Report `found` where `want` was needed; `true` when it fits.
    fn expect(&mut self, f: usize, e: &Expr, found: Ty, want: Ty, help: Option<&str>) -> bool {
        if found == want || found == Ty::Err {
            return true;
        }
        self.err(
            f,
            e.span,
            CheckError::TypeMismatch {
                expected: want.word().into(),
                found: found.word().into(),
                help: help.map(str::to_string),
                src: self.src(f),
                span: e.span.into(),
            },
        );
        false
    }

    fn resolve(&mut self, f: usize, scope: Scope<'_>, e: &Expr, what: &str) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        if self.full() {
            return bad;
        }
        match &e.kind {
            ExprKind::Num(v) => (Ir::Num(*v), Ty::Num),
            ExprKind::Var(name) => self.var(f, scope, name, e.span, what),
            ExprKind::At { dim, offset } => {
                let Scope::Point { domain, params } = scope else {
                    self.not_here(f, scope, &dim.name, e.span, what);
                    return bad;
                };
                let (off, ty) = self.resolve(f, scope, offset, what);
                let num = self.expect(
                    f,
                    offset,
                    ty,
                    Ty::Num,
                    Some("an offset counts points, e.g. `bearing[-3]`"),
                );
                if num && ty == Ty::Num && off.is_constant() {
                    let v = off.eval_uniform(&[], f64::NAN);
                    if !v.is_finite() {
                        self.err(
                            f,
                            offset.span,
                            CheckError::NotFinite {
                                value: v,
                                src: self.src(f),
                                span: offset.span.into(),
                            },
                        );
                        return bad;
                    }
                }
                match domain.find(&dim.name) {
                    Some((space, idx)) => (Ir::At(space, idx, Box::new(off)), Ty::Num),
                    None if params.iter().any(|p| p.name == dim.name)
                        || RESERVED.iter().any(|(r, _)| *r == dim.name) =>
                    {
                        self.err(
                            f,
                            dim.span,
                            CheckError::OffsetNeedsDimension {
                                name: dim.name.clone(),
                                src: self.src(f),
                                span: dim.span.into(),
                            },
                        );
                        bad
                    }
                    None => {
                        let names = dim_names(domain);
                        let help = hint(&dim.name, "dimensions", &names);
                        self.err(
                            f,
                            dim.span,
                            CheckError::UnknownDimension {
                                name: dim.name.clone(),
                                domain: domain.name.clone(),
                                help,
                                src: self.src(f),
                                span: dim.span.into(),
                            },
                        );
                        bad
                    }
                }
            }
            ExprKind::Call { func, args } => {
                let resolved: Vec<(Ir, Ty)> = args
                    .iter()
                    .map(|a| self.resolve(f, scope, a, what))
                    .collect();
                let Some(fun) = Func::by_name(&func.name) else {
                    let names: Vec<&str> = Func::ALL.iter().map(|f| f.name()).collect();
                    let help = hint(&func.name, "functions", &names);
                    self.err(
                        f,
                        func.span,
                        CheckError::UnknownFunction {
                            name: func.name.clone(),
                            help,
                            src: self.src(f),
                            span: func.span.into(),
                        },
                    );
                    return bad;
                };
                if args.len() != fun.arity() {
                    self.err(
                        f,
                        e.span,
                        CheckError::WrongArity {
                            func: func.name.clone(),
                            expected: fun.arity(),
                            found: args.len(),
                            signature: fun.signature().into(),
                            src: self.src(f),
                            span: e.span.into(),
                        },
                    );
                    return bad;
                }
                let mut ok = true;
                for (a, (_, ty)) in args.iter().zip(&resolved) {
                    ok &= self.expect(f, a, *ty, Ty::Num, None);
                }
                let irs = resolved.into_iter().map(|(ir, _)| ir).collect();
                (Ir::Func(fun, irs), if ok { Ty::Num } else { Ty::Err })
            }
            ExprKind::Unary(op, inner) => {
                let (ir, ty) = self.resolve(f, scope, inner, what);
                match op {
                    UnOp::Neg => {
                        let ok = self.expect(
                            f,
                            inner,
                            ty,
                            Ty::Num,
                            Some("`-` negates a number; `not` negates a condition"),
                        );
                        (Ir::Neg(Box::new(ir)), if ok { Ty::Num } else { Ty::Err })
                    }
                    UnOp::Not => {
                        let ok = self.expect(
                            f,
                            inner,
                            ty,
                            Ty::Bool,
                            Some("`not` negates a condition such as `rot > 0`"),
                        );
                        (Ir::Not(Box::new(ir)), if ok { Ty::Bool } else { Ty::Err })
                    }
                }
            }
            ExprKind::Binary(op, a, b) => {
                let (ia, ta) = self.resolve(f, scope, a, what);
                let (ib, tb) = self.resolve(f, scope, b, what);
                let (want, out, help) = if op.is_logical() {
                    (
                        Ty::Bool,
                        Ty::Bool,
                        "`and` and `or` join conditions such as `rot > 0`",
                    )
                } else if op.is_comparison() {
                    (
                        Ty::Num,
                        Ty::Bool,
                        "comparisons take numbers; join conditions with `and` or `or`",
                    )
                } else {
                    (Ty::Num, Ty::Num, "arithmetic takes numbers, not conditions")
                };
                let oka = self.expect(f, a, ta, want, Some(help));
                let okb = self.expect(f, b, tb, want, Some(help));
                let ty = if oka && okb && ta != Ty::Err && tb != Ty::Err {
                    out
                } else {
                    Ty::Err
                };
                (Ir::Bin(*op, Box::new(ia), Box::new(ib)), ty)
            }
        }
    }

    fn var(&mut self, f: usize, scope: Scope<'_>, name: &str, span: Span, what: &str) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        if name == "pi" {
            return (Ir::Num(std::f64::consts::PI), Ty::Num);
        }
        let params: &[Param] = match scope {
            Scope::Const => &[],
            Scope::Point { params, .. } | Scope::Arg { params, .. } => params,
        };
        if let Some(i) = params.iter().position(|p| p.name == name) {
            return (Ir::Param(i), Ty::Num);
        }
        match (scope, name) {
            (Scope::Point { .. }, "k") => return (Ir::K, Ty::Num),
            (Scope::Point { .. } | Scope::Arg { .. }, "n") => return (Ir::N, Ty::Num),
            (Scope::Const, "k" | "n") | (Scope::Arg { .. }, "k") => {
                self.not_here(f, scope, name, span, what);
                return bad;
            }
            _ => {}
        }
        let dims: Vec<&str> = match scope {
            Scope::Point { domain, .. } => {
                if let Some((space, idx)) = domain.find(name) {
                    return (Ir::Dim(space, idx), Ty::Num);
                }
                dim_names(domain)
            }
            Scope::Arg { domain, .. } => {
                if domain.find(name).is_some() {
                    self.not_here(f, scope, name, span, what);
                    return bad;
                }
                Vec::new()
            }
            Scope::Const => Vec::new(),
        };
        let mut candidates: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
        candidates.extend(dims);
        if !matches!(scope, Scope::Const) {
            candidates.extend(["k", "n"]);
        }
        candidates.push("pi");
        let mut help = match suggest(name, candidates.iter().copied()) {
            Some(s) => format!("did you mean `{s}`?"),
            None => match scope {
                Scope::Const => {
                    "limits and defaults are constants: numbers, `pi` and arithmetic".into()
                }
                Scope::Arg { .. } => {
                    "an argument may use the operator's parameters, numbers, `n` and `pi`".into()
                }
                Scope::Point { .. } => format!(
                    "the names here are the domain's dimensions, the parameters, `k` (the point's index in the chunk), `n` (the chunk length) and `pi`: {}",
                    listing(&candidates)
                ),
            },
        };
        if let Scope::Point { domain, .. } = scope
            && let Some(other) = other_domain_with_dim(name, &domain.name)
        {
            help = format!(
                "`{name}` is a dimension of the `{other}` domain, not `{}`; {help}",
                domain.name
            );
        }
        self.err(
            f,
            span,
            CheckError::UnknownName {
                name: name.into(),
                help,
                src: self.src(f),
                span: span.into(),
            },
        );
        bad
    }

    /// A name that exists but cannot be used in this scope.
    fn not_here(&mut self, f: usize, scope: Scope<'_>, name: &str, span: Span, what: &str) {
        let e = match scope {
            Scope::Arg { .. } => CheckError::PerPointArgument {
                name: name.into(),
                src: self.src(f),
                span: span.into(),
            },
            _ => CheckError::NotConstant {
                what: if what.is_empty() {
                    "this".into()
                } else {
                    what.into()
                },
                name: name.into(),
                src: self.src(f),
                span: span.into(),
            },
        };
        self.err(f, span, e);
    }
}

fn dim_names(domain: &Domain) -> Vec<&str> {
    domain
        .observe
        .iter()
        .chain(&domain.act)
        .map(|d| d.name.as_str())
        .collect()
}

/// The built-in domain other than `exclude` that has a dimension `name` (for hints).
fn other_domain_with_dim(name: &str, exclude: &str) -> Option<&'static str> {
    ["positioning", "interception"]
        .into_iter()
        .find(|d| *d != exclude && Domain::builtin(d).is_some_and(|dom| dom.find(name).is_some()))
}

/// A body that passed the checker, before compilation.
enum Body2 {
    Block(BlockIr),
    Pipeline(Vec<Stage>),
}

fn stages_of(b: &Option<Body2>) -> &[Stage] {
    match b {
        Some(Body2::Pipeline(st)) => st.as_slice(),
        _ => &[],
    }
}

/// A stage count for a message (a saturated count is "more than 10^19").
fn count_text(n: u64) -> String {
    if n == u64::MAX {
        "more than 10^19".into()
    } else {
        n.to_string()
    }
}

/// How two declarations of a domain differ, in words; `None` when they agree.
fn domain_difference(a: &Domain, b: &Domain) -> Option<String> {
    for space in [Space::Observation, Space::Action] {
        let (da, db) = (a.dims(space), b.dims(space));
        let names = |d: &[Dim]| {
            d.iter()
                .map(|x| x.name.clone())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if da.len() != db.len() || da.iter().zip(db).any(|(x, y)| x.name != y.name) {
            return Some(format!(
                "its {space} dimensions are [{}], the standard ones [{}]",
                names(db),
                names(da)
            ));
        }
        for (x, y) in da.iter().zip(db) {
            if x.unit != y.unit {
                return Some(format!(
                    "`{}` has the unit \"{}\", not \"{}\"",
                    x.name, y.unit, x.unit
                ));
            }
            if x.limits != y.limits {
                let show = |l: Option<Limits>| match l {
                    Some(l) => format!("[{}, {}]", l.lo, l.hi),
                    None => "no limits".into(),
                };
                return Some(format!(
                    "`{}` has {}, not {}",
                    x.name,
                    show(y.limits),
                    show(x.limits)
                ));
            }
        }
    }
    None
}
