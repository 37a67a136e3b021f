//! An operator's body: its guard and statements resolved, their targets and literal values checked,
//! its size bounded; or, for a composition, its stages.

use std::collections::HashSet;

use super::names::{Dom, Scope, Ty, other_domain_with_dim};
use super::*;
use crate::domain::Space;
use crate::program::ir::{BlockIr, Ir};

impl Checker<'_> {
    pub(super) fn body(&mut self, known: &Known<'_, '_>, i: usize, domain: &Dom) -> Option<Body2> {
        let sig = &known.sigs[i];
        let before = self.error_count();
        let body = match &sig.decl.body {
            Body::Block { .. } => return self.block(sig.file, sig.decl, &sig.params, domain),
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

    /// A per-point body (`o`'s, whose parameters are `params`), checked and compiled; `None`
    /// when it has errors (reported).
    pub(super) fn block(
        &mut self,
        f: usize,
        o: &OperatorDecl,
        params: &[Param],
        domain: &Dom,
    ) -> Option<Body2> {
        let Body::Block { guard, stmts } = &o.body else {
            return None;
        };
        let before = self.error_count();
        let scope = Scope::Point { domain, params };
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
                    span: self.at(f, o.name.span),
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
            let Some((space, idx)) = self.target(f, &s.target, o, params, domain) else {
                continue;
            };
            if !assigned.insert((space, idx)) {
                self.err(
                    f,
                    s.target.span,
                    CheckError::DuplicateAssignment {
                        name: s.target.name.clone(),
                        span: self.at(f, s.target.span),
                    },
                );
                continue;
            }
            let constant =
                (ty == Ty::Num && value.is_constant()).then(|| value.eval_uniform(&[], f64::NAN));
            if let Some(v) = constant.filter(|v| !v.is_finite()) {
                self.err(
                    f,
                    s.value.span,
                    CheckError::NotFinite {
                        value: v,
                        span: self.at(f, s.value.span),
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
                        span: self.at(f, s.value.span),
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
                    span: self.at(f, o.name.span),
                },
            );
        }
        if self.error_count() != before {
            return None;
        }
        // Compiled now, not after every body is checked: the program is what the set keeps,
        // and the IR of all of a large file's operators at once was a third of the check's
        // peak memory (issue 31).
        let block = BlockIr {
            space: o.space,
            guard,
            writes,
        };
        Some(Body2::Block(super::compile::compile(
            &block,
            domain.domain(),
        )))
    }

    /// Resolve the dimension a statement assigns to.
    pub(super) fn target(
        &mut self,
        f: usize,
        t: &Ident,
        o: &OperatorDecl,
        params: &[Param],
        domain: &Dom,
    ) -> Option<(Space, usize)> {
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
                            span: self.at(f, t.span),
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
                if params.iter().any(|p| p.name == t.name) {
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
                        span: self.at(f, t.span),
                    },
                );
                None
            }
        }
    }
}
