//! `advise test`: the examples in operators' doc comments, run.
//!
//! An example is one doc comment line of an operator:
//!
//! ```text
//! /// Example: speed_up(0.5) on {trans: 0.4, rot: 0.2} gives {trans: 0.6, rot: 0.3}
//! /// Example: translational_acceleration on 10 of {trans: 0.3} gives 10 of {trans: 0.33 .. 0.6}
//! /// Example: no_turning on {rot: 0.3}, {rot: 0}, {rot: -0.2} gives {rot: 0}, skipped, {rot: 0}
//! ```
//!
//! The invocation is what a teacher types; the chunk is a list of points, `N of {..}` repeating
//! one, each naming some of the domain's dimensions (the others are 0). The outputs are the same
//! number of points in order: `skipped` for a point the operator's guard leaves out, or the values
//! expected of the named dimensions (every other dimension must keep its input value). `a .. b` in
//! a repeated output is a ramp: point k of the N goes from a to b in equal steps. A value is exact
//! (to 1e-9, relatively) unless written `~0.33`: then it holds to half a unit of its last digit.

use std::ops::Range;

use miette::Diagnostic;
use thiserror::Error;

use crate::check::{self, OperatorSet};
use crate::diag::{Loc, SourceId, SourceMap};
use crate::domain::{Domain, Space};
use crate::program::Operator;
use crate::syntax::ast::{Item, OperatorDecl};
use crate::trace::{Chunk, Trace};

/// The most points one example may hold.
pub const MAX_POINTS: usize = 10_000;

/// What an example line starts with.
const MARK: &str = "Example:";

/// An example that does not hold, or cannot be read or run.
#[derive(Debug, Error, Diagnostic)]
pub enum ExampleError {
    #[error("the example of `{op}` does not hold: {what}")]
    #[diagnostic(code(advise::test::failed), help("{detail}"))]
    Failed {
        op: String,
        what: String,
        /// Expected against got, point by point.
        detail: String,
        #[label("this example")]
        at: Loc,
    },
    #[error("cannot read the example of `{op}`: {reason}")]
    #[diagnostic(
        code(advise::test::bad_example),
        help(
            "write `Example: INVOCATION on POINTS gives POINTS`, e.g. `Example: speed_up(0.5) on {{trans: 0.4}} gives {{trans: 0.6}}`; `N of {{..}}` repeats a point, `skipped` is a point the guard leaves out, `a .. b` a ramp over a repeated point, `~0.33` a rounded value"
        )
    )]
    Bad {
        op: String,
        reason: String,
        #[label("here")]
        at: Loc,
    },
}

/// The outcome of running the examples of some files.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Examples run.
    pub examples: usize,
    pub failures: Vec<ExampleError>,
    /// Operators of the files with no example, `domain/name`.
    pub without_example: Vec<String>,
    /// Every example run, in order (for callers that list passes as well as failures).
    pub ran: Vec<Ran>,
}

/// One example run: its operator (`domain/name`), its line (`Example: ...` to the line's end, a
/// byte range of source `id`) and, when it failed, the index of its error in
/// [`Outcome::failures`].
#[derive(Debug, Clone)]
pub struct Ran {
    pub op: String,
    pub id: SourceId,
    pub line: Range<usize>,
    pub failure: Option<usize>,
}

/// Run every example of the operators declared in `ids` (sources of `map`, already checked into
/// `set`).
pub fn run(map: &mut SourceMap, set: &OperatorSet, ids: &[SourceId]) -> Outcome {
    let mut outcome = Outcome::default();
    for &id in ids {
        let text = map.text(id).to_string();
        let Ok(file) = crate::syntax::parse(map.src(id)) else {
            continue;
        };
        for item in &file.items {
            let Item::Operator(decl) = item else { continue };
            let Some(op) = set.operator(&decl.domain.name, &decl.name.name) else {
                continue;
            };
            let examples = example_lines(&text, decl);
            if examples.is_empty() {
                outcome
                    .without_example
                    .push(format!("{}/{}", decl.domain.name, decl.name.name));
            }
            for range in examples {
                outcome.examples += 1;
                let at = |r: Range<usize>| id.at(range.start + r.start..range.start + r.end);
                let line = &text[range.clone()];
                let failure = run_one(map, set, op, line, &at).err().map(|e| {
                    outcome.failures.push(e);
                    outcome.failures.len() - 1
                });
                outcome.ran.push(Ran {
                    op: format!("{}/{}", decl.domain.name, decl.name.name),
                    id,
                    line: range.clone(),
                    failure,
                });
            }
        }
    }
    outcome
}

/// The byte ranges of the example lines of `decl`'s doc comment, from `Example:` to the line's
/// end.
fn example_lines(text: &str, decl: &OperatorDecl) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut at = decl.span.start;
    for line in text[decl.span.start..decl.span.end].split_inclusive('\n') {
        let trimmed = line.trim_start();
        let Some(doc) = trimmed.strip_prefix("///") else {
            if trimmed.starts_with("//") || trimmed.trim().is_empty() {
                at += line.len();
                continue;
            }
            break;
        };
        let body = doc.trim_start();
        if body.starts_with(MARK) {
            let start = at + (line.len() - body.len());
            let end = at + line.trim_end().len();
            out.push(start..end);
        }
        at += line.len();
    }
    out
}

/// A value expected of one dimension: exact, rounded (`~`), or a ramp over its group.
#[derive(Clone, Copy, Debug)]
struct Num {
    v: f64,
    tol: f64,
}

#[derive(Clone, Debug)]
enum Value {
    One(Num),
    Ramp(Num, Num),
}

/// One `{..}` of the example, with its repeat count; `None` values for `skipped`.
#[derive(Clone, Debug)]
struct Group {
    count: usize,
    dims: Option<Vec<(String, Range<usize>, Value)>>,
    span: Range<usize>,
}

struct Parser<'t> {
    text: &'t str,
    pos: usize,
}

type PResult<T> = Result<T, (String, Range<usize>)>;

impl<'t> Parser<'t> {
    fn blank(&mut self) {
        let rest = &self.text[self.pos..];
        self.pos += rest.len() - rest.trim_start().len();
    }

    fn peek(&mut self) -> &'t str {
        self.blank();
        &self.text[self.pos..]
    }

    fn eat(&mut self, s: &str) -> bool {
        if self.peek().starts_with(s) {
            self.pos += s.len();
            true
        } else {
            false
        }
    }

    fn word(&mut self) -> Option<(&'t str, Range<usize>)> {
        let rest = self.peek();
        let n = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        if n == 0 || rest.starts_with(|c: char| c.is_ascii_digit()) {
            return None;
        }
        let start = self.pos;
        self.pos += n;
        Some((&rest[..n], start..self.pos))
    }

    fn here(&self, what: &str) -> (String, Range<usize>) {
        let end = (self.pos + 1).min(self.text.len()).max(self.pos);
        let end = (self.pos..=end)
            .rev()
            .find(|&e| self.text.is_char_boundary(e))
            .unwrap_or(self.pos);
        (format!("expected {what}"), self.pos..end)
    }

    fn number(&mut self) -> PResult<Num> {
        let rounded = self.eat("~");
        let rest = self.peek();
        let start = self.pos;
        let neg = usize::from(rest.starts_with('-'));
        let digits = |s: &str| s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
        let int = digits(&rest[neg..]);
        if int == 0 {
            return Err(self.here("a number"));
        }
        let mut n = neg + int;
        let mut decimals = 0;
        if rest[n..].starts_with('.') && !rest[n..].starts_with("..") {
            decimals = digits(&rest[n + 1..]);
            if decimals == 0 {
                self.pos += n + 1;
                return Err(self.here("digits after the decimal point"));
            }
            n += 1 + decimals;
        }
        self.pos += n;
        let v: f64 = rest[..n]
            .parse()
            .map_err(|_| ("not a number".to_string(), start..self.pos))?;
        let tol = if rounded {
            0.5 * 10f64.powi(-(decimals as i32))
        } else {
            1e-9 * v.abs().max(1.0)
        };
        Ok(Num { v, tol })
    }

    fn count(&mut self) -> PResult<usize> {
        let save = self.pos;
        let rest = self.peek();
        let n = rest
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(rest.len());
        if n == 0 {
            return Ok(1);
        }
        let start = self.pos;
        self.pos += n;
        if self.word().is_some_and(|(w, _)| w == "of") {
            let count: usize = rest[..n].parse().unwrap_or(usize::MAX);
            if count == 0 || count > MAX_POINTS {
                return Err((
                    format!("a point is repeated 1 to {MAX_POINTS} times"),
                    start..start + n,
                ));
            }
            return Ok(count);
        }
        self.pos = save;
        Ok(1)
    }

    fn group(&mut self, outputs: bool) -> PResult<Group> {
        let count = self.count()?;
        let start = self.pos;
        if outputs
            && self.peek().starts_with("skipped")
            && let Some((_, span)) = self.word()
        {
            return Ok(Group {
                count,
                dims: None,
                span: start..span.end,
            });
        }
        if !self.eat("{") {
            return Err(self.here(if outputs { "`{` or `skipped`" } else { "`{`" }));
        }
        let mut dims = Vec::new();
        if !self.eat("}") {
            loop {
                let Some((name, span)) = self.word() else {
                    return Err(self.here("a dimension's name"));
                };
                if !self.eat(":") {
                    return Err(self.here("`:`"));
                }
                let a = self.number()?;
                let value = if outputs && self.eat("..") {
                    if count < 2 {
                        return Err((
                            "a ramp needs a repeated point, `N of {..}`".into(),
                            span.start..self.pos,
                        ));
                    }
                    Value::Ramp(a, self.number()?)
                } else {
                    Value::One(a)
                };
                dims.push((name.to_string(), span, value));
                if self.eat("}") {
                    break;
                }
                if !self.eat(",") {
                    return Err(self.here("`,` or `}`"));
                }
            }
        }
        Ok(Group {
            count,
            dims: Some(dims),
            span: start..self.pos,
        })
    }

    fn groups(&mut self, outputs: bool) -> PResult<Vec<Group>> {
        let mut out = vec![self.group(outputs)?];
        let mut total = out[0].count;
        while self.eat(",") {
            let g = self.group(outputs)?;
            total += g.count;
            if total > MAX_POINTS {
                return Err((format!("at most {MAX_POINTS} points"), g.span));
            }
            out.push(g);
        }
        Ok(out)
    }
}

/// Where the invocation ends: the first ` on ` outside parentheses.
fn split_on(text: &str) -> Option<usize> {
    let mut depth = 0i32;
    for (i, c) in text.char_indices() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ if depth == 0 && text[i..].starts_with(" on ") => return Some(i),
            _ => {}
        }
    }
    None
}

/// Run one doc-comment example: parse it, build its chunk, apply the operator and compare point
/// by point.
///
/// Over 150 lines because each of those steps reports against the example's own spans, which
/// the one function keeps at hand.
fn run_one(
    map: &mut SourceMap,
    set: &OperatorSet,
    op: &Operator,
    line: &str,
    at: &dyn Fn(Range<usize>) -> Loc,
) -> Result<(), ExampleError> {
    let bad = |reason: String, r: Range<usize>| ExampleError::Bad {
        op: op.name().to_string(),
        reason,
        at: at(r),
    };
    let body_start = MARK.len();
    let rest = &line[body_start..];
    let Some(on) = split_on(rest) else {
        return Err(bad(
            "no ` on ` after the invocation".into(),
            body_start..line.len(),
        ));
    };
    let inv_text = rest[..on].trim();
    let inv_start = body_start + (rest.len() - rest.trim_start().len());
    let inv_span = inv_start..inv_start + inv_text.len();
    let inv = crate::syntax::parse_invocation(inv_text)
        .map_err(|e| bad(e.to_string(), inv_span.clone()))?;
    let domain: Domain = op.domain_decl().clone();
    let call = check::bind(map, set, &domain.name, &inv)
        .map_err(|e| bad(e.to_string(), inv_span.clone()))?;
    let mut p = Parser {
        text: line,
        pos: body_start + on + " on ".len(),
    };
    let inputs = p.groups(false).map_err(|(r, s)| bad(r, s))?;
    match p.word() {
        Some(("gives", _)) => {}
        _ => {
            let (r, s) = p.here("`gives` after the points");
            return Err(bad(r, s));
        }
    }
    let outputs = p.groups(true).map_err(|(r, s)| bad(r, s))?;
    if !p.peek().is_empty() {
        let (r, s) = p.here("the end of the example");
        return Err(bad(r, s));
    }
    // Every named dimension exists.
    for g in inputs.iter().chain(&outputs) {
        for (name, span, _) in g.dims.iter().flatten() {
            if domain.find(name).is_none() {
                return Err(bad(
                    format!(
                        "`{name}` is not a dimension of `{}` (it has {})",
                        domain.name,
                        domain.names().join(", ")
                    ),
                    span.clone(),
                ));
            }
        }
    }
    let n_in: usize = inputs.iter().map(|g| g.count).sum();
    let n_out: usize = outputs.iter().map(|g| g.count).sum();
    if n_in != n_out {
        return Err(bad(
            format!("{n_in} points go in but {n_out} are given out"),
            outputs[0].span.start..outputs.last().map_or(line.len(), |g| g.span.end),
        ));
    }
    // The chunk.
    let mut trace = Trace::new(&domain);
    for g in &inputs {
        let mut z = vec![0.0; domain.obs_dim()];
        let mut a = vec![0.0; domain.act_dim()];
        for (name, _, value) in g.dims.iter().flatten() {
            let Value::One(num) = value else { continue };
            match domain.find(name) {
                Some((Space::Observation, i)) => z[i] = num.v,
                Some((Space::Action, i)) => a[i] = num.v,
                None => {}
            }
        }
        for _ in 0..g.count {
            let t = trace.len() as f64 * 0.1;
            trace.push(t, &z, &a, None);
        }
    }
    let n = trace.len();
    let chunk = Chunk::new(0, n, n).map_err(|e| bad(e.to_string(), inv_span.clone()))?;
    let out = crate::interp::apply(&call, &trace, chunk)
        .map_err(|e| bad(format!("applying it fails: {e}"), inv_span.clone()))?;
    // Compare point by point.
    let mut failures = Vec::new();
    let mut detail = Vec::new();
    let mut i = 0;
    for g in &outputs {
        for k in 0..g.count {
            let got = out.source_index.iter().position(|&s| s == i);
            let (expected, actual) = match (&g.dims, got) {
                (None, None) => ("skipped".to_string(), "skipped".to_string()),
                (None, Some(j)) => {
                    failures.push(format!("point {i} was expected to be skipped"));
                    (
                        "skipped".into(),
                        show(&domain, out.points.z(j), out.points.a(j), None),
                    )
                }
                (Some(_), None) => {
                    failures.push(format!("point {i} was skipped"));
                    let shown: Vec<String> =
                        g.dims.iter().flatten().map(|(n, _, _)| n.clone()).collect();
                    (
                        expect_text(&domain, g, k, trace.z(i), trace.a(i), &shown),
                        "skipped".into(),
                    )
                }
                (Some(dims), Some(j)) => {
                    let (z, a) = (out.points.z(j), out.points.a(j));
                    // The dimensions shown: those the example names and those that went wrong.
                    let mut shown: Vec<String> = dims.iter().map(|(n, _, _)| n.clone()).collect();
                    for (space, values, input) in [
                        (Space::Observation, z, trace.z(i)),
                        (Space::Action, a, trace.a(i)),
                    ] {
                        for (d, (&v, &v_in)) in values.iter().zip(input).enumerate() {
                            let name = &domain.dims(space)[d].name;
                            let want = dims
                                .iter()
                                .find(|(n, _, _)| n == name)
                                .map(|(_, _, value)| at_k(value, k, g.count))
                                .unwrap_or(Num {
                                    v: v_in,
                                    tol: 1e-9 * v_in.abs().max(1.0),
                                });
                            // A NaN result is never within the tolerance.
                            let close = (v - want.v).abs() <= want.tol;
                            if !close {
                                if !shown.contains(name) {
                                    shown.push(name.clone());
                                }
                                failures.push(format!(
                                    "point {i} {name}: expected {}, got {}",
                                    crate::number::fmt_num(round(want.v)),
                                    crate::number::fmt_num(round(v))
                                ));
                            }
                        }
                    }
                    (
                        expect_text(&domain, g, k, trace.z(i), trace.a(i), &shown),
                        show(&domain, z, a, Some(&shown)),
                    )
                }
            };
            detail.push(format!("point {i}: expected {expected}, got {actual}"));
            i += 1;
        }
    }
    if failures.is_empty() {
        return Ok(());
    }
    let what = if failures.len() == 1 {
        failures.remove(0)
    } else {
        format!("{} (and {} more)", failures[0], failures.len() - 1)
    };
    // Long chunks: the first and last points are enough to see a ramp go wrong.
    let detail = if detail.len() > 12 {
        let mut d: Vec<String> = detail[..6].to_vec();
        d.push(format!("... {} more points ...", detail.len() - 12));
        d.extend_from_slice(&detail[detail.len() - 6..]);
        d
    } else {
        detail
    };
    Err(ExampleError::Failed {
        op: op.name().to_string(),
        what,
        detail: detail.join("\n"),
        at: at(0..line.len()),
    })
}

fn at_k(value: &Value, k: usize, count: usize) -> Num {
    match value {
        Value::One(n) => *n,
        Value::Ramp(a, b) => {
            let f = k as f64 / (count - 1).max(1) as f64;
            Num {
                v: a.v + (b.v - a.v) * f,
                tol: a.tol.max(b.tol),
            }
        }
    }
}

/// The values expected of point `k` of group `g` in the dimensions `shown` (those the example does
/// not name keep the input's `z`, `a`).
fn expect_text(
    domain: &Domain,
    g: &Group,
    k: usize,
    z: &[f64],
    a: &[f64],
    shown: &[String],
) -> String {
    let dims = g.dims.as_deref().unwrap_or(&[]);
    let parts: Vec<String> = domain
        .observe
        .iter()
        .zip(z)
        .chain(domain.act.iter().zip(a))
        .filter(|(d, _)| shown.contains(&d.name))
        .map(|(d, &input)| {
            let v = dims
                .iter()
                .find(|(n, _, _)| *n == d.name)
                .map_or(input, |(_, _, v)| at_k(v, k, g.count).v);
            format!("{}: {}", d.name, crate::number::fmt_num(round(v)))
        })
        .collect();
    format!("{{{}}}", parts.join(", "))
}

/// A point's values in the dimensions `shown` (all of them for `None`).
fn show(domain: &Domain, z: &[f64], a: &[f64], shown: Option<&[String]>) -> String {
    let parts: Vec<String> = domain
        .observe
        .iter()
        .zip(z)
        .chain(domain.act.iter().zip(a))
        .filter(|(d, _)| shown.is_none_or(|s| s.contains(&d.name)))
        .map(|(d, v)| format!("{}: {}", d.name, crate::number::fmt_num(round(*v))))
        .collect();
    format!("{{{}}}", parts.join(", "))
}

/// Twelve significant digits: what a person compares by eye.
fn round(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(11 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outcome(text: &str) -> (SourceMap, Outcome) {
        let mut map = SourceMap::new();
        let id = map.add("t.adv", text.to_string());
        let set = OperatorSet::standard()
            .merge_in(&map, &[id])
            .expect("the test file checks")
            .set;
        let o = run(&mut map, &set, &[id]);
        (map, o)
    }

    #[test]
    fn the_standard_library_has_an_example_per_operator_and_all_hold() {
        let mut map = SourceMap::new();
        let ids: Vec<SourceId> = check::STANDARD_SOURCES
            .iter()
            .map(|(n, t)| map.add(*n, *t))
            .collect();
        let set = OperatorSet::standard();
        let o = run(&mut map, &set, &ids);
        let failures: Vec<String> = o.failures.iter().map(|f| format!("{f:?}")).collect();
        assert!(failures.is_empty(), "{failures:#?}");
        assert!(o.without_example.is_empty(), "{:?}", o.without_example);
        assert!(o.examples >= set.operator_count());
    }

    #[test]
    fn ramps_skips_and_rounding() {
        let (_, o) = outcome(
            "/// Example: double on 3 of {trans: 0.1}, {trans: 0} gives 3 of {trans: 0.2 .. 0.2}, skipped\n\
             /// Example: double on {trans: 0.333} gives {trans: ~0.67}\n\
             operator double for positioning on action where trans != 0 { trans *= 2 }\n",
        );
        assert_eq!(o.examples, 2);
        assert!(o.failures.is_empty(), "{:?}", o.failures);
    }

    #[test]
    fn wrong_examples_say_what_was_expected_and_got() {
        let (_, o) = outcome(
            "/// Example: double on {trans: 0.1} gives {trans: 0.3}\n\
             /// Example: double on {trans: 0.1} gives {trans: 0.2, rot: 1}\n\
             /// Example: double on {trans: 0} gives {trans: 0}\n\
             /// Example: double on {speed: 1} gives {speed: 2}\n\
             /// Example: double on 2 of {trans: 1} gives {trans: 2}\n\
             /// Example: double(3) on {trans: 1} gives {trans: 2}\n\
             /// Example: double on {trans: 1} gives {trans: 1 .. 2}\n\
             operator double for positioning on action where trans != 0 { trans *= 2 }\n",
        );
        assert_eq!(o.examples, 7);
        let msgs: Vec<String> = o.failures.iter().map(|f| f.to_string()).collect();
        assert_eq!(msgs.len(), 7, "{msgs:#?}");
        assert!(
            msgs[0].contains("point 0 trans: expected 0.3, got 0.2"),
            "{msgs:?}"
        );
        assert!(
            msgs[1].contains("point 0 rot: expected 1, got 0"),
            "{msgs:?}"
        );
        assert!(msgs[2].contains("point 0 was skipped"), "{msgs:?}");
        assert!(msgs[3].contains("`speed` is not a dimension"), "{msgs:?}");
        assert!(
            msgs[4].contains("2 points go in but 1 are given out"),
            "{msgs:?}"
        );
        assert!(
            msgs[6].contains("a ramp needs a repeated point"),
            "{msgs:?}"
        );
    }

    #[test]
    fn hostile_examples_are_errors_not_hangs() {
        let (_, o) = outcome(
            "/// Example: double on 99999999999999999999 of {trans: 1} gives {trans: 2}\n\
             /// Example: double on {trans: 1.} gives {trans: é}\n\
             /// Example: double on {trans: 1} gives\n\
             /// Example: double\n\
             operator double for positioning on action { trans *= 2 }\n",
        );
        assert_eq!(o.failures.len(), 4, "{:?}", o.failures);
    }
}
