//! The checked program: what the checker builds and the interpreter only reads.
//!
//! An [`OperatorSet`] holds checked domains and [`Operator`]s; each operator carries its bytecode
//! ([`code::Program`]) or the operators it composes, and a [`DefinitionHash`] of its canonical
//! definition. A [`Call`] is an operator with every parameter bound to a value (defaults filled in,
//! limits checked) and its compositions expanded into stages. None of these has a public
//! constructor: only `check` builds them (`check::check`, `check::bind`), so a checked type cannot
//! hold an unchecked program. The record of an application ([`AppliedAdvice`]) lives here too,
//! because binding it again (`check::rebind`) and producing it (`interp::apply`) are two phases.
//! This module does no IO, parses nothing and runs nothing.

pub mod code;
pub mod ir;
pub mod task;

use std::collections::HashMap;
use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::domain::{Domain, Limits, Space};
use crate::syntax;
use crate::trace::Chunk;
use ir::Ir;

/// A parameter of a checked operator.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: String,
    /// `None` when every invocation must give a value.
    pub default: Option<f64>,
    /// Allowed values, when declared.
    pub limits: Option<Limits>,
}

impl fmt::Display for Param {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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

/// A hash of an operator's definition: its canonical text and, for a composition, the hashes of
/// the operators it calls (so redefining a callee and then the composition with the same text
/// gives another hash). FNV-1a over bytes, the same in every run and on every machine; written as
/// 16 hexadecimal digits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub struct DefinitionHash(u64);

impl DefinitionHash {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    /// The hash of a canonical definition and, in order, the hashes of the operators it calls.
    pub(crate) fn of(definition: &str, callees: impl IntoIterator<Item = DefinitionHash>) -> Self {
        let mut h = Self::OFFSET;
        let mut eat = |bytes: &[u8]| {
            for b in bytes {
                h ^= u64::from(*b);
                h = h.wrapping_mul(Self::PRIME);
            }
        };
        eat(definition.as_bytes());
        for c in callees {
            // A separator no definition text contains, so text and callees cannot run together.
            eat(&[0]);
            eat(&c.0.to_le_bytes());
        }
        DefinitionHash(h)
    }
}

impl fmt::Display for DefinitionHash {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

impl From<DefinitionHash> for String {
    fn from(h: DefinitionHash) -> String {
        h.to_string()
    }
}

impl TryFrom<String> for DefinitionHash {
    type Error = String;

    fn try_from(s: String) -> Result<Self, String> {
        if s.len() == 16 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
            u64::from_str_radix(&s, 16)
                .map(DefinitionHash)
                .map_err(|e| e.to_string())
        } else {
            Err(format!(
                "a definition hash is 16 hexadecimal digits, not {s:?}"
            ))
        }
    }
}

/// A checked, compiled operator.
#[derive(Clone, Debug)]
pub struct Operator {
    pub(crate) name: String,
    /// The domain it belongs to (shared by the operators of the domain).
    pub(crate) domain: Arc<Domain>,
    pub(crate) space: Space,
    pub(crate) doc: String,
    pub(crate) params: Vec<Param>,
    pub(crate) definition: String,
    pub(crate) hash: DefinitionHash,
    /// Where it was defined: `operators/positioning.adv at line 12`.
    pub(crate) origin: String,
    /// Whether it comes from the standard library (`operators/*.adv`).
    pub(crate) standard: bool,
    /// The per-point stages it expands to (1 for a block), at most `check::MAX_STAGES`.
    pub(crate) stages: u64,
    pub(crate) body: OpBody,
}

impl Drop for Operator {
    /// A chain of compositions is as long as its file (each holding the one it calls), and the
    /// default drop would recurse once per link: unlink the chain with a stack instead.
    fn drop(&mut self) {
        let OpBody::Pipeline(stages) = &mut self.body else {
            return;
        };
        let mut stack: Vec<Arc<Operator>> = stages.drain(..).map(|s| s.op).collect();
        while let Some(op) = stack.pop() {
            if let Some(mut last) = Arc::into_inner(op)
                && let OpBody::Pipeline(stages) = &mut last.body
            {
                stack.extend(stages.drain(..).map(|s| s.op));
            }
        }
    }
}

/// What applying an operator runs.
#[derive(Clone, Debug)]
pub(crate) enum OpBody {
    /// A per-point program.
    Block(code::Program),
    /// Operators applied in sequence on the same chunk.
    Pipeline(Vec<Stage>),
}

/// One step of a composition: the callee as it was when the composition was checked (a later
/// operator of the same name does not change it) and, per callee parameter, the argument (an
/// expression over the caller's parameters and `n`) or `None` for its default.
#[derive(Clone, Debug)]
pub(crate) struct Stage {
    pub op: Arc<Operator>,
    pub args: Vec<Option<Ir>>,
}

impl Operator {
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Name of the domain it belongs to.
    pub fn domain(&self) -> &str {
        &self.domain.name
    }

    /// The domain it belongs to, with its dimensions.
    pub fn domain_decl(&self) -> &Domain {
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

    /// The hash of the definition (and of the operators it calls): equal hashes, same operator.
    pub fn hash(&self) -> DefinitionHash {
        self.hash
    }

    /// What the session's `help NAME` shows, and the language server's hover: the signature,
    /// the space it modifies, then the doc comment.
    pub fn help(&self) -> String {
        format!("{}  (on {})\n{}", self.signature(), self.space, self.doc)
    }

    /// `speed_up(rate = 0.2 in [0, 1])`
    pub fn signature(&self) -> String {
        if self.params.is_empty() {
            return self.name.clone();
        }
        let ps: Vec<String> = self.params.iter().map(|p| p.to_string()).collect();
        format!("{}({})", self.name, ps.join(", "))
    }

    /// Where it was defined, e.g. `operators/positioning.adv at line 12`.
    pub fn origin(&self) -> &str {
        &self.origin
    }

    /// Whether it comes from the standard library (`operators/*.adv`).
    pub fn is_standard(&self) -> bool {
        self.standard
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

/// Checked domains and operators, ready to bind and apply.
#[derive(Clone, Debug, Default)]
pub struct OperatorSet {
    pub(crate) domains: Vec<Domain>,
    /// The domains that are also tasks, checked.
    pub(crate) tasks: Vec<Arc<task::TaskDef>>,
    /// In definition order; a later operator with the same domain and name shadows an earlier one
    /// (a user's file over the standard library) while compositions keep what they were built on.
    pub(crate) ops: Vec<Arc<Operator>>,
    /// `(domain, name)` to the index of the visible operator of that name.
    pub(crate) visible: HashMap<(String, String), usize>,
}

impl OperatorSet {
    pub(crate) fn reindex(&mut self) {
        self.visible.clear();
        for (i, o) in self.ops.iter().enumerate() {
            self.visible
                .insert((o.domain.name.clone(), o.name.clone()), i);
        }
    }

    fn is_visible(&self, i: usize) -> bool {
        let o = &self.ops[i];
        self.find(&o.domain.name, &o.name) == Some(i)
    }

    pub fn domains(&self) -> &[Domain] {
        &self.domains
    }

    pub fn domain(&self, name: &str) -> Option<&Domain> {
        self.domains.iter().find(|d| d.name == name)
    }

    /// The domains that are also tasks.
    pub fn tasks(&self) -> &[Arc<task::TaskDef>] {
        &self.tasks
    }

    /// The task declared by the domain `name`.
    pub fn task(&self, name: &str) -> Option<&Arc<task::TaskDef>> {
        self.tasks.iter().find(|t| t.name() == name)
    }

    /// Index of the visible operator `name` of `domain`.
    pub(crate) fn find(&self, domain: &str, name: &str) -> Option<usize> {
        self.visible
            .get(&(domain.to_string(), name.to_string()))
            .copied()
    }

    pub(crate) fn op(&self, index: usize) -> &Arc<Operator> {
        &self.ops[index]
    }

    /// The operator `name` of `domain`.
    pub fn operator(&self, domain: &str, name: &str) -> Option<&Operator> {
        self.find(domain, name).map(|i| &*self.ops[i])
    }

    /// The visible operators of `domain`, in definition order.
    pub fn operators<'s>(&'s self, domain: &'s str) -> impl Iterator<Item = &'s Operator> + 's {
        self.ops
            .iter()
            .enumerate()
            .filter(move |(i, o)| o.domain.name == domain && self.is_visible(*i))
            .map(|(_, o)| &**o)
    }

    /// Names of the visible operators of `domain` (what a REPL completes).
    pub fn operator_names(&self, domain: &str) -> Vec<&str> {
        self.ops
            .iter()
            .enumerate()
            .filter(|(i, o)| o.domain.name == domain && self.is_visible(*i))
            .map(|(_, o)| o.name.as_str())
            .collect()
    }

    /// Number of visible operators over all domains.
    pub fn operator_count(&self) -> usize {
        self.visible.len()
    }

    /// Domains that define an operator called `name`.
    pub(crate) fn domains_with(&self, name: &str) -> Vec<&str> {
        let mut v: Vec<&str> = self
            .ops
            .iter()
            .filter(|o| o.name == name)
            .map(|o| o.domain.name.as_str())
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }
}

/// An operator with every parameter bound: what the interpreter runs. Built only by `check::bind`
/// (from an invocation) and `check::rebind` (from recorded advice).
#[derive(Clone, Debug)]
pub struct Call {
    pub(crate) op: Arc<Operator>,
    /// One value per parameter of `op`, in declaration order, within its limits.
    pub(crate) params: Vec<f64>,
    /// `op` and every operator its composition reaches, parents before children and stages in
    /// order, so the per-point ones (blocks) in this order are the stages to run.
    pub(crate) frames: Vec<Frame>,
}

/// One operator reached by a call: the call's own (frame 0), or stage `stage` of the composition
/// in frame `parent`, whose arguments (expressions of the parent's parameters and `n`) give its
/// parameter values once the chunk's length is known.
#[derive(Clone, Debug)]
pub(crate) struct Frame {
    pub op: Arc<Operator>,
    pub parent: usize,
    pub stage: usize,
}

impl Call {
    /// The operator called.
    pub fn operator(&self) -> &Operator {
        &self.op
    }

    /// The value of every parameter, in declaration order.
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// What applying this call to `chunk` leaves in a point's provenance.
    pub fn applied_to(&self, chunk: Chunk) -> AppliedAdvice {
        let op = &self.op;
        AppliedAdvice {
            operator: op.name.clone(),
            domain: op.domain.name.clone(),
            params: op
                .params
                .iter()
                .zip(&self.params)
                .map(|(p, &value)| ParamValue {
                    name: p.name.clone(),
                    value,
                })
                .collect(),
            chunk,
            space: op.space,
            definition: op.definition.clone(),
            hash: Some(op.hash),
        }
    }
}

impl fmt::Display for Call {
    /// `speed_up(rate = 0.2)`: every parameter named.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = self.op.params.iter().map(|p| p.name.as_str());
        write_call(f, &self.op.name, names.zip(self.params.iter().copied()))
    }
}

fn write_call<'a>(
    f: &mut fmt::Formatter<'_>,
    name: &str,
    params: impl ExactSizeIterator<Item = (&'a str, f64)>,
) -> fmt::Result {
    f.write_str(name)?;
    if params.len() == 0 {
        return Ok(());
    }
    f.write_str("(")?;
    for (i, (p, v)) in params.enumerate() {
        if i > 0 {
            f.write_str(", ")?;
        }
        write!(f, "{p} = {}", syntax::print::number(v))?;
    }
    f.write_str(")")
}

/// The value given to one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamValue {
    pub name: String,
    pub value: f64,
}

/// What was applied, recorded with the points it produced: the bound call's values and the
/// definition's hash, enough to re-synthesize the points exactly from the same trace
/// (`check::rebind`, then `interp::apply`) or to re-parameterise the advice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AppliedAdvice {
    pub operator: String,
    pub domain: String,
    /// Every parameter of the operator, defaults filled in, in declaration order.
    pub params: Vec<ParamValue>,
    pub chunk: Chunk,
    /// The space the operator modified.
    pub space: Space,
    /// The operator's definition in canonical text when it was applied (for people: `why`, a
    /// saved dataset).
    pub definition: String,
    /// The hash of the operator when it was applied, to tell whether the operator of that name is
    /// still the same. `None` in records written before hashes were kept (their `definition` text
    /// is compared instead).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hash: Option<DefinitionHash>,
}

impl AppliedAdvice {
    /// The call that reproduces this advice, every parameter named: `speed_up(rate = 0.2)`.
    /// Printed from the recorded values, never parsed back.
    pub fn invocation(&self) -> String {
        struct Text<'a>(&'a AppliedAdvice);
        impl fmt::Display for Text<'_> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                let ps = self.0.params.iter().map(|p| (p.name.as_str(), p.value));
                write_call(f, &self.0.operator, ps)
            }
        }
        Text(self).to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn definition_hashes_are_fixed_and_see_callees() {
        // FNV-1a 64 of the empty string and of "a": the published test vectors.
        assert_eq!(DefinitionHash::of("", []).to_string(), "cbf29ce484222325");
        assert_eq!(DefinitionHash::of("a", []).to_string(), "af63dc4c8601ec8c");
        let callee = DefinitionHash::of("x", []);
        let other = DefinitionHash::of("y", []);
        assert_ne!(
            DefinitionHash::of("a", [callee]),
            DefinitionHash::of("a", [other])
        );
        assert_ne!(
            DefinitionHash::of("a", [callee]),
            DefinitionHash::of("a", [])
        );
    }

    #[test]
    fn definition_hashes_round_trip_as_hex_text() {
        let h = DefinitionHash::of("operator stop for d on action { u = 0 }", []);
        let json = serde_json::to_string(&h).unwrap();
        assert_eq!(json, format!("\"{h}\""));
        assert_eq!(serde_json::from_str::<DefinitionHash>(&json).unwrap(), h);
        assert!(serde_json::from_str::<DefinitionHash>("\"12\"").is_err());
        assert!(serde_json::from_str::<DefinitionHash>("\"zzzzzzzzzzzzzzzz\"").is_err());
    }
}
