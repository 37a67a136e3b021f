//! Binding arguments to parameters, the one place it happens: an invocation typed by a teacher
//! ([`bind`]), recorded advice applied again ([`rebind`]) and a composition's call of another
//! operator (the checker's `stage`) all go through [`Binder`]: by position or by name, each
//! parameter at most once, every parameter without a default given, literal values within limits.
//! [`bind`] and [`rebind`] also expand a composition into the frames the interpreter runs.

use std::sync::Arc;

use super::error::CheckError;
use super::hint;
use crate::diag::{Loc, SourceId, SourceMap};
use crate::program::{Call, Frame, OpBody, Operator, OperatorSet, Param};
use crate::syntax::Invocation;
use crate::syntax::ast::{Ident, Span};

/// The parameters of an operator being called, and the source its call is written in.
pub(crate) struct Binder<'a> {
    pub operator: &'a str,
    pub params: &'a [Param],
    /// The source the call's spans are in.
    pub at: SourceId,
    /// Whether the call was typed at the prompt (or recorded from there) rather than written in
    /// a composition: only then is the value, not the limits, the thing to change.
    pub typed: bool,
}

impl Binder<'_> {
    fn loc(&self, span: Span) -> Loc {
        self.at.at(span.start..span.end)
    }

    /// "`speed_up(rate = 0.2 in [0, 4])`", or that it takes no arguments.
    fn signature(&self) -> String {
        if self.params.is_empty() {
            format!("`{}` takes no arguments", self.operator)
        } else {
            let ps: Vec<String> = self.params.iter().map(|p| p.to_string()).collect();
            format!("`{}({})`", self.operator, ps.join(", "))
        }
    }

    /// The parameter that argument `pos` of `count` fills (by position, or by `name` when it has
    /// one), marked in `given`; or the mistake and where it is.
    pub fn slot(
        &self,
        pos: usize,
        count: usize,
        name: Option<&Ident>,
        span: Span,
        given: &mut [bool],
    ) -> Result<usize, (Span, CheckError)> {
        let slot = match name {
            None if pos >= self.params.len() => {
                return Err((
                    span,
                    CheckError::TooManyArguments {
                        operator: self.operator.into(),
                        expected: self.params.len(),
                        found: count,
                        signature: self.signature(),
                        span: self.loc(span),
                    },
                ));
            }
            None => pos,
            Some(n) => match self.params.iter().position(|p| p.name == n.name) {
                Some(s) => s,
                None => {
                    let names: Vec<&str> = self.params.iter().map(|p| p.name.as_str()).collect();
                    let help = hint(
                        &n.name,
                        &format!("parameters of `{}`", self.operator),
                        &names,
                    );
                    return Err((
                        n.span,
                        CheckError::UnknownParameter {
                            name: n.name.clone(),
                            operator: self.operator.into(),
                            help,
                            span: self.loc(n.span),
                        },
                    ));
                }
            },
        };
        if given[slot] {
            return Err((
                span,
                CheckError::DuplicateArgument {
                    name: self.params[slot].name.clone(),
                    span: self.loc(span),
                },
            ));
        }
        given[slot] = true;
        Ok(slot)
    }

    /// Refuse a known value outside the limits of parameter `slot`.
    pub fn in_range(&self, slot: usize, value: f64, span: Span) -> Result<(), CheckError> {
        let p = &self.params[slot];
        match p.limits {
            Some(l) if !l.contains(value) => Err(CheckError::ParamOutOfRange {
                what: "argument".into(),
                param: p.name.clone(),
                value,
                lo: l.lo,
                hi: l.hi,
                help: if self.typed {
                    format!("give `{}` a value in [{}, {}]", p.name, l.lo, l.hi)
                } else {
                    super::decls::widen(&p.name, l)
                },
                span: self.loc(span),
            }),
            _ => Ok(()),
        }
    }

    /// The parameters neither `given` nor defaulted, as errors at `span` (the call).
    pub fn missing<'b>(
        &'b self,
        given: &'b [bool],
        span: Span,
    ) -> impl Iterator<Item = CheckError> + 'b {
        self.params
            .iter()
            .zip(given)
            .filter(|(p, g)| !**g && p.default.is_none())
            .map(move |(p, _)| CheckError::MissingArgument {
                operator: self.operator.into(),
                param: p.name.clone(),
                span: self.loc(span),
            })
    }
}

/// Bind the operator `inv` names, among those of `domain` in `set`, to its arguments: every
/// parameter's value (defaults filled in, limits checked) and its composition expanded.
/// `inv`'s text joins `sources` as `advice`, for the diagnostics.
pub fn bind(
    sources: &mut SourceMap,
    set: &OperatorSet,
    domain: &str,
    inv: &Invocation,
) -> Result<Call, CheckError> {
    let at = sources.add("advice", inv.text.as_str());
    let Some(index) = set.find(domain, &inv.name.name) else {
        let names = set.operator_names(domain);
        let what = format!("operators for `{domain}`");
        let help = match set.domains_with(&inv.name.name).first() {
            Some(o) => format!(
                "`{}` is an operator for the `{o}` domain; {}",
                inv.name.name,
                hint(&inv.name.name, &what, &names)
            ),
            None => hint(&inv.name.name, &what, &names),
        };
        return Err(CheckError::UnknownOperator {
            name: inv.name.name.clone(),
            domain: domain.into(),
            help,
            span: at.at(inv.name.span.start..inv.name.span.end),
        });
    };
    bind_to(set.op(index), inv, at)
}

fn bind_to(op: &Arc<Operator>, inv: &Invocation, at: SourceId) -> Result<Call, CheckError> {
    let b = Binder {
        operator: op.name(),
        params: op.params(),
        at,
        typed: true,
    };
    let mut given = vec![false; op.params().len()];
    let mut values: Vec<Option<f64>> = vec![None; op.params().len()];
    for (pos, a) in inv.args.iter().enumerate() {
        let slot = b
            .slot(pos, inv.args.len(), a.name.as_ref(), a.span, &mut given)
            .map_err(|(_, e)| e)?;
        b.in_range(slot, a.value, a.span)?;
        values[slot] = Some(a.value);
    }
    if let Some(e) = b.missing(&given, inv.name.span).next() {
        return Err(e);
    }
    let params = op
        .params()
        .iter()
        .zip(values)
        .map(|(p, v)| v.or(p.default).unwrap_or(f64::NAN))
        .collect();
    Ok(Call {
        op: op.clone(),
        params,
        frames: frames(op),
    })
}

/// `op` and every operator its composition reaches, depth first, parents before children and
/// stages in order. The checker bounds the stages (`MAX_STAGES`), not the nesting, so this walks
/// with its own stack.
fn frames(op: &Arc<Operator>) -> Vec<Frame> {
    let mut frames = vec![Frame {
        op: op.clone(),
        parent: 0,
        stage: 0,
    }];
    // Each entry: a frame and its next stage.
    let mut stack: Vec<(usize, usize)> = vec![(0, 0)];
    while let Some((at, next)) = stack.pop() {
        let OpBody::Pipeline(stages) = &frames[at].op.body else {
            continue;
        };
        let Some(st) = stages.get(next) else {
            continue;
        };
        let child = Frame {
            op: st.op.clone(),
            parent: at,
            stage: next,
        };
        stack.push((at, next + 1));
        frames.push(child);
        stack.push((frames.len() - 1, 0));
    }
    frames
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::Source;
    use crate::syntax::parse_invocation;
    use miette::Diagnostic;

    fn set_with(text: &str) -> OperatorSet {
        OperatorSet::standard()
            .merge(&[Source::new("user.adv", text)])
            .unwrap_or_else(|e| panic!("{}", crate::check::render_all(&e)))
    }

    fn code(e: &CheckError) -> String {
        e.code().map(|c| c.to_string()).unwrap_or_default()
    }

    #[test]
    fn an_invocation_binds_by_position_and_name_with_defaults() {
        let set = OperatorSet::standard();
        let inv = parse_invocation("start_turning_earlier(steps = 4)").unwrap();
        let call = bind(&mut SourceMap::new(), &set, "positioning", &inv).unwrap();
        assert_eq!(call.params(), &[4.0]);
        assert_eq!(call.to_string(), "start_turning_earlier(steps = 4)");
        let call = bind(
            &mut SourceMap::new(),
            &set,
            "positioning",
            &Invocation::bare("speed_up"),
        )
        .unwrap();
        assert_eq!(call.params(), &[0.2]);
        // A composition is expanded: itself, then its two stages in order.
        let call = bind(
            &mut SourceMap::new(),
            &set,
            "positioning",
            &Invocation::bare("brake_straight"),
        )
        .unwrap();
        let names: Vec<&str> = call.frames.iter().map(|f| f.op.name()).collect();
        assert_eq!(
            names,
            ["brake_straight", "translational_deceleration", "no_turning"]
        );
    }

    #[test]
    fn binding_mistakes_have_the_checkers_codes() {
        let set = OperatorSet::standard();
        let cases = [
            ("speed_upp", "advise::check::unknown_operator"),
            ("speed_up(rat = 1)", "advise::check::unknown_parameter"),
            ("speed_up(7)", "advise::check::parameter_out_of_range"),
            ("speed_up(1, 2)", "advise::check::wrong_arity"),
            ("speed_up(1, rate = 2)", "advise::check::duplicate_argument"),
        ];
        for (text, want) in cases {
            let inv = parse_invocation(text).unwrap();
            let e = bind(&mut SourceMap::new(), &set, "positioning", &inv).unwrap_err();
            assert_eq!(code(&e), want, "{text}");
        }
        let set = set_with("operator push(by) for positioning on action { trans += by }");
        let e = bind(
            &mut SourceMap::new(),
            &set,
            "positioning",
            &Invocation::bare("push"),
        )
        .unwrap_err();
        assert_eq!(code(&e), "advise::check::missing_argument");
        // A domain without operators: nothing to bind to, and the hint says where it is.
        let e = bind(
            &mut SourceMap::new(),
            &set,
            "nowhere",
            &Invocation::bare("push"),
        )
        .unwrap_err();
        assert!(
            matches!(&e, CheckError::UnknownOperator { help, .. } if help == "`push` is an operator for the `positioning` domain; there are no operators for `nowhere`"),
            "{e:?}"
        );
    }

    #[test]
    fn a_compositions_hash_sees_the_operators_it_calls() {
        let text = |body: &str| {
            format!(
                "operator a for positioning on action {{ {body} }}\noperator b for positioning on action = a\n"
            )
        };
        let one = set_with(&text("trans = 0.1"));
        let two = set_with(&text("trans = 0.2"));
        let b1 = one.operator("positioning", "b").unwrap();
        let b2 = two.operator("positioning", "b").unwrap();
        assert_eq!(b1.definition(), b2.definition());
        assert_ne!(b1.hash(), b2.hash());
        // And the same text checked twice hashes the same.
        let again = set_with(&text("trans = 0.1"));
        assert_eq!(
            again.operator("positioning", "b").unwrap().hash(),
            b1.hash()
        );
    }
}
