//! The web view's hold-to-drive pad: while a person holds it, the page posts where on the pad
//! their pointer is (`POST /api/takeover`, fractions of the base's limits) every tenth of a
//! second, and a robot's run is theirs; releasing it (or a page that stops posting for
//! [`PAD_TIMEOUT`]: a closed tab, a lost connection) hands back to the learner.
//!
//! The pad is the session's live takeover ([`advise::session::LiveTakeover`]): its state lives
//! outside the session's lock, since a run holds that lock for as long as it drives. The
//! request passes the same guard as every other (token, Host, Origin, body size).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use advise::backend::teleop::Commands;
use advise::session::{LiveTakeover, RunInfo};

/// No post for this long hands back: three of the page's 100 ms posts missed.
pub const PAD_TIMEOUT: Duration = Duration::from_millis(300);

/// Where the pad is held, shared by the web server and the session's runs (cheap to clone).
#[derive(Clone, Default)]
pub struct Pad {
    held: Arc<Mutex<Option<Held>>>,
}

#[derive(Clone, Copy)]
struct Held {
    /// Fractions of the base's speed and turn limits, each in [-1, 1].
    speed: f64,
    turn: f64,
    at: Instant,
}

/// What a page posts: the pad held at fractions of the limits, or released.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Post {
    #[serde(default)]
    pub speed: f64,
    #[serde(default)]
    pub turn: f64,
    #[serde(default)]
    pub release: bool,
}

impl Pad {
    /// Take a page's post; an error (for a 400) when its numbers are not fractions.
    pub fn post(&self, p: &Post) -> Result<(), String> {
        let mut held = self.held.lock().unwrap_or_else(|e| e.into_inner());
        if p.release {
            *held = None;
            return Ok(());
        }
        let fraction = |v: f64| v.is_finite() && (-1.0..=1.0).contains(&v);
        if !(fraction(p.speed) && fraction(p.turn)) {
            return Err(format!(
                "speed and turn are fractions of the base's limits, from -1 to 1 (got {} and {})",
                p.speed, p.turn
            ));
        }
        *held = Some(Held {
            speed: p.speed,
            turn: p.turn,
            at: Instant::now(),
        });
        Ok(())
    }

    /// The fractions held now, if the pad is held and the page keeps posting.
    fn now(&self) -> Option<(f64, f64)> {
        let mut held = self.held.lock().unwrap_or_else(|e| e.into_inner());
        match *held {
            Some(h) if h.at.elapsed() <= PAD_TIMEOUT => Some((h.speed, h.turn)),
            _ => {
                *held = None;
                None
            }
        }
    }
}

impl LiveTakeover for Pad {
    fn for_run(&mut self, run: &RunInfo) -> Option<Box<dyn Commands>> {
        // A hold from before the run does not take it over at its first step.
        let _ = self.post(&Post {
            speed: 0.0,
            turn: 0.0,
            release: true,
        });
        Some(Box::new(PadCommands {
            pad: self.clone(),
            max: (run.max_speed_mps, run.max_rot_radps),
        }))
    }
}

struct PadCommands {
    pad: Pad,
    max: (f64, f64),
}

impl Commands for PadCommands {
    fn command(&mut self, _now: (f64, f64)) -> Option<(f64, f64)> {
        self.pad
            .now()
            .map(|(s, t)| (s * self.max.0.abs(), t * self.max.1.abs()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pad_drives_while_held_and_hands_back_on_release_or_silence() {
        let mut pad = Pad::default();
        let info = RunInfo {
            task: advise::task::TaskKind::Positioning,
            max_speed_mps: 2.0,
            max_rot_radps: 1.0,
            period_s: 1.0 / 30.0,
        };
        let mut c = pad.for_run(&info).unwrap();
        assert_eq!(c.command((0.3, 0.0)), None);
        let hold = |speed, turn| Post {
            speed,
            turn,
            release: false,
        };
        pad.post(&hold(0.5, -0.25)).unwrap();
        assert_eq!(c.command((0.3, 0.0)), Some((1.0, -0.25)));
        pad.post(&Post {
            speed: 0.0,
            turn: 0.0,
            release: true,
        })
        .unwrap();
        assert_eq!(c.command((0.3, 0.0)), None);
        pad.post(&hold(0.1, 0.0)).unwrap();
        std::thread::sleep(PAD_TIMEOUT + Duration::from_millis(50));
        assert_eq!(c.command((0.3, 0.0)), None, "a silent page hands back");
        assert!(pad.post(&hold(1.5, 0.0)).is_err());
        assert!(pad.post(&hold(f64::NAN, 0.0)).is_err());
    }
}
