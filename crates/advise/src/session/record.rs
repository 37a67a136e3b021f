//! `record demo`: a person drives the ROS 2 base with their own teleoperation and the session
//! keeps it as a demonstration ([`crate::backend::ros2::record`] listens; the samples become a
//! positioning demonstration as a CSV log's do, [`crate::recording::episode`]). Journalled as
//! demonstrations, so a resume needs neither the base nor the person.

use super::effect::{DemoEpisode, Effect};
use super::text::short_num;
use super::{Session, SessionError};

#[cfg(feature = "ros2")]
use crate::backend::ros2::Ros2Backend;
#[cfg(feature = "ros2")]
use crate::backend::ros2::record::{Ended, RecordOptions, record_teleop};
#[cfg(feature = "ros2")]
use crate::backend::teleop::Key;
use crate::backend::teleop::{DriveEnd, KEYS_HELP, Teleop, console, drive};
use crate::geometry::Pose;
use crate::task::TaskKind;
use crate::task::episode_seed;

/// The longest recording `for` accepts, and the default, in seconds.
pub const MAX_RECORD_S: f64 = 3600.0;
pub const DEFAULT_RECORD_S: f64 = 600.0;
/// No command for this long with the base at rest ends a recording.
#[cfg(feature = "ros2")]
pub const RECORD_IDLE_S: f64 = 3.0;

impl Session {
    /// `record demo` in a build without ROS 2: the base it listens on cannot be connected.
    #[cfg(not(feature = "ros2"))]
    pub(super) fn record_demo(
        &mut self,
        _topic: Option<&str>,
        goal: Option<[f64; 3]>,
        _seconds: Option<f64>,
        _keep_idle: bool,
    ) -> Result<String, SessionError> {
        self.check_recordable(goal.is_some())?;
        Err(SessionError::RecordNeedsRos2 {
            backend: self.backend_name(),
        })
    }

    #[cfg(feature = "ros2")]
    pub(super) fn record_demo(
        &mut self,
        topic: Option<&str>,
        goal: Option<[f64; 3]>,
        seconds: Option<f64>,
        keep_idle: bool,
    ) -> Result<String, SessionError> {
        self.check_recordable(goal.is_some())?;
        let Some(backend) = self.backend.downcast_ref::<Ros2Backend>() else {
            return Err(SessionError::RecordNeedsRos2 {
                backend: self.backend_name(),
            });
        };
        let (max_s, goal) = checked_limits(goal, seconds)?;
        let spec = backend.spec().clone();
        let opts = RecordOptions {
            teleop_topic: topic.unwrap_or("cmd_vel").to_string(),
            period_s: self.sim_params().period_s(),
            max_s,
            idle_s: RECORD_IDLE_S,
        };
        self.stop.clear();
        // At a terminal, Enter (or Ctrl-C, a key in raw mode) ends the recording; in a script the
        // time limit, the idle rule or the stop signal do.
        let mut terminal = console().and_then(|console| {
            console.show(format_args!(
                "recording {}: drive with your teleoperation; Enter ends\r\n",
                spec.resolve(&opts.teleop_topic)
            ));
            console.keys().ok()
        });
        let mut person_ended = || {
            terminal.as_mut().is_some_and(|t| {
                t.keys(std::time::Duration::ZERO)
                    .is_ok_and(|keys| keys.iter().any(|k| matches!(k, Key::End | Key::Interrupt)))
            })
        };
        let rec = record_teleop(&spec, &opts, &self.stop, &mut person_ended);
        drop(terminal);
        let rec = rec.map_err(|error| SessionError::RecordFailed { error })?;
        self.stop.clear();
        if rec.samples.len() < 2 {
            return Err(SessionError::RecordEmpty {
                topic: rec.teleop_topic,
                heard: rec.commands_heard,
                ty: rec.command_type.map_or_else(
                    || "no Twist or TwistStamped publisher".into(),
                    |t| format!("a {t} publisher"),
                ),
                seen: rec.seen,
            });
        }
        let mut idle = (0, 0);
        let samples = crate::recording::trimmed(&rec.samples, keep_idle, &mut idle);
        let (name, points) = self.add_driven_demo(
            samples,
            goal,
            format!("record demo from {}", rec.teleop_topic),
        )?;
        let secs = samples.last().map_or(0.0, |s| s.0) - samples.first().map_or(0.0, |s| s.0);
        let trimmed = crate::recording::describe_trim(idle, "`--keep-idle`")
            .map(|t| format!("; {t}"))
            .unwrap_or_default();
        let ended = match rec.ended {
            Ended::Stopped => "ended by you",
            Ended::Idle => "the commands stopped and the base came to rest",
            Ended::TimeLimit => "the time limit",
            Ended::LinkLost => "odometry went stale; what came before is kept",
        };
        Ok(format!(
            "recorded demonstration `{name}` from {} ({}) and {}: {points} points over {secs:.1} s ({ended}{trimmed}); the {} policy now has {} points",
            rec.teleop_topic,
            rec.command_type.unwrap_or("?"),
            rec.odom_topic,
            self.state.learner.kind_name(),
            self.state.learner.len(),
        ))
    }

    /// `teleop`: drive the base from this terminal's keys and keep the drive as a demonstration.
    pub(super) fn teleop(
        &mut self,
        goal: Option<[f64; 3]>,
        seconds: Option<f64>,
    ) -> Result<String, SessionError> {
        self.check_recordable(goal.is_some())?;
        let (max_s, goal) = checked_limits(goal, seconds)?;
        let Some(console) = console() else {
            return Err(SessionError::TeleopNeedsTerminal);
        };
        let params = self.sim_params();
        let mut teleop = Teleop::new(params.max_speed_mps, params.max_rot_radps);
        let mut keys = console
            .keys()
            .map_err(|error| SessionError::RecordFailed { error })?;
        to_terminal(format_args!(
            "teleop on {}: {KEYS_HELP}\r\n",
            self.backend_name()
        ));
        let mut show = |t: &Teleop| {
            to_terminal(format_args!(
                "\r  speed {:+.2} m/s, turn {:+.2} rad/s (steps of {:.0}%)      ",
                t.speed_mps,
                t.rot_radps,
                t.step_fraction * 100.0
            ));
        };
        self.stop.clear();
        let seed = episode_seed(self.seed, 2_000_000 + self.state.runs);
        // The simulator starts afresh and is paced here; a robot paces itself.
        self.backend.begin(seed);
        let real_time = self.backend.is_simulator();
        let drive = drive(
            self.backend.as_mut(),
            keys.as_mut(),
            &mut teleop,
            &self.stop,
            max_s,
            real_time,
            &mut show,
        );
        drop(keys);
        to_terminal(format_args!("\n"));
        self.stop.clear();
        let drive = drive.map_err(|error| SessionError::RecordFailed { error })?;
        // The demonstration starts at the first key that moved the base, as `record demo`'s.
        let Some(first) = drive.samples.iter().position(|s| s.2 != 0.0 || s.3 != 0.0) else {
            return Err(SessionError::TeleopEmpty);
        };
        let samples = &drive.samples[first..];
        let (name, points) = self.add_driven_demo(samples, goal, "teleop".into())?;
        let secs = samples.last().map_or(0.0, |s| s.0) - samples[0].0;
        let ended = match drive.end {
            DriveEnd::Ended => "ended by you",
            DriveEnd::Stopped => "stopped by Ctrl-C",
            DriveEnd::TimeLimit => "the time limit",
        };
        Ok(format!(
            "recorded demonstration `{name}` driven from the terminal: {points} points over {secs:.1} s ({ended}); the {} policy now has {} points",
            self.state.learner.kind_name(),
            self.state.learner.len(),
        ))
    }

    /// Whether a drive of the base makes a demonstration of the current task: its goal is read
    /// from where the drive ends (positioning, a declared task's `recorded`) and its actions are
    /// the commanded speeds; a goal given on the command line is a positioning goal pose.
    fn check_recordable(&self, goal_given: bool) -> Result<(), SessionError> {
        let ok = match self.task.def() {
            Some(d) => {
                d.recorded.is_some()
                    && [&d.speed, &d.turn]
                        .iter()
                        .all(|x| x.as_ref().is_none_or(|x| x.integrate.is_none()))
                    && (!goal_given || self.task == TaskKind::Positioning)
            }
            None => false,
        };
        if ok {
            Ok(())
        } else {
            Err(SessionError::RecordTask {
                task: self.task.clone(),
            })
        }
    }

    /// A driven recording as the next demonstration (`teleop N`), journalled; its name and size.
    fn add_driven_demo(
        &mut self,
        samples: &[(f64, Pose, f64, f64)],
        goal: Option<Pose>,
        source: String,
    ) -> Result<(String, usize), SessionError> {
        let number = self.state.learner.dataset().demos().len();
        let name = format!("teleop {number}");
        let options = match self.task.def() {
            Some(def) if self.task != TaskKind::Positioning => crate::recording::ImportOptions {
                task: Some(def),
                ..Default::default()
            },
            _ => crate::recording::ImportOptions {
                goal,
                ..Default::default()
            },
        };
        // The rule every path into a dataset holds: what `load demos` would refuse is refused
        // here too, naming the time.
        let episode =
            options.checked_episode(std::path::Path::new(&source), name, samples, &|t: f64| {
                format!("{t:.2} s into the recording")
            })?;
        let points = episode.trace.len();
        let name = episode.name.clone();
        self.commit(Effect::Demos {
            source,
            episodes: vec![DemoEpisode {
                name: episode.name,
                trace: episode.trace.to_json(),
            }],
        })?;
        Ok((name, points))
    }
}

/// The time limit (default [`DEFAULT_RECORD_S`]) and the goal of a recorded demonstration,
/// checked.
fn checked_limits(
    goal: Option<[f64; 3]>,
    seconds: Option<f64>,
) -> Result<(f64, Option<Pose>), SessionError> {
    let max_s = seconds.unwrap_or(DEFAULT_RECORD_S);
    if !(max_s.is_finite() && max_s > 0.0 && max_s <= MAX_RECORD_S) {
        return Err(SessionError::RecordTime {
            seconds: short_num(max_s),
        });
    }
    let goal = match goal {
        Some([x, y, theta]) => {
            super::run::check_goal(x, y, theta)?;
            Some(Pose::new(x, y, theta))
        }
        None => None,
    };
    Ok((max_s, goal))
}

/// What the teacher reads while driving, on the front end's console (none: dropped).
fn to_terminal(args: std::fmt::Arguments<'_>) {
    if let Some(console) = console() {
        console.show(args);
    }
}
