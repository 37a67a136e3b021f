//! Running the policy and looking at what it did: `run`, `show`, `plot`.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::Path;

use super::effect::{Effect, ExecutionEntry, RunEntry};
use super::text::{outcome_line, short_num, worth_a_look};
use super::{HeldExecution, MAX_GOAL_M, Ran, Reply, Session, SessionError, plot};
use crate::backend::Interruptible;
use crate::backend::sim::SimParams;
use crate::diag::did_you_mean;
use crate::program::task::Drawn;
use crate::program::task::GoalParam;
use crate::syntax::InvArg;
use crate::syntax::command::{PlotKind, TakeoverSeconds};
use crate::task;
use crate::task::{Start, TaskKind, episode_seed};
use crate::trace::Pose;

impl Session {
    pub(super) fn sim_params(&self) -> SimParams {
        self.sim.clone()
    }

    /// `run goal V...`: the task's goal, its values in the declared order or by name. A
    /// positioning goal is any pose a run can reach ([`check_goal`]); a declared task's goal stays
    /// within its declared ranges.
    pub(super) fn run_goal(
        &mut self,
        args: &[InvArg],
        takeover: Option<TakeoverSeconds>,
    ) -> Result<Reply, SessionError> {
        let Some(def) = self.task.def() else {
            return Err(SessionError::GoalForWrongTask {
                task: self.task.clone(),
            });
        };
        let positioning = self.task == TaskKind::Positioning;
        let values = bind_goal(self.task.name(), &def.goal, args, !positioning)?;
        let start = if positioning {
            check_goal(values[0], values[1], values[2])?;
            Start::Goal(Pose::new(values[0], values[1], values[2]))
        } else {
            check_goal_ranges(self.task.name(), &def.goal, &values)?;
            Start::Declared(def.clone(), values.clone())
        };
        let goal = match &start {
            Start::Goal(g) => Some(*g),
            _ => None,
        };
        let label = format!(
            "run goal {}",
            values
                .iter()
                .map(|v| short_num(*v))
                .collect::<Vec<_>>()
                .join(" ")
        );
        self.run(start, label, goal, takeover)
    }

    pub(super) fn run_start(
        &mut self,
        n: usize,
        takeover: Option<TakeoverSeconds>,
    ) -> Result<Reply, SessionError> {
        let start = self.task.practice_start(self.seed, n as u64)?;
        let goal = match start {
            Start::Goal(g) => Some(g),
            Start::Ball(_) | Start::Declared(..) => None,
        };
        self.run(start, format!("run start {n}"), goal, takeover)
    }

    pub(super) fn run(
        &mut self,
        start: Start,
        label: String,
        goal: Option<Pose>,
        window: Option<TakeoverSeconds>,
    ) -> Result<Reply, SessionError> {
        if self.state.learner.is_empty() {
            return Err(SessionError::EmptyPolicy {
                task: self.task.clone(),
            });
        }
        let label = match window {
            Some(w) => format!("{label} takeover {w}"),
            None => label,
        };
        // A declared task's goal is kept for its pictures; positioning's is `goal`.
        let goal_values = match &start {
            Start::Declared(_, values) => Some(values.clone()),
            Start::Goal(_) | Start::Ball(_) => None,
        };
        let number = self.state.runs;
        let seed = episode_seed(self.seed, 1_000_000 + number);
        // Checked before anything moves; the teacher's own randomness has a seed of its own.
        let mut takeover = self.takeover_for(window, episode_seed(seed, 1))?;
        self.state.learner.prepare();
        // One control loop for every base: the simulator starts afresh from the run's seed (as
        // `run_sim` does), a robot is the connected one. Ctrl-C reaches the loop through `stop`.
        self.backend.begin(seed);
        self.stop.clear();
        let mut guarded = Interruptible::new(self.backend.as_mut(), self.stop.clone());
        let driven = {
            let mut controller = self.state.learner.policy();
            let mut task = start.task();
            task::takeover::run_episode_with(
                &mut guarded,
                task.as_mut(),
                &mut controller,
                takeover.as_mut(),
                seed,
            )
        };
        drop(takeover);
        let (result, teacher) = (driven.result, driven.teacher);
        let (exec, failure) = match result {
            Ok(exec) => (exec, None),
            Err(interrupted) => {
                let task::Interrupted { execution, error } = interrupted;
                (*execution, Some(error))
            }
        };
        let stopped = exec.outcome.non_finite.clone();
        let label = match (&failure, &stopped) {
            (Some(_), _) => format!("{label} (interrupted)"),
            (None, Some(_)) => format!("{label} (stopped)"),
            (None, None) => label,
        };
        // The dataset has not changed during the run: the points nearest now are the ones that
        // recommended each action, kept for `critique`.
        let support = self.state.learner.support_provenance(&exec.trace);
        let kernel = self.state.learner.kernel_coverage(&exec.trace);
        let summary = outcome_line(&exec);
        let goal_named = self
            .task
            .def()
            .zip(start.goal_values())
            .map(|(def, values)| name_goal(&def.goal, &values));
        let n = exec.trace.len();
        let hint = worth_a_look(exec.path(), &exec.trace.t, 30);
        // What the base did is kept even when the run failed: on a robot it cannot be had again.
        self.commit(Effect::Execution(Box::new(ExecutionEntry {
            label: label.clone(),
            trace: exec.trace.to_json(),
            goal,
            goal_values,
            run: Some(RunEntry {
                number,
                outcome: exec.outcome,
                true_poses: exec.true_poses,
                ball: exec.ball,
                support,
                teacher: teacher.clone(),
            }),
        })))?;
        let index = self.state.executions.len() - 1;
        // What the teacher drove is kept, even of a run that failed.
        let takeovers = self.keep_takeovers(index, &teacher)?;
        let takeover_missed = window
            .filter(|_| takeovers.is_empty())
            .map(|w| w.to_string());
        let took_over: String = takeovers
            .iter()
            .map(|t| {
                format!(
                    "; the teacher drove steps {} ({:.2} s to {:.2} s), kept as takeover #{} ({} points)",
                    t.steps, t.from_s, t.to_s, t.number, t.points
                )
            })
            .collect();
        if let Some(error) = failure {
            return Err(SessionError::RunInterrupted {
                index,
                label,
                steps: n,
                took_over,
                error,
            });
        }
        if let Some(reason) = stopped {
            return Err(SessionError::RunStopped {
                index,
                label,
                steps: n,
                took_over,
                reason,
            });
        }
        Ok(Reply::Ran(Ran {
            index,
            label,
            points: n,
            goal: goal_named,
            outcome: summary,
            worth_a_look: hint,
            kernel,
            takeovers,
            takeover_missed,
        }))
    }

    pub(super) fn current(&self) -> Result<(usize, &HeldExecution), SessionError> {
        let i = self.state.current.ok_or(SessionError::NoExecution)?;
        Ok((i, &self.state.executions[i]))
    }

    pub(super) fn show(&self, n: Option<usize>) -> Result<String, SessionError> {
        let (i, rec) = match n {
            Some(n) => (n, self.numbered(n)?),
            None => self.current()?,
        };
        let mut out = format!("execution {i}: {} ({} points", rec.label, rec.trace.len());
        if let (Some(first), Some(last)) = (rec.trace.t.first(), rec.trace.t.last()) {
            let _ = write!(out, ", {:.2} s", last - first);
        }
        out.push_str(")\n");
        if let Some(e) = &rec.execution {
            let _ = writeln!(out, "{}", outcome_line(e));
        }
        if let Some(sel) = self
            .state
            .selection
            .filter(|_| self.state.current == Some(i))
        {
            let _ = writeln!(out, "selected {sel} ({} points)", sel.len());
        }
        let view = self.plot_view(i, rec);
        if view.path.is_empty() {
            out.push_str("(no poses recorded: no path to plot)\n");
        } else {
            out.push_str(&plot::ascii(&view, 64, 16));
        }
        out.push_str(&plot::strip(&view, 64));
        Ok(out)
    }

    pub(super) fn plot_poses<'a>(&self, rec: &'a HeldExecution) -> Option<&'a [Pose]> {
        rec.execution
            .as_ref()
            .and_then(|e| e.true_poses.as_deref())
            .or(rec.trace.pose.as_deref())
    }

    pub(super) fn plot_view<'a>(&'a self, i: usize, rec: &'a HeldExecution) -> plot::PlotView<'a> {
        let rules = crate::task::interception::InterceptionRules::default();
        let interception = self.task == TaskKind::Interception;
        plot::PlotView {
            title: format!("execution {i}: {}", rec.label),
            domain: &self.domain,
            trace: &rec.trace,
            path: self.plot_poses(rec).unwrap_or(&[]),
            drawn: self.drawn(rec),
            ball: rec.execution.as_ref().and_then(|e| e.ball.as_deref()),
            arena: interception.then_some(plot::Arena {
                half_m: rules.arena_half_m,
                capture_m: rules.capture_m,
            }),
            outcome: rec.execution.as_ref().map(outcome_line),
            speed_limits: interception.then_some([rules.max_speed_mps, rules.max_rot_radps]),
            selection: self
                .state
                .selection
                .filter(|_| self.state.current == Some(i)),
            flagged: rec.flagged.clone(),
            advised: rec.advised.clone(),
            teacher: rec.teacher.clone(),
        }
    }

    /// What the task draws for the execution's goal (its `draw` clauses); nothing for an
    /// execution without a goal or a task that draws none.
    fn drawn(&self, rec: &HeldExecution) -> Vec<Drawn> {
        let values = rec
            .goal_values
            .clone()
            .or_else(|| rec.goal.map(|g| vec![g.x_m, g.y_m, g.theta_rad]));
        match (self.task.def(), values) {
            (Some(def), Some(values)) => task::declared::drawings(&def, &values),
            _ => Vec::new(),
        }
    }

    /// `plot FILE` draws the selected execution's path, `plot actions FILE` its actions against
    /// point index, `plot compare FILE N M` the paths of executions N and M overlaid.
    pub(super) fn plot(&self, kind: PlotKind, path: &str) -> Result<String, SessionError> {
        self.check_output(path, false)?;
        let file = Path::new(path);
        let no_poses = |n: usize| SessionError::NoPoses { n };
        match kind {
            PlotKind::Path => {
                let (i, rec) = self.current()?;
                let view = self.plot_view(i, rec);
                if view.path.is_empty() {
                    return Err(no_poses(i));
                }
                plot::svg(&view, file)?;
                Ok(format!("wrote {path}: the path of execution {i}"))
            }
            PlotKind::Actions => {
                let (i, rec) = self.current()?;
                plot::svg_actions(&self.plot_view(i, rec), file)?;
                Ok(format!(
                    "wrote {path}: the actions of execution {i} against point index"
                ))
            }
            PlotKind::Compare { before, after } => {
                let a = self.plot_view(before, self.numbered(before)?);
                let b = self.plot_view(after, self.numbered(after)?);
                for (n, v) in [(before, &a), (after, &b)] {
                    if v.path.is_empty() {
                        return Err(no_poses(n));
                    }
                }
                plot::svg_compare(&a, &b, file)?;
                Ok(format!(
                    "wrote {path}: execution {before} (blue) and {after} (green) overlaid"
                ))
            }
        }
    }
}

/// A journalled goal of a declared task: a finite value, within the bound every goal range has,
/// for each of the task's goal parameters.
pub(super) fn check_goal_values(task: &TaskKind, values: &[f64]) -> Result<(), SessionError> {
    let params = task.def().map(|d| d.goal.clone()).unwrap_or_default();
    let fits = |v: &f64| v.is_finite() && v.abs() <= crate::program::task::MAX_GOAL_ABS;
    if values.len() == params.len() && values.iter().all(fits) {
        return Ok(());
    }
    let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
    Err(SessionError::BadGoalValues {
        goal: values
            .iter()
            .take(8)
            .map(|v| short_num(*v))
            .collect::<Vec<_>>()
            .join(", "),
        task: task.clone(),
        params: if names.is_empty() {
            "none (its runs have no goal values)".into()
        } else {
            names.join(", ")
        },
    })
}

/// A goal a run can reach: x and y within [`MAX_GOAL_M`] of the start, theta within ±2π. The one
/// rule for `run goal`, `record demo ... goal` and a journalled execution's goal.
pub(super) fn check_goal(x: f64, y: f64, theta: f64) -> Result<(), SessionError> {
    let within = |v: f64, limit: f64| v.is_finite() && v.abs() <= limit;
    if within(x, MAX_GOAL_M) && within(y, MAX_GOAL_M) && within(theta, 2.0 * PI) {
        Ok(())
    } else {
        Err(SessionError::BadGoal {
            goal: [x, y, theta].map(short_num).join(", "),
        })
    }
}

/// A goal's values with their names and units, as a run's reply names them: `px = 2.31 m, py = -0.5 m`.
pub(super) fn name_goal(params: &[GoalParam], values: &[f64]) -> String {
    params
        .iter()
        .zip(values)
        .map(|(p, v)| {
            let v = (v * 1e4).round() / 1e4;
            match p.unit.as_str() {
                "" => format!("{} = {}", p.name, short_num(v)),
                u => format!("{} = {} {u}", p.name, short_num(v)),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A task's goal parameters with their ranges, as a diagnostic lists them:
/// `px in [1.5, 4] m, py in [-2, 2] m`; without the ranges (`x_g m, ...`) where any reachable
/// value is taken (positioning's ranges are its practice and test goals' only).
fn goal_ranges(params: &[GoalParam], ranges: bool) -> String {
    params
        .iter()
        .map(|p| {
            let range = if ranges {
                format!("{} in [{}, {}]", p.name, short_num(p.lo), short_num(p.hi))
            } else {
                p.name.clone()
            };
            match p.unit.as_str() {
                "" => range,
                u => format!("{range} {u}"),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The goal `run goal` names, in the declared order: positional values fill the parameters from
/// the first, named ones (`px=2`) their own; every parameter once, none unknown.
fn bind_goal(
    task: &str,
    params: &[GoalParam],
    args: &[InvArg],
    with_ranges: bool,
) -> Result<Vec<f64>, SessionError> {
    let ranges = || goal_ranges(params, with_ranges);
    let example = || {
        let mid = |p: &GoalParam| ((p.lo + p.hi) * 5.0).round() / 10.0;
        let named: Vec<String> = params
            .iter()
            .map(|p| format!("{}={}", p.name, short_num(mid(p))))
            .collect();
        format!("`run goal {}`", named.join(" "))
    };
    let positional = args.iter().filter(|a| a.name.is_none()).count();
    if positional > params.len() || args.len() > params.len() {
        return Err(SessionError::GoalCount {
            task: task.to_string(),
            given: args.len(),
            expected: params.len(),
            params: ranges(),
            example: example(),
        });
    }
    let mut values: Vec<Option<f64>> = vec![None; params.len()];
    let mut next = 0;
    for a in args {
        let i = match &a.name {
            None => {
                next += 1;
                next - 1
            }
            Some(n) => params
                .iter()
                .position(|p| p.name == n.name)
                .ok_or_else(|| {
                    let names = params.iter().map(|p| p.name.as_str());
                    SessionError::UnknownGoalParam {
                        name: n.name.clone(),
                        task: task.to_string(),
                        help: did_you_mean(&n.name, names)
                            .map(|h| format!("{h} ({})", ranges()))
                            .unwrap_or_else(|| format!("the goal of {task} is {}", ranges())),
                    }
                })?,
        };
        if values[i].replace(a.value).is_some() {
            return Err(SessionError::GoalParamTwice {
                name: params[i].name.clone(),
                params: ranges(),
            });
        }
    }
    let missing: Vec<&str> = params
        .iter()
        .zip(&values)
        .filter(|(_, v)| v.is_none())
        .map(|(p, _)| p.name.as_str())
        .collect();
    if !missing.is_empty() {
        return Err(SessionError::GoalMissing {
            task: task.to_string(),
            missing: missing.join(", "),
            params: ranges(),
            example: example(),
        });
    }
    Ok(values.into_iter().flatten().collect())
}

/// A declared task's goal within its declared ranges (what its practice and test goals are drawn
/// from, and what its rules were written for).
fn check_goal_ranges(task: &str, params: &[GoalParam], values: &[f64]) -> Result<(), SessionError> {
    for (p, v) in params.iter().zip(values) {
        if !(v.is_finite() && (p.lo..=p.hi).contains(v)) {
            return Err(SessionError::GoalOutOfRange {
                task: task.to_string(),
                name: p.name.clone(),
                value: short_num(*v),
                params: goal_ranges(params, true),
            });
        }
    }
    Ok(())
}
