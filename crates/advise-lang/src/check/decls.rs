//! Declarations: domains (dimensions, units, limits), operator signatures (parameters, defaults,
//! limits), constants, and how a redeclared domain differs from the standard one.

use std::collections::{HashMap, HashSet};

use super::names::{Dom, RESERVED, Scope, Ty};
use super::*;
use crate::domain::{Dim, Limits, Space};

impl Checker<'_> {
    pub(super) fn domain(&mut self, f: usize, d: &DomainDecl) -> Domain {
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
                        span: self.at(f, dim.name.span),
                    },
                );
            }
            if !seen.insert(name) {
                self.err(
                    f,
                    dim.name.span,
                    CheckError::DuplicateDimension {
                        name: name.into(),
                        span: self.at(f, dim.name.span),
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

    pub(super) fn limits(&mut self, f: usize, l: &LimitsExpr) -> Option<Limits> {
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
                    span: self.at(f, l.span),
                },
            );
            return None;
        }
        Some(Limits::new(lo, hi))
    }

    /// Evaluate a constant expression, reporting why it is not one.
    pub(super) fn constant(&mut self, f: usize, e: &Expr, what: &str) -> Option<f64> {
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
                    span: self.at(f, e.span),
                },
            );
            return None;
        }
        Some(v)
    }

    pub(super) fn signature<'f>(
        &mut self,
        f: usize,
        o: &'f OperatorDecl,
        by_name: &HashMap<String, usize>,
        domains: &[Dom],
    ) -> Sig<'f> {
        let domain = by_name.get(&o.domain.name).copied();
        // Said once per file: every operator of a file names its domain, and one missing domain
        // is one mistake (the file that declares it was not passed).
        let said = || {
            self.errors.iter().any(|(file, _, e)| {
                *file == f
                    && matches!(e, ParseOrCheckError::Check(CheckError::UnknownDomain { name, .. })
                        if *name == o.domain.name)
            })
        };
        if domain.is_none() && !self.full() && !said() {
            let names: Vec<&str> = domains.iter().map(|d| d.name.as_str()).collect();
            let help = match suggest(&o.domain.name, names.iter().copied()) {
                Some(s) => format!("did you mean `{s}`?"),
                None => format!(
                    "every operator `for {0}` of this file needs it: check with the file that declares it (`advise check --tasks {0}.adv FILE`; in a session, `tasks {0}.adv` first), or declare it with `domain {0} {{ observe ... act ... }}`{1}",
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
                    span: self.at(f, o.domain.span),
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
                    span: self.at(f, extra.name.span),
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
                        span: self.at(f, p.name.span),
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
                        span: self.at(f, p.name.span),
                    },
                );
            }
            if params.iter().any(|q| q.name == name) {
                self.err(
                    f,
                    p.name.span,
                    CheckError::DuplicateParameter {
                        name: name.into(),
                        span: self.at(f, p.name.span),
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
                        help: widen(name, l),
                        span: self.at(f, e.span),
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
}

/// How two declarations of a domain differ, in words; `None` when they agree.
pub(super) fn domain_difference(a: &Domain, b: &Domain) -> Option<String> {
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

/// The help of a value outside a parameter's limits in a file: either side may be wrong.
pub(super) fn widen(param: &str, l: Limits) -> String {
    format!(
        "write a value in [{}, {}] or widen the limits of `{param}`",
        l.lo, l.hi
    )
}
