//! Conflicting advice: new advice whose synthesized points land where earlier advice or
//! demonstrations recommend clearly different actions, in the learner's own neighbourhood.
//!
//! LWR answers an observation with the kernel-weighted mean of the actions around it, so two
//! pieces of advice that say "slow down here" and "speed up here" about observations the kernel
//! treats as one are silently averaged: neither is followed. The session says so when the second
//! is given, naming the first, and `history --conflicts` lists every such pair still in force.
//!
//! **The rule.** The learner's neighbourhood of a new point is the data within one kernel
//! bandwidth of it in the space the learner measures distance in
//! ([`crate::policy::learner::Learner::neighbourhood`]: weight at least `exp(-1/2)` ≈ 0.61 of a
//! point at the same observation; a BC learner uses the same radius in range-scaled units). What
//! an earlier source *recommends* there is the kernel-weighted mean of its points in that
//! neighbourhood: each earlier piece of advice alone, the demonstrations together (teleoperated
//! demonstrations differ among themselves by a person's style; what they recommend is what the
//! learner made of them, not any one of them). The new point *contradicts* a source when, in
//! some action dimension (observation dimension, for advice on observations), it differs from
//! the source's recommendation by more than [`CONTRADICTION_SHARE`] of that dimension's range
//! (its declared limits; the data's spread when it has none) *and* the advice pulled it away
//! from that recommendation: at least [`PULLED_AWAY_SHARE`] of the range further from it than
//! the executed action was. Advice that moves an action toward what a source recommends agrees
//! with it, however far apart they still are (the demonstrations near a run's start drive off at
//! speed while the learner is still at rest; `creep` there is no conflict with them). A quarter of the range because the
//! paper's operators at their largest standard rate ("much more", 0.5) move a speed by half of
//! itself, at most a quarter of a symmetric range: refining a recommendation stays under it, and
//! only advice that pulls the other way (or a much larger step) crosses it. The new advice
//! conflicts with an earlier source (one piece of advice, one demonstration) when at least
//! [`MIN_CONFLICTING_SHARE`] of its points, and at least [`MIN_CONFLICTING_POINTS`], contradict
//! that source: a stray neighbour at the kernel's edge is not a conflict a teacher must hear of.
//!
//! The check is bounded: at most [`MAX_CHECKED_POINTS`] of the new points (evenly spread over
//! them) and [`MAX_NEIGHBOURS`] neighbours of each are compared. It reads the learner and
//! changes nothing; it runs when advice is added, live, redone or restored from a journal alike,
//! so a resumed session lists the same conflicts.

use std::collections::BTreeMap;
use std::fmt;

use serde::Serialize;

use std::fmt::Write as _;

use super::Session;
use super::undo::Edit;
use crate::domain::{Dim, Space};
use crate::interp::Synthesized;
use crate::policy::dataset::Provenance;
use crate::policy::learner::Learner;
use crate::trace::Chunk;

/// Two recommendations differ clearly when they are this share of the dimension's range apart.
pub const CONTRADICTION_SHARE: f64 = 0.25;
/// ... and when the advice pulled the point at least this share of the range further from the
/// source's recommendation than the executed action was.
pub const PULLED_AWAY_SHARE: f64 = 0.125;
/// Advice conflicts with a source when this share of its points contradict it ...
pub const MIN_CONFLICTING_SHARE: f64 = 0.2;
/// ... and at least this many.
pub const MIN_CONFLICTING_POINTS: usize = 3;
/// New points compared, at most.
pub const MAX_CHECKED_POINTS: usize = 2_000;
/// Neighbours of one new point compared, at most.
pub const MAX_NEIGHBOURS: usize = 512;

/// What earlier source new advice contradicts.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Earlier {
    Advice {
        /// Its number in `history`.
        number: usize,
        execution: usize,
        chunk: Chunk,
        invocation: String,
        /// Whether it is undone now (listed by `history --conflicts`, not live).
        undone: bool,
    },
    /// The demonstrations near the new points, their recommendation taken together.
    Demonstrations {
        /// The one that weighed most there.
        heaviest: String,
    },
}

/// One earlier source a piece of advice contradicts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Against {
    pub earlier: Earlier,
    /// New points that contradict it.
    pub points: usize,
    /// The dimensions they differ in, by name.
    pub dims: Vec<String>,
}

/// A piece of advice and what it contradicts: the warning `advise::session::conflicting_advice`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conflict {
    /// The new advice's number.
    pub number: usize,
    pub execution: usize,
    pub chunk: Chunk,
    pub invocation: String,
    /// Its points compared (all, or [`MAX_CHECKED_POINTS`]).
    pub checked: usize,
    pub against: Vec<Against>,
}

impl Conflict {
    fn message(&self) -> String {
        let whom: Vec<String> = self
            .against
            .iter()
            .map(|a| {
                format!(
                    "{} ({} of its {} points, in {})",
                    a.earlier,
                    a.points,
                    self.checked,
                    a.dims.join(", ")
                )
            })
            .collect();
        format!(
            "advice #{} ({} on {} of execution {}) recommends clearly different actions than {}, where the learner treats the observations as one: it will average them",
            self.number,
            self.invocation,
            self.chunk,
            self.execution,
            whom.join(" and ")
        )
    }

    fn help(&self) -> String {
        let mut h = format!("`undo` takes back advice #{} (the last edit)", self.number);
        for a in &self.against {
            match &a.earlier {
                Earlier::Advice {
                    number,
                    execution,
                    chunk,
                    ..
                } => h.push_str(&format!(
                    "; to keep it and drop advice #{number} instead, `undo` back past #{number} (`history` lists the order), then give this advice again: `select {chunk} in {execution}`, `advise {}`",
                    self.invocation
                )),
                Earlier::Demonstrations { .. } => h.push_str(
                    "; demonstrations stay: if this advice is what you mean, give it on more of the stretch (or more strongly) so it outweighs them",
                ),
            }
        }
        h.push_str(". `history --conflicts` lists the conflicts still in force");
        h
    }
}

impl fmt::Display for Conflict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message())
    }
}

impl std::error::Error for Conflict {}

impl miette::Diagnostic for Conflict {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new("advise::session::conflicting_advice"))
    }

    fn severity(&self) -> Option<miette::Severity> {
        Some(miette::Severity::Warning)
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(Conflict::help(self)))
    }
}

impl fmt::Display for Earlier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Earlier::Advice {
                number,
                execution,
                chunk,
                invocation,
                undone,
            } => {
                write!(
                    f,
                    "advice #{number} ({invocation} on {chunk} of execution {execution})"
                )?;
                if *undone {
                    f.write_str(" (undone)")?;
                }
                Ok(())
            }
            Earlier::Demonstrations { heaviest } => {
                write!(f, "the demonstrations (most weight there: `{heaviest}`)")
            }
        }
    }
}

/// The source a data point came from, as recommendations are gathered: each piece of advice
/// alone, the demonstrations together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Source {
    Advice(u32),
    Demos,
}

/// What advice `syn` (number `number`, on `execution`) contradicts in `learner`'s data as it is
/// before the advice is added; `None` when nothing.
pub(super) fn find(
    learner: &Learner,
    edits: &[Edit],
    syn: &Synthesized,
    executed: &crate::trace::Trace,
    execution: usize,
    number: usize,
) -> Option<Conflict> {
    let n = syn.points.len();
    if n == 0 || learner.is_empty() {
        return None;
    }
    let ds = learner.dataset();
    let space = syn.advice.space;
    let dims: &[Dim] = learner.domain().dims(space);
    let spans: Vec<f64> = (0..dims.len())
        .map(|d| span_of(learner, space, dims, d))
        .collect();
    let checked = n.min(MAX_CHECKED_POINTS);
    // Per earlier source: how many new points contradict its recommendation, and in which
    // dimensions.
    let mut tally: BTreeMap<Source, (usize, Vec<bool>)> = BTreeMap::new();
    // The kernel weight each demonstration carried near the new points (to name the heaviest).
    let mut demo_weight: BTreeMap<u32, f64> = BTreeMap::new();
    let mut hits = Vec::new();
    // Per source near one new point: kernel weight and weighted sum of its values.
    let mut near: BTreeMap<Source, (f64, Vec<f64>)> = BTreeMap::new();
    for c in 0..checked {
        let j = c * n / checked;
        let (z, mine) = (syn.points.z(j), values(&syn.points, space, j));
        let Some(was) = syn
            .source_index
            .get(j)
            .filter(|&&src| src < executed.len())
            .map(|&src| values(executed, space, src))
        else {
            continue;
        };
        learner.neighbourhood(z, &mut hits);
        near.clear();
        for &(p, d2) in hits.iter().take(MAX_NEIGHBOURS) {
            let w = (-0.5 * d2).exp();
            let theirs = match space {
                Space::Action => ds.a(p),
                Space::Observation => ds.z(p),
            };
            let source = match ds.provenance(p) {
                Provenance::Advice { advice, .. } => Source::Advice(advice),
                Provenance::Demonstration { demo, .. } => {
                    *demo_weight.entry(demo).or_insert(0.0) += w;
                    Source::Demos
                }
            };
            let (sw, sum) = near
                .entry(source)
                .or_insert_with(|| (0.0, vec![0.0; dims.len()]));
            *sw += w;
            for (s, v) in sum.iter_mut().zip(theirs) {
                *s += w * v;
            }
        }
        for (source, (sw, sum)) in &near {
            if *sw <= 0.0 {
                continue;
            }
            let apart: Vec<bool> = (0..dims.len())
                .map(|d| {
                    let (theirs, span) = (sum[d] / sw, spans[d]);
                    let (now, before) = ((mine[d] - theirs).abs(), (was[d] - theirs).abs());
                    span > 0.0
                        && now > CONTRADICTION_SHARE * span
                        && now - before > PULLED_AWAY_SHARE * span
                })
                .collect();
            if !apart.contains(&true) {
                continue;
            }
            let entry = tally
                .entry(*source)
                .or_insert_with(|| (0, vec![false; dims.len()]));
            entry.0 += 1;
            for (d, a) in entry.1.iter_mut().zip(&apart) {
                *d |= *a;
            }
        }
    }
    let least =
        MIN_CONFLICTING_POINTS.max((MIN_CONFLICTING_SHARE * checked as f64).ceil() as usize);
    let heaviest = demo_weight
        .iter()
        .max_by(|a, b| a.1.partial_cmp(b.1).unwrap_or(std::cmp::Ordering::Equal))
        .and_then(|(id, _)| ds.demos().iter().find(|d| d.id == *id))
        .map(|d| d.name.clone());
    let against: Vec<Against> = tally
        .into_iter()
        .filter(|(_, (count, _))| *count >= least)
        .filter_map(|(source, (points, apart))| {
            let earlier = match source {
                Source::Advice(id) => edits.iter().find_map(|e| match e {
                    Edit::Advice {
                        number,
                        id: a,
                        execution,
                        syn,
                    } if *a == id => Some(Earlier::Advice {
                        number: *number,
                        execution: *execution,
                        chunk: syn.advice.chunk,
                        invocation: syn.advice.invocation(),
                        undone: false,
                    }),
                    _ => None,
                })?,
                Source::Demos => Earlier::Demonstrations {
                    heaviest: heaviest.clone().unwrap_or_default(),
                },
            };
            Some(Against {
                earlier,
                points,
                dims: dims
                    .iter()
                    .zip(&apart)
                    .filter(|(_, a)| **a)
                    .map(|(d, _)| d.name.clone())
                    .collect(),
            })
        })
        .collect();
    (!against.is_empty()).then(|| Conflict {
        number,
        execution,
        chunk: syn.advice.chunk,
        invocation: syn.advice.invocation(),
        checked,
        against,
    })
}

impl Session {
    /// `history --conflicts`: each piece of advice in force that contradicted earlier advice or
    /// demonstrations when it was given ([`super::conflict`]), with what it contradicted (advice
    /// taken back since is marked undone).
    pub(super) fn history_conflicts(&self) -> String {
        let st = &self.state;
        let live = |n: usize| {
            st.undo
                .iter()
                .any(|e| matches!(e, Edit::Advice { number, .. } if *number == n))
        };
        let mut out = String::new();
        for c in st.conflicts.iter().filter(|c| live(c.number)) {
            let _ = writeln!(
                out,
                "  #{} advise {} on {} of execution {} contradicts:",
                c.number, c.invocation, c.chunk, c.execution
            );
            for a in &c.against {
                let mut earlier = a.earlier.clone();
                if let Earlier::Advice { number, undone, .. } = &mut earlier {
                    *undone = !live(*number);
                }
                let _ = writeln!(
                    out,
                    "      {earlier}: {} of {} points apart in {}",
                    a.points,
                    c.checked,
                    a.dims.join(", ")
                );
            }
        }
        if out.is_empty() {
            return "no conflicting advice: no advice in force recommends clearly different actions than earlier advice or demonstrations where the learner treats the observations as one".into();
        }
        out.push_str("(`undo` takes back the last advice; `history` lists the order)\n");
        out
    }
}
fn values(points: &crate::trace::Trace, space: Space, j: usize) -> &[f64] {
    match space {
        Space::Action => points.a(j),
        Space::Observation => points.z(j),
    }
}

/// Dimension `d`'s range: its declared limits, else the data's spread (0: never compared).
fn span_of(learner: &Learner, space: Space, dims: &[Dim], d: usize) -> f64 {
    if let Some(l) = dims[d].limits {
        let w = l.hi - l.lo;
        if w.is_finite() && w > 0.0 {
            return w;
        }
    }
    let ds = learner.dataset();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in 0..ds.len() {
        let v = match space {
            Space::Action => ds.a(p)[d],
            Space::Observation => ds.z(p)[d],
        };
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if hi > lo { hi - lo } else { 0.0 }
}
