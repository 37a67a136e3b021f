//! Compositions: the operators a composition calls (bound through the one binder), cycles among
//! them, and how many per-point stages each expands to.

use std::collections::HashMap;

use super::bind::Binder;
use super::names::{Dom, Scope, Ty};
use super::*;
use crate::domain::Space;
use crate::program::ir::Ir;

/// One step of a composition being checked: the callee (an index into the base set's operators,
/// then the signatures being checked) and, per callee parameter, the bound argument or `None` for
/// its default.
#[derive(Clone, Debug)]
pub(super) struct Step {
    pub op: usize,
    pub args: Vec<Option<Ir>>,
}

/// The operators a composition may call: those being checked and those of the base set.
pub(super) struct Known<'k, 'f> {
    pub(super) sigs: &'k [Sig<'f>],
    /// `(domain, name)` to the first signature of that name.
    pub(super) first: &'k HashMap<(usize, &'f str), usize>,
    pub(super) base: Option<&'k OperatorSet>,
    pub(super) base_ops: usize,
}

/// What a composition needs to know about an operator it calls.
pub(super) struct CalleeInfo<'x> {
    name: &'x str,
    space: Space,
    params: &'x [Param],
}

impl Checker<'_> {
    /// How many per-point stages each operator of `sigs` expands to; reports those past
    /// [`MAX_STAGES`] whose callees are all within it (the rest only inherit the excess). Needs
    /// bodies without cycles. Iterative: a chain of compositions may be as long as the file.
    pub(super) fn expansions(
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
                    span: self.at(f, sig.decl.name.span),
                },
            );
        }
        count
    }

    pub(super) fn callee<'x>(
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

    pub(super) fn stage(
        &mut self,
        known: &Known<'_, '_>,
        i: usize,
        c: &crate::syntax::ast::Call,
        domain: &Dom,
    ) -> Option<Step> {
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
                        span: self.at(f, c.name.span),
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
                    span: self.at(f, c.name.span),
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
                    span: self.at(f, c.name.span),
                },
            );
            ok = false;
        }
        let cparams = callee.params;
        let binder = Binder {
            operator: callee.name,
            params: cparams,
            at: self.sources[f].id,
            typed: false,
        };
        let mut args: Vec<Option<Ir>> = vec![None; cparams.len()];
        let mut given = vec![false; cparams.len()];
        for (pos, a) in c.args.iter().enumerate() {
            let slot = match binder.slot(pos, c.args.len(), a.name.as_ref(), a.span, &mut given) {
                Ok(slot) => slot,
                Err((span, e)) => {
                    self.err(f, span, e);
                    ok = false;
                    continue;
                }
            };
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
                && let Err(e) = binder.in_range(slot, ir.eval_uniform(&[], f64::NAN), a.value.span)
            {
                self.err(f, a.value.span, e);
                ok = false;
            }
            args[slot] = Some(ir);
        }
        for e in binder.missing(&given, c.span) {
            self.err(f, c.span, e);
            ok = false;
        }
        ok.then_some(Step { op: idx, args })
    }

    /// Report compositions that lead back to themselves.
    pub(super) fn cycles(&mut self, sigs: &[Sig<'_>], bodies: &[Option<Body2>], base_ops: usize) {
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
                                    span: self.at(f, span),
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
}

/// A stage count for a message (a saturated count is "more than 10^19").
pub(super) fn count_text(n: u64) -> String {
    if n == u64::MAX {
        "more than 10^19".into()
    } else {
        n.to_string()
    }
}
