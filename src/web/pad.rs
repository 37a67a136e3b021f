//! The web view's hold-to-drive pad: while a person holds it, the page posts where on the pad
//! their pointer is (`POST /api/takeover`, fractions of the base's limits) every tenth of a
//! second, and a robot's run is theirs; releasing it (or a page that stops posting for
//! [`PAD_TIMEOUT`]: a closed tab, a lost connection) hands back to the learner.
//!
//! The pad is the library's [`Hold`], installed as the session's live takeover: its state lives
//! outside the session's lock, since a run holds that lock for as long as it drives. The
//! request passes the same guard as every other (token, Host, Origin, body size); this module
//! only reads the page's post.

use std::time::Duration;

use advise::session::Hold;

/// No post for this long hands back: three of the page's 100 ms posts missed.
pub const PAD_TIMEOUT: Duration = Duration::from_millis(300);

/// The page's pad: a hold with the pad's timeout.
pub fn pad() -> Hold {
    Hold::new(PAD_TIMEOUT)
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

/// Take a page's post; an error (for a 400) when its numbers are not fractions.
pub fn post(pad: &Hold, p: &Post) -> Result<(), String> {
    if p.release {
        pad.release();
        Ok(())
    } else {
        pad.hold(p.speed, p.turn)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use advise::session::{LiveTakeover, RunInfo};

    #[test]
    fn the_pad_drives_while_held_and_hands_back_on_release_or_silence() {
        let mut pad = pad();
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
        post(&pad, &hold(0.5, -0.25)).unwrap();
        assert_eq!(c.command((0.3, 0.0)), Some((1.0, -0.25)));
        post(
            &pad,
            &Post {
                speed: 0.0,
                turn: 0.0,
                release: true,
            },
        )
        .unwrap();
        assert_eq!(c.command((0.3, 0.0)), None);
        post(&pad, &hold(0.1, 0.0)).unwrap();
        std::thread::sleep(PAD_TIMEOUT + Duration::from_millis(50));
        assert_eq!(c.command((0.3, 0.0)), None, "a silent page hands back");
        assert!(post(&pad, &hold(1.5, 0.0)).is_err());
        assert!(post(&pad, &hold(f64::NAN, 0.0)).is_err());
    }
}
