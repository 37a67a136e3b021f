//! AST to checked [`OperatorSet`]: names, dimensions, parameters, types, ranges; and the binding
//! of an invocation to a [`Call`] ([`bind`]).
//!
//! The checker reads every file it is given, reports every mistake of every file at once (each a
//! [`CheckError`] with a stable code, a label and a hint), and only when there are none builds an
//! [`OperatorSet`] whose operators are already compiled for the interpreter (the types are in
//! [`crate::program`]; only this module builds them). The standard library in `operators/*.adv`
//! goes through this same path ([`OperatorSet::standard`]), and so do the paper's domains
//! ([`Domain::positioning`]); a user's file is checked on top of it ([`OperatorSet::merge`]) so it
//! may use the standard domains and compose the standard operators. This module does no IO and
//! applies nothing; it imports nothing of the interpreter.
//!
//! The seams: `names` resolves expressions, `decls` checks domains and signatures, `body` an
//! operator's statements, `compose` its compositions (callees, cycles, expansion), `bind` binds
//! arguments (compositions and invocations alike), `compile` turns a checked body into bytecode,
//! `standard` holds the embedded library.

mod bind;
mod body;
mod compile;
mod compose;
mod decls;
pub mod error;
mod names;
mod standard;
mod task;
mod task_scope;
mod trace_domain;

use std::collections::HashMap;
use std::ops::ControlFlow;
use std::sync::Arc;

// "Did you mean" has one home, `diag::suggest`; the checker's passes use it under these names.
use crate::diag::suggest::{closest as suggest, hint, listing};
use crate::diag::{Loc, SourceId, SourceMap, Sourced, Src};
use crate::domain::Domain;
pub use crate::program::{Call, OperatorSet, Param};
use crate::program::{DefinitionHash, OpBody, Operator, Stage};
use crate::syntax::{self, ast::*};
pub use bind::bind;
use compose::{Known, Step};
use decls::domain_difference;
pub use error::{CheckError, CheckErrors, CheckWarning, ParseOrCheckError};
use names::Dom;
pub use standard::{STANDARD_SOURCES, role_operators, role_source_name, with_role_operators};
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

/// How many per-point stages a composition may expand to (each stage runs over the whole chunk,
/// so this bounds an application's work; a composition that composes the one before it four times
/// reaches 4^k).
pub const MAX_STAGES: usize = 1024;

/// How many expression nodes an operator's body may hold: each becomes an instruction whose
/// register holds a batch of points, so this bounds an application's memory (a few MB).
pub const MAX_NODES: usize = 4096;

/// How many parameters an operator may declare (every composition stage binds them all).
pub const MAX_PARAMS: usize = 64;

/// The most operator text one check reads, all its sources together: 64 MiB. A check holds
/// what it reads until it ends (the trees of compositions, compiled bodies, definitions), about
/// 20 bytes a byte of text where it is densest (long compositions), so this is what bounds its
/// memory (issue 47: 250 MB of compositions, under the 256 MiB any file may be, aborted at
/// 3.6 GB).
pub const MAX_CHECK_BYTES: usize = 64 * 1024 * 1024;

/// The most operators one check reads: each costs about 2 KB while it is checked whatever its
/// length (`operator a for d on action = b`), so a file of short ones is bounded by this.
pub const MAX_OPERATORS: usize = 400_000;

/// How many errors one check reports before it stops looking: each costs work in proportion to
/// the text (hints compare names), so an input of many mistakes would otherwise cost its square.
pub const MAX_ERRORS: usize = 100;

/// A checked set with what the check found worth saying but not refusing.
#[derive(Clone, Debug)]
pub struct Checked {
    pub set: OperatorSet,
    pub warnings: Vec<CheckWarning>,
}

impl OperatorSet {
    /// Check `sources` on top of this set: they may use its domains and operators, and their
    /// operators shadow same-named ones of this set. The errors bring the texts with them.
    pub fn merge(&self, sources: &[Source]) -> Result<OperatorSet, Sourced<CheckErrors>> {
        check_texts(Some(self), sources)
    }

    /// [`OperatorSet::merge`] of sources of `map` (where the errors and warnings point), with
    /// the warnings (a standard operator shadowed, say).
    pub fn merge_in(&self, map: &SourceMap, ids: &[SourceId]) -> Result<Checked, CheckErrors> {
        check_in(map, Some(self), ids)
    }
}

/// Parse and check `sources` on their own; the errors bring the texts with them.
pub fn check(sources: &[Source]) -> Result<OperatorSet, Sourced<CheckErrors>> {
    check_texts(None, sources)
}

fn check_texts(
    base: Option<&OperatorSet>,
    sources: &[Source],
) -> Result<OperatorSet, Sourced<CheckErrors>> {
    let mut map = SourceMap::new();
    let ids: Vec<SourceId> = sources
        .iter()
        .map(|s| map.add(s.name.as_str(), s.text.as_str()))
        .collect();
    match check_in(&map, base, &ids) {
        Ok(checked) => Ok(checked.set),
        Err(e) => Err(map.attach(e)),
    }
}

/// Parse and check the sources `ids` of `map` on top of `base` (see [`OperatorSet::merge`]);
/// errors and warnings point into `map`.
pub fn check_in(
    map: &SourceMap,
    base: Option<&OperatorSet>,
    ids: &[SourceId],
) -> Result<Checked, CheckErrors> {
    let srcs: Vec<Src<'_>> = ids.iter().map(|&id| map.src(id)).collect();
    let size: usize = srcs.iter().map(|s| s.text.len()).sum();
    if size > MAX_CHECK_BYTES {
        let what = match srcs.as_slice() {
            [one] => format!("`{}`", one.name),
            many => format!("the {} files", many.len()),
        };
        let error = CheckError::TooLarge {
            what,
            size: crate::files::fmt_bytes(size as u64),
            limit: crate::files::fmt_bytes(MAX_CHECK_BYTES as u64),
        };
        return Err(CheckErrors {
            errors: vec![error.into()],
        });
    }
    let mut c = Checker::new(&srcs);
    let result = c.run(base);
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
        let mut errors: Vec<ParseOrCheckError> = errors.into_iter().map(|(_, _, e)| e).collect();
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
pub fn render_all(errors: &Sourced<CheckErrors>) -> String {
    errors
        .error
        .errors
        .iter()
        .map(|e| crate::diag::render(&errors.sources, e, false))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Render one diagnostic that brings its own source (a [`Sourced`] one) or needs none, as the
/// terminal shows it, without colour, 100 columns wide.
pub fn render(diag: &dyn miette::Diagnostic) -> String {
    crate::diag::render(&crate::diag::SourceMap::new(), diag, false)
}

/// The signature of an operator being checked, before its body is known to be good.
struct Sig<'f> {
    file: usize,
    decl: &'f OperatorDecl,
    domain: Option<usize>,
    params: Vec<Param>,
}

struct Checker<'s> {
    /// The files, each a source of the map the diagnostics point into.
    sources: &'s [Src<'s>],
    /// Each text's line index, to turn offsets into lines without rescanning.
    lines: Vec<crate::diag::LineIndex>,
    errors: Vec<(usize, usize, ParseOrCheckError)>,
    /// Errors found past [`MAX_ERRORS`], not reported.
    dropped: usize,
    warnings: Vec<(usize, usize, CheckWarning)>,
}

impl<'s> Checker<'s> {
    fn new(sources: &'s [Src<'s>]) -> Checker<'s> {
        Checker {
            sources,
            lines: sources
                .iter()
                .map(|s| crate::diag::LineIndex::new(s.text))
                .collect(),
            errors: Vec::new(),
            dropped: 0,
            warnings: Vec::new(),
        }
    }

    /// The place of `span` in file `file`, for a diagnostic.
    fn at(&self, file: usize, span: Span) -> Loc {
        self.sources[file].at(span.start..span.end)
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
        self.lines[file].line(byte) + 1
    }

    fn error_count(&self) -> usize {
        self.errors.len() + self.dropped
    }

    /// Whether enough errors were found: the rest of the check skips work that only finds more.
    fn full(&self) -> bool {
        self.errors.len() >= MAX_ERRORS
    }

    /// Read file `f` item by item into `read`. A file that does not parse adds nothing and
    /// reports only its parse error, as if it had never been read.
    fn read_file(&mut self, f: usize, read: &mut Read) {
        let mark = (
            self.errors.len(),
            self.warnings.len(),
            self.dropped,
            read.doms.len(),
            read.tasks.len(),
            read.ops.len(),
        );
        syntax::each_item(self.sources[f], |item| {
            match item {
                Ok(Item::Domain(d)) => self.read_domain(f, &d, read),
                Ok(Item::Operator(o)) if read.ops.len() >= MAX_OPERATORS => {
                    let span = self.at(f, o.name.span);
                    self.errors.push((
                        f,
                        o.name.span.start,
                        CheckError::TooManyOperators {
                            limit: MAX_OPERATORS,
                            span,
                        }
                        .into(),
                    ));
                    return ControlFlow::Break(());
                }
                Ok(Item::Operator(o)) => self.read_operator(f, o, read),
                Err(e) => {
                    let (errors, warnings, dropped, doms, tasks, ops) = mark;
                    self.errors.truncate(errors);
                    self.warnings.truncate(warnings);
                    self.dropped = dropped;
                    read.doms.truncate(doms);
                    read.tasks.truncate(tasks);
                    read.ops.truncate(ops);
                    read.early.truncate(ops);
                    read.by_name.retain(|_, i| *i < doms);
                    read.declared.retain(|_, (file, _)| *file != f);
                    self.errors.push((f, 0, e.into()));
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(())
        });
    }

    /// A domain as it is read: checked, and known from here on unless it was declared before.
    fn read_domain(&mut self, f: usize, d: &DomainDecl, read: &mut Read) {
        if self.full() {
            return;
        }
        let dom = self.domain(f, d);
        if let Some(&(ff, fs)) = read.declared.get(&dom.name) {
            let first = format!(
                "the first declaration is in {} at line {}",
                self.sources[ff].name,
                self.line(ff, fs.start)
            );
            self.err(
                f,
                d.name.span,
                CheckError::DuplicateDomain {
                    name: dom.name.clone(),
                    first,
                    span: self.at(f, d.name.span),
                },
            );
            return;
        }
        read.declared.insert(dom.name.clone(), (f, d.name.span));
        if let Some(&existing) = read
            .by_name
            .get(&dom.name)
            .filter(|&&i| i < read.base_domains)
        {
            if let Some(difference) = domain_difference(&read.doms[existing], &dom) {
                self.err(
                    f,
                    d.name.span,
                    CheckError::ConflictingDomain {
                        name: dom.name.clone(),
                        difference,
                        span: self.at(f, d.name.span),
                    },
                );
            }
            return;
        }
        if let Some(t) = self.task(f, d, &dom) {
            read.tasks.push(Arc::new(t));
        }
        read.by_name.insert(dom.name.clone(), read.doms.len());
        read.doms.push(Dom::new(dom));
    }

    /// An operator as it is read. One whose domain is known and whose body is a block is checked
    /// and compiled now and kept without its body; the rest wait until every file is read.
    fn read_operator(&mut self, f: usize, mut o: OperatorDecl, read: &mut Read) {
        let domain = read.by_name.get(&o.domain.name).copied();
        let early = match (domain, &o.body) {
            (Some(d), Body::Block { .. }) => {
                let sig = self.signature(f, &o, &read.by_name, &read.doms);
                let params = sig.params;
                let body = if self.full() {
                    None
                } else {
                    self.block(f, &o, &params, &read.doms[d])
                };
                // Only a set without errors is built; its operators' definitions are kept.
                let definition = if self.errors.is_empty() {
                    let doc = std::mem::take(&mut o.doc);
                    let text = o.to_string();
                    o.doc = doc;
                    text
                } else {
                    String::new()
                };
                // What is left is what the set needs: the name, the doc, the places. (A
                // vector of parameters as parsed held four slots of a few hundred bytes each:
                // the largest part of a large file's memory.)
                o.body = Body::Block {
                    guard: None,
                    stmts: Vec::new(),
                };
                o.params = Vec::new();
                o.doc.shrink_to_fit();
                Some(Early {
                    domain: d,
                    params,
                    body,
                    definition,
                })
            }
            _ => None,
        };
        read.ops.push((f, Box::new(o)));
        read.early.push(early);
    }

    /// Read every file, item by item, and check what was read: domains as they come, an
    /// operator whose domain is already known and whose body is a block as it comes (its tree
    /// dropped once it is compiled, so a large file is never held whole as a tree: issue 31),
    /// the rest (compositions, operators of domains declared later) once every file is read.
    fn run(&mut self, base: Option<&OperatorSet>) -> OperatorSet {
        let mut read = Read::new(base);
        for f in 0..self.sources.len() {
            self.read_file(f, &mut read);
        }
        let Read {
            doms,
            by_name,
            tasks,
            ops,
            mut early,
            ..
        } = read;
        let base_ops = base.map_or(0, |b| b.ops.len());
        let (sigs, bodies) = {
            // Signatures first, so compositions may name operators defined later in any file.
            let mut sigs: Vec<Sig<'_>> = Vec::new();
            // `(domain, name)` to the first signature of that name.
            let mut first: HashMap<(usize, &str), usize> = HashMap::new();
            for (&(f, ref o), e) in ops.iter().zip(&early) {
                let sig = match e {
                    Some(e) => Sig {
                        file: f,
                        decl: o,
                        domain: Some(e.domain),
                        params: e.params.clone(),
                    },
                    None => self.signature(f, o, &by_name, &doms),
                };
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
                                f,
                                o.name.span,
                                CheckError::DuplicateOperator {
                                    name: o.name.name.clone(),
                                    domain: doms[d].name.clone(),
                                    first: msg,
                                    span: self.at(f, o.name.span),
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
            let known = Known {
                sigs: &sigs,
                first: &first,
                base,
                base_ops,
            };
            let mut bodies: Vec<Option<Body2>> = Vec::with_capacity(sigs.len());
            for (i, sig) in sigs.iter().enumerate() {
                let body = match (&mut early[i], sig.domain) {
                    (Some(e), _) => e.body.take(),
                    (None, Some(d)) if !self.full() => self.body(&known, i, &doms[d]),
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
            domains: doms.iter().map(|d| d.domain().clone()).collect(),
            tasks,
            ops: base.map(|b| b.ops.clone()).unwrap_or_default(),
            visible: HashMap::new(),
        };
        if !self.errors.is_empty() {
            return set;
        }
        // Each domain once, shared by its operators.
        let shared: Vec<Arc<Domain>> = doms.iter().map(|d| d.shared().clone()).collect();
        let mut bodies: Vec<Option<Body2>> = bodies;
        let mut built: Vec<Option<Arc<Operator>>> = vec![None; sigs.len()];
        // Callees before callers: a composition holds the operators it calls.
        for i in callees_first(&bodies, set.ops.len()) {
            let sig = &sigs[i];
            let (Some(d), Some(body)) = (sig.domain, bodies[i].take()) else {
                continue;
            };
            let domain = &shared[d];
            let definition = match early[i].as_mut() {
                Some(e) => std::mem::take(&mut e.definition),
                None => definition_of(sig.decl),
            };
            built[i] = Some(self.operator(
                sig, body, definition, domain, &set.ops, &built, base, stages[i],
            ));
        }
        // In definition order, so that a later definition shadows an earlier one.
        set.ops.extend(built.into_iter().flatten());
        set.reindex();
        set
    }

    /// One checked operator as the set keeps it (`built`: those of this check built so far, its
    /// callees among them; `base_ops`: the base set's; `expanded`: how many per-point stages it runs).
    /// Warns where it shadows a standard one.
    #[allow(clippy::too_many_arguments)]
    fn operator(
        &mut self,
        sig: &Sig<'_>,
        body: Body2,
        definition: String,
        domain: &Arc<Domain>,
        base_ops: &[Arc<Operator>],
        built: &[Option<Arc<Operator>>],
        base: Option<&OperatorSet>,
        expanded: u64,
    ) -> Arc<Operator> {
        let (body, hash) = match body {
            Body2::Block(program) => (OpBody::Block(program), DefinitionHash::of(&definition, [])),
            Body2::Pipeline(steps) => {
                let stages: Vec<Stage> = steps
                    .into_iter()
                    .filter_map(|st| {
                        let op = match st.op.checked_sub(base_ops.len()) {
                            None => base_ops[st.op].clone(),
                            Some(j) => built[j].clone()?,
                        };
                        Some(Stage { op, args: st.args })
                    })
                    .collect();
                let hash = DefinitionHash::of(&definition, stages.iter().map(|s| s.op.hash));
                (OpBody::Pipeline(stages), hash)
            }
        };
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
                    span: self.at(sig.file, span),
                },
            ));
        }
        let source = &self.sources[sig.file];
        Arc::new(Operator {
            name: sig.decl.name.name.clone(),
            domain: domain.clone(),
            space: sig.decl.space,
            doc: sig.decl.doc.join("\n"),
            params: sig.params.clone(),
            definition,
            hash,
            origin: match source.name.strip_prefix(standard::ROLE_SOURCE_PREFIX) {
                // Generated text: its lines are nobody's; name the file it was written from.
                Some(task) => format!(
                    "{}, rewritten for `{task}`'s actions by the roles they drive",
                    STANDARD_SOURCES[0].0
                ),
                None => format!(
                    "{} at line {}",
                    source.name,
                    self.line(sig.file, sig.decl.name.span.start)
                ),
            },
            standard: STANDARD_SOURCES.iter().any(|(n, _)| *n == source.name)
                || source.name.starts_with(standard::ROLE_SOURCE_PREFIX),
            stages: expanded,
            body,
        })
    }
}

/// What the checker has read so far: the domains (the base set's first), the tasks, and the
/// operators in definition order.
struct Read {
    doms: Vec<Dom>,
    /// How many of `doms` are the base set's.
    base_domains: usize,
    by_name: HashMap<String, usize>,
    /// Each domain declared in the files, with where its first declaration is.
    declared: HashMap<String, (usize, Span)>,
    tasks: Vec<Arc<crate::program::task::TaskDef>>,
    /// Each operator with its file: for one checked as it was read, its declaration without its
    /// body.
    ops: Vec<(usize, Box<OperatorDecl>)>,
    /// For each of `ops`, what checking it as it was read found.
    early: Vec<Option<Early>>,
}

/// An operator checked as it was read: its signature, its compiled body (`None` when either had
/// errors, reported), and its definition as text.
struct Early {
    domain: usize,
    params: Vec<Param>,
    body: Option<Body2>,
    definition: String,
}

impl Read {
    fn new(base: Option<&OperatorSet>) -> Read {
        let doms: Vec<Dom> = base
            .map(|b| b.domains.iter().cloned().map(Dom::new).collect())
            .unwrap_or_default();
        let by_name = doms
            .iter()
            .enumerate()
            .map(|(i, d)| (d.name.clone(), i))
            .collect();
        Read {
            base_domains: doms.len(),
            doms,
            by_name,
            declared: HashMap::new(),
            tasks: base.map(|b| b.tasks.clone()).unwrap_or_default(),
            ops: Vec::new(),
            early: Vec::new(),
        }
    }
}

/// An operator's definition as the set keeps it: its text as printed, without its doc comment.
fn definition_of(o: &OperatorDecl) -> String {
    let mut def = o.clone();
    def.doc.clear();
    def.to_string()
}

/// A body that passed the checker: a block already compiled, a composition's stages.
enum Body2 {
    Block(crate::program::code::Program),
    Pipeline(Vec<Step>),
}

fn stages_of(b: &Option<Body2>) -> &[Step] {
    match b {
        Some(Body2::Pipeline(st)) => st.as_slice(),
        _ => &[],
    }
}

/// The operators being checked (indices into `bodies`), each after every one it calls. Needs
/// bodies without cycles; iterative, since a chain of compositions may be as long as the file.
fn callees_first(bodies: &[Option<Body2>], base_ops: usize) -> Vec<usize> {
    let mut order = Vec::with_capacity(bodies.len());
    let mut done = vec![false; bodies.len()];
    for start in 0..bodies.len() {
        // Each entry: an operator and its next stage to visit.
        let mut stack = vec![(start, 0)];
        while let Some((i, next)) = stack.pop() {
            if done[i] {
                continue;
            }
            match stages_of(&bodies[i]).get(next) {
                Some(st) => {
                    stack.push((i, next + 1));
                    if let Some(j) = st.op.checked_sub(base_ops).filter(|&j| !done[j]) {
                        stack.push((j, 0));
                    }
                }
                None => {
                    done[i] = true;
                    order.push(i);
                }
            }
        }
    }
    order
}
