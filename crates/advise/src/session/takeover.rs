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
use super::undo::{Edit, Taken};
use super::{Session, SessionError};
use crate::backend::teleop::{Commands, KEYS_HELP_RUN, KeyCommands, console};
use crate::policy::dataset::TakeoverLink;
use crate::syntax::command::TakeoverSeconds;
use crate::task::TaskKind;
use crate::task::takeover::{Never, Person, Takeover, Window, window_trace};
use crate::trace::{Chunk, Trace};

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

/// Makes the live takeover of each run (a web page's pad, a Python caller's commands): what a
/// front end installs with [`Session::set_live_takeover`]. It is asked once per run; `None`
/// leaves the learner driving (but for the terminal's keys and the base's own takeover topic).
pub trait LiveTakeover: Send {
    fn for_run(&mut self, run: &RunInfo) -> Option<Box<dyn Commands>>;
}

/// A person's command held from another thread (a web page's pad, a Python caller): while it
/// is refreshed within its timeout a robot's run is theirs; released, or not refreshed (a closed
/// tab, a stopped script), the learner drives again. Cheap to clone; install one clone on the
/// session ([`Session::set_live_takeover`]) and hold with another, which needs no lock of the
/// session's (a run holds it for as long as it drives).
#[derive(Clone)]
pub struct Hold {
    held: std::sync::Arc<std::sync::Mutex<Option<(f64, f64, std::time::Instant)>>>,
    timeout: std::time::Duration,
}

impl Hold {
    /// A hold that hands back after `timeout` without a refresh.
    pub fn new(timeout: std::time::Duration) -> Hold {
        Hold {
            held: Default::default(),
            timeout,
        }
    }

    fn slot(&self) -> std::sync::MutexGuard<'_, Option<(f64, f64, std::time::Instant)>> {
        self.held.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Hold `speed` and `turn`, each a fraction of the base's limit from -1 to 1 (refused
    /// otherwise, with what was wrong).
    pub fn hold(&self, speed: f64, turn: f64) -> Result<(), String> {
        let fraction = |v: f64| v.is_finite() && (-1.0..=1.0).contains(&v);
        if !(fraction(speed) && fraction(turn)) {
            return Err(format!(
                "speed and turn are fractions of the base's limits, from -1 to 1 (got {speed} and {turn})"
            ));
        }
        *self.slot() = Some((speed, turn, std::time::Instant::now()));
        Ok(())
    }

    /// Let go: the learner drives from the next step.
    pub fn release(&self) {
        *self.slot() = None;
    }

    /// The fractions held now, if held and refreshed within the timeout.
    pub fn now(&self) -> Option<(f64, f64)> {
        let mut slot = self.slot();
        match *slot {
            Some((s, t, at)) if at.elapsed() <= self.timeout => Some((s, t)),
            _ => {
                *slot = None;
                None
            }
        }
    }
}

impl LiveTakeover for Hold {
    fn for_run(&mut self, run: &RunInfo) -> Option<Box<dyn Commands>> {
        // A hold from before the run does not take it over at its first step.
        self.release();
        Some(Box::new(HeldCommands {
            hold: self.clone(),
            max: (run.max_speed_mps, run.max_rot_radps),
        }))
    }
}

struct HeldCommands {
    hold: Hold,
    max: (f64, f64),
}

impl Commands for HeldCommands {
    fn command(&mut self, _now: (f64, f64)) -> Option<(f64, f64)> {
        self.hold
            .now()
            .map(|(s, t)| (s * self.max.0.abs(), t * self.max.1.abs()))
    }
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

/// Several live takeovers, each asked per run (a web page's pad and a Python caller's hold may
/// both be installed).
pub struct Both(pub Box<dyn LiveTakeover>, pub Box<dyn LiveTakeover>);

impl LiveTakeover for Both {
    fn for_run(&mut self, run: &RunInfo) -> Option<Box<dyn Commands>> {
        let all: Vec<Box<dyn Commands>> = [self.0.for_run(run), self.1.for_run(run)]
            .into_iter()
            .flatten()
            .collect();
        (!all.is_empty()).then(|| Box::new(Either(all)) as Box<dyn Commands>)
    }
}

/// Several people's commands, the first who drives a step driving it (a terminal's keys and a
/// ROS 2 topic may both be live in one run).
struct Either(Vec<Box<dyn Commands>>);

impl Commands for Either {
    fn command(&mut self, now: (f64, f64)) -> Option<(f64, f64)> {
        // Every source is asked each step (a key source drains its keys), the first answer kept.
        let mut out = None;
        for c in &mut self.0 {
            let got = c.command(now);
            out = out.or(got);
        }
        out
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
        let Some(axes) = speed_axes(&self.task) else {
            // The actions are not speed commands (interception's are changes of speed): a
            // person's commands cannot be given to this task's runs.
            return Ok(Box::new(Never));
        };
        let info = RunInfo {
            task: self.task.clone(),
            max_speed_mps: self.sim.max_speed_mps,
            max_rot_radps: self.sim.max_rot_radps,
            period_s,
        };
        let mut sources: Vec<Box<dyn Commands>> = Vec::new();
        if let Some(c) = self.live_takeover.as_mut().and_then(|l| l.for_run(&info)) {
            sources.push(c);
        }
        if let Some(c) = self.backend.takeover_commands() {
            sources.push(c);
        }
        // A person at the terminal can take over a robot's run (the simulator's runs are over
        // before a key could be pressed, and its runs stay free of the terminal's raw mode).
        if !self.backend.is_simulator()
            && let Some(console) = console()
            && let Ok(keys) = console.keys()
        {
            console.show(format_args!("{KEYS_HELP_RUN}\r\n"));
            sources.push(Box::new(KeyCommands::new(
                keys,
                info.max_speed_mps,
                info.max_rot_radps,
                self.stop.clone(),
                Some(console),
            )));
        }
        if sources.is_empty() {
            return Ok(Box::new(Never));
        }
        Ok(Box::new(Person {
            commands: Box::new(Either(sources)),
            axes,
            max: (info.max_speed_mps, info.max_rot_radps),
        }))
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
            let trace = window_trace(&self.numbered(execution)?.trace, steps, every);
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

    /// Apply a journalled [`Effect::Takeover`]: its points, as a live takeover adds them.
    pub(super) fn apply_takeover(
        &mut self,
        execution: usize,
        steps: Chunk,
        every: u32,
        name: &str,
        points: &crate::trace::JsonTrace,
    ) -> Result<(), SessionError> {
        let trace = Trace::from_json(&self.domain, points)?;
        let number = self.state.take_number();
        self.add_takeover(
            Taken {
                execution,
                steps,
                every,
                name: name.to_string(),
                trace,
            },
            number,
        )?;
        self.state.redo.clear();
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

/// The indices of the actions that are a task's speed and turn commands, when both are commands
/// as given (positioning's, a declared task's without `integrate`): what a person's commands
/// take over.
pub(crate) fn speed_axes(task: &TaskKind) -> Option<(usize, usize)> {
    let def = task.def()?;
    match (&def.speed, &def.turn) {
        (Some(s), Some(t)) if s.integrate.is_none() && t.integrate.is_none() => {
            Some((s.action, t.action))
        }
        _ => None,
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
