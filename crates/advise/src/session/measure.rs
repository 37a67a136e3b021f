//! Measuring and choosing the policy: `rederive`, `eval`, `learner`.

use std::time::Instant;

use super::effect::Effect;
use super::{Evaluated, Reply, Session, SessionError, Since};
use crate::diag::did_you_mean;
use crate::eval;
use crate::eval::EvalOptions;
use crate::policy::learner::{CoverageCounter, LearnerKind};
use crate::syntax::ast::Ident;

impl Session {
    pub(super) fn rederive(&mut self) -> Result<String, SessionError> {
        let started = Instant::now();
        // Re-derivation is deterministic for the session's seed, so the journal keeps the fact,
        // not the tuned numbers (`apply` makes the same call on restore).
        let what = self.state.learner.rederive();
        self.journal_effect(Effect::Rederive)?;
        let warning = match (
            self.state.learner.kind(),
            self.state.learner.held_out_coverage(),
        ) {
            (LearnerKind::Lwr, Some(c)) => crate::policy::learner::kernel_warning(
                c,
                "held-out points",
                "the demonstrations and advice lie too far apart for any kernel the data supports, so the learner's runs will mostly answer as 1-NN: demonstrate more starts (`load demos`, `teleop`) so that trajectories neighbour each other",
            ),
            _ => String::new(),
        };
        Ok(format!(
            "re-derived the {} policy from {} points in {:.1} ms{what}{warning}",
            self.state.learner.kind_name(),
            self.state.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        ))
    }

    pub(super) fn eval(&mut self, detail: bool) -> Result<Reply, SessionError> {
        if self.state.learner.is_empty() {
            return Err(SessionError::EmptyPolicy {
                task: self.task.clone(),
            });
        }
        self.state.learner.ensure_derived();
        let opts = EvalOptions {
            seed: self.seed,
            params: self.sim_params(),
            progress: self.progress,
        };
        let counter = CoverageCounter::new(&self.state.learner);
        let mut report = eval::evaluate(self.task.clone(), &counter, &opts);
        report.kernel = counter.coverage();
        // The whole test set on a robot takes minutes and needs room: not from the prompt.
        let robot = (!self.backend.is_simulator()).then(|| self.backend.name());
        // The simulator and the learners are deterministic: a report equal to the last one means
        // no test's result changed (the policy did not, or not where the tests go). Such an
        // evaluation is no new point of comparison, so `eval --detail` after `eval` lists the
        // changes that `eval` counted (the last evaluation against the one before it).
        if self.state.last_eval.as_ref() == Some(&report) {
            let (before, since) = match (&self.state.prev_eval, detail) {
                (Some(prev), true) => (prev.clone(), Since::LastAgainstPrevious),
                _ => (report.clone(), Since::Unchanged),
            };
            return Ok(Reply::Evaluated(Evaluated {
                report: Box::new(report),
                before: Some(Box::new(before)),
                detail,
                robot,
                since,
            }));
        }
        let before = self.state.last_eval.clone().map(Box::new);
        // Kept (and journalled) so the next `eval` can say what changed, after a resume too.
        self.commit(Effect::Evaluated {
            report: Box::new(report.clone()),
        })?;
        Ok(Reply::Evaluated(Evaluated {
            report: Box::new(report),
            before,
            detail,
            robot,
            since: Since::LastEval,
        }))
    }

    pub(super) fn set_learner(
        &mut self,
        name: &Ident,
        k: Option<usize>,
    ) -> Result<String, SessionError> {
        let Some(kind) = LearnerKind::from_name(&name.name) else {
            let names = LearnerKind::ALL.map(LearnerKind::name);
            return Err(SessionError::UnknownLearner {
                name: name.name.clone(),
                hint: did_you_mean(&name.name, names)
                    .map(|h| format!("; {h}"))
                    .unwrap_or_default(),
            });
        };
        // `k 0` would sum nothing: at least one point.
        let k = k.map(|k| k.max(1));
        if kind == self.state.learner.kind() && k == self.state.learner.lwr_k() {
            return Ok(format!(
                "the running learner is already {}: nothing changed",
                self.state.learner.kind_name()
            ));
        }
        let started = Instant::now();
        self.commit(Effect::Learner { learner: kind, k })?;
        let limit = match self.state.learner.lwr_query_k() {
            Some(k) if kind == LearnerKind::Lwr => {
                format!(", its kernel limited to the {k} nearest points")
            }
            _ => String::new(),
        };
        Ok(format!(
            "the running learner is now {}{limit} on {} points (re-derived in {:.1} ms); critique weights steer BC, advice points feed both",
            self.state.learner.kind_name(),
            self.state.learner.len(),
            started.elapsed().as_secs_f64() * 1e3
        ))
    }
}
