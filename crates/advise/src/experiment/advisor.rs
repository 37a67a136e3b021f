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
//! 2. When it ended far from the goal, first how it ended, on the chunk next to the end:
//!    - **overshoot** (the robot came within the tolerance, then stopped farther away):
//!      `translational_deceleration(gain)` on the last [`AdvisorRules::chunk_len`] driving
//!      points up to the closest approach: "slow down as you get there";
//!    - **stopped short** (at rest with the goal still ahead, within pi/4 of the heading):
//!      `translational_acceleration(gain)` on the last driving chunk: "keep going here".
//!
//!    Then how it got there: the **arcs of the approach**, judged against the goal *pose*. A
//!    person expects the robot to bend onto the goal heading as it comes (the paper's "smoothly
//!    coupled rotational and translational speeds"), so the reference is the arc to an aim point
//!    behind the goal along its heading, set back by half the remaining distance (at most 1 m),
//!    tangent to the robot's heading: curvature `2 sin(bearing) / distance` to that point. The
//!    driven curvature is the path's (heading change over distance, over 5 points). Beyond 0.6 m
//!    of the goal, a driving point is **too wide** when it turns toward the aim at less than 0.6
//!    of the wanted curvature, **too tight** above 1.7 of it, **away** when it turns the other
//!    way, **straight** when it drives straight with the aim clearly off to the side. Runs of at
//!    least [`AdvisorRules::min_chunk`] points with the same fault are the chunks a person would
//!    select; the longest [`AdvisorRules::approach_chunks`] of them are advised, each cut to its
//!    first [`AdvisorRules::chunk_len`] points: too wide gets `turn_tighter(rate)`, too tight
//!    `turn_looser(rate)`, away `no_turning`; a straight run the robot ended by turning toward
//!    the aim (within 10 points) gets `start_turning_earlier(steps)` on the first chunk of that
//!    turn, `steps` the straight run's length rounded up to 5 points.
//!
//!    If neither found anything (missed to the side with no clear arc): over the last driving
//!    chunk before the closest approach, `turn_tighter(rate)` if the robot was turning toward the
//!    goal, else `translational_deceleration(rate)`.
//! 3. Then heading, when the heading is off: over the last chunk in which the robot was turning,
//!    if it turned toward the goal heading but stopped turning too soon, `rotational_acceleration
//!    (gain)`; if it turned past it, `rotational_deceleration(gain)`.
//! 4. Close enough but never at rest (the time limit passed near the goal): `stop` on the last
//!    chunk: "you were there; stop".
//!
//! **Rates.** Every rate and gain is one of [`RATES`], 0.1, 0.25 or 0.5: "a little", "more",
//! "much more", chosen from the size of what the path shows (the paper's advisor did not need
//! "value-based execution details (e.g. speed) to select operators"): an overshoot, a shortfall
//! or a miss as a share of the distance the run covered (more from 0.2, much more from 0.4); an
//! arc by the share of the wanted turn missing or overdone (more from 0.6, much more from 0.8);
//! a heading by its error as a share of half a turn (more from 0.25, much more from 0.5).
//!
//! So a poor execution gets up to eight pieces of advice, each on one chunk of at most
//! [`AdvisorRules::chunk_len`] points, and no point of an execution is advised twice by rule 2
//! (the operators' guards may skip some points). Why several: the learner is local (LWR with a
//! narrow kernel), so a correction holds only near the states it was given in; a person fixes
//! the stretches of the path that went wrong, not one moment of it.

use serde::{Deserialize, Serialize};

use crate::domain::columns::positioning::{BEARING, DHEADING, DIST2, ROT, TRANS};
use crate::syntax::Invocation;
use crate::task::{Ending, Execution, Outcome};
use crate::trace::{Chunk, Pose, Trace};

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
    /// Largest chunk advised, points: the one chunk rule's [`crate::experiment::CHUNK_POINTS`]
    /// (the second protocol, S4).
    pub chunk_len: usize,
    /// At most this many chunks of the approach are advised on one execution (rule 2).
    pub approach_chunks: usize,
    /// Shortest stretch of the approach worth advising, points (a person does not pick out a
    /// fraction of a second).
    pub min_chunk: usize,
    /// The advisor the protocol replaced (issue 33, choice 5), for the ablation only (`advise
    /// experiment aopi --revert advisor`): arcs judged against the goal *point* with the
    /// commanded curvature `rot / trans`, arc rates rounded from the median commanded ratio
    /// (tighter by 0.5, 1, 2 or 4; looser by 0.25, 0.5 or 0.75), speed and heading advice at the
    /// operators' default gains, and a miss to the side answered with `turn_tighter(2)` or
    /// `translational_deceleration(0.5)`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub pre_protocol: bool,
}

impl Default for AdvisorRules {
    fn default() -> Self {
        AdvisorRules {
            position_tol_m: 0.5,
            heading_tol_rad: 0.5,
            chunk_len: crate::experiment::CHUNK_POINTS,
            approach_chunks: 6,
            min_chunk: 8,
            pre_protocol: false,
        }
    }
}

/// Why an execution was advised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    ArcTooWide,
    ArcTooTight,
    TurningAway,
    TurnedTooLate,
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
            Reason::ArcTooWide => "arc too wide",
            Reason::ArcTooTight => "arc too tight",
            Reason::TurningAway => "turning away",
            Reason::TurnedTooLate => "turned too late",
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
    // An operator with a person's gain; before the protocol, at its default gain.
    let said = |op: &str, gain: f64| {
        if rules.pre_protocol {
            op.to_string()
        } else {
            format!("{op}({gain})")
        }
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
        // How it ended: overshoot or stopped short, on the chunk next to the end.
        let mut end_chunk = None;
        // The distance the run covered toward the goal, which a miss is judged against.
        let covered = (trace.z(0)[DIST2].sqrt()).max(1e-6);
        if passed {
            if let Some(c) = last_chunk_where(trace, closest + 1, rules.chunk_len, driving) {
                // How far past the goal it rolled, against the distance covered.
                let past = last[DIST2].sqrt() - closest_m;
                let gain = rate_for(past / covered, 0.2, 0.4);
                out.push(advice(
                    &said("translational_deceleration", gain),
                    c,
                    Reason::Overshoot,
                ));
                end_chunk = Some(c);
            }
        } else if goal_ahead
            && o.ending == Ending::Rested
            && let Some(c) = last_chunk_where(trace, n, rules.chunk_len, driving)
        {
            // How far short it stopped, against the distance covered.
            let gain = rate_for(last[DIST2].sqrt() / covered, 0.2, 0.4);
            out.push(advice(
                &said("translational_acceleration", gain),
                c,
                Reason::StoppedShort,
            ));
            end_chunk = Some(c);
        }
        // How it got there: the arcs of the approach, up to the closest approach (or the end
        // chunk, so that no point is advised twice).
        let approach_end = end_chunk.map_or(closest + 1, |c| c.start.min(closest + 1));
        let arcs = approach_advice(trace, exec.path(), approach_end, rules);
        let had_arcs = !arcs.is_empty();
        for (text, c, reason) in arcs {
            out.push(advice(&text, c, reason));
        }
        if end_chunk.is_none()
            && !had_arcs
            && let Some(c) = last_chunk_where(trace, closest + 1, rules.chunk_len, driving)
        {
            // Missed to the side with no clear arc to correct: over the approach's last chunk,
            // was the robot turning toward the goal (too little) or away from it?
            let toward: f64 = c
                .range()
                .map(|t| trace.a(t)[ROT] * trace.z(t)[BEARING].signum())
                .sum();
            // How far to the side it missed, against the distance covered.
            let rate = rate_for(o.position_error_m / covered, 0.2, 0.4);
            let (tighter, slower) = if rules.pre_protocol {
                (2.0, 0.5)
            } else {
                (rate, rate)
            };
            if toward > 0.0 {
                out.push(advice(
                    &format!("turn_tighter({tighter})"),
                    c,
                    Reason::MissedTurningTooLittle,
                ));
            } else {
                out.push(advice(
                    &format!("translational_deceleration({slower})"),
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
        // How far off the heading it ended, as a share of half a turn.
        let gain = rate_for(
            o.heading_error_rad.unwrap_or(0.0) / std::f64::consts::PI,
            0.25,
            0.5,
        );
        if turn * to_go > 0.0 {
            out.push(advice(
                &said("rotational_acceleration", gain),
                c,
                Reason::TurnedTooLittle,
            ));
        } else {
            out.push(advice(
                &said("rotational_deceleration", gain),
                c,
                Reason::TurnedTooMuch,
            ));
        }
    }
    if out.is_empty() && o.ending != Ending::Rested {
        let start = n.saturating_sub(rules.chunk_len);
        out.push(advice("stop", Chunk { start, end: n }, Reason::NotStopping));
    }
    out
}

/// Where a poor execution began to go wrong: the first point of the earliest chunk the advisor
/// advises on it (the one chunk rule: a chunk begins where the flaw begins); `None` for a good
/// execution or one on which it names no chunk. The takeover arm's teacher takes over there
/// (docs/protocol.md, T2).
pub fn went_wrong_at(exec: &Execution, rules: &AdvisorRules) -> Option<usize> {
    advise(exec, rules).iter().map(|a| a.chunk.start).min()
}

/// Whether the advisor's arc rule (rule 2) judges point `t` of `trace` right: driving forward
/// beyond [`ARC_NEAR_M`] of the goal on an arc that bends onto the goal pose, the path's
/// curvature read from `path` (poses of the trace's points, and of the
/// [`CURVE_WINDOW`] points after `t` when there are). What the takeover arm's teacher reads to
/// hand back (docs/protocol.md, T4).
pub fn arc_is_right(trace: &Trace, path: &[Pose], t: usize) -> bool {
    t < trace.len()
        && trace.obs_dim() > DHEADING
        && trace.act_dim() > ROT
        && arc_at(trace, path, t, false) == Some(Arc::Right)
}

/// Advice is not given on arcs nearer the goal than this, m: there the robot should be turning
/// onto the goal heading in place or nearly.
pub const ARC_NEAR_M: f64 = 0.6;
/// An arc is right when its curvature is within these factors of the arc that reaches the goal.
const ARC_OK: (f64, f64) = (0.6, 1.7);
/// With the goal this nearly straight ahead (curvature of the arc to it, 1/m), driving straight
/// is right.
const ARC_STRAIGHT: f64 = 0.12;
/// The path's curvature at a point is measured over this many points of it.
pub const CURVE_WINDOW: usize = 5;

/// How a point of the approach curves, against the arc that would reach the goal.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Arc {
    Right,
    /// Turning toward the goal, too gently: the wanted curvature over the driven one.
    Wide(f64),
    /// Turning toward the goal, too sharply: the wanted curvature over the driven one.
    Tight(f64),
    /// Turning away from the goal.
    Away,
    /// Driving straight with the goal clearly off to the side.
    Straight,
}

/// Where a person expects the robot to head from an observation: the goal pose approached along
/// its heading (the paper's "smoothly coupled rotational and translational speeds ... in
/// contrast to turning on spot to θg after attaining (xg, yg)"). The aim point lies behind the
/// goal along the goal heading, set back by half the remaining distance (at most 1 m); returns
/// its distance and bearing in the robot's frame.
fn aim(z: &[f64]) -> (f64, f64) {
    let d = z[DIST2].max(0.0).sqrt();
    let (gx, gy) = (d * z[BEARING].cos(), d * z[BEARING].sin());
    let back = (0.5 * d).min(1.0);
    let (ax, ay) = (gx - back * z[DHEADING].cos(), gy - back * z[DHEADING].sin());
    (ax.hypot(ay), ay.atan2(ax))
}

/// The curvature the path shows at point `t` (1/m): the heading change over the next
/// [`CURVE_WINDOW`] points over the distance driven, from the poses a person watching sees (the
/// true path when the backend knew it, else odometry); without poses, the commanded arc.
fn driven_curvature(trace: &Trace, path: &[Pose], t: usize) -> f64 {
    let (a_t, v) = (trace.a(t), trace.a(t)[TRANS]);
    if path.len() < trace.len() || t + 1 >= path.len() {
        return a_t[ROT] / v;
    }
    let e = (t + CURVE_WINDOW).min(path.len() - 1);
    let dist: f64 = (t..e)
        .map(|i| (path[i + 1].x_m - path[i].x_m).hypot(path[i + 1].y_m - path[i].y_m))
        .sum();
    if dist < 1e-6 {
        return a_t[ROT] / v;
    }
    crate::geometry::wrap_angle(path[e].theta_rad - path[t].theta_rad) / dist
}

/// The arc at point `t`, or `None` where the robot was not driving forward or was already near.
/// The arc that reaches the aim point ([`aim`]) from the robot's pose, tangent to its heading,
/// has curvature `2 sin(bearing) / distance`; the driven arc is the path's
/// ([`driven_curvature`]). This is what a person sees from the side: whether the robot is
/// curving onto the goal pose, past it, or away.
///
/// With `pre_protocol` (the ablation's advisor), the arc is the one to the goal *point* and the
/// driven curvature the commanded one, `rot / trans`, as before the protocol.
fn arc_at(trace: &Trace, path: &[Pose], t: usize, pre_protocol: bool) -> Option<Arc> {
    let (z, a) = (trace.z(t), trace.a(t));
    let d = z[DIST2].max(0.0).sqrt();
    if a[TRANS] <= MOVING_MPS || d < ARC_NEAR_M {
        return None;
    }
    let (ad, ab) = if pre_protocol {
        (d, z[BEARING])
    } else {
        aim(z)
    };
    let wanted = 2.0 * ab.sin() / ad.max(1e-6);
    let (driven, turning) = if pre_protocol {
        (a[ROT] / a[TRANS], a[ROT].abs() > TURNING_RADPS)
    } else {
        let driven = driven_curvature(trace, path, t);
        (driven, driven.abs() * a[TRANS] > TURNING_RADPS)
    };
    if wanted.abs() < ARC_STRAIGHT && driven.abs() < ARC_STRAIGHT {
        return Some(Arc::Right);
    }
    if wanted * driven < 0.0 && turning && wanted.abs() >= ARC_STRAIGHT {
        return Some(Arc::Away);
    }
    if !turning {
        // Scaling cannot make a turn out of driving straight; the turn that came later can be
        // moved earlier (see `approach_advice`).
        return (wanted.abs() >= 2.0 * ARC_STRAIGHT).then_some(Arc::Straight);
    }
    let ratio = wanted.abs() / driven.abs().max(1e-9);
    Some(if wanted * driven < 0.0 || ratio < 1.0 / ARC_OK.1 {
        Arc::Tight(ratio)
    } else if ratio > 1.0 / ARC_OK.0 {
        Arc::Wide(ratio)
    } else {
        Arc::Right
    })
}

/// The rates a person says: "a little", "more", "much more".
pub const RATES: [f64; 3] = [0.1, 0.25, 0.5];

/// The rate for a fault of `size` (a fraction: of the distance the run covered, of the turn
/// that was wanted, ...), given where "more" and "much more" begin.
fn rate_for(size: f64, more: f64, much_more: f64) -> f64 {
    if size >= much_more {
        RATES[2]
    } else if size >= more {
        RATES[1]
    } else {
        RATES[0]
    }
}

/// The approach's arcs to correct (rule 2): runs of consecutive points before `end` that curve
/// the same wrong way, the longest first, at most [`AdvisorRules::approach_chunks`] of them,
/// each cut to its first [`AdvisorRules::chunk_len`] points (the earlier a correction comes, the
/// more of the path it changes). The operator's rate is the run's median correction, rounded
/// to the coarse values a person would choose.
fn approach_advice(
    trace: &Trace,
    path: &[Pose],
    end: usize,
    rules: &AdvisorRules,
) -> Vec<(String, Chunk, Reason)> {
    let kind = |a: Option<Arc>| match a {
        Some(Arc::Wide(_)) => 1,
        Some(Arc::Tight(_)) => 2,
        Some(Arc::Away) => 3,
        Some(Arc::Straight) => 4,
        _ => 0,
    };
    let arcs: Vec<Option<Arc>> = (0..end.min(trace.len()))
        .map(|t| arc_at(trace, path, t, rules.pre_protocol))
        .collect();
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut t = 0;
    while t < arcs.len() {
        let k = kind(arcs[t]);
        let mut e = t + 1;
        while e < arcs.len() && kind(arcs[e]) == k {
            e += 1;
        }
        if k != 0 && e - t >= rules.min_chunk.max(1) {
            runs.push((t, e));
        }
        t = e;
    }
    runs.sort_by_key(|&(s, e)| std::cmp::Reverse(e - s));
    runs.truncate(rules.approach_chunks);
    runs.sort_unstable();
    runs.into_iter()
        .filter_map(|(start, e)| {
            if arcs[start] == Some(Arc::Straight) {
                // Drove straight past the moment to turn, then turned toward the goal: the turn
                // should have begun when the straight stretch did. The chunk is the turn that
                // followed; each of its points is paired with the observation `steps` earlier.
                let wanted = trace.z(start)[BEARING].signum();
                let toward = |t: usize| {
                    t < trace.len()
                        && turning(trace, t)
                        && driving(trace, t)
                        && trace.a(t)[ROT] * wanted > 0.0
                };
                let turn_start = (e..(e + 10).min(trace.len())).find(|&t| toward(t))?;
                let mut turn_end = turn_start;
                while turn_end < trace.len()
                    && toward(turn_end)
                    && turn_end - turn_start < rules.chunk_len.max(1)
                {
                    turn_end += 1;
                }
                if turn_end - turn_start < rules.min_chunk.max(1) {
                    return None;
                }
                // A person judges the delay coarsely: to the nearest 5 points (1/6 s).
                let steps = ((turn_start - start).div_ceil(5) * 5).clamp(5, 300);
                return Some((
                    format!("start_turning_earlier(steps = {steps})"),
                    Chunk {
                        start: turn_start,
                        end: turn_end,
                    },
                    Reason::TurnedTooLate,
                ));
            }
            Some((start, e)).map(|(start, e)| {
                let chunk = Chunk {
                    start,
                    end: e.min(start + rules.chunk_len.max(1)),
                };
                // How far the arc is from the wanted one, as a person sees it: the share of the
                // wanted turn that was missing (too wide) or overdone (too tight), over the chunk.
                let shares: Vec<f64> = chunk
                    .range()
                    .filter_map(|t| match arcs[t] {
                        Some(Arc::Wide(r)) => Some(1.0 - 1.0 / r),
                        Some(Arc::Tight(r)) => Some(1.0 - r),
                        _ => None,
                    })
                    .collect();
                let share = shares.iter().sum::<f64>() / shares.len().max(1) as f64;
                let rate = if rules.pre_protocol {
                    median_rate(&arcs[chunk.range()], arcs[start])
                } else {
                    rate_for(share, 0.6, 0.8)
                };
                match arcs[start] {
                    Some(Arc::Wide(_)) => {
                        (format!("turn_tighter({rate})"), chunk, Reason::ArcTooWide)
                    }
                    Some(Arc::Tight(_)) => {
                        (format!("turn_looser({rate})"), chunk, Reason::ArcTooTight)
                    }
                    _ => ("no_turning".to_string(), chunk, Reason::TurningAway),
                }
            })
        })
        .collect()
}

/// The arc rate before the protocol (the ablation's advisor): the median of the chunk's
/// wanted-over-driven curvature ratios, rounded to the nearest of the coarse factors (tighter by
/// 0.5, 1, 2 or 4, judged on a log scale; looser by 0.25, 0.5 or 0.75).
fn median_rate(arcs: &[Option<Arc>], first: Option<Arc>) -> f64 {
    let mut ratios: Vec<f64> = arcs
        .iter()
        .filter_map(|a| match a {
            Some(Arc::Wide(r) | Arc::Tight(r)) => Some(*r),
            _ => None,
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let median = ratios.get(ratios.len() / 2).copied().unwrap_or(1.0);
    let nearest = |set: &[f64], off: &dyn Fn(f64) -> f64, fallback: f64| {
        set.iter()
            .copied()
            .min_by(|a, b| off(*a).total_cmp(&off(*b)))
            .unwrap_or(fallback)
    };
    match first {
        Some(Arc::Wide(_)) => nearest(
            &[0.5, 1.0, 2.0, 4.0],
            &|a| ((1.0 + a) / median).ln().abs(),
            1.0,
        ),
        _ => nearest(&[0.25, 0.5, 0.75], &|a| ((1.0 - a) - median).abs(), 0.5),
    }
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
                efficiency: None,
                steps: trace.len(),
                duration_s: t,
                final_pose: Pose::new(x, 0.0, 0.0),
                non_finite: None,
                end_rule: None,
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
        // 1.5 m short of a goal 3 m away: half the way, "much more".
        assert_eq!(a.operator.to_string(), "translational_acceleration(0.5)");
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
        // 1 m past a goal 1.5 m away: "much more".
        assert_eq!(a.operator.to_string(), "translational_deceleration(0.5)");
        assert_eq!(a.reason, Reason::Overshoot);
        let closest_x = 1.5;
        let end_pose = exec.trace.pose.as_ref().unwrap()[a.chunk.end - 1];
        assert!((end_pose.x_m - closest_x).abs() < 0.05, "{end_pose:?}");
    }

    /// A constant arc (`speed` m/s, `rot` rad/s) from the origin for `steps` points, then at
    /// rest, toward `goal`; observations as the positioning task makes them.
    fn arc(goal: Pose, speed: f64, rot: f64, steps: usize) -> Execution {
        path(goal, &[(speed, rot, steps)])
    }

    /// Constant-speed legs `(speed, rot, steps)` from the origin, then at rest.
    fn path(goal: Pose, legs: &[(f64, f64, usize)]) -> Execution {
        let mut trace = Trace::new(&Domain::positioning());
        let dt = 1.0 / 30.0;
        let mut p = Pose::new(0.0, 0.0, 0.0);
        let mut commands: Vec<(f64, f64)> = legs
            .iter()
            .flat_map(|&(v, w, n)| std::iter::repeat_n((v, w), n))
            .collect();
        commands.extend(std::iter::repeat_n((0.0, 0.0), 16));
        for (i, &(v, w)) in commands.iter().enumerate() {
            let z = crate::task::positioning::observe(goal, p);
            trace.push(i as f64 * dt, &z, &[v, w], Some(p));
            p = Pose::new(
                p.x_m + v * p.theta_rad.cos() * dt,
                p.y_m + v * p.theta_rad.sin() * dt,
                p.theta_rad + w * dt,
            );
        }
        let error = (goal.x_m - p.x_m).hypot(goal.y_m - p.y_m);
        Execution {
            outcome: Outcome {
                success: error < 1.0,
                ending: Ending::Rested,
                position_error_m: error,
                heading_error_rad: Some(0.0),
                length_m: legs.iter().map(|l| l.0 * l.2 as f64 * dt).sum(),
                efficiency: None,
                steps: trace.len(),
                duration_s: trace.len() as f64 * dt,
                final_pose: p,
                non_finite: None,
                end_rule: None,
            },
            trace,
            true_poses: None,
            ball: None,
        }
    }

    #[test]
    fn an_arc_too_wide_for_the_goal_gets_turn_tighter_on_the_approach() {
        // The goal is 3 m off to the left; the robot curves left far too gently and passes it.
        let exec = arc(Pose::new(2.0, 2.0, 0.0), 0.5, 0.08, 240);
        assert!(exec.outcome.position_error_m > 1.0);
        let advice = advise(&exec, &AdvisorRules::default());
        let wide: Vec<_> = advice
            .iter()
            .filter(|a| a.reason == Reason::ArcTooWide)
            .collect();
        assert!(!wide.is_empty(), "{advice:?}");
        for a in wide {
            assert!(a.operator.to_string().starts_with("turn_tighter("));
            assert!(a.chunk.len() <= 25 && a.chunk.len() >= 8);
        }
        // No point is advised twice by the position rules.
        let mut seen = std::collections::HashSet::new();
        for a in advice
            .iter()
            .filter(|a| a.reason != Reason::TurnedTooLittle)
        {
            for t in a.chunk.range() {
                assert!(seen.insert(t), "point {t} advised twice: {advice:?}");
            }
        }
    }

    #[test]
    fn a_straight_run_past_the_goal_then_a_turn_gets_start_turning_earlier() {
        // The goal is off to the left; the robot drives straight for 2 s, then turns left.
        let exec = path(Pose::new(2.0, 2.0, 0.0), &[(0.5, 0.0, 60), (0.5, 0.8, 40)]);
        let advice = advise(&exec, &AdvisorRules::default());
        let late: Vec<_> = advice
            .iter()
            .filter(|a| a.reason == Reason::TurnedTooLate)
            .collect();
        assert_eq!(late.len(), 1, "{advice:?}");
        assert_eq!(
            late[0].operator.to_string(),
            "start_turning_earlier(steps = 60)"
        );
        // The chunk is the turn that followed the straight stretch.
        assert_eq!(late[0].chunk.start, 60);
        assert_eq!(late[0].chunk.len(), 25);
    }

    /// The ablation's advisor (`--revert advisor`): default gains, the goal point, median rates.
    #[test]
    fn the_pre_protocol_advisor_speaks_as_before_the_protocol() {
        let old = AdvisorRules {
            pre_protocol: true,
            ..AdvisorRules::default()
        };
        let first =
            |exec: &Execution, rules: &AdvisorRules| advise(exec, rules)[0].operator.to_string();
        assert_eq!(
            first(&drive(3.0, 1.5, 0.5), &old),
            "translational_acceleration"
        );
        assert_eq!(
            first(&drive(1.5, 2.5, 0.5), &old),
            "translational_deceleration"
        );
        // Arcs: rates from the old coarse sets, and a different judgement of the same path.
        let exec = arc(Pose::new(2.0, 2.0, 0.0), 0.5, 0.08, 240);
        let texts = |rules: &AdvisorRules| -> Vec<String> {
            advise(&exec, rules)
                .iter()
                .map(|a| a.operator.to_string())
                .collect()
        };
        let before = texts(&old);
        assert!(
            before.iter().any(|t| [
                "turn_tighter(0.5)",
                "turn_tighter(1)",
                "turn_tighter(2)",
                "turn_tighter(4)"
            ]
            .contains(&t.as_str())),
            "{before:?}"
        );
        assert_ne!(before, texts(&AdvisorRules::default()));
    }

    #[test]
    fn an_arc_turning_away_from_the_goal_gets_no_turning() {
        // The goal is off to the left; the robot curves right.
        let exec = arc(Pose::new(2.0, 2.0, 0.0), 0.5, -0.3, 150);
        let advice = advise(&exec, &AdvisorRules::default());
        assert!(
            advice
                .iter()
                .any(|a| a.reason == Reason::TurningAway && a.operator.to_string() == "no_turning"),
            "{advice:?}"
        );
    }

    #[test]
    fn the_aim_is_behind_the_goal_along_its_heading() {
        // The goal 2 m straight ahead, facing the same way: aim straight at it, 1 m short.
        let (d, b) = aim(&[4.0, 0.0, 0.0]);
        assert!((d - 1.0).abs() < 1e-12 && b.abs() < 1e-12);
        // The same goal facing left (+pi/2): the aim lies to the right of it, so the robot
        // swings out right and bends in onto the heading.
        let (_, b) = aim(&[4.0, 0.0, std::f64::consts::FRAC_PI_2]);
        assert!(b < -0.3, "{b}");
        // Far away the set-back is at most 1 m.
        let (d, _) = aim(&[100.0, 0.0, 0.0]);
        assert!((d - 9.0).abs() < 1e-12);
    }

    #[test]
    fn every_rate_is_one_a_person_would_say() {
        for exec in [
            drive(3.0, 1.5, 0.5),
            drive(1.5, 2.5, 0.5),
            drive(4.0, 0.5, 0.5),
            arc(Pose::new(2.0, 2.0, 0.0), 0.5, 0.08, 240),
            arc(Pose::new(3.0, 0.5, 0.0), 0.5, 0.6, 150),
            arc(Pose::new(3.0, -1.0, -1.5), 0.5, 0.2, 150),
        ] {
            for a in advise(&exec, &AdvisorRules::default()) {
                let text = a.operator.to_string();
                if text.starts_with("start_turning_earlier") || !text.contains('(') {
                    continue;
                }
                let arg: f64 = text
                    .split(['(', ')'])
                    .nth(1)
                    .and_then(|v| v.rsplit('=').next())
                    .and_then(|v| v.trim().parse().ok())
                    .unwrap_or_else(|| panic!("{text}"));
                assert!(RATES.contains(&arg), "{text}");
            }
        }
    }

    #[test]
    fn advice_speaks_only_through_standard_operators() {
        let ops = OperatorSet::standard();
        for exec in [
            drive(3.0, 1.5, 0.5),
            drive(1.5, 2.5, 0.5),
            arc(Pose::new(2.0, 2.0, 0.0), 0.5, 0.08, 240),
            arc(Pose::new(2.0, 2.0, 0.0), 0.5, -0.3, 150),
            arc(Pose::new(3.0, 0.5, 0.0), 0.5, 0.6, 150),
            path(Pose::new(2.0, 2.0, 0.0), &[(0.5, 0.0, 60), (0.5, 0.8, 40)]),
        ] {
            for a in advise(&exec, &AdvisorRules::default()) {
                let call = crate::check::bind(
                    &mut crate::diag::SourceMap::new(),
                    &ops,
                    &exec.trace.domain,
                    &a.operator,
                )
                .unwrap();
                let syn = crate::interp::apply(&call, &exec.trace, a.chunk).unwrap();
                assert!(!syn.points.is_empty());
                assert!(syn.source_index.iter().all(|i| a.chunk.range().contains(i)));
            }
        }
    }
}
