//! Names in expressions: resolving an expression to [`Ir`] in its scope (constants, an operator's
//! body, a composition's arguments), with its type, and "did you mean" for what is not there.

use std::collections::HashMap;
use std::ops::Deref;

use super::*;
use crate::domain::Space;
use crate::program::ir::{Func, Ir};
use crate::program::task::WindowKind;

pub(super) const RESERVED: [(&str, &str); 3] = [
    ("k", "the index of the point in the chunk"),
    ("n", "the number of points in the chunk"),
    ("pi", "the constant 3.14159..."),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Ty {
    Num,
    Bool,
    /// Already reported; compatible with everything so one mistake gives one diagnostic.
    Err,
}

impl Ty {
    pub(super) fn word(self) -> &'static str {
        match self {
            Ty::Num => "a number",
            Ty::Bool => "a condition",
            Ty::Err => "an error",
        }
    }
}

/// What names mean where an expression is resolved.
#[derive(Clone, Copy)]
pub(super) enum Scope<'a> {
    /// Limits and defaults: numbers, `pi` and arithmetic only.
    Const,
    /// An operator body: dimensions, parameters, `k`, `n`.
    Point {
        domain: &'a Dom,
        params: &'a [Param],
    },
    /// An argument in a composition: the caller's parameters and `n`.
    Arg {
        domain: &'a Dom,
        params: &'a [Param],
    },
    /// A clause of a task declaration: the task's named values that clause may read.
    Task(&'a super::task_scope::TaskScope<'a>),
}

/// A domain with its dimensions indexed by name, so that resolving a name does not scan them.
/// It owns what it indexes, so the checker can keep one for each domain as domains are read.
pub(super) struct Dom {
    domain: Arc<Domain>,
    names: HashMap<String, (Space, usize)>,
}

impl Dom {
    /// The domain itself.
    pub(super) fn domain(&self) -> &Domain {
        &self.domain
    }

    /// The domain, shared.
    pub(super) fn shared(&self) -> &Arc<Domain> {
        &self.domain
    }

    pub(super) fn new(domain: Domain) -> Dom {
        let mut names = HashMap::new();
        for space in [Space::Observation, Space::Action] {
            for (i, d) in domain.dims(space).iter().enumerate() {
                names.entry(d.name.clone()).or_insert((space, i));
            }
        }
        Dom {
            domain: Arc::new(domain),
            names,
        }
    }

    /// The space and index of the dimension `name` (as [`Domain::find`], by hashing).
    pub(super) fn find(&self, name: &str) -> Option<(Space, usize)> {
        self.names.get(name).copied()
    }
}

impl Deref for Dom {
    type Target = Domain;

    fn deref(&self) -> &Domain {
        &self.domain
    }
}

impl Checker<'_> {
    /// Report `found` where `want` was needed; `true` when it fits.
    pub(super) fn expect(
        &mut self,
        f: usize,
        e: &Expr,
        found: Ty,
        want: Ty,
        help: Option<&str>,
    ) -> bool {
        if found == want || found == Ty::Err {
            return true;
        }
        // A comparison where a number belongs (`let near = gr < 0.2`): the number it meant is
        // chosen by the condition.
        let help = help.or((found == Ty::Bool && want == Ty::Num).then_some(
            "a comparison is a condition, not a number: to choose a number by it, write \
             `if(CONDITION, THEN, ELSE)`, e.g. `if(d < 0.2, 1, 0)`",
        ));
        self.err(
            f,
            e.span,
            CheckError::TypeMismatch {
                expected: want.word().into(),
                found: found.word().into(),
                help: help.map(str::to_string),
                span: self.at(f, e.span),
            },
        );
        false
    }

    /// An expression resolved in `scope` to its IR and type, every mistake reported.
    ///
    /// Over 150 lines because it is one match arm per expression kind, each short; the dispatch
    /// stays in one place.
    pub(super) fn resolve(&mut self, f: usize, scope: Scope<'_>, e: &Expr, what: &str) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        if self.full() {
            return bad;
        }
        match &e.kind {
            ExprKind::Num(v) => (Ir::Num(*v), Ty::Num),
            ExprKind::Var(name) => self.var(f, scope, name, e.span, what),
            ExprKind::At { dim, .. } if matches!(scope, Scope::Task(_)) => {
                self.err(
                    f,
                    e.span,
                    CheckError::TaskNameNotHere {
                        name: dim.name.clone(),
                        context:
                            "a task (`NAME[offset]` reads other points of a chunk, in operators)"
                                .into(),
                        help: "a task reads the previous control step with `prev(NAME)`".into(),
                        span: self.at(f, e.span),
                    },
                );
                bad
            }
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
                                span: self.at(f, offset.span),
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
                                span: self.at(f, dim.span),
                            },
                        );
                        bad
                    }
                    None => {
                        let names = domain.names();
                        let help = hint(&dim.name, "dimensions", &names);
                        self.err(
                            f,
                            dim.span,
                            CheckError::UnknownDimension {
                                name: dim.name.clone(),
                                domain: domain.name.clone(),
                                help,
                                span: self.at(f, dim.span),
                            },
                        );
                        bad
                    }
                }
            }
            ExprKind::Call { func, args }
                if func.name == "prev" && matches!(scope, Scope::Task(_)) =>
            {
                let Scope::Task(ts) = scope else { return bad };
                self.task_prev(f, ts, args, e.span)
            }
            ExprKind::Call { func, args }
                if matches!(scope, Scope::Task(_)) && WindowKind::named(&func.name).is_some() =>
            {
                let Scope::Task(ts) = scope else { return bad };
                let Some(kind) = WindowKind::named(&func.name) else {
                    return bad;
                };
                self.task_window(f, ts, kind, args, e.span)
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
                            span: self.at(f, func.span),
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
                            span: self.at(f, e.span),
                        },
                    );
                    return bad;
                }
                let mut ok = true;
                for (i, (a, (_, ty))) in args.iter().zip(&resolved).enumerate() {
                    let want = if fun.takes_condition(i) {
                        Ty::Bool
                    } else {
                        Ty::Num
                    };
                    ok &= self.expect(f, a, *ty, want, None);
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

    pub(super) fn var(
        &mut self,
        f: usize,
        scope: Scope<'_>,
        name: &str,
        span: Span,
        what: &str,
    ) -> (Ir, Ty) {
        let bad = (Ir::Num(f64::NAN), Ty::Err);
        if name == "pi" {
            return (Ir::Num(std::f64::consts::PI), Ty::Num);
        }
        if let Scope::Task(ts) = scope {
            return self.task_var(f, ts, name, span);
        }
        let params: &[Param] = match scope {
            Scope::Const | Scope::Task(_) => &[],
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
                domain.names()
            }
            Scope::Arg { domain, .. } => {
                if domain.find(name).is_some() {
                    self.not_here(f, scope, name, span, what);
                    return bad;
                }
                Vec::new()
            }
            Scope::Const | Scope::Task(_) => Vec::new(),
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
                Scope::Const | Scope::Task(_) => {
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
                span: self.at(f, span),
            },
        );
        bad
    }

    /// A name that exists but cannot be used in this scope.
    pub(super) fn not_here(
        &mut self,
        f: usize,
        scope: Scope<'_>,
        name: &str,
        span: Span,
        what: &str,
    ) {
        let e = match scope {
            Scope::Arg { .. } => CheckError::PerPointArgument {
                name: name.into(),
                span: self.at(f, span),
            },
            _ => CheckError::NotConstant {
                what: if what.is_empty() {
                    "this".into()
                } else {
                    what.into()
                },
                name: name.into(),
                span: self.at(f, span),
            },
        };
        self.err(f, span, e);
    }
}

/// The built-in domain other than `exclude` that has a dimension `name` (for hints).
pub(super) fn other_domain_with_dim(name: &str, exclude: &str) -> Option<&'static str> {
    standard::standard_domains()
        .iter()
        .find(|d| d.name != exclude && d.find(name).is_some())
        .map(|d| d.name.as_str())
}
