//! The automated critic of the BC study: it watches an interception execution and flags the chunks
//! a human would call poor, the way the paper's teacher flagged the loop of its Figure 4.
//!
//! It sees what a person watching the robot and the ball sees: the execution's trace (the
//! observations the robot recorded, as numbers), whether the ball was caught, and where. It never
//! looks at the policy, its data points or their weights. The rule, in full:
//!
//! 0. **Only poor executions are critiqued.** The paper's teacher judged by "a combination of
//!    ball interception success and human intuition": a miss is poor, and so is a catch by "a
//!    very convoluted path". A catch whose path was at most [`CriticRules::detour_ratio`] times
//!    the straight line from the start to where the ball was caught, plus
//!    [`CriticRules::detour_slack_m`], is left alone ([`critique_execution`]).
//! 1. The execution is cut into consecutive chunks of [`CriticRules::chunk_len`] points (25, in
//!    the paper's typical 20-30); a short remainder joins the chunk before it (so chunks hold
//!    `chunk_len` to `2 * chunk_len - 1` points), and an execution shorter than one chunk is one
//!    chunk. The opening is never judged: the robot starts at rest, facing wherever it was put,
//!    and has to get going and turn to the ball. Judging starts once the ball is within
//!    [`CriticRules::face_rad`] of straight ahead, but not before [`CriticRules::settle_points`]
//!    and not after [`CriticRules::max_settle_points`] (a robot that has not faced the ball by
//!    then is doing something wrong).
//! 2. For each chunk it measures the robot's travel (the sum of `|travel_delta|`), its turning
//!    (the sum of `|heading_delta|`) and its progress (the ball distance at the chunk's start
//!    minus at its end).
//! 3. A chunk is flagged as:
//!    - **moving away** when the ball ends the chunk farther away than it started, by more than
//!      [`CriticRules::away_m`], while the robot was driving (travel above
//!      [`CriticRules::min_travel_m`]) and its own driving took it away from the ball;
//!    - **wasted turning** when the robot turned more than [`CriticRules::turn_rad`] but closed
//!      less than [`CriticRules::min_efficiency`] of the distance it drove: it was circling, not
//!      approaching;
//!    - **loop** when most of the chunk comes after the robot had already turned through
//!      [`CriticRules::loop_rad`] (half a circle) one way and kept turning that way, however it
//!      fared on distance: turning toward the ball is fine, going around is a loop. Straight
//!      driving for more than [`CriticRules::loop_break_points`] points, or a turn the other
//!      way, ends a turn.
//!
//!    At most [`CriticRules::max_flags`] chunks are flagged per execution, the first ones: the
//!    paper's teacher marked where an execution "began to go wrong", not every bad second of it.
//! 4. A straight approach closes the distance about as fast as it drives and turns little, so it
//!    is never flagged.
//!
//! This module only judges; it does not touch the learner (see [`crate::experiment::bc`]).

use serde::{Deserialize, Serialize};

use crate::domain::columns::interception::{BALL_ANGLE, BALL_DIST, HEADING_DELTA, TRAVEL_DELTA};
use crate::task::Execution;
use crate::trace::{Chunk, Trace};

/// A point turning less than this (rad per point, 0.15 rad/s at 30 Hz) is not part of a loop.
const LOOP_TURN_RAD: f64 = 0.005;

/// The numbers of the critic's rule (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CriticRules {
    /// Chunk length, points (the paper's chunks were 20-30 points).
    pub chunk_len: usize,
    /// Points at the start of an execution that are never judged (the robot starts at rest).
    pub settle_points: usize,
    /// The opening turn to the ball is not judged: judging starts once the ball is within this
    /// angle of straight ahead, rad ...
    pub face_rad: f64,
    /// ... or after this many points at the latest.
    pub max_settle_points: usize,
    /// A successful execution is critiqued only when its path was longer than this many times
    /// the straight line from its start to where it caught the ball ...
    pub detour_ratio: f64,
    /// ... plus this, m.
    pub detour_slack_m: f64,
    /// Moving away: the ball distance grew over the chunk by more than this, m.
    pub away_m: f64,
    /// A chunk in which the robot drove less than this is not judged on distance, m.
    pub min_travel_m: f64,
    /// Wasted turning: the robot turned more than this within the chunk, rad ...
    pub turn_rad: f64,
    /// ... and closed less than this fraction of the distance it drove.
    pub min_efficiency: f64,
    /// Loop: once the robot has turned this far one way, rad, turning on is a loop ...
    pub loop_rad: f64,
    /// ... unless it drove straight for more than this many points in between.
    pub loop_break_points: usize,
    /// At most this many chunks are flagged per execution, the first ones: where the execution
    /// began to go wrong (0: no limit).
    pub max_flags: usize,
}

impl Default for CriticRules {
    fn default() -> Self {
        CriticRules {
            chunk_len: 25,
            settle_points: 10,
            face_rad: 0.5,
            max_settle_points: 60,
            detour_ratio: 1.6,
            detour_slack_m: 0.5,
            away_m: 0.03,
            min_travel_m: 0.05,
            turn_rad: 0.35,
            min_efficiency: 0.5,
            loop_rad: std::f64::consts::PI,
            loop_break_points: 15,
            max_flags: 2,
        }
    }
}

/// Why a chunk was flagged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Flaw {
    MovingAway,
    WastedTurning,
    Loop,
}

impl Flaw {
    pub fn name(self) -> &'static str {
        match self {
            Flaw::MovingAway => "moving away",
            Flaw::WastedTurning => "wasted turning",
            Flaw::Loop => "loop",
        }
    }
}

/// One flagged chunk and the reason.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flag {
    pub chunk: Chunk,
    pub flaw: Flaw,
}

/// What the critic measured on one chunk.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChunkMeasures {
    pub travel_m: f64,
    pub turning_rad: f64,
    pub progress_m: f64,
    /// How far the robot's own driving took it toward the ball (negative: away), m.
    pub toward_m: f64,
}

/// Cut `len` points into the critic's chunks (see the module docs, step 1).
pub fn chunks(len: usize, chunk_len: usize) -> Vec<Chunk> {
    let chunk_len = chunk_len.max(1);
    if len == 0 {
        return Vec::new();
    }
    let mut out = Vec::new();
    let mut start = 0;
    while start < len {
        let mut end = (start + chunk_len).min(len);
        if len - end < chunk_len {
            end = len;
        }
        out.push(Chunk { start, end });
        start = end;
    }
    out
}

/// Measure one chunk of an interception trace.
pub fn measure(trace: &Trace, chunk: Chunk) -> ChunkMeasures {
    let mut m = ChunkMeasures {
        travel_m: 0.0,
        turning_rad: 0.0,
        progress_m: 0.0,
        toward_m: 0.0,
    };
    if chunk.is_empty() {
        return m;
    }
    for t in chunk.range() {
        let z = trace.z(t);
        m.travel_m += z[TRAVEL_DELTA].abs();
        m.turning_rad += z[HEADING_DELTA].abs();
        m.toward_m += z[TRAVEL_DELTA] * z[BALL_ANGLE].cos();
    }
    // The observation at a point is taken before its action; the distance after the chunk's last
    // action is the next point's (or, at the very end, the last one's).
    let after = chunk.end.min(trace.len() - 1);
    m.progress_m = trace.z(chunk.start)[BALL_DIST] - trace.z(after)[BALL_DIST];
    m
}

/// Judge an interception execution: the chunks a human would flag, in order, each once.
pub fn critique(trace: &Trace, rules: &CriticRules) -> Vec<Flag> {
    let n = trace.len();
    if n == 0 || trace.obs_dim() <= HEADING_DELTA {
        return Vec::new();
    }
    let in_loop = loop_points(trace, rules);
    let settle = opening(trace, rules);
    let mut flags = Vec::new();
    for chunk in chunks(n, rules.chunk_len) {
        // Only the part after the opening is judged.
        let judged = Chunk {
            start: chunk.start.max(settle),
            end: chunk.end,
        };
        if judged.len() < rules.chunk_len.div_ceil(2) {
            continue;
        }
        let m = measure(trace, judged);
        let driving = m.travel_m > rules.min_travel_m;
        let flaw = if judged.range().filter(|&t| in_loop[t]).count() * 2 > judged.len() {
            Some(Flaw::Loop)
        } else if driving && -m.progress_m > rules.away_m && m.toward_m < 0.0 {
            Some(Flaw::MovingAway)
        } else if m.turning_rad > rules.turn_rad && m.progress_m < rules.min_efficiency * m.travel_m
        {
            Some(Flaw::WastedTurning)
        } else {
            None
        };
        if let Some(flaw) = flaw {
            flags.push(Flag { chunk, flaw });
            if flags.len() == rules.max_flags {
                break;
            }
        }
    }
    flags
}

/// Judge an execution as a person would (rule 0 of the module docs, then [`critique`]): a catch
/// by a path close to the straight line is left alone; a miss, or a catch by a detour, gets its
/// poor chunks flagged.
pub fn critique_execution(exec: &Execution, rules: &CriticRules) -> Vec<Flag> {
    if exec.outcome.success && !is_detour(exec, rules) {
        return Vec::new();
    }
    critique(&exec.trace, rules)
}

/// Whether a successful execution took "a very convoluted path": longer than `detour_ratio`
/// times the straight line from its start (the first pose of the path its length was measured
/// over; interception runs start at the origin) to where it ended, plus `detour_slack_m`.
pub fn is_detour(exec: &Execution, rules: &CriticRules) -> bool {
    let start = exec.path().first().copied().unwrap_or_default();
    let end = exec.outcome.final_pose;
    let straight = (end.x_m - start.x_m).hypot(end.y_m - start.y_m);
    exec.outcome.length_m > rules.detour_ratio * straight + rules.detour_slack_m
}

/// The points of the opening that are not judged (rule 1): until the ball is first within
/// `face_rad` of straight ahead, at least `settle_points`, at most `max_settle_points`.
fn opening(trace: &Trace, rules: &CriticRules) -> usize {
    let n = trace.len();
    let faced = (0..n)
        .find(|&t| trace.z(t)[BALL_ANGLE].abs() < rules.face_rad)
        .unwrap_or(n);
    faced
        .min(rules.max_settle_points)
        .max(rules.settle_points)
        .min(n)
}

/// Which points lie inside a loop: while the robot keeps turning one way (a stretch of
/// straight driving longer than `loop_break_points`, or a turn the other way, ends the turn),
/// every point after the first `loop_rad` of the turn.
fn loop_points(trace: &Trace, rules: &CriticRules) -> Vec<bool> {
    let n = trace.len();
    let mut marked = vec![false; n];
    let mut turned = 0.0f64;
    let mut straight = 0;
    for (t, m) in marked.iter_mut().enumerate() {
        let dh = trace.z(t)[HEADING_DELTA];
        if dh.abs() <= LOOP_TURN_RAD {
            straight += 1;
            if straight > rules.loop_break_points {
                turned = 0.0;
            }
            continue;
        }
        straight = 0;
        if turned != 0.0 && dh.signum() != turned.signum() {
            turned = 0.0;
        }
        turned += dh;
        *m = turned.abs() > rules.loop_rad;
    }
    marked
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;

    /// A trace from per-point (ball distance, travel, heading change), the ball ahead.
    fn trace(points: &[(f64, f64, f64)]) -> Trace {
        trace_at(points, 0.0)
    }

    /// The same with the ball at `angle` in the robot's frame.
    fn trace_at(points: &[(f64, f64, f64)], angle: f64) -> Trace {
        let mut t = Trace::new(&Domain::interception());
        for (i, &(d, travel, dh)) in points.iter().enumerate() {
            t.push(
                i as f64 / 30.0,
                &[d, angle, 0.0, 0.0, travel, dh],
                &[0.0, 0.0],
                None,
            );
        }
        t
    }

    #[test]
    fn chunks_cover_the_trace_in_20_to_30_point_pieces() {
        for len in [0, 1, 24, 25, 49, 50, 51, 137, 400] {
            let cs = chunks(len, 25);
            assert_eq!(cs.iter().map(|c| c.len()).sum::<usize>(), len);
            for w in cs.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
            if len >= 25 {
                assert!(
                    cs.iter().all(|c| (25..50).contains(&c.len())),
                    "{len}: {cs:?}"
                );
            }
        }
    }

    #[test]
    fn a_straight_approach_is_not_flagged() {
        // 0.8 m/s straight at a still ball 3 m away: 0.0267 m per point, no turning.
        let step = 0.8 / 30.0;
        let pts: Vec<_> = (0..100)
            .map(|i| (3.0 - step * i as f64, step, 0.0))
            .collect();
        assert!(critique(&trace(&pts), &CriticRules::default()).is_empty());
    }

    /// Approach, then a full circle at 0.6 rad/s (the ball distance swings out and back), then a
    /// straight final approach; and the number of points in the circle.
    fn looping_trace() -> (Trace, usize) {
        let step = 0.5 / 30.0;
        let mut pts = Vec::new();
        let mut d = 3.0;
        for _ in 0..40 {
            d -= step;
            pts.push((d, step, 0.0));
        }
        let loop_pts = (2.0 * std::f64::consts::PI / (0.6 / 30.0)) as usize;
        for i in 0..loop_pts {
            let phase = i as f64 / loop_pts as f64 * std::f64::consts::TAU;
            pts.push((d + 0.8 * phase.sin().abs(), step, 0.6 / 30.0));
        }
        for _ in 0..40 {
            d -= step;
            pts.push((d, step, 0.0));
        }
        (trace(&pts), loop_pts)
    }

    #[test]
    fn a_looping_trace_is_flagged() {
        let (t, loop_pts) = looping_trace();
        let flags = critique(&t, &CriticRules::default());
        assert!(!flags.is_empty());
        let all = critique(
            &t,
            &CriticRules {
                max_flags: 0,
                ..CriticRules::default()
            },
        );
        assert!(all.iter().any(|f| f.flaw == Flaw::Loop));
        // Every flag lies in or next to the loop (points 40 .. 40 + loop_pts), none in the
        // final straight approach.
        let loop_end = 40 + loop_pts;
        for f in flags.iter().chain(&all) {
            assert!(
                f.chunk.end > 40 && f.chunk.start < loop_end,
                "{:?} outside the loop 40..{loop_end}",
                f.chunk
            );
            assert!((20..=50).contains(&f.chunk.len()));
        }
    }

    #[test]
    fn driving_away_from_the_ball_is_flagged() {
        // The ball behind the robot, which drives on forward.
        let step = 0.6 / 30.0;
        let pts: Vec<_> = (0..75)
            .map(|i| (1.5 + step * i as f64, step, 0.0))
            .collect();
        let flags = critique(&trace_at(&pts, 3.0), &CriticRules::default());
        assert!(!flags.is_empty());
        assert!(flags.iter().all(|f| f.flaw == Flaw::MovingAway));
        // A ball rolling away from a robot chasing it is not the robot's fault.
        assert!(critique(&trace(&pts), &CriticRules::default()).is_empty());
    }

    #[test]
    fn at_most_max_flags_chunks_are_flagged_the_first_ones() {
        let pts: Vec<_> = (0..200).map(|_| (2.0, 0.004, 0.025)).collect();
        let rules = CriticRules::default();
        let flags = critique(&trace(&pts), &rules);
        assert_eq!(flags.len(), rules.max_flags);
        assert_eq!(flags[0].chunk.start, 0);
        let all = critique(
            &trace(&pts),
            &CriticRules {
                max_flags: 0,
                ..rules
            },
        );
        assert_eq!(all.len(), chunks(200, 25).len());
    }

    #[test]
    fn turning_on_the_spot_without_progress_is_wasted() {
        // Creeping while turning hard for two chunks: little travel, no progress.
        let pts: Vec<_> = (0..60).map(|_| (2.0, 0.004, 0.025)).collect();
        let flags = critique(&trace(&pts), &CriticRules::default());
        assert!(flags.iter().any(|f| f.flaw == Flaw::WastedTurning));
    }

    /// An interception run of the hand-written teacher from `start`.
    fn teacher_run(start: crate::task::BallStart) -> Execution {
        use crate::backend::sim::SimParams;
        use crate::task::{Start, TaskKind};
        let sim = SimParams::default();
        let mut teacher = TaskKind::Interception.teacher(sim.period_s());
        crate::task::run_sim(&Start::Ball(start), teacher.as_mut(), &sim, 1)
    }

    #[test]
    fn a_quick_catch_is_left_alone_and_a_detour_is_judged() {
        // The ball still, 2 m straight ahead: the teacher drives at it.
        let quick = teacher_run(crate::task::BallStart::default());
        assert!(quick.outcome.success);
        let rules = CriticRules::default();
        assert!(!is_detour(&quick, &rules));
        assert!(critique_execution(&quick, &rules).is_empty());
        // The same run held to a stricter standard than the straight line is a detour, and is
        // judged chunk by chunk (a straight approach still has nothing to flag).
        let strict = CriticRules {
            detour_ratio: 0.5,
            detour_slack_m: 0.0,
            ..rules.clone()
        };
        assert!(is_detour(&quick, &strict));
        assert!(critique_execution(&quick, &strict).is_empty());
    }

    #[test]
    fn misses_and_detours_are_judged_quick_catches_are_not() {
        // The looping trace, as a catch 2 m from the start by a path of `length_m`, or a miss.
        let (trace, _) = looping_trace();
        let exec = |success: bool, length_m: f64| Execution {
            trace: trace.clone(),
            true_poses: None,
            ball: None,
            outcome: crate::task::Outcome {
                success,
                ending: if success {
                    crate::task::Ending::Captured
                } else {
                    crate::task::Ending::TimeLimit
                },
                position_error_m: 0.0,
                heading_error_rad: None,
                length_m,
                efficiency: None,
                steps: trace.len(),
                duration_s: trace.len() as f64 / 30.0,
                final_pose: crate::trace::Pose {
                    x_m: 2.0,
                    ..Default::default()
                },
                non_finite: None,
            },
        };
        let rules = CriticRules::default();
        // 1.6 * 2 m + 0.5 m = 3.7 m is the longest path left alone.
        assert!(critique_execution(&exec(true, 3.6), &rules).is_empty());
        assert!(!critique_execution(&exec(true, 3.8), &rules).is_empty());
        assert!(!critique_execution(&exec(false, 3.6), &rules).is_empty());
    }

    #[test]
    fn the_opening_turn_to_the_ball_is_not_judged() {
        // The ball behind the robot: turning round to it at the start is not a flaw.
        let mut trace = Trace::new(&Domain::interception());
        for i in 0..40 {
            // Turning in place from the ball behind (pi) to ahead, then a straight approach.
            let angle = (std::f64::consts::PI - 0.1 * i as f64).max(0.0);
            trace.push(
                i as f64 / 30.0,
                &[2.0, angle, 0.0, 0.0, 0.004, 0.1],
                &[0.0, 0.0],
                None,
            );
        }
        let step = 0.8 / 30.0;
        for i in 0..60 {
            trace.push(
                (40 + i) as f64 / 30.0,
                &[2.0 - step * i as f64, 0.0, -step, 0.0, step, 0.0],
                &[0.0, 0.0],
                None,
            );
        }
        let rules = CriticRules::default();
        assert_eq!(opening(&trace, &rules), 27);
        assert!(critique(&trace, &rules).is_empty());
        // Judged from the first point instead, the turn in place is wasted turning.
        let eager = CriticRules {
            face_rad: 10.0,
            settle_points: 0,
            ..rules
        };
        assert!(
            critique(&trace, &eager)
                .iter()
                .any(|f| f.flaw == Flaw::WastedTurning)
        );
    }
}
