//! The teacher takes over: a run in which some steps are driven by the teacher instead of the
//! learner, and the record of who drove each step.
//!
//! [`run_episode_with`] is [`super::run_episode`]'s loop with a [`Takeover`] asked before every
//! step whether the teacher drives it (and with what action). The same loop drives every base, so
//! the base's own safety holds in a teacher's steps as in the learner's: the action is clamped to
//! the domain's limits, the base's watchdog and clamps stay armed, and a stop signal or a lost
//! link ends the run whoever drives. Control passes to the teacher at once; when the teacher
//! hands back, the learner's action is blended in from the teacher's last one over
//! [`HANDBACK_S`], so the command does not jump (the base's acceleration limits then smooth what
//! is left).
//!
//! A takeover is a hook: a scripted window ([`Window`]: the task's own teacher drives from one
//! time to another, the stand-in for a person in tests and studies), a person's keys, a ROS 2
//! topic, a study's automated teacher that takes over where a run goes wrong. It only decides
//! and acts; what the teacher drove is returned as [`Driven::teacher`], windows of steps, and it
//! is the session's business to keep them as demonstrations.
//!
//! No IO, nothing printed.

use super::{Controller, Execution, Interrupted, Stepper, Task};
use crate::backend::teleop::Commands;
use crate::backend::{Backend, BaseState};
use crate::trace::{Chunk, Trace};

/// Who drove a step of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Driver {
    Learner,
    Teacher,
}

/// How long the learner's action is blended in from the teacher's last one when the teacher
/// hands back, s: long enough that a command does not jump, short against a run (a few control
/// steps at 30 Hz).
pub const HANDBACK_S: f64 = 0.3;

/// What a takeover decides from, before each step.
#[derive(Debug)]
pub struct Moment<'a> {
    /// The step about to be taken (the trace's point it becomes).
    pub step: usize,
    /// Control time since the run started: `step` times the base's period, s.
    pub t_s: f64,
    /// The base's state now (odometry).
    pub state: &'a BaseState,
    /// The task's observation now: what the step's action answers.
    pub observation: &'a [f64],
    /// The action executed at the last step (zero before the first).
    pub last_action: &'a [f64],
    /// Who drove the last step (the learner before the first).
    pub last: Driver,
}

/// Who drives a run, step by step: the hook [`run_episode_with`] asks before each step.
pub trait Takeover {
    /// Whether the teacher drives this step; if so, its action is written into `a` (zeros on
    /// entry). The learner drives when it returns false.
    fn drive(&mut self, at: &Moment<'_>, a: &mut [f64]) -> bool;
}

/// No takeover: the learner drives every step.
pub struct Never;

impl Takeover for Never {
    fn drive(&mut self, _at: &Moment<'_>, _a: &mut [f64]) -> bool {
        false
    }
}

/// A scripted takeover: `teacher` (a controller: the task's own teacher, a study's) drives the
/// steps from `from_s` to `to_s` of control time, and is begun afresh at the window's start.
pub struct Window {
    steps: Chunk,
    teacher: Box<dyn Controller + Send>,
    seed: u64,
}

impl Window {
    /// The window `[from_s, to_s)` on a base of period `period_s`: the steps whose control time
    /// (step times the period) falls in it, rounded to the nearest step.
    pub fn new(
        from_s: f64,
        to_s: f64,
        period_s: f64,
        teacher: Box<dyn Controller + Send>,
        seed: u64,
    ) -> Window {
        Window {
            steps: seconds_to_steps(from_s, to_s, period_s),
            teacher,
            seed,
        }
    }

    /// The steps the window covers (a run that ends sooner covers fewer).
    pub fn steps(&self) -> Chunk {
        self.steps
    }
}

/// The steps of `[from_s, to_s)` at `period_s`, each end rounded to the nearest step; empty
/// when the times are not numbers.
pub fn seconds_to_steps(from_s: f64, to_s: f64, period_s: f64) -> Chunk {
    let step = |s: f64| {
        let k = (s / period_s.max(1e-6)).round();
        if k.is_finite() && k > 0.0 {
            (k as usize).min(super::MAX_EPISODE_STEPS)
        } else {
            0
        }
    };
    let (start, end) = (step(from_s), step(to_s));
    Chunk {
        start,
        end: end.max(start),
    }
}

impl Takeover for Window {
    fn drive(&mut self, at: &Moment<'_>, a: &mut [f64]) -> bool {
        if !self.steps.range().contains(&at.step) {
            return false;
        }
        if at.last != Driver::Teacher {
            self.teacher.begin(self.seed);
        }
        self.teacher.act(at.observation, a);
        true
    }
}

/// A person takes over: each step, the teleoperation `commands` (a terminal's keys, a ROS 2
/// topic, a web page's pad) say whether the person drives and with what speed command, which
/// becomes the task's action on its speed and turn axes (`axes`: their indices among the
/// actions; the other actions are zero), clamped to the base's limits (`max`) before the
/// domain's clamp.
pub struct Person {
    pub commands: Box<dyn Commands>,
    pub axes: (usize, usize),
    pub max: (f64, f64),
}

impl Takeover for Person {
    fn drive(&mut self, at: &Moment<'_>, a: &mut [f64]) -> bool {
        let (si, ti) = self.axes;
        let get = |i: usize| at.last_action.get(i).copied().unwrap_or(0.0);
        let Some((v, w)) = self.commands.command((get(si), get(ti))) else {
            return false;
        };
        let clamp = |x: f64, max: f64| {
            if x.is_finite() {
                x.clamp(-max, max)
            } else {
                0.0
            }
        };
        if let Some(slot) = a.get_mut(si) {
            *slot = clamp(v, self.max.0.abs());
        }
        if let Some(slot) = a.get_mut(ti) {
            *slot = clamp(w, self.max.1.abs());
        }
        true
    }
}

/// A run with a takeover: the execution (or the interrupted one) and the windows of steps the
/// teacher drove, in order, each within the recorded trace.
pub struct Driven {
    pub result: Result<Execution, Interrupted>,
    pub teacher: Vec<Chunk>,
}

impl Driven {
    /// Who drove step `k`.
    pub fn driver(&self, k: usize) -> Driver {
        driver_at(&self.teacher, k)
    }
}

/// The points of `trace` the teacher drove in `steps`, kept every `every`-th from the first (a
/// task's demonstration rate, [`super::TaskKind::record_every`]): a takeover's demonstration,
/// what a session adds with its link to the run and a study may add as it likes.
pub fn window_trace(trace: &Trace, steps: Chunk, every: usize) -> Trace {
    let mut part = Trace::with_dims(&trace.domain, trace.obs_dim(), trace.act_dim());
    for k in steps.range().filter(|&k| k < trace.len()) {
        let pose = trace.pose.as_ref().and_then(|p| p.get(k).copied());
        part.push(trace.t[k], trace.z(k), trace.a(k), pose);
    }
    super::recorded_at(&part, every)
}

/// Who drove step `k`, given the windows the teacher drove.
pub fn driver_at(teacher: &[Chunk], k: usize) -> Driver {
    if teacher.iter().any(|w| w.range().contains(&k)) {
        Driver::Teacher
    } else {
        Driver::Learner
    }
}

/// The control loop of every episode ([`super::run_episode`] is it with [`Never`]), with
/// `takeover` asked before every step whether the teacher drives it.
/// The learner (`controller`) acts only on its own steps, so a stateful controller sees the run
/// it drove; the teacher's actions go through the same clamp and base as the learner's.
pub fn run_episode_with(
    backend: &mut dyn Backend,
    task: &mut dyn Task,
    controller: &mut dyn Controller,
    takeover: &mut dyn Takeover,
    episode_seed: u64,
) -> Driven {
    let mut ep = match Stepper::begin(backend, task) {
        Ok(ep) => ep,
        Err(i) => {
            return Driven {
                result: Err(i),
                teacher: Vec::new(),
            };
        }
    };
    controller.begin(episode_seed);
    let period_s = backend.period_s();
    let act_dim = task.domain().act_dim();
    let blend_steps = ((HANDBACK_S / period_s.max(1e-6)).ceil() as usize).max(1);
    let (mut a, mut last_action) = (vec![0.0; act_dim], vec![0.0; act_dim]);
    let mut handback = vec![0.0; act_dim];
    let mut last = Driver::Learner;
    let mut since_handback = usize::MAX;
    let mut windows: Vec<Chunk> = Vec::new();
    while !ep.is_over() {
        let step = ep.steps();
        a.iter_mut().for_each(|v| *v = 0.0);
        let moment = Moment {
            step,
            t_s: step as f64 * period_s,
            state: ep.state(),
            observation: ep.observation(),
            last_action: &last_action,
            last,
        };
        let driver = if takeover.drive(&moment, &mut a) {
            Driver::Teacher
        } else {
            Driver::Learner
        };
        match driver {
            Driver::Teacher => {
                match windows.last_mut() {
                    Some(w) if w.end == step => w.end += 1,
                    _ => windows.push(Chunk {
                        start: step,
                        end: step + 1,
                    }),
                }
                since_handback = usize::MAX;
            }
            Driver::Learner => {
                if last == Driver::Teacher {
                    handback.copy_from_slice(&last_action);
                    since_handback = 0;
                }
                a.iter_mut().for_each(|v| *v = 0.0);
                controller.act(ep.observation(), &mut a);
                if since_handback < blend_steps {
                    since_handback += 1;
                    let w = since_handback as f64 / (blend_steps + 1) as f64;
                    for (v, h) in a.iter_mut().zip(&handback) {
                        *v = w * *v + (1.0 - w) * h;
                    }
                }
            }
        }
        if let Err(error) = ep.step(backend, task, &a) {
            let interrupted = ep.interrupt(backend, task, error);
            let n = interrupted.execution.trace.len();
            return Driven {
                result: Err(interrupted),
                teacher: within(windows, n),
            };
        }
        last_action.copy_from_slice(ep.action());
        last = driver;
    }
    let result = ep.finish(backend, task);
    let n = match &result {
        Ok(e) => e.trace.len(),
        Err(i) => i.execution.trace.len(),
    };
    Driven {
        result,
        teacher: within(windows, n),
    }
}

/// The windows cut to a trace of `n` points (a step the base failed on was never recorded).
fn within(windows: Vec<Chunk>, n: usize) -> Vec<Chunk> {
    windows
        .into_iter()
        .filter_map(|w| {
            let end = w.end.min(n);
            (w.start < end).then_some(Chunk {
                start: w.start,
                end,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::sim::{SimBackend, SimParams};
    use crate::task::Start;
    use crate::trace::Pose;

    /// A learner that always drives straight at a fixed speed.
    struct Constant(f64, f64);
    impl Controller for Constant {
        fn act(&mut self, _z: &[f64], a: &mut [f64]) {
            a[0] = self.0;
            a[1] = self.1;
        }
    }

    fn run(takeover: &mut dyn Takeover) -> Driven {
        let params = SimParams::default();
        let mut base = SimBackend::new(params, 3);
        let start = Start::Goal(Pose::new(4.0, 0.0, 0.0));
        let mut task = start.task();
        run_episode_with(
            &mut base,
            task.as_mut(),
            &mut Constant(0.2, 0.0),
            takeover,
            3,
        )
    }

    #[test]
    fn a_window_is_driven_by_the_teacher_and_handed_back_without_a_jump() {
        let period = SimParams::default().period_s();
        let teacher = Box::new(Constant(0.6, 0.3));
        let mut w = Window::new(1.0, 2.0, period, teacher, 1);
        assert_eq!(w.steps(), Chunk { start: 30, end: 60 });
        let d = run(&mut w);
        assert_eq!(d.teacher, [Chunk { start: 30, end: 60 }]);
        let e = d.result.as_ref().unwrap();
        assert_eq!(e.trace.a(29), [0.2, 0.0]);
        assert_eq!(e.trace.a(30), [0.6, 0.3], "at once");
        assert_eq!(e.trace.a(59), [0.6, 0.3]);
        // Handed back: blended from the teacher's last action, never a jump to the learner's.
        let blend = (HANDBACK_S / period).ceil() as usize;
        let mut prev = e.trace.a(59)[0];
        for k in 60..60 + blend {
            let v = e.trace.a(k)[0];
            assert!(v < prev && v > 0.2, "step {k}: {v} after {prev}");
            prev = v;
        }
        assert_eq!(e.trace.a(60 + blend), [0.2, 0.0]);
        assert_eq!(d.driver(29), Driver::Learner);
        assert_eq!(d.driver(30), Driver::Teacher);
        assert_eq!(d.driver(60), Driver::Learner);
    }

    #[test]
    fn a_window_past_the_end_is_cut_to_the_run_and_never_is_a_plain_run() {
        let period = SimParams::default().period_s();
        let mut w = Window::new(1.0, 1e9, period, Box::new(Constant(0.0, 0.0)), 1);
        let d = run(&mut w);
        let n = d.result.as_ref().unwrap().trace.len();
        assert_eq!(d.teacher, [Chunk { start: 30, end: n }]);
        let plain = run(&mut Never);
        assert!(plain.teacher.is_empty());
        let mut base = SimBackend::new(SimParams::default(), 3);
        let start = Start::Goal(Pose::new(4.0, 0.0, 0.0));
        let e =
            crate::task::run_episode(&mut base, start.task().as_mut(), &mut Constant(0.2, 0.0), 3)
                .unwrap();
        assert_eq!(e.trace, plain.result.unwrap().trace, "the same loop");
    }

    #[test]
    fn seconds_become_steps() {
        let p = 1.0 / 30.0;
        assert_eq!(
            seconds_to_steps(2.0, 4.0, p),
            Chunk {
                start: 60,
                end: 120
            }
        );
        assert_eq!(
            seconds_to_steps(f64::NAN, 4.0, p),
            Chunk { start: 0, end: 120 }
        );
        assert_eq!(seconds_to_steps(3.0, 1.0, p), Chunk { start: 90, end: 90 });
    }
}
