//! The automated advisor of the A-OPI study: it watches a positioning execution and, when the
//! execution is poor, names a standard advice operator and the chunk to apply it to, the way the
//! paper's human advisor did. It never writes an action: what it returns is an operator name
//! and a chunk, and the points come from [`crate::interp::apply`] of the checked operator from
//! `operators/positioning.adv`, exactly as `advise OPERATOR` in a session.
//!
//! It sees what a person watching the robot sees: where the robot stopped relative to the goal
//! (the true final pose, as [`Outcome`] records it) and the execution's trace (observations and
//! the speeds the robot drove). It does not see the policy or its data. The rule:
//!
//! 1. An execution is **poor** when the robot ended farther than [`AdvisorRules::position_tol_m`]
//!    from the goal or more than [`AdvisorRules::heading_tol_rad`] off the goal heading, or did not
//!    come to rest. A good execution gets no advice.
//! 2. Position first (a human fixes where the robot goes before how it faces):
//!    - **stopped short** (the goal still ahead when it stopped, within pi/2 of the heading):
//!      `translational_acceleration` on the last [`AdvisorRules::chunk_len`] points at which the
//!      robot was still driving: "keep going here".
//!    - **overshoot** (the goal ended behind the robot, and the robot had been closer to the goal
//!      than where it stopped): `translational_deceleration` on the chunk leading up to the
//!      closest approach: "slow down as you get there".
//!    - **wandering** (the time limit passed with the robot far from the goal): `slow_down` on the
//!      last chunk of driving.
//! 3. Then heading, when the heading is off: over the last chunk in which the robot was turning,
//!    if it turned toward the goal heading but stopped turning too soon (the remaining heading
//!    error has the sign of the turn), `rotational_acceleration`; if it turned past it (opposite
//!    sign), `rotational_deceleration`.
//! 4. Close enough but never at rest (the time limit passed near the goal): `stop` on the last
//!    chunk: "you were there; stop".
//!
//! So an execution gets one or two pieces of advice, each on one chunk of at most
//! [`AdvisorRules::chunk_len`] points (the operators' guards may skip some of them).

use serde::{Deserialize, Serialize};

use crate::syntax::Invocation;
use crate::task::{Ending, Execution, Outcome};
use crate::trace::{Chunk, Trace};

/// Positioning's columns: observation `[dist2, bearing, dheading]`, action `[trans, rot]`.
const DIST2: usize = 0;
const BEARING: usize = 1;
const DHEADING: usize = 2;
const TRANS: usize = 0;
const ROT: usize = 1;

/// A point counts as driving / turning above these speeds (m/s, rad/s).
const MOVING_MPS: f64 = 0.02;
const TURNING_RADPS: f64 = 0.02;

/// The numbers of the advisor's rule (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdvisorRules {
    /// A final position error above this is poor, m (stricter than success's 1.0 m: a person
    /// advises a run that was clearly off, even if it would pass).
    pub position_tol_m: f64,
    /// A final heading error above this is poor, rad.
    pub heading_tol_rad: f64,
    /// Largest chunk advised, points.
    pub chunk_len: usize,
}

impl Default for AdvisorRules {
    fn default() -> Self {
        AdvisorRules {
            position_tol_m: 0.5,
            heading_tol_rad: 0.5,
            chunk_len: 25,
        }
    }
}

/// Why an execution was advised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    StoppedShort,
    Overshoot,
    MissedTurningTooLittle,
    MissedTurningAway,
    TurnedTooLittle,
    TurnedTooMuch,
    NotStopping,
}

impl Reason {
    pub fn name(self) -> &'static str {
        match self {
            Reason::StoppedShort => "stopped short",
            Reason::Overshoot => "overshoot",
            Reason::MissedTurningTooLittle => "missed, turning too little",
            Reason::MissedTurningAway => "missed, turning away",
            Reason::TurnedTooLittle => "turned too little",
            Reason::TurnedTooMuch => "turned too much",
            Reason::NotStopping => "not stopping",
        }
    }
}

/// One piece of advice: an operator invocation and the chunk it applies to.
#[derive(Clone, Debug, PartialEq)]
pub struct Advice {
    pub operator: Invocation,
    pub chunk: Chunk,
    pub reason: Reason,
}

/// Whether an execution is poor (rule 1).
pub fn is_poor(outcome: &Outcome, rules: &AdvisorRules) -> bool {
    outcome.position_error_m > rules.position_tol_m
        || outcome.heading_error_rad.unwrap_or(0.0) > rules.heading_tol_rad
        || outcome.ending != Ending::Rested
}

/// The advice for a positioning execution: empty when the execution is good.
pub fn advise(exec: &Execution, rules: &AdvisorRules) -> Vec<Advice> {
    let trace = &exec.trace;
    let n = trace.len();
    if n == 0 || trace.obs_dim() <= DHEADING || trace.act_dim() <= ROT {
        return Vec::new();
    }
    let o = &exec.outcome;
    if !is_poor(o, rules) {
        return Vec::new();
    }
    let mut out = Vec::new();
    let advice = |text: &str, chunk: Chunk, reason: Reason| Advice {
        // The advisor's invocations are fixed, well-formed texts.
        operator: crate::syntax::parse_invocation(text).unwrap_or_else(|_| Invocation::bare(text)),
        chunk,
        reason,
    };
    let far = o.position_error_m > rules.position_tol_m;
    let last = trace.z(n - 1);
    if far {
        let closest = (0..n)
            .min_by(|&i, &j| trace.z(i)[DIST2].total_cmp(&trace.z(j)[DIST2]))
            .unwrap_or(n - 1);
        let closest_m = trace.z(closest)[DIST2].sqrt();
        let passed = closest_m <= rules.position_tol_m && closest_m + 0.1 < last[DIST2].sqrt();
        let goal_ahead = last[BEARING].abs() < std::f64::consts::FRAC_PI_4;
        if passed {
            if let Some(c) = last_chunk_where(trace, closest + 1, rules.chunk_len, driving) {
                out.push(advice("translational_deceleration", c, Reason::Overshoot));
            }
        } else if goal_ahead && o.ending == Ending::Rested {
            if let Some(c) = last_chunk_where(trace, n, rules.chunk_len, driving) {
                out.push(advice(
                    "translational_acceleration",
                    c,
                    Reason::StoppedShort,
                ));
            }
        } else if let Some(c) = last_chunk_where(trace, closest + 1, rules.chunk_len, driving) {
            // Missed to the side: over the approach's last chunk, was the robot turning toward
            // the goal (too little) or away from it?
            let toward: f64 = c
                .range()
                .map(|t| trace.a(t)[ROT] * trace.z(t)[BEARING].signum())
                .sum();
            if toward > 0.0 {
                out.push(advice("turn_tighter(2)", c, Reason::MissedTurningTooLittle));
            } else {
                out.push(advice(
                    "translational_deceleration(0.5)",
                    c,
                    Reason::MissedTurningAway,
                ));
            }
        }
    }
    if o.heading_error_rad.unwrap_or(0.0) > rules.heading_tol_rad
        && let Some(c) = last_chunk_where(trace, n, rules.chunk_len, turning)
    {
        // The turn's direction over the chunk, against the heading still to go at the end
        // (`dheading` = theta_g - theta_r, odometry's view, which is what the robot turned on).
        let turn: f64 = c.range().map(|t| trace.a(t)[ROT]).sum();
        let to_go = last[DHEADING];
        if turn * to_go > 0.0 {
            out.push(advice(
                "rotational_acceleration",
                c,
                Reason::TurnedTooLittle,
            ));
        } else {
            out.push(advice("rotational_deceleration", c, Reason::TurnedTooMuch));
        }
    }
    if out.is_empty() && o.ending != Ending::Rested {
        let start = n.saturating_sub(rules.chunk_len);
        out.push(advice("stop", Chunk { start, end: n }, Reason::NotStopping));
    }
    out
}

fn driving(trace: &Trace, t: usize) -> bool {
    trace.a(t)[TRANS].abs() > MOVING_MPS
}

fn turning(trace: &Trace, t: usize) -> bool {
    trace.a(t)[ROT].abs() > TURNING_RADPS
}

/// The last run of up to `len` consecutive points before `end` that satisfy `pred` (the chunk a
/// person would select: the latest stretch of the behaviour), or `None` if no point does.
fn last_chunk_where(
    trace: &Trace,
    end: usize,
    len: usize,
    pred: fn(&Trace, usize) -> bool,
) -> Option<Chunk> {
    let last = (0..end.min(trace.len())).rev().find(|&t| pred(trace, t))?;
    let mut start = last;
    while start > 0 && last + 1 - start < len && pred(trace, start - 1) {
        start -= 1;
    }
    Some(Chunk {
        start,
        end: last + 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::OperatorSet;
    use crate::domain::Domain;
    use crate::task::Outcome;
    use crate::trace::Pose;

    /// A straight drive along +x toward a goal at (goal_x, 0) heading 0, at `speed` until
    /// `stop_x`, then at rest; observations as the positioning task makes them.
    fn drive(goal_x: f64, stop_x: f64, speed: f64) -> Execution {
        let mut trace = Trace::new(&Domain::positioning());
        let step = speed / 30.0;
        let mut x = 0.0;
        let mut t = 0.0;
        loop {
            let moving = x < stop_x;
            let d = goal_x - x;
            let bearing = if d >= 0.0 { 0.0 } else { std::f64::consts::PI };
            trace.push(
                t,
                &[d * d, bearing, 0.0],
                &[if moving { speed } else { 0.0 }, 0.0],
                Some(Pose::new(x, 0.0, 0.0)),
            );
            if !moving {
                break;
            }
            x += step;
            t += 1.0 / 30.0;
        }
        let error = (goal_x - x).abs();
        Execution {
            outcome: Outcome {
                success: error < 1.0,
                ending: Ending::Rested,
                position_error_m: error,
                heading_error_rad: Some(0.0),
                length_m: x,
                steps: trace.len(),
                duration_s: t,
                final_pose: Pose::new(x, 0.0, 0.0),
            },
            trace,
            true_poses: None,
            ball: None,
        }
    }

    #[test]
    fn a_straight_approach_to_the_goal_gets_no_advice() {
        let exec = drive(2.0, 2.0, 0.5);
        assert!(exec.outcome.position_error_m < 0.05);
        assert!(advise(&exec, &AdvisorRules::default()).is_empty());
    }

    #[test]
    fn stopping_short_gets_translational_acceleration_on_the_last_driving_chunk() {
        let exec = drive(3.0, 1.5, 0.5);
        let advice = advise(&exec, &AdvisorRules::default());
        assert_eq!(advice.len(), 1);
        let a = &advice[0];
        assert_eq!(a.operator.to_string(), "translational_acceleration");
        assert_eq!(a.reason, Reason::StoppedShort);
        assert_eq!(a.chunk.len(), 25);
        // The chunk ends at the last driving point.
        assert!(driving(&exec.trace, a.chunk.end - 1));
        assert!(!driving(&exec.trace, a.chunk.end));
    }

    #[test]
    fn overshooting_gets_deceleration_up_to_the_closest_approach() {
        let exec = drive(1.5, 2.5, 0.5);
        let advice = advise(&exec, &AdvisorRules::default());
        assert_eq!(advice.len(), 1);
        let a = &advice[0];
        assert_eq!(a.operator.to_string(), "translational_deceleration");
        assert_eq!(a.reason, Reason::Overshoot);
        let closest_x = 1.5;
        let end_pose = exec.trace.pose.as_ref().unwrap()[a.chunk.end - 1];
        assert!((end_pose.x_m - closest_x).abs() < 0.05, "{end_pose:?}");
    }

    #[test]
    fn advice_speaks_only_through_standard_operators() {
        let ops = OperatorSet::standard();
        for exec in [drive(3.0, 1.5, 0.5), drive(1.5, 2.5, 0.5)] {
            for a in advise(&exec, &AdvisorRules::default()) {
                let syn = crate::interp::apply(&ops, &a.operator, &exec.trace, a.chunk).unwrap();
                assert!(!syn.points.is_empty());
                assert!(syn.source_index.iter().all(|i| a.chunk.range().contains(i)));
            }
        }
    }
}
