//! Driving a base from the keyboard: a person's demonstration on any backend (the simulator, an
//! RMP, a ROS 2 base).
//!
//! [`Teleop`] is the state machine, with no terminal in it: keys in, a held command out. Up/`w`
//! and down/`s` step the speed, left/`a` and right/`d` step the turn rate, space stops, `+`/`-`
//! scale the steps, Enter or `q` ends. Every command is clamped to the base's limits before it is
//! sent, and the base's own safety rules (its watchdog, zero at the end) still hold. [`drive`]
//! runs it on a [`Backend`] at the base's rate with keys from a [`KeySource`]: a person's, from the
//! [`Console`] a front end installs (the command line's terminal), or a script (tests).
//! A key that is not repeated leaves the command held, as a base holds its last `cmd_vel`;
//! space or Ctrl-C brings it to zero.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use super::{Backend, BackendError, StopSignal};
use crate::geometry::Pose;

/// A key that means something to [`Teleop`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Faster,
    Slower,
    Left,
    Right,
    Stop,
    ScaleUp,
    ScaleDown,
    End,
    /// Tab: take over a run, or hand it back (nothing in `teleop`).
    Toggle,
    /// Ctrl-C in raw mode: stop (ends a drive as `End` does; stops a run).
    Interrupt,
}

impl Key {
    /// The key a character stands for (`w`, `a`, `s`, `d`, space, `+`, `-`, `q`), if any.
    pub fn from_char(c: char) -> Option<Key> {
        Some(match c.to_ascii_lowercase() {
            'w' => Key::Faster,
            's' => Key::Slower,
            'a' => Key::Left,
            'd' => Key::Right,
            ' ' => Key::Stop,
            '+' | '=' => Key::ScaleUp,
            '-' | '_' => Key::ScaleDown,
            'q' | '\n' | '\r' => Key::End,
            _ => return None,
        })
    }
}

/// The keys' meaning, for the prompt.
pub const KEYS_HELP: &str = "up/w faster, down/s slower, left/a and right/d turn, space stops, +/- scale the steps, Enter or q ends";

/// The teleoperation state: the command held and the step size.
#[derive(Clone, Debug, PartialEq)]
pub struct Teleop {
    pub max_speed_mps: f64,
    pub max_rot_radps: f64,
    /// A step is this fraction of the limit (scaled by `+`/`-` between 0.05 and 0.5).
    pub step_fraction: f64,
    pub speed_mps: f64,
    pub rot_radps: f64,
    pub ended: bool,
}

impl Teleop {
    pub fn new(max_speed_mps: f64, max_rot_radps: f64) -> Teleop {
        Teleop {
            max_speed_mps: max_speed_mps.abs(),
            max_rot_radps: max_rot_radps.abs(),
            step_fraction: 0.1,
            speed_mps: 0.0,
            rot_radps: 0.0,
            ended: false,
        }
    }

    /// Take one key; the command stays within the limits.
    pub fn key(&mut self, key: Key) {
        let (dv, dw) = (
            self.step_fraction * self.max_speed_mps,
            self.step_fraction * self.max_rot_radps,
        );
        match key {
            Key::Faster => self.speed_mps += dv,
            Key::Slower => self.speed_mps -= dv,
            Key::Left => self.rot_radps += dw,
            Key::Right => self.rot_radps -= dw,
            Key::Stop => (self.speed_mps, self.rot_radps) = (0.0, 0.0),
            Key::ScaleUp => self.step_fraction = (self.step_fraction * 2.0).min(0.5),
            Key::ScaleDown => self.step_fraction = (self.step_fraction / 2.0).max(0.05),
            Key::End | Key::Interrupt => {
                self.ended = true;
                (self.speed_mps, self.rot_radps) = (0.0, 0.0);
            }
            Key::Toggle => {}
        }
        // Round away the sum's float noise (0.1 + 0.2 ...) so a command reads as typed.
        let tidy = |v: f64, max: f64| ((v * 1e9).round() / 1e9).clamp(-max, max);
        self.speed_mps = tidy(self.speed_mps, self.max_speed_mps);
        self.rot_radps = tidy(self.rot_radps, self.max_rot_radps);
    }
}

/// Where keys come from.
pub trait KeySource {
    /// The keys pressed since the last call, waiting at most `wait` for the first.
    fn keys(&mut self, wait: Duration) -> Result<Vec<Key>, BackendError>;
}

/// Keys at given control steps (for tests and scripted demonstrations): `(step, key)`.
pub struct ScriptedKeys {
    script: Vec<(usize, Key)>,
    step: usize,
}

impl ScriptedKeys {
    pub fn new(mut script: Vec<(usize, Key)>) -> ScriptedKeys {
        script.sort_by_key(|(s, _)| *s);
        ScriptedKeys { script, step: 0 }
    }
}

impl KeySource for ScriptedKeys {
    fn keys(&mut self, _wait: Duration) -> Result<Vec<Key>, BackendError> {
        let now = self.step;
        self.step += 1;
        let keys = self
            .script
            .iter()
            .filter(|(s, _)| *s == now)
            .map(|(_, k)| *k)
            .collect();
        Ok(keys)
    }
}

/// The person at the controls, as a front end gives them to a drive: their keys and a place to
/// show them the drive's state. The command line installs its terminal ([`install_console`]:
/// raw-mode keys, lines on standard error); a front end without one (Python, a script) has
/// none, and `teleop` then says it needs a terminal.
pub trait Console: Send + Sync {
    /// Whether a person is there to drive (the command line: standard input is a terminal).
    fn present(&self) -> bool;
    /// The person's keys, for as long as the source lives (a terminal in raw mode, restored when
    /// it is dropped, on error and on a panic's unwinding alike).
    fn keys(&self) -> Result<Box<dyn KeySource>, BackendError>;
    /// Show the person `text` (a drive's state); text that cannot be shown is dropped.
    fn show(&self, text: std::fmt::Arguments<'_>);
}

static CONSOLE: OnceLock<Box<dyn Console>> = OnceLock::new();

/// Install the front end's console; the first one installed stays (returns whether this was it).
pub fn install_console(console: Box<dyn Console>) -> bool {
    CONSOLE.set(console).is_ok()
}

/// The console, when a front end installed one and a person is there.
pub fn console() -> Option<&'static dyn Console> {
    CONSOLE.get().map(|c| c.as_ref()).filter(|c| c.present())
}

/// A person's speed commands as they arrive during a run (a terminal's keys, a ROS 2 teleop
/// topic, a web page's pad): what a live takeover drives with. Asked once per control step.
pub trait Commands {
    /// The command `(m/s, rad/s)` the person holds now, or `None` while they are not driving.
    /// `now` is the command the base was given at the last step (where a person who takes over
    /// starts from, so the command does not jump).
    fn command(&mut self, now: (f64, f64)) -> Option<(f64, f64)>;
}

/// The keys during a run: Tab takes over holding the command the base was given, and space
/// takes over and stops; while taken over the keys of `teleop` drive, and Tab, Enter or `q` hand
/// back. Ctrl-C (a key in raw mode) raises `stop`, which ends the run and stops the base. Keys
/// before a takeover mean nothing else, so typing ahead does not drive the robot.
pub struct KeyCommands {
    keys: Box<dyn KeySource>,
    teleop: Teleop,
    active: bool,
    stop: StopSignal,
    /// Where the person reads what their keys did.
    console: Option<&'static dyn Console>,
}

impl KeyCommands {
    pub fn new(
        keys: Box<dyn KeySource>,
        max_speed_mps: f64,
        max_rot_radps: f64,
        stop: StopSignal,
        console: Option<&'static dyn Console>,
    ) -> KeyCommands {
        KeyCommands {
            keys,
            teleop: Teleop::new(max_speed_mps, max_rot_radps),
            active: false,
            stop,
            console,
        }
    }

    fn show(&self, text: std::fmt::Arguments<'_>) {
        if let Some(c) = self.console {
            c.show(text);
        }
    }

    fn take_over(&mut self, now: (f64, f64)) {
        self.active = true;
        self.teleop.ended = false;
        let (v, w) = now;
        let finite = |x: f64, max: f64| {
            if x.is_finite() {
                x.clamp(-max, max)
            } else {
                0.0
            }
        };
        self.teleop.speed_mps = finite(v, self.teleop.max_speed_mps);
        self.teleop.rot_radps = finite(w, self.teleop.max_rot_radps);
        self.show(format_args!("\r\nyou drive: {KEYS_HELP_RUN}\r\n"));
    }
}

/// The keys' meaning during a run, for the prompt.
pub const KEYS_HELP_RUN: &str = "Tab takes over (space: takes over and stops), then up/w down/s left/a right/d drive, space stops, +/- scale; Tab, Enter or q hands back; Ctrl-C stops the run";

impl Commands for KeyCommands {
    fn command(&mut self, now: (f64, f64)) -> Option<(f64, f64)> {
        let keys = match self.keys.keys(Duration::ZERO) {
            Ok(k) => k,
            Err(_) => {
                // The person's terminal is gone: nobody can take over or stop from it.
                self.active = false;
                Vec::new()
            }
        };
        for k in keys {
            match k {
                Key::Interrupt => {
                    self.active = false;
                    self.stop.raise();
                    self.show(format_args!(
                        "\r\n^C: stopping the base (zero commanded)\r\n"
                    ));
                }
                Key::Toggle | Key::End if self.active => {
                    self.active = false;
                    self.show(format_args!("\r\nhanded back to the learner\r\n"));
                }
                Key::Toggle => self.take_over(now),
                Key::Stop if !self.active => {
                    self.take_over(now);
                    self.teleop.key(Key::Stop);
                }
                k if self.active && k != Key::End => self.teleop.key(k),
                _ => {}
            }
        }
        self.active
            .then_some((self.teleop.speed_mps, self.teleop.rot_radps))
    }
}

/// Why a drive ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveEnd {
    /// Enter or `q` (or Ctrl-C at the terminal).
    Ended,
    /// The stop signal (Ctrl-C from the session's handler).
    Stopped,
    /// The time limit.
    TimeLimit,
}

/// A drive: per control step `(t, odometry pose, command sent)`, and how it ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    pub samples: Vec<(f64, Pose, f64, f64)>,
    pub end: DriveEnd,
}

/// Drive `base` from `keys` at its rate from where it stands (re-zeroed there) until the person
/// ends it, `stop` is raised, or `max_s` passes; the base is stopped at the end whatever
/// happens. With `real_time`, a step of the simulator (which does not wait) is paced to the
/// control period; a real base paces itself. `on_command` sees each new command (a prompt line).
pub fn drive(
    base: &mut dyn Backend,
    keys: &mut dyn KeySource,
    teleop: &mut Teleop,
    stop: &StopSignal,
    max_s: f64,
    real_time: bool,
    on_command: &mut dyn FnMut(&Teleop),
) -> Result<Drive, BackendError> {
    let period_s = base.period_s().max(1e-3);
    let steps = ((max_s / period_s).ceil() as usize).max(1);
    let mut run = |base: &mut dyn Backend| -> Result<Drive, BackendError> {
        let mut state = base.reset(Pose::new(0.0, 0.0, 0.0))?;
        let mut samples = Vec::new();
        let mut next = Instant::now();
        for _ in 0..steps {
            let before = (teleop.speed_mps, teleop.rot_radps);
            for k in keys.keys(Duration::ZERO)? {
                teleop.key(k);
            }
            if (teleop.speed_mps, teleop.rot_radps) != before {
                on_command(teleop);
            }
            let end = if teleop.ended {
                Some(DriveEnd::Ended)
            } else {
                stop.is_raised().then_some(DriveEnd::Stopped)
            };
            if let Some(end) = end {
                return Ok(Drive { samples, end });
            }
            let (v, w) = (teleop.speed_mps, teleop.rot_radps);
            samples.push((state.t_s, state.pose, v, w));
            base.command(v, w)?;
            state = base.step()?;
            if real_time {
                super::wait_for_tick(&mut next, period_s);
            }
        }
        Ok(Drive {
            samples,
            end: DriveEnd::TimeLimit,
        })
    };
    let result = run(base);
    let stopped = base.stop();
    let drive = result?;
    stopped?;
    Ok(drive)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::sim::{SimBackend, SimParams};

    #[test]
    fn keys_step_scale_and_stop_within_the_limits() {
        let mut t = Teleop::new(1.0, 2.0);
        t.key(Key::Faster);
        t.key(Key::Faster);
        assert_eq!((t.speed_mps, t.rot_radps), (0.2, 0.0));
        t.key(Key::Left);
        assert_eq!(t.rot_radps, 0.2);
        t.key(Key::ScaleUp);
        t.key(Key::Right);
        assert_eq!(t.rot_radps, -0.2);
        for _ in 0..20 {
            t.key(Key::Faster);
        }
        assert_eq!(t.speed_mps, 1.0, "clamped to the limit");
        for _ in 0..5 {
            t.key(Key::ScaleUp);
        }
        assert_eq!(t.step_fraction, 0.5);
        t.key(Key::Stop);
        assert_eq!((t.speed_mps, t.rot_radps), (0.0, 0.0));
        t.key(Key::Slower);
        assert_eq!(t.speed_mps, -0.5);
        t.key(Key::End);
        assert!(t.ended);
        assert_eq!((t.speed_mps, t.rot_radps), (0.0, 0.0));
        assert_eq!(Key::from_char('W'), Some(Key::Faster));
        assert_eq!(Key::from_char('x'), None);
    }

    #[test]
    fn a_scripted_drive_on_the_simulator_records_the_held_commands() {
        let mut base = SimBackend::new(SimParams::default(), 1);
        let mut keys = ScriptedKeys::new(vec![
            (0, Key::Faster),
            (0, Key::Faster),
            (0, Key::Faster),
            (30, Key::Left),
            (60, Key::Stop),
            (90, Key::End),
        ]);
        let mut t = Teleop::new(1.0, 1.0);
        let mut commands = Vec::new();
        let d = drive(
            &mut base,
            &mut keys,
            &mut t,
            &StopSignal::new(),
            60.0,
            false,
            &mut |t| commands.push((t.speed_mps, t.rot_radps)),
        )
        .unwrap();
        assert_eq!(d.end, DriveEnd::Ended);
        assert_eq!(d.samples.len(), 90);
        assert_eq!((d.samples[0].2, d.samples[0].3), (0.3, 0.0));
        assert_eq!((d.samples[45].2, d.samples[45].3), (0.3, 0.1));
        assert_eq!((d.samples[89].2, d.samples[89].3), (0.0, 0.0));
        assert_eq!(
            commands,
            [(0.3, 0.0), (0.3, 0.1), (0.0, 0.0), (0.0, 0.0)][..3]
        );
        // The base moved forward and turned left while commanded.
        let p = d.samples[60].1;
        assert!(p.x_m > 0.3 && p.theta_rad > 0.0, "{p:?}");
    }

    #[test]
    fn the_stop_signal_and_the_time_limit_end_a_drive() {
        let mut base = SimBackend::new(SimParams::default(), 1);
        let stop = StopSignal::new();
        stop.raise();
        let mut keys = ScriptedKeys::new(vec![(0, Key::Faster)]);
        let d = drive(
            &mut base,
            &mut keys,
            &mut Teleop::new(1.0, 1.0),
            &stop,
            10.0,
            false,
            &mut |_| {},
        )
        .unwrap();
        assert_eq!((d.end, d.samples.len()), (DriveEnd::Stopped, 0));
        let mut keys = ScriptedKeys::new(vec![(0, Key::Faster)]);
        let d = drive(
            &mut base,
            &mut keys,
            &mut Teleop::new(1.0, 1.0),
            &StopSignal::new(),
            1.0,
            false,
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(d.end, DriveEnd::TimeLimit);
        assert_eq!(d.samples.len(), 30);
    }
}
