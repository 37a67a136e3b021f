//! The teacher takes over a run: who may drive (`run ... takeover A..B`: the task's own teacher
//! in a window; live: a person, through the hook a front end installs), and what is kept of it.
//!
//! The run records every step with who drove it (the execution's teacher windows); each window
//! the teacher drove joins the dataset as a demonstration linked to the execution
//! ([`crate::policy::dataset::TakeoverLink`]), committed as an [`Effect::Takeover`] of its
//! points, so `why` names it, `history` lists it, `undo` takes it back and a resume restores it
//! without driving anything.

use super::effect::Effect;
use super::text::short_num;
use super::undo::Edit;
use super::{Session, SessionError};
use crate::policy::dataset::TakeoverLink;
use crate::syntax::command::TakeoverSeconds;
use crate::task::takeover::{Moment, Never, Takeover, Window};
use crate::task::{TaskKind, recorded_at};
use crate::trace::{Chunk, Trace};

/// A takeover's demonstration: the points the teacher drove, and where in which execution.
#[derive(Clone, Debug)]
pub(crate) struct Taken {
    pub execution: usize,
    pub steps: Chunk,
    pub every: u32,
    pub name: String,
    pub trace: Trace,
}

/// What a run's reply says of one takeover window.
#[derive(Clone, Debug, PartialEq)]
pub struct TookOver {
    pub steps: Chunk,
    /// Control time at the window's start and end, s.
    pub from_s: f64,
    pub to_s: f64,
    /// The demonstration's points, and its number in `history`.
    pub points: usize,
    pub number: usize,
}

/// Makes the live takeover of each run (a person at the terminal, the web view's pad, a ROS 2
/// topic): what a front end installs with [`Session::set_live_takeover`]. It is asked once per
/// run, with the task and the base's limits; `None` leaves the learner driving.
pub trait LiveTakeover: Send {
    fn for_run(&mut self, run: &RunInfo) -> Option<Box<dyn Takeover>>;
}

/// What a live takeover knows of the run it is made for.
#[derive(Clone, Debug)]
pub struct RunInfo {
    pub task: TaskKind,
    /// The base's speed limits: a person's commands are clamped to these.
    pub max_speed_mps: f64,
    pub max_rot_radps: f64,
    pub period_s: f64,
}

/// Any number of takeovers, the first that drives a step driving it: a person's keys and a ROS
/// 2 topic may both be live in one run.
pub struct Either(pub Vec<Box<dyn Takeover>>);

impl Takeover for Either {
    fn drive(&mut self, at: &Moment<'_>, a: &mut [f64]) -> bool {
        self.0.iter_mut().any(|t| t.drive(at, a))
    }
}

impl Session {
    /// Install the live takeover a front end offers for every run from now on (`None`: runs are
    /// the learner's, but for a `takeover A..B` window).
    pub fn set_live_takeover(&mut self, live: Option<Box<dyn LiveTakeover>>) {
        self.live_takeover = live;
    }

    /// Who may drive the next run: the task's teacher in the window `window` (checked first),
    /// else the live takeover the front end installed, else nobody but the learner.
    pub(super) fn takeover_for(
        &mut self,
        window: Option<TakeoverSeconds>,
        seed: u64,
    ) -> Result<Box<dyn Takeover>, SessionError> {
        let period_s = self.backend.period_s();
        if let Some(w) = window {
            let max_s = crate::program::task::MAX_TIME_LIMIT_S;
            if !(w.from_s.is_finite() && w.to_s.is_finite() && w.from_s < w.to_s && w.to_s <= max_s)
            {
                return Err(SessionError::BadTakeover {
                    window: w.to_string(),
                    max_s: short_num(max_s),
                });
            }
            if !self.task.has_teacher() {
                return Err(SessionError::TakeoverNoTeacher {
                    task: self.task.clone(),
                });
            }
            let teacher = self.task.teacher(period_s);
            return Ok(Box::new(Window::new(
                w.from_s, w.to_s, period_s, teacher, seed,
            )));
        }
        let info = RunInfo {
            task: self.task.clone(),
            max_speed_mps: self.sim.max_speed_mps,
            max_rot_radps: self.sim.max_rot_radps,
            period_s,
        };
        Ok(self
            .live_takeover
            .as_mut()
            .and_then(|l| l.for_run(&info))
            .unwrap_or_else(|| Box::new(Never)))
    }

    /// Keep each window the teacher drove of execution `execution` as a demonstration linked to
    /// it, at the task's demonstration rate: one effect (and one `history` entry) per window.
    pub(super) fn keep_takeovers(
        &mut self,
        execution: usize,
        windows: &[Chunk],
    ) -> Result<Vec<TookOver>, SessionError> {
        let every = self.task.record_every().max(1);
        let period_s = self.backend.period_s();
        let mut out = Vec::new();
        for &steps in windows {
            let trace = {
                let held = self.numbered(execution)?;
                let mut part = Trace::with_dims(
                    &held.trace.domain,
                    held.trace.obs_dim(),
                    held.trace.act_dim(),
                );
                for k in steps.range() {
                    let pose = held.trace.pose.as_ref().and_then(|p| p.get(k).copied());
                    part.push(held.trace.t[k], held.trace.z(k), held.trace.a(k), pose);
                }
                recorded_at(&part, every)
            };
            let name = format!("takeover of execution {execution}, steps {steps}");
            let points = trace.len();
            self.commit(Effect::Takeover {
                execution,
                steps,
                every: every as u32,
                name,
                points: trace.to_json(),
            })?;
            out.push(TookOver {
                steps,
                from_s: steps.start as f64 * period_s,
                to_s: steps.end as f64 * period_s,
                points,
                number: self.state.next_edit - 1,
            });
        }
        Ok(out)
    }

    /// Add a takeover's demonstration, numbered `number` in `history` (a new one, a redo, a
    /// restored one alike).
    pub(super) fn add_takeover(&mut self, taken: Taken, number: usize) -> Result<(), SessionError> {
        let held = self.numbered(taken.execution)?;
        let link = TakeoverLink {
            execution: held.id,
            steps: taken.steps,
            every: taken.every,
        };
        let id = self
            .state
            .learner
            .add_takeover(&taken.name, &taken.trace, link)?;
        self.state.undo.push(Edit::Takeover {
            number,
            id,
            taken: Box::new(taken),
        });
        Ok(())
    }

    /// What `why` calls a takeover's demonstration: `takeover #N`, as `history` numbers it.
    pub(super) fn takeover_name(&self, id: crate::policy::learner::DemoId) -> String {
        self.state
            .undo
            .iter()
            .find_map(|e| match e {
                Edit::Takeover { number, id: d, .. } if *d == id => {
                    Some(format!("takeover #{number}"))
                }
                _ => None,
            })
            .unwrap_or_else(|| format!("takeover (dataset id {id})"))
    }
}

/// A journalled execution's teacher windows: in order, apart, each within its `len` steps.
pub(super) fn check_windows(windows: &[Chunk], len: usize) -> Result<(), SessionError> {
    let mut after = 0;
    for w in windows {
        // Overlapping or out of order: reported as the reversed stretch between them.
        Chunk::new(after, w.start, len)?;
        Chunk::new(w.start, w.end, len)?;
        after = w.end;
    }
    Ok(())
}
