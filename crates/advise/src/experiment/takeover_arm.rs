//! The A-OPI study's takeover arm's teacher (docs/protocol.md, "The takeover arm", T2-T4): a
//! [`Takeover`] that lets the study's teleoperator drive from the step where the run began to go
//! wrong until it recovers.
//!
//! From `from` (the advisor's judgement of where the first drive of the goal went wrong,
//! [`advisor::went_wrong_at`]) the teacher drives; it hands back at the first step at which it
//! has driven at least [`MIN_STEPS`] steps and the advisor's arc rule judges each of its last
//! [`AdvisorRules::min_chunk`] driven points right ([`advisor::arc_is_right`]). The arc at a
//! point needs the [`advisor::CURVE_WINDOW`] points after it, so the judgement runs that many
//! steps behind the robot; it reads the base's odometry, the view the hook has during the run.
//! Once within [`advisor::ARC_NEAR_M`] of the goal the teacher drives on to the run's end. It
//! takes over once: after handing back it never drives again in the run.

use crate::domain::Domain;
use crate::domain::columns::positioning::DIST2;
use crate::experiment::CHUNK_POINTS;
use crate::experiment::advisor::{self, AdvisorRules};
use crate::task::takeover::{Moment, Takeover};
use crate::task::{Controller, PositioningTeacher};
use crate::trace::{Pose, Trace};

/// The least the teacher drives before it may hand back, control steps: one chunk of the one
/// chunk rule (T4 (a)).
pub const MIN_STEPS: usize = CHUNK_POINTS;

/// Where the teacher is in the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Watching,
    Driving,
    HandedBack,
}

/// The takeover arm's teacher on one practice goal.
pub struct Recovery {
    from: usize,
    teacher: PositioningTeacher,
    seed: u64,
    settle: usize,
    phase: Phase,
    to_the_end: bool,
    /// The teacher's driven points so far (observation, executed action, odometry pose), and
    /// the poses of those points and of the step now about to be taken.
    trace: Trace,
    path: Vec<Pose>,
    last_z: Vec<f64>,
    last_t: f64,
}

impl Recovery {
    /// The teacher `teacher` takes over at step `from`, begun with `seed`; `rules` are the
    /// advisor's (its shortest stretch worth advising is how many right points recover a run).
    pub fn new(from: usize, teacher: PositioningTeacher, seed: u64, rules: &AdvisorRules) -> Self {
        Recovery {
            from,
            teacher,
            seed,
            settle: rules.min_chunk.max(1),
            phase: Phase::Watching,
            to_the_end: false,
            trace: Trace::new(&Domain::positioning()),
            path: Vec::new(),
            last_z: Vec::new(),
            last_t: 0.0,
        }
    }

    /// Whether the run has recovered, `driven` steps into the takeover: T4 (a) and (b).
    fn recovered(&self, driven: usize) -> bool {
        if self.to_the_end || driven < MIN_STEPS {
            return false;
        }
        // Points judged so far: those with CURVE_WINDOW poses after them.
        let Some(judged) = self.path.len().checked_sub(advisor::CURVE_WINDOW) else {
            return false;
        };
        let judged = judged.min(self.trace.len());
        judged >= self.settle
            && (judged - self.settle..judged)
                .all(|t| advisor::arc_is_right(&self.trace, &self.path, t))
    }
}

impl Takeover for Recovery {
    fn drive(&mut self, at: &Moment<'_>, a: &mut [f64]) -> bool {
        match self.phase {
            Phase::HandedBack => return false,
            Phase::Watching if at.step < self.from => return false,
            Phase::Watching => {
                self.phase = Phase::Driving;
                self.teacher.begin(self.seed);
            }
            Phase::Driving => {
                // The point of the last step, now that its executed action is known.
                let pose = self.path.last().copied();
                self.trace
                    .push(self.last_t, &self.last_z, at.last_action, pose);
            }
        }
        self.path.push(at.state.pose);
        self.last_z.clear();
        self.last_z.extend_from_slice(at.observation);
        self.last_t = at.t_s;
        if at
            .observation
            .get(DIST2)
            .is_some_and(|d2| d2.max(0.0).sqrt() < advisor::ARC_NEAR_M)
        {
            self.to_the_end = true;
        }
        if self.recovered(at.step - self.from) {
            self.phase = Phase::HandedBack;
            return false;
        }
        self.teacher.act(at.observation, a);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::sim::SimParams;
    use crate::experiment::pilot::PilotStyle;
    use crate::task::{Start, run_sim, run_sim_with};
    use crate::trace::Chunk;

    /// A learner that drives away from any goal: straight at 0.5 m/s, turning steadily left.
    struct Wanderer;
    impl Controller for Wanderer {
        fn act(&mut self, _z: &[f64], a: &mut [f64]) {
            a[0] = 0.5;
            a[1] = 0.4;
        }
    }

    fn goal() -> Start {
        Start::Goal(Pose {
            x_m: 3.0,
            y_m: -2.0,
            theta_rad: -0.5,
        })
    }

    #[test]
    fn the_run_is_the_learners_up_to_the_takeover_and_the_teacher_drives_from_there() {
        let sim = SimParams::default();
        let plain = run_sim(&goal(), &mut Wanderer, &sim, 11);
        let teacher = PilotStyle::default().teacher(3, 4, sim.period_s());
        let mut hook = Recovery::new(40, teacher, 5, &AdvisorRules::default());
        let (exec, windows) = run_sim_with(&goal(), &mut Wanderer, &mut hook, &sim, 11);
        // Identical up to the takeover, bit for bit.
        for k in 0..40 {
            assert_eq!(exec.trace.z(k), plain.trace.z(k), "step {k}");
            assert_eq!(exec.trace.a(k), plain.trace.a(k), "step {k}");
        }
        assert_eq!(windows.len(), 1, "one takeover: {windows:?}");
        let w = windows[0];
        assert_eq!(w.start, 40);
        assert!(w.len() >= MIN_STEPS, "{w:?}");
        // The wanderer never reaches the goal; with the teacher the run ends nearer it.
        assert!(
            exec.outcome.position_error_m < plain.outcome.position_error_m,
            "{} vs {}",
            exec.outcome.position_error_m,
            plain.outcome.position_error_m
        );
    }

    #[test]
    fn the_teacher_hands_back_once_the_arc_is_right_and_never_takes_over_again() {
        let sim = SimParams::default();
        // A goal far ahead: the teacher recovers long before it is near, and hands back.
        let far = Start::Goal(Pose {
            x_m: 8.0,
            y_m: 0.5,
            theta_rad: 0.0,
        });
        let teacher = PilotStyle::default().teacher(3, 4, sim.period_s());
        let mut hook = Recovery::new(30, teacher, 5, &AdvisorRules::default());
        let (exec, windows) = run_sim_with(&far, &mut Wanderer, &mut hook, &sim, 11);
        assert_eq!(windows.len(), 1, "{windows:?}");
        let w: Chunk = windows[0];
        assert!(
            w.end < exec.trace.len(),
            "handed back before the end: {w:?} of {}",
            exec.trace.len()
        );
        // Handed back after at least one chunk, with the last settle points judged right.
        assert!(w.len() >= MIN_STEPS);
        let path = exec.trace.pose.as_ref().unwrap();
        let settle = AdvisorRules::default().min_chunk;
        let judged_end = w.end + 1 - advisor::CURVE_WINDOW;
        for t in judged_end - settle..judged_end {
            assert!(
                advisor::arc_is_right(&exec.trace, path, t),
                "point {t} of the window {w:?} is not judged right"
            );
        }
    }

    #[test]
    fn before_its_step_the_teacher_never_drives() {
        let sim = SimParams::default();
        let teacher = PilotStyle::default().teacher(3, 4, sim.period_s());
        let mut hook = Recovery::new(usize::MAX, teacher, 5, &AdvisorRules::default());
        let plain = run_sim(&goal(), &mut Wanderer, &sim, 11);
        let (exec, windows) = run_sim_with(&goal(), &mut Wanderer, &mut hook, &sim, 11);
        assert!(windows.is_empty());
        assert_eq!(exec.trace.len(), plain.trace.len());
        assert_eq!(exec.outcome, plain.outcome);
    }
}
