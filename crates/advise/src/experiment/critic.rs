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
//! 1. The opening is never judged: the robot starts at rest, facing wherever it was put, and has
//!    to get going and turn to the ball. Judging starts once the ball is within
//!    [`CriticRules::face_rad`] of straight ahead, but not before [`CriticRules::settle_points`]
//!    and not after [`CriticRules::max_settle_points`] (a robot that has not faced the ball by
//!    then is doing something wrong).
//! 2. Each judged point is labelled by what the robot was doing there:
//!    - **moving away**: the robot was driving (travel above [`CriticRules::min_travel_m`] a
//!      point), its own driving took it away from the ball, and the distance to the ball grew:
//!      the distance stopped closing;
//!    - **loop**: the robot kept turning one way past [`CriticRules::loop_rad`] (half a circle).
//!      The loop is the whole one-way turn, from where it began: turning toward the ball is fine,
//!      going around is a detour from its first point. Straight driving for more than
//!      [`CriticRules::loop_break_points`] points, or a turn the other way, ends a turn;
//!    - **wasted turning**: the robot turned (more than [`LOOP_TURN_RAD`] a point) while the
//!      distance to the ball did not close.
//! 3. The flaws are found on the stretches of labelled points: a stretch begins where the run
//!    began to go wrong and ends where the flaw ends. Stretches separated by at most
//!    [`CriticRules::merge_gap`] points are one chunk (a person does not split a flaw at a
//!    twitch). A stretch is flagged when it is a flaw a person sees: a loop of any length, or a
//!    stretch of at least [`CriticRules::min_points`] points that lost more than
//!    [`CriticRules::away_m`] of distance (moving away) or turned more than
//!    [`CriticRules::turn_rad`] while closing less than [`CriticRules::min_efficiency`] of the
//!    distance it drove (wasted turning). Each flawed stretch is flagged by the one chunk rule of
//!    both studies (the second protocol, S4: [`crate::experiment::chunk_rule`]): the chunk
//!    begins where the stretch begins and holds at most 25 points (the paper's "typical sizes in
//!    this work are 20-30 points"); any number of chunks, one a stretch, each named by its
//!    stretch's worst flaw (loop, then moving away, then wasted turning).
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
    /// Moving away: the ball distance grew over the stretch by more than this, m.
    pub away_m: f64,
    /// A point at which the robot drove less than this is not judged on distance, m.
    pub min_travel_m: f64,
    /// Wasted turning: the robot turned more than this within the stretch, rad ...
    pub turn_rad: f64,
    /// ... and closed less than this fraction of the distance it drove.
    pub min_efficiency: f64,
    /// Loop: once the robot has turned this far one way, rad, turning on is a loop ...
    pub loop_rad: f64,
    /// ... unless it drove straight for more than this many points in between.
    pub loop_break_points: usize,
    /// Stretches of flawed points at most this many points apart are one chunk.
    pub merge_gap: usize,
    /// A stretch of moving away or wasted turning shorter than this is not a flaw a person sees,
    /// points.
    pub min_points: usize,
}

impl Default for CriticRules {
    fn default() -> Self {
        CriticRules {
            settle_points: 10,
            face_rad: 0.5,
            max_settle_points: 60,
            detour_ratio: 1.6,
            detour_slack_m: 0.5,
            away_m: 0.03,
            min_travel_m: 0.002,
            turn_rad: 0.35,
            min_efficiency: 0.5,
            loop_rad: std::f64::consts::PI,
            loop_break_points: 15,
            merge_gap: 5,
            min_points: 5,
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
    /// What is flagged: the start of the flawed stretch, by the one chunk rule
    /// ([`crate::experiment::chunk_rule`]).
    pub chunk: Chunk,
    /// The whole flawed stretch the flaw was found on (what perfect critique would remove).
    pub stretch: Chunk,
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

/// What a judged point of a run shows (rule 2 of the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Label {
    Fine,
    Away,
    Turning,
    Loop,
}

/// Judge an interception execution: the chunks a human would flag, in order, each once.
pub fn critique(trace: &Trace, rules: &CriticRules) -> Vec<Flag> {
    let n = trace.len();
    if n == 0 || trace.obs_dim() <= HEADING_DELTA {
        return Vec::new();
    }
    let in_loop = loop_points(trace, rules, true);
    let settle = opening(trace, rules);
    // How much the distance to the ball grew after the action at `t` (the next observation's).
    let closing = |t: usize| {
        if t + 1 < n {
            trace.z(t + 1)[BALL_DIST] - trace.z(t)[BALL_DIST]
        } else {
            0.0
        }
    };
    let labels: Vec<Label> = (0..n)
        .map(|t| {
            let z = trace.z(t);
            let driving = z[TRAVEL_DELTA].abs() > rules.min_travel_m;
            let away_from_ball = z[TRAVEL_DELTA] * z[BALL_ANGLE].cos() < 0.0;
            if t < settle {
                Label::Fine
            } else if in_loop[t] {
                Label::Loop
            } else if driving && away_from_ball && closing(t) > 0.0 {
                Label::Away
            } else if z[HEADING_DELTA].abs() > LOOP_TURN_RAD && closing(t) >= 0.0 {
                Label::Turning
            } else {
                Label::Fine
            }
        })
        .collect();
    let mut flags = Vec::new();
    for chunk in stretches(&labels, rules.merge_gap) {
        let count = |l: Label| chunk.range().filter(|&t| labels[t] == l).count();
        let m = measure(trace, chunk);
        let long = chunk.len() >= rules.min_points.max(1);
        let flaw = if count(Label::Loop) > 0 {
            Some(Flaw::Loop)
        } else if long && count(Label::Away) > 0 && -m.progress_m > rules.away_m {
            Some(Flaw::MovingAway)
        } else if long
            && m.turning_rad > rules.turn_rad
            && m.progress_m < rules.min_efficiency * m.travel_m
        {
            Some(Flaw::WastedTurning)
        } else {
            None
        };
        if let Some(flaw) = flaw {
            flags.push(Flag {
                chunk: crate::experiment::chunk_rule(chunk),
                stretch: chunk,
                flaw,
            });
        }
    }
    flags
}

/// The stretches of points that are not [`Label::Fine`], those at most `gap` points apart joined.
fn stretches(labels: &[Label], gap: usize) -> Vec<Chunk> {
    let mut out: Vec<Chunk> = Vec::new();
    let mut t = 0;
    while t < labels.len() {
        if labels[t] == Label::Fine {
            t += 1;
            continue;
        }
        let start = t;
        while t < labels.len() && labels[t] != Label::Fine {
            t += 1;
        }
        match out.last_mut() {
            Some(last) if start - last.end <= gap => last.end = t,
            _ => out.push(Chunk { start, end: t }),
        }
    }
    out
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

/// The critic the protocol replaced (issue 33, choice 3), for the ablation
/// (`advise experiment bc --revert chunks`): rule 0 as in [`critique_execution`], then
/// [`critique_fixed`].
pub fn critique_execution_fixed(exec: &Execution, rules: &CriticRules) -> Vec<Flag> {
    if exec.outcome.success && !is_detour(exec, rules) {
        return Vec::new();
    }
    critique_fixed(&exec.trace, rules)
}

/// Chunk length of the critic the protocol replaced, points.
pub const FIXED_CHUNK_LEN: usize = 25;
/// At most this many chunks were flagged per execution, the first ones.
pub const FIXED_MAX_FLAGS: usize = 2;
/// A chunk in which the robot drove less than this was not judged on distance, m.
const FIXED_MIN_TRAVEL_M: f64 = 0.05;

/// Consecutive chunks of [`FIXED_CHUNK_LEN`] points covering `len` points: a short remainder
/// joins the chunk before it, and a run shorter than one chunk is one chunk.
pub fn fixed_chunks(len: usize) -> Vec<Chunk> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < len {
        let mut end = (start + FIXED_CHUNK_LEN).min(len);
        if len - end < FIXED_CHUNK_LEN {
            end = len;
        }
        out.push(Chunk { start, end });
        start = end;
    }
    out
}

/// The critic's judgement before the protocol: the run cut into [`fixed_chunks`], the part of
/// each after the opening judged whole (at least half a chunk of it), a chunk flagged as a loop
/// when most of it comes after the robot had turned half a circle one way, as moving away or
/// wasted turning on the chunk's own measures, and at most the first [`FIXED_MAX_FLAGS`] poor
/// chunks flagged. The thresholds are [`CriticRules`]' (they did not change), but for the travel
/// below which a chunk is not judged on distance ([`FIXED_MIN_TRAVEL_M`] over the chunk).
pub fn critique_fixed(trace: &Trace, rules: &CriticRules) -> Vec<Flag> {
    let n = trace.len();
    if n == 0 || trace.obs_dim() <= HEADING_DELTA {
        return Vec::new();
    }
    let in_loop = loop_points(trace, rules, false);
    let settle = opening(trace, rules);
    let mut flags = Vec::new();
    for chunk in fixed_chunks(n) {
        let judged = Chunk {
            start: chunk.start.max(settle),
            end: chunk.end,
        };
        if judged.len() < FIXED_CHUNK_LEN.div_ceil(2) {
            continue;
        }
        let m = measure(trace, judged);
        let driving = m.travel_m > FIXED_MIN_TRAVEL_M;
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
            flags.push(Flag {
                chunk,
                stretch: chunk,
                flaw,
            });
            if flags.len() == FIXED_MAX_FLAGS {
                break;
            }
        }
    }
    flags
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
/// once the turn has passed `loop_rad`, every point of it from where it began (`from_start`),
/// or only the points after the first `loop_rad` of it (the critic before the protocol).
fn loop_points(trace: &Trace, rules: &CriticRules, from_start: bool) -> Vec<bool> {
    let n = trace.len();
    let mut marked = vec![false; n];
    let mut turned = 0.0f64;
    let mut straight = 0;
    let mut began = 0;
    for t in 0..n {
        let dh = trace.z(t)[HEADING_DELTA];
        if dh.abs() <= LOOP_TURN_RAD {
            straight += 1;
            if straight > rules.loop_break_points {
                turned = 0.0;
            }
            continue;
        }
        straight = 0;
        if turned == 0.0 || dh.signum() != turned.signum() {
            turned = 0.0;
            began = t;
        }
        turned += dh;
        if turned.abs() > rules.loop_rad {
            let from = if from_start { began } else { t };
            marked[from..=t].iter_mut().for_each(|m| *m = true);
        }
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
    fn stretches_are_the_flawed_points_with_short_gaps_joined() {
        use Label::*;
        let l = [
            Fine, Away, Away, Fine, Fine, Loop, Fine, Fine, Fine, Turning, Fine,
        ];
        let c = |start, end| Chunk { start, end };
        assert_eq!(stretches(&l, 0), [c(1, 3), c(5, 6), c(9, 10)]);
        assert_eq!(stretches(&l, 2), [c(1, 6), c(9, 10)]);
        assert_eq!(stretches(&l, 3), [c(1, 10)]);
        assert!(stretches(&[Fine; 4], 5).is_empty());
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
        // One flaw: the whole loop, from where the turn began to where it ended; none in the
        // straight approaches before and after. The chunk flagged is its first 25 points (the
        // one chunk rule).
        assert!(loop_pts > 25);
        assert_eq!(
            flags,
            [Flag {
                chunk: Chunk {
                    start: 40,
                    end: 40 + 25
                },
                stretch: Chunk {
                    start: 40,
                    end: 40 + loop_pts
                },
                flaw: Flaw::Loop
            }]
        );
    }

    /// The ablation's critic (`--revert chunks`): fixed 25-point chunks, the first two poor ones.
    #[test]
    fn the_pre_protocol_critic_flags_at_most_two_fixed_chunks() {
        for len in [0, 1, 24, 25, 49, 50, 51, 137] {
            let cs = fixed_chunks(len);
            assert_eq!(cs.iter().map(|c| c.len()).sum::<usize>(), len);
            if len >= 25 {
                assert!(cs.iter().all(|c| (25..50).contains(&c.len())), "{cs:?}");
            }
        }
        let (t, _) = looping_trace();
        let rules = CriticRules::default();
        let fixed = critique_fixed(&t, &rules);
        assert!(
            !fixed.is_empty() && fixed.len() <= FIXED_MAX_FLAGS,
            "{fixed:?}"
        );
        assert!(fixed.iter().all(|f| f.chunk.start % FIXED_CHUNK_LEN == 0));
        // The protocol's critic flags the loop from where the turn began, in one chunk.
        assert_ne!(fixed, critique(&t, &rules));
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
    fn any_number_of_chunks_of_any_length_are_flagged() {
        // The ball behind: driving away for 12 points, a straight approach of 40, away for 30.
        let step = 0.6 / 30.0;
        let mut t = Trace::new(&Domain::interception());
        let mut d = 2.0;
        let mut push = |t: &mut Trace, away: bool| {
            d += if away { step } else { -step };
            let angle = if away { 3.0 } else { 0.0 };
            t.push(0.0, &[d, angle, 0.0, 0.0, step, 0.0], &[0.0, 0.0], None);
        };
        for _ in 0..10 {
            push(&mut t, false);
        }
        for _ in 0..12 {
            push(&mut t, true);
        }
        for _ in 0..40 {
            push(&mut t, false);
        }
        for _ in 0..30 {
            push(&mut t, true);
        }
        let flags = critique(&t, &CriticRules::default());
        let stretches: Vec<(usize, usize)> = flags
            .iter()
            .map(|f| (f.stretch.start, f.stretch.end))
            .collect();
        // Each stretch from where the distance stopped closing to where it closed again (the
        // last point of each has no next distance to judge by, or closes).
        assert_eq!(stretches, [(10, 21), (62, 91)], "{flags:?}");
        // Each flagged chunk: the stretch's first 25 points at most.
        let chunks: Vec<(usize, usize)> =
            flags.iter().map(|f| (f.chunk.start, f.chunk.end)).collect();
        assert_eq!(chunks, [(10, 21), (62, 87)], "{flags:?}");
        assert!(flags.iter().all(|f| f.flaw == Flaw::MovingAway));
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
                end_rule: None,
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
        // Nothing of the opening is flagged, nor the straight approach; the turn that goes on
        // past half a circle after the robot faced the ball (points 27-39) is a loop from there.
        let flags = critique(&trace, &rules);
        assert!(
            flags
                .iter()
                .all(|f| f.chunk.start >= 27 && f.chunk.end <= 40),
            "{flags:?}"
        );
        // Judged from the first point instead, the turn in place (4 rad) is a loop.
        let eager = CriticRules {
            face_rad: 10.0,
            settle_points: 0,
            ..rules
        };
        assert!(
            critique(&trace, &eager)
                .iter()
                .any(|f| f.flaw == Flaw::Loop)
        );
    }
}
