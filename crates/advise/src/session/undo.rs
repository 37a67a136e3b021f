//! Taking back and putting back: the [`Edit`]s `undo` and `redo` move between their stacks, and
//! `history`, which lists them.

use std::fmt::Write as _;

use super::effect::Effect;
use super::{HeldExecution, Session, SessionError};
use crate::interp::Synthesized;
use crate::policy::dataset::Critique;
use crate::policy::learner;
use crate::trace::Chunk;

/// A takeover's demonstration: the points the teacher drove, and where in which execution.
#[derive(Clone, Debug)]
pub(crate) struct Taken {
    pub execution: usize,
    pub steps: Chunk,
    pub every: u32,
    pub name: String,
    pub trace: crate::trace::Trace,
}

/// An edit that `undo` can take back, holding everything `redo` needs to put it back exactly.
#[derive(Clone, Debug)]
pub(super) enum Edit {
    Advice {
        /// The number `history` and `why` show (kept by undo and redo).
        number: usize,
        id: learner::AdviceId,
        execution: usize,
        /// The synthesized points themselves: redo adds these, never a re-synthesis with an
        /// operator that may have been redefined since.
        syn: Box<Synthesized>,
    },
    Critique {
        number: usize,
        id: learner::CritiqueId,
        execution: usize,
        /// The critique as made: redo makes these increments again.
        critique: Critique,
    },
    /// A demonstration the teacher gave by taking over a run.
    Takeover {
        number: usize,
        id: learner::DemoId,
        /// Its points and where they came from: redo adds these again.
        taken: Box<Taken>,
    },
}

impl Edit {
    pub(super) fn number(&self) -> usize {
        match self {
            Edit::Advice { number, .. }
            | Edit::Critique { number, .. }
            | Edit::Takeover { number, .. } => *number,
        }
    }

    /// The learner's id of the advice or critique (one counter for both: id order is the order
    /// they were made).
    pub(super) fn id(&self) -> u32 {
        match self {
            Edit::Advice { id, .. } | Edit::Critique { id, .. } | Edit::Takeover { id, .. } => *id,
        }
    }

    /// Give the edit the number `history` shows (an opened file's edits are numbered afresh).
    pub(super) fn renumber(&mut self, n: usize) {
        match self {
            Edit::Advice { number, .. }
            | Edit::Critique { number, .. }
            | Edit::Takeover { number, .. } => *number = n,
        }
    }

    pub(super) fn describe(&self, executions: &[HeldExecution]) -> String {
        match self {
            Edit::Advice { execution, syn, .. } => format!(
                "#{} advise {} on {} of execution {} ({}): {} points",
                self.number(),
                syn.advice.invocation(),
                syn.advice.chunk,
                execution,
                executions.get(*execution).map_or("?", |e| e.label.as_str()),
                syn.points.len()
            ),
            Edit::Critique {
                execution,
                critique,
                ..
            } => format!(
                "#{} critique {} of execution {execution} ({}) with kappa {}{}",
                self.number(),
                critique.chunk,
                executions.get(*execution).map_or("?", |e| e.label.as_str()),
                critique.kappa,
                if critique.directional {
                    " (directional)"
                } else {
                    ""
                }
            ),
            Edit::Takeover { taken, .. } => format!(
                "#{} takeover of execution {} ({}): the teacher drove steps {}, {} points",
                self.number(),
                taken.execution,
                executions
                    .get(taken.execution)
                    .map_or("?", |e| e.label.as_str()),
                taken.steps,
                taken.trace.len()
            ),
        }
    }
}

impl Session {
    pub(super) fn undo(&mut self) -> Result<String, SessionError> {
        let edit = self.state.undo.last().ok_or(SessionError::NothingToUndo)?;
        let text = edit.describe(&self.state.executions);
        self.commit(Effect::Undo)?;
        Ok(format!(
            "undid: {text}; the policy has {} points",
            self.state.learner.len()
        ))
    }

    pub(super) fn undo_edit(&mut self) -> Result<(), SessionError> {
        let st = &mut self.state;
        let edit = st.undo.pop().ok_or(SessionError::NothingToUndo)?;
        let result = match &edit {
            Edit::Advice {
                id, execution, syn, ..
            } => st
                .learner
                .remove_advice(*id)
                .map(|()| remove_chunk(&mut st.executions[*execution].advised, syn.advice.chunk)),
            Edit::Critique {
                id,
                execution,
                critique,
                ..
            } => st
                .learner
                .remove_critique(*id)
                .map(|()| remove_chunk(&mut st.executions[*execution].flagged, critique.chunk)),
            Edit::Takeover { id, .. } => st.learner.remove_demonstration(*id),
        };
        match result {
            Ok(()) => {
                st.redo.push(edit);
                Ok(())
            }
            Err(e) => {
                st.undo.push(edit);
                Err(e.into())
            }
        }
    }

    pub(super) fn redo(&mut self) -> Result<String, SessionError> {
        let edit = self.state.redo.last().ok_or(SessionError::NothingToRedo)?;
        let text = edit.describe(&self.state.executions);
        self.commit(Effect::Redo)?;
        Ok(format!(
            "redid: {text}; the policy has {} points",
            self.state.learner.len()
        ))
    }

    /// Put back exactly what the last undo took: the same points, the same increments.
    pub(super) fn redo_edit(&mut self) -> Result<(), SessionError> {
        let edit = self.state.redo.pop().ok_or(SessionError::NothingToRedo)?;
        let number = edit.number();
        let result = match edit.clone() {
            Edit::Advice { execution, syn, .. } => self.add_advice(execution, syn, number),
            Edit::Critique {
                execution,
                critique,
                ..
            } => self.add_critique(execution, critique, number),
            Edit::Takeover { taken, .. } => self.add_takeover(*taken, number),
        };
        if result.is_err() {
            self.state.redo.push(edit);
        }
        result
    }

    pub(super) fn history(&self) -> String {
        let st = &self.state;
        if st.undo.is_empty() && st.redo.is_empty() {
            return "no advice or critiques yet".into();
        }
        let mut out = String::new();
        for e in &st.undo {
            let _ = writeln!(out, "  {}", e.describe(&st.executions));
        }
        for e in st.redo.iter().rev() {
            let _ = writeln!(out, "  (undone) {}", e.describe(&st.executions));
        }
        out
    }
}

pub(super) fn remove_chunk(chunks: &mut Vec<Chunk>, chunk: Chunk) {
    if let Some(pos) = chunks.iter().rposition(|c| *c == chunk) {
        chunks.remove(pos);
    }
}
