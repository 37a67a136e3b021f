//! Correcting an execution: selecting a chunk, critiquing it, advising it (or previewing the
//! advice), and asking why the policy acted as it did.

use std::fmt::Write as _;
use std::time::Instant;

use super::effect::Effect;
use super::text::{fmt_named, short_num};
use super::undo::Edit;
use super::{Advised, HeldExecution, MAX_KAPPA, Reply, Session, SessionError};
use crate::policy::dataset::CritiqueRule;
use crate::policy::learner;
use crate::trace::{Chunk, PointRange};
use crate::{check, interp};

impl Session {
    /// `select A..B` selects in the latest execution, `select A..B in N` in execution N; the
    /// selected execution is what `advise`, `critique`, `preview`, `why` and `plot` act on.
    pub(super) fn select(
        &mut self,
        range: PointRange,
        execution: Option<usize>,
    ) -> Result<Reply, SessionError> {
        let i = self.execution_or_last(execution)?;
        let rec = self.numbered(i)?;
        let chunk = range.resolve(rec.trace.len())?;
        self.commit(Effect::Select {
            execution: i,
            chunk,
        })?;
        Ok(Reply::Selected {
            execution: i,
            chunk,
        })
    }

    /// Execution `n` when given, else the last one; `NoExecution` when there is none.
    pub(super) fn execution_or_last(&self, n: Option<usize>) -> Result<usize, SessionError> {
        match n {
            Some(n) => Ok(n),
            None => self
                .state
                .executions
                .len()
                .checked_sub(1)
                .ok_or(SessionError::NoExecution),
        }
    }

    /// Execution `n`, or a diagnostic naming the executions there are.
    pub(super) fn numbered(&self, n: usize) -> Result<&HeldExecution, SessionError> {
        let count = self.state.executions.len();
        self.state
            .executions
            .get(n)
            .ok_or(SessionError::NoSuchExecution { n, count })
    }

    pub(super) fn selection(&self) -> Result<(usize, Chunk), SessionError> {
        let (i, _) = self.current()?;
        let chunk = self.state.selection.ok_or(SessionError::NoSelection)?;
        Ok((i, chunk))
    }

    pub(super) fn critique(
        &mut self,
        kappa: f64,
        rule: CritiqueRule,
    ) -> Result<Reply, SessionError> {
        check_kappa(kappa)?;
        let (i, chunk) = self.selection()?;
        let st = &mut self.state;
        let rec = &st.executions[i];
        let plan =
            st.learner
                .plan_critique(&rec.trace, chunk, kappa, rec.support.as_deref(), rule)?;
        self.commit(Effect::Critique {
            execution: i,
            critique: plan.critique.clone(),
        })?;
        Ok(Reply::Critiqued {
            execution: i,
            chunk,
            summary: self.state.learner.critique_summary(&plan),
        })
    }

    pub(super) fn advise(
        &mut self,
        inv: &crate::syntax::Invocation,
    ) -> Result<Reply, SessionError> {
        let (i, chunk) = self.selection()?;
        let started = Instant::now();
        let rec = &self.state.executions[i];
        let call = check::bind(&mut self.sources, &self.ops, &rec.trace.domain, inv)?;
        let syn = interp::apply(&call, &rec.trace, chunk)?;
        let points = syn.points.len();
        let skipped = chunk.len() - points;
        let invocation = syn.advice.invocation();
        self.commit(Effect::Advice {
            execution: i,
            points: syn.points.to_json(),
            source_index: syn.source_index,
            applied: syn.advice,
        })?;
        let number = self.state.next_edit - 1;
        let conflict = self
            .state
            .conflicts
            .iter()
            .find(|c| c.number == number)
            .cloned();
        Ok(Reply::Advised(Advised {
            execution: i,
            chunk,
            invocation,
            added: points,
            skipped,
            dataset: self.state.learner.len(),
            ready_ms: started.elapsed().as_secs_f64() * 1e3,
            conflict,
        }))
    }

    /// What `inv` would add to the selection, synthesized and nothing added: `preview`'s text
    /// and the web view's data (`Session::execute_previewing`) both come from it.
    pub(super) fn preview_points(
        &mut self,
        inv: &crate::syntax::Invocation,
    ) -> Result<Previewed, SessionError> {
        let (execution, chunk) = self.selection()?;
        let rec = &self.state.executions[execution];
        let call = check::bind(&mut self.sources, &self.ops, &rec.trace.domain, inv)?;
        let syn = interp::apply(&call, &rec.trace, chunk)?;
        Ok(Previewed {
            execution,
            chunk,
            guard: guard_of(call.operator().definition()),
            syn,
        })
    }

    pub(super) fn preview(
        &mut self,
        inv: &crate::syntax::Invocation,
    ) -> Result<String, SessionError> {
        let previewed = self.preview_points(inv)?;
        if self.previewed.is_some() {
            self.previewed = Some(self.preview_data(&previewed));
        }
        let Previewed {
            execution: i,
            chunk,
            guard,
            syn,
        } = previewed;
        let rec = &self.state.executions[i];
        let space = syn.advice.space;
        let dims = self.domain.dims(space);
        let skipped = chunk.len() - syn.points.len();
        let guard = match guard {
            Some(guard) if skipped > 0 => format!(" by its guard `{guard}`"),
            _ => String::new(),
        };
        let mut out = format!(
            "{} on {chunk} of execution {i} would add {} points ({skipped} skipped{guard}); {} before -> after:\n",
            syn.advice.invocation(),
            syn.points.len(),
            space
        );
        let _ = write!(out, "{:>6}", "point");
        for d in dims {
            let _ = write!(out, "  {:>24}", format!("{} ({})", d.name, d.unit));
        }
        out.push('\n');
        let shown = syn.points.len().min(12);
        for (j, &src) in syn.source_index.iter().take(shown).enumerate() {
            let _ = write!(out, "{src:>6}");
            let (before, after) = before_after(&rec.trace, &syn, j, src);
            for (b, a) in before.iter().zip(after) {
                let _ = write!(out, "  {:>24}", format!("{b:.4} -> {a:.4}"));
            }
            out.push('\n');
        }
        if syn.points.len() > shown {
            let _ = writeln!(out, "   ... and {} more", syn.points.len() - shown);
        }
        Ok(out)
    }

    pub(super) fn why(&mut self, t: usize) -> Result<String, SessionError> {
        let (i, rec) = self.current()?;
        if t >= rec.trace.len() {
            return Err(SessionError::PointOutOfRange {
                t,
                len: rec.trace.len(),
            });
        }
        let z = rec.trace.z(t).to_vec();
        let a = rec.trace.a(t).to_vec();
        self.state.learner.ensure_derived();
        let mut out = format!(
            "point {t} of execution {i}: z = {}, executed a = {}\n",
            fmt_named(&self.domain.observe, &z),
            fmt_named(&self.domain.act, &a)
        );
        let name = |id: learner::AdviceId| {
            self.state
                .undo
                .iter()
                .find_map(|e| match e {
                    Edit::Advice { number, id: a, .. } if *a == id => {
                        Some(format!("advice #{number}"))
                    }
                    _ => None,
                })
                .unwrap_or_else(|| format!("advice (dataset id {id})"))
        };
        let takeover = |id| self.takeover_name(id);
        out.push_str(&self.state.learner.why_named(&z, &name, &takeover)?);
        Ok(out)
    }
}

/// An operator's guard as written (`where trans > 0`), read from its definition's head (before
/// its block); `None` for an operator without one, or a composition.
fn guard_of(definition: &str) -> Option<String> {
    let head = definition.split('{').next()?;
    let at = head.find(" where ")?;
    Some(
        head[at + 1..]
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" "),
    )
}

/// A critique's kappa: positive and at most [`MAX_KAPPA`] (a typed one, a journalled one and
/// Python's `critique`).
pub fn check_kappa(kappa: f64) -> Result<(), SessionError> {
    if kappa.is_finite() && kappa > 0.0 && kappa <= MAX_KAPPA {
        Ok(())
    } else {
        Err(SessionError::BadKappa {
            kappa: short_num(kappa),
        })
    }
}

/// The points a piece of advice would add, and where: [`Session::preview_points`].
pub(super) struct Previewed {
    pub execution: usize,
    pub chunk: Chunk,
    /// The operator's guard, as written, if it has one.
    pub guard: Option<String>,
    pub syn: interp::Synthesized,
}

/// Synthesized point `j`'s values in the advice's space, beside those of the executed point `src`
/// it came from: `(before, after)`.
pub(super) fn before_after<'a>(
    trace: &'a crate::trace::Trace,
    syn: &'a interp::Synthesized,
    j: usize,
    src: usize,
) -> (&'a [f64], &'a [f64]) {
    match syn.advice.space {
        crate::domain::Space::Action => (trace.a(src), syn.points.a(j)),
        crate::domain::Space::Observation => (trace.z(src), syn.points.z(j)),
    }
}
