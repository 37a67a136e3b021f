//! The session as data for a live view (the web page of `advise serve`, issue 37): what the page
//! draws, read from the same state the REPL's `show`, `history` and `plot` read. Nothing here
//! changes the session; the page changes it only by statements ([`Session::execute`]).

use serde_json::{Value, json};

use super::{HeldExecution, Session, SessionError};
use crate::trace::Chunk;

fn chunk(c: Chunk) -> Value {
    json!([c.range().start, c.range().end])
}

impl Session {
    /// The session's state for the page: the task, the executions, the one shown (`execution`, or
    /// the current one) with its path, ball, goal and action series, the selection, the
    /// numbered advice and critiques, and the operators of the task's domain with their
    /// parameters' defaults and declared ranges.
    pub fn view_json(&self, execution: Option<usize>) -> Value {
        let st = &self.state;
        let executions: Vec<Value> = st
            .executions
            .iter()
            .enumerate()
            .map(|(i, e)| json!({"index": i, "label": e.label, "points": e.trace.len()}))
            .collect();
        let shown = execution
            .filter(|&i| i < st.executions.len())
            .or(st.current)
            .map(|i| self.execution_json(i, &st.executions[i]));
        let mut history: Vec<Value> = st
            .undo
            .iter()
            .map(|e| json!({"number": e.number(), "text": e.describe(&st.executions), "undone": false}))
            .collect();
        history.extend(st.redo.iter().rev().map(
            |e| json!({"number": e.number(), "text": e.describe(&st.executions), "undone": true}),
        ));
        let operators: Vec<Value> = self
            .ops
            .operators(&self.domain.name)
            .map(|o| {
                let params: Vec<Value> = o
                    .params()
                    .iter()
                    .map(|p| {
                        json!({
                            "name": p.name,
                            "default": p.default,
                            "lo": p.limits.map(|l| l.lo),
                            "hi": p.limits.map(|l| l.hi),
                        })
                    })
                    .collect();
                json!({
                    "name": o.name(),
                    "signature": o.signature(),
                    "doc": o.doc(),
                    "space": o.space().to_string(),
                    "params": params,
                })
            })
            .collect();
        json!({
            "task": self.task.name(),
            "status": self.status(),
            "backend": self.backend_name(),
            "simulator": self.backend.is_simulator(),
            "points": st.learner.len(),
            "learner": st.learner.kind_name(),
            "current": st.current,
            "selection": st.selection.map(chunk),
            "executions": executions,
            "shown": shown,
            "history": history,
            "operators": operators,
            "tasks": self.task_names(),
            "suggestions": serde_json::to_value(&st.suggested).unwrap_or(Value::Null),
        })
    }

    /// One execution as the page draws it: the path (true poses where known), goal, ball, arena,
    /// outcome, the action plot's series (each marked with the action dimension it plots, when it
    /// plots one as executed), times, and the chunks selected, critiqued and advised.
    fn execution_json(&self, i: usize, rec: &HeldExecution) -> Value {
        let view = self.plot_view(i, rec);
        let series = view.action_series();
        // `action_series` gives each action dimension, followed (for changes of speed) by the
        // speed it integrates to: the first of each is the dimension as executed.
        let mut dims = vec![None; series.len()];
        let mut k = 0;
        for d in 0..self.domain.act.len().min(rec.trace.act_dim()) {
            if let Some(slot) = dims.get_mut(k) {
                *slot = Some(d);
            }
            k += if view.speed_limits.is_some() && d < 2 {
                2
            } else {
                1
            };
        }
        let series: Vec<Value> = series
            .iter()
            .zip(dims)
            .map(|(s, dim)| json!({"label": s.label, "values": s.values, "dim": dim}))
            .collect();
        json!({
            "index": i,
            "label": rec.label,
            "title": view.title,
            "points": rec.trace.len(),
            "t": rec.trace.t,
            "path": view.path.iter().map(|p| [p.x_m, p.y_m]).collect::<Vec<_>>(),
            // Which way the robot faced at the end, to compare with the goal's heading.
            "final_heading": view.path.last().map(|p| p.theta_rad).filter(|h| h.is_finite()),
            // The `end when` rule that ended the run (a declared task's), as written.
            "end_rule": rec.execution.as_ref().and_then(|e| e.outcome.end_rule.clone()),
            "drawn": view
                .drawn
                .iter()
                .map(|d| json!({"name": d.name, "shape": d.shape.word(), "values": d.values, "goal": d.is_goal()}))
                .collect::<Vec<_>>(),
            "ball": view.ball,
            "arena": view.arena.map(|a| json!({"half_m": a.half_m, "capture_m": a.capture_m})),
            "outcome": view.outcome,
            "series": series,
            "selection": view.selection.map(chunk),
            "flagged": view.flagged.iter().copied().map(chunk).collect::<Vec<_>>(),
            "advised": view.advised.iter().copied().map(chunk).collect::<Vec<_>>(),
            // The windows the teacher drove (a takeover).
            "teacher": view.teacher.iter().copied().map(chunk).collect::<Vec<_>>(),
        })
    }

    /// Run `statement` as [`Session::execute`] does; when it is a `preview`, also give what it
    /// would add as data (else `null`): for each synthesized point the executed point it came
    /// from, and its values before and after in the operator's space. The reply's text and the
    /// data come from one synthesis, so they agree.
    pub fn execute_previewing(
        &mut self,
        statement: &str,
        origin: &str,
    ) -> (Result<super::Reply, SessionError>, Value) {
        self.previewed = Some(Value::Null);
        let reply = self.execute(statement, origin);
        (reply, self.previewed.take().unwrap_or(Value::Null))
    }

    /// [`Session::execute_previewing`]'s data.
    pub(super) fn preview_data(&self, previewed: &super::advice::Previewed) -> Value {
        let super::advice::Previewed {
            execution: i,
            chunk: sel,
            syn,
            ..
        } = previewed;
        let (i, sel) = (*i, *sel);
        let rec = &self.state.executions[i];
        let space = syn.advice.space;
        let (before, after): (Vec<Vec<f64>>, Vec<Vec<f64>>) = syn
            .source_index
            .iter()
            .enumerate()
            .map(|(j, &src)| {
                let (b, a) = super::advice::before_after(&rec.trace, syn, j, src);
                (b.to_vec(), a.to_vec())
            })
            .unzip();
        json!({
            "execution": i,
            "chunk": chunk(sel),
            "invocation": syn.advice.invocation(),
            "space": space.to_string(),
            "dims": self.domain.dims(space).iter().map(|d| d.name.clone()).collect::<Vec<_>>(),
            "source_index": syn.source_index,
            "before": before,
            "after": after,
        })
    }
}
