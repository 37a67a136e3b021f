//! Where a task's `flaw` clauses hold on an execution: the stretches a person would call poor, by
//! the task's own words.
//!
//! The environment of each point is rebuilt from the recorded trace as the run filled it: the
//! pose from odometry, `t` from the trace, the goal, then the task's values in their checked
//! order, with each observation taken as recorded (what the robot saw). Two things differ from a
//! live step, both written in the language reference: the speeds `v` and `w` are the ones the
//! odometry shows between the point and the one before it (a trace keeps poses, not speeds; 0 at
//! the first point), and an action reads the action *taken at* the point, not the one before.
//! `prev(NAME)` reads the point before (at the first point, the point itself), and the look-backs
//! (`total`, `change`) read the points of the stretch before. The work is linear in the trace's
//! length times the declaration's size, whatever the look-backs' lengths. This module does no IO.

use crate::geometry::wrap_angle;
use crate::program::task::{self as def, TaskDef, WindowKind};
use crate::trace::{Chunk, Trace};

/// A stretch where a flaw held: `flaw` is its index in [`TaskDef::flaws`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Held {
    pub flaw: usize,
    pub chunk: Chunk,
}

/// Why flaws cannot be looked for on a trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unreadable {
    /// The trace keeps no poses (a loaded trace without them): a task's values cannot be rebuilt.
    NoPoses,
    /// The trace's dimensions are not the task's.
    WrongShape,
}

/// Small enough that 30 periods of 1/30 s count as one second.
const EPS_S: f64 = 1e-9;

/// The stretches where `def`'s flaws held on `trace` toward `goal` (one value per goal
/// parameter), by flaw in declaration order and then by start. A stretch is a maximal run of
/// points where the condition held, kept when it lasted at least the flaw's `for` time (a
/// point lasts one control period).
pub fn find(def: &TaskDef, goal: &[f64], trace: &Trace) -> Result<Vec<Held>, Unreadable> {
    let n = trace.len();
    if def.flaws.is_empty() || n == 0 {
        return Ok(Vec::new());
    }
    if trace.obs_dim() != def.domain.obs_dim() || trace.act_dim() != def.domain.act_dim() {
        return Err(Unreadable::WrongShape);
    }
    let Some(poses) = trace.pose.as_deref() else {
        return Err(Unreadable::NoPoses);
    };
    if poses.len() != n || trace.t.len() != n {
        return Err(Unreadable::WrongShape);
    }
    let slots = def.slots();
    let width = slots + def.windows.len();
    // Every point's environment, task slots then window slots, row after row.
    let mut envs = vec![0.0; n * width];
    let mut obs_of = vec![None; slots];
    for (i, s) in def.observe.iter().enumerate() {
        obs_of[*s] = Some(i);
    }
    for k in 0..n {
        let (done, rest) = envs.split_at_mut(k * width);
        let env = &mut rest[..width];
        let p = poses[k];
        env[def::X] = p.x_m;
        env[def::Y] = p.y_m;
        env[def::THETA] = p.theta_rad;
        env[def::T] = trace.t[k];
        if k > 0 {
            let q = poses[k - 1];
            let dt = trace.t[k] - trace.t[k - 1];
            if dt > 0.0 {
                let (dx, dy) = (p.x_m - q.x_m, p.y_m - q.y_m);
                env[def::V] = (dx * q.theta_rad.cos() + dy * q.theta_rad.sin()) / dt;
                env[def::W] = wrap_angle(p.theta_rad - q.theta_rad) / dt;
            }
        }
        let g = def.goal_slot();
        for (slot, v) in env[g..g + def.goal.len()].iter_mut().zip(goal) {
            *slot = *v;
        }
        let a = def.action_slot();
        env[a..a + trace.act_dim()].copy_from_slice(trace.a(k));
        for (slot, ir) in &def.computed {
            env[*slot] = match obs_of[*slot] {
                Some(i) => trace.z(k)[i],
                None if k == 0 => ir.eval_task(env, env),
                None => ir.eval_task(env, &done[(k - 1) * width..k * width]),
            };
        }
    }
    fill_windows(def, trace, &mut envs, width);
    let period_s = if n > 1 {
        (trace.t[n - 1] - trace.t[0]) / (n - 1) as f64
    } else {
        0.0
    };
    let mut held = Vec::new();
    for (fi, flaw) in def.flaws.iter().enumerate() {
        let mut start = None;
        for k in 0..=n {
            let holds = k < n && {
                let env = &envs[k * width..(k + 1) * width];
                let prev = &envs[k.saturating_sub(1) * width..(k.saturating_sub(1) + 1) * width];
                let v = flaw.cond.eval_task(env, prev);
                v.is_finite() && v != 0.0
            };
            match (holds, start) {
                (true, None) => start = Some(k),
                (false, Some(s)) => {
                    start = None;
                    let lasted_s = trace.t[k - 1] - trace.t[s] + period_s;
                    if lasted_s >= flaw.hold_s - EPS_S
                        && let Ok(chunk) = Chunk::new(s, k, n)
                    {
                        held.push(Held { flaw: fi, chunk });
                    }
                }
                _ => {}
            }
        }
    }
    Ok(held)
}

/// Each look-back's value at each point, in its slot: running sums over a window kept by two
/// indices, so the work is linear whatever the window's length. A value that is not a number
/// makes the windows holding it not numbers (a flaw there does not hold), not the whole run.
fn fill_windows(def: &TaskDef, trace: &Trace, envs: &mut [f64], width: usize) {
    let n = trace.len();
    for (wi, w) in def.windows.iter().enumerate() {
        let slot = def.window_slot(wi);
        let values: Vec<f64> = (0..n)
            .map(|k| {
                let prev = k.saturating_sub(1);
                let env = &envs[k * width..(k + 1) * width];
                w.value
                    .eval_task(env, &envs[prev * width..(prev + 1) * width])
            })
            .collect();
        let (mut lo, mut sum, mut bad) = (0usize, 0.0, 0usize);
        for k in 0..n {
            let v = values[k];
            if v.is_finite() {
                sum += v;
            } else {
                bad += 1;
            }
            let out = match w.kind {
                WindowKind::Total => {
                    // The points of the last `seconds`, this one included.
                    while trace.t[k] - trace.t[lo] >= w.seconds - EPS_S && lo < k {
                        if values[lo].is_finite() {
                            sum -= values[lo];
                        } else {
                            bad -= 1;
                        }
                        lo += 1;
                    }
                    if bad > 0 { f64::NAN } else { sum }
                }
                WindowKind::Change => {
                    // The earliest point at most `seconds` back.
                    while trace.t[k] - trace.t[lo] > w.seconds + EPS_S && lo < k {
                        lo += 1;
                    }
                    v - values[lo]
                }
            };
            envs[k * width + slot] = out;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{OperatorSet, Source};
    use crate::geometry::Pose;

    /// A task on a line: the robot drives along x toward `px`; `gap` is what is left.
    const LINE: &str = r#"
domain line {
  observe gap "m" in [-10, 10] = px - x
  act trans "m/s" in [-1, 1] drives speed
  goal px "m" in [1, 3]
  score error = abs(gap)
  success when error < 0.1
  end after 30
  flaw backing when trans < 0 for 0.2
  flaw receding when change(gap, 0.5) > 0.2
  flaw busy when total(abs(trans), 1) > 25
}
"#;

    fn def() -> std::sync::Arc<TaskDef> {
        let set = OperatorSet::standard()
            .merge(&[Source::new("line.adv", LINE)])
            .unwrap_or_else(|e| panic!("{}", crate::check::render_all(&e)));
        set.task("line").expect("a task").clone()
    }

    /// 10 Hz: forward at 1 m/s for 2 s, back at 1 m/s for 1 s, then forward again for 1 s.
    fn trace(def: &TaskDef) -> Trace {
        let mut tr = Trace::new(&def.domain);
        let mut x = 0.0;
        for k in 0..40 {
            let speed: f64 = if (20..30).contains(&k) { -1.0 } else { 1.0 };
            tr.push(
                k as f64 * 0.1,
                &[2.0 - x],
                &[speed],
                Some(Pose::new(x, 0.0, 0.0)),
            );
            x += 0.1 * speed;
        }
        tr
    }

    #[test]
    fn stretches_where_each_flaw_held() {
        let d = def();
        let held = find(&d, &[2.0], &trace(&d)).unwrap();
        let of = |name: &str| -> Vec<(usize, usize)> {
            held.iter()
                .filter(|h| d.flaws[h.flaw].name == name)
                .map(|h| (h.chunk.start, h.chunk.end))
                .collect()
        };
        // Backing: exactly the ten points driven backwards.
        assert_eq!(of("backing"), vec![(20, 30)]);
        // Receding: the gap now minus the gap five points (0.5 s) before is above 0.2 m from
        // point 24 (0.4 - 0.1) to point 31 (0.9 - 0.6); at 32 the forward drive has undone it
        // (0.8 - 0.7).
        assert_eq!(of("receding"), vec![(24, 32)]);
        // Busy: a total of |trans| over 1 s is at most 10 (ten points of 1): never above 25.
        assert_eq!(of("busy"), vec![]);
    }

    #[test]
    fn a_flaw_that_did_not_hold_long_enough_is_not_one() {
        let d = def();
        let mut tr = trace(&d);
        // One point backwards only (0.1 s < 0.2 s).
        for k in 21..30 {
            tr.a_mut(k)[0] = 1.0;
        }
        let held = find(&d, &[2.0], &tr).unwrap();
        assert!(
            held.iter().all(|h| d.flaws[h.flaw].name != "backing"),
            "{held:?}"
        );
    }

    #[test]
    fn a_trace_without_poses_is_refused() {
        let d = def();
        let mut tr = trace(&d);
        tr.pose = None;
        assert_eq!(find(&d, &[2.0], &tr), Err(Unreadable::NoPoses));
    }
}
