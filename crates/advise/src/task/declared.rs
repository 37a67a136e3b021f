//! Tasks declared in the language: a [`TaskDef`] run as a [`Task`], its goals drawn, its teacher
//! run as a [`Controller`].
//!
//! Each control step fills an environment of numbers ([`crate::program::task`]): the pose and
//! speeds from odometry, the goal, the last action, then the task's values in their checked
//! order; the observation is read from it, end rules are evaluated on it after the step, and the
//! scores and the success rule on the final pose. `prev(NAME)` reads the environment of the step
//! before (at the first step, this step's). A step's work is fixed by the declaration's size.
//! This module does no IO.

use std::sync::Arc;

use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::backend::BaseState;
use crate::domain::Domain;
use crate::geometry::Pose;
use crate::policy::Policy;
use crate::program::task::{self as def, Drawn, EndRule, TaskDef, TeacherTarget};
use crate::task::{Controller, Ending, Score, Task};

/// One run of a declared task toward one goal.
#[derive(Clone, Debug)]
pub struct Declared {
    def: Arc<TaskDef>,
    goal: Vec<f64>,
    /// The environment of the last step the controller acted on (what `prev` reads).
    prev: Vec<f64>,
    started: bool,
    action: Vec<f64>,
    command: (f64, f64),
    /// Seconds each `end when ... for` rule has held.
    held_s: Vec<f64>,
    /// The `end when` rule that ended the episode (its index in `def.ends`).
    fired: Option<usize>,
    last: BaseState,
}

impl Declared {
    /// A run of `def` toward `goal` (one value per goal parameter; missing ones are 0).
    pub fn new(def: Arc<TaskDef>, goal: &[f64]) -> Declared {
        let mut g = vec![0.0; def.goal.len()];
        for (v, x) in g.iter_mut().zip(goal) {
            *v = *x;
        }
        Declared {
            prev: vec![0.0; def.slots()],
            action: vec![0.0; def.domain.act_dim()],
            held_s: vec![0.0; def.ends.len()],
            fired: None,
            def,
            goal: g,
            started: false,
            command: (0.0, 0.0),
            last: BaseState::default(),
        }
    }

    pub fn def(&self) -> &Arc<TaskDef> {
        &self.def
    }

    pub fn goal(&self) -> &[f64] {
        &self.goal
    }

    /// The environment of a state: base values, goal, last action, then the computed values.
    fn env(&self, state: &BaseState, pose: Pose) -> Vec<f64> {
        let d = &self.def;
        let mut env = vec![0.0; d.slots()];
        env[def::X] = pose.x_m;
        env[def::Y] = pose.y_m;
        env[def::THETA] = pose.theta_rad;
        env[def::V] = state.speed_mps;
        env[def::W] = state.rot_radps;
        env[def::T] = state.t_s;
        let g = d.goal_slot();
        env[g..g + self.goal.len()].copy_from_slice(&self.goal);
        let a = d.action_slot();
        env[a..a + self.action.len()].copy_from_slice(&self.action);
        for (slot, ir) in &d.computed {
            // At the first step `prev` reads this step: the checker ordered the values so that
            // what a value reads with `prev` is computed before it.
            let v = if self.started {
                ir.eval_task(&env, &self.prev)
            } else {
                ir.eval_task(&env, &env)
            };
            env[*slot] = v;
        }
        env
    }

    fn drive(&self, drive: &Option<def::Drive>, current: f64, a: &[f64]) -> f64 {
        match drive {
            None => 0.0,
            Some(d) => {
                let v = a.get(d.action).copied().unwrap_or(0.0);
                match d.integrate {
                    None => v,
                    Some(l) => l.clamp(current + v),
                }
            }
        }
    }
}

impl Task for Declared {
    fn domain(&self) -> &Domain {
        &self.def.domain
    }

    fn start(&self) -> Pose {
        Pose::default()
    }

    fn begin(&mut self, state: &BaseState) {
        self.started = false;
        self.command = (0.0, 0.0);
        self.action.iter_mut().for_each(|v| *v = 0.0);
        self.held_s.iter_mut().for_each(|v| *v = 0.0);
        self.fired = None;
        self.last = *state;
    }

    fn observe(&self, state: &BaseState, z: &mut [f64]) {
        let env = self.env(state, state.pose);
        for (v, slot) in z.iter_mut().zip(&self.def.observe) {
            *v = env[*slot];
        }
    }

    fn command(&mut self, state: &BaseState, a: &[f64]) -> (f64, f64) {
        // What `prev` reads from now on: this step, as the controller saw it.
        self.prev = self.env(state, state.pose);
        self.started = true;
        for (v, x) in self.action.iter_mut().zip(a) {
            *v = *x;
        }
        let d = &self.def;
        self.command = (
            self.drive(&d.speed, self.command.0, a),
            self.drive(&d.turn, self.command.1, a),
        );
        self.command
    }

    fn advance(
        &mut self,
        dt_s: f64,
        state: &BaseState,
        _true_pose: Option<Pose>,
    ) -> Option<Ending> {
        self.last = *state;
        let env = self.env(state, state.pose);
        let mut ending = None;
        for (i, (rule, held)) in self.def.ends.iter().zip(self.held_s.iter_mut()).enumerate() {
            match rule {
                EndRule::When { cond, hold_s, .. } => {
                    let holds = cond.eval_task(&env, &self.prev) != 0.0;
                    *held = if holds { *held + dt_s } else { 0.0 };
                    if ending.is_none() && holds {
                        if *hold_s == 0.0 {
                            ending = Some(Ending::Rule);
                            self.fired = Some(i);
                        } else if *held >= hold_s - 1e-9 {
                            // A small tolerance so that 30 periods of 1/30 s count as one second.
                            ending = Some(Ending::Rested);
                            self.fired = Some(i);
                        }
                    }
                }
                EndRule::After { limit_s } => {
                    if ending.is_none() && state.t_s >= limit_s - 1e-9 {
                        ending = Some(Ending::TimeLimit);
                    }
                }
            }
        }
        ending
    }

    fn end_rule(&self) -> Option<String> {
        let whens = self
            .def
            .ends
            .iter()
            .filter(|r| matches!(r, EndRule::When { .. }))
            .count();
        match self.def.ends.get(self.fired?)? {
            // A task's only `end when` rule that must hold `for` a while is what "rested" says
            // (positioning's): naming it would only repeat it.
            EndRule::When { text, hold_s, .. } if whens > 1 || *hold_s == 0.0 => Some(text.clone()),
            _ => None,
        }
    }

    fn score(&self, _ending: Ending, pose: Pose) -> Score {
        let d = &self.def;
        let mut env = self.env(&self.last, pose);
        for (slot, ir) in &d.score {
            let v = ir.eval_task(&env, &self.prev);
            env[*slot] = v;
        }
        Score {
            success: d.success.eval_task(&env, &self.prev) != 0.0,
            position_error_m: env[d.error],
            heading_error_rad: d.heading_error.map(|s| env[s]),
            efficiency: d.efficiency.map(|s| env[s]),
        }
    }
}

/// The fixed test set of a declared task: its `test` count of goals from its seed (stream 0).
pub fn test_goals(def: &TaskDef) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(def.test_seed);
    rng.set_stream(0);
    (0..def.test_count).map(|_| sample(def, &mut rng)).collect()
}

/// `n` practice goals drawn from `seed` (stream 1, so never the test set's).
pub fn practice_goals(def: &TaskDef, seed: u64, n: usize) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    (0..n).map(|_| sample(def, &mut rng)).collect()
}

/// Practice goal `index` of `seed`, computed directly: a goal takes two 32-bit words a parameter
/// (one `u64` draw each, never rejected), so goal `index` starts at a known word of the stream.
pub fn practice_goal(def: &TaskDef, seed: u64, index: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    rng.set_word_pos(u128::from(index) * 2 * def.goal.len() as u128);
    sample(def, &mut rng)
}

/// One goal: a value per parameter, uniform in its range. The checker bounds every range
/// ([`def::MAX_GOAL_ABS`]); a range that is not one anyway (a definition built by hand) cannot
/// panic the draw: it gives the range's middle, or 0, and still takes its draw.
fn sample(def: &TaskDef, rng: &mut ChaCha8Rng) -> Vec<f64> {
    def.goal
        .iter()
        .map(|g| {
            // `random_range` refuses (panics on) a range whose width is not a finite number.
            if g.lo < g.hi && (g.hi - g.lo).is_finite() {
                rng.random_range(g.lo..g.hi)
            } else {
                // A range of one value still takes its draw, so later parameters keep theirs.
                rng.next_u64();
                let mid = g.lo / 2.0 + g.hi / 2.0;
                if g.lo == g.hi && g.lo.is_finite() {
                    g.lo
                } else if mid.is_finite() {
                    mid
                } else {
                    0.0
                }
            }
        })
        .collect()
}

/// The goal a recording ending at `pose` demonstrates, by the task's `recorded` clause.
pub fn recorded_goal(def: &TaskDef, pose: Pose) -> Option<Vec<f64>> {
    let rec = def.recorded.as_ref()?;
    let mut env = vec![0.0; def.slots()];
    env[def::X] = pose.x_m;
    env[def::Y] = pose.y_m;
    env[def::THETA] = pose.theta_rad;
    Some(rec.iter().map(|ir| ir.eval_task(&env, &env)).collect())
}

/// What pictures of a run toward `goal` draw, by the task's `draw` clauses (missing goal values
/// read 0, as [`Declared::new`] runs them).
pub fn drawings(def: &TaskDef, goal: &[f64]) -> Vec<Drawn> {
    let mut env = vec![0.0; def.slots()];
    let g = def.goal_slot();
    for (slot, v) in env[g..g + def.goal.len()].iter_mut().zip(goal) {
        *slot = *v;
    }
    def.draw
        .iter()
        .map(|d| Drawn {
            name: d.name.clone(),
            shape: d.shape,
            values: d.args.iter().map(|ir| ir.eval_task(&env, &env)).collect(),
        })
        .collect()
}

/// A teacher written in the language: a stateless policy of the observations.
#[derive(Clone, Debug)]
pub struct DeclaredTeacher {
    def: Arc<TaskDef>,
}

impl DeclaredTeacher {
    /// The teacher of `def`, when it declares one.
    pub fn new(def: Arc<TaskDef>) -> Option<DeclaredTeacher> {
        def.teacher.as_ref()?;
        Some(DeclaredTeacher { def })
    }
}

impl Policy for DeclaredTeacher {
    fn act(&self, z: &[f64], a: &mut [f64]) {
        let Some(t) = &self.def.teacher else { return };
        let mut env = vec![0.0; t.slots];
        for (v, x) in env.iter_mut().zip(z) {
            *v = *x;
        }
        for (target, ir) in &t.stmts {
            let v = ir.eval_task(&env, &env);
            match *target {
                TeacherTarget::Local(s) => env[s] = v,
                TeacherTarget::Action(i) => {
                    if let Some(x) = a.get_mut(i) {
                        *x = v;
                    }
                }
            }
        }
    }
}

impl Controller for DeclaredTeacher {
    fn act(&mut self, z: &[f64], a: &mut [f64]) {
        Policy::act(self, z, a)
    }
}
