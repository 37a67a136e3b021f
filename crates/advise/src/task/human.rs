//! A person's hand on the joystick: the one model of a human teleoperator that both studies'
//! teachers drive through (the BC interception teacher's demonstrations and every A-OPI
//! teleoperation alike).
//!
//! A teacher decides what it *means* to command (its intention, a pair of speeds); the [`Hand`]
//! turns that into what reaches the robot, as a person's hand does:
//! - **reaction lag**: the stick follows the intention through a first-order lag of time
//!   constant `reaction_s`;
//! - **tremor**: slow noise on each axis (AR(1), about a second of memory), of standard
//!   deviation `tremor` (m/s on the first axis, rad/s on the second);
//! - **hesitation**: now and then (at `hesitate_per_s` a second on average) the person pauses for
//!   `hesitate_s` and the stick stays where it was, whatever the intention.
//!
//! The numbers of one episode are a [`HandStyle`]; [`HandRanges`] draws one per episode, from the
//! episode seed salted apart from the simulator's noise, so a person is never the same twice but a
//! run is reproducible bit for bit. A demonstration therefore holds different actions for similar
//! observations, as a person's do; a teacher that is a function of the observation leaves
//! critique nothing to choose between.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::backend::sim::normal_pair;

/// Salt of the style draw.
const STYLE_SALT: u64 = 0x4A4D_0000_0000_0006;

/// One episode's hand.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HandStyle {
    /// Time constant between intention and stick, s.
    pub reaction_s: f64,
    /// Standard deviation of the slow noise on each stick axis.
    pub tremor: f64,
    /// Pauses a second, on average.
    pub hesitate_per_s: f64,
    /// How long a pause lasts, s.
    pub hesitate_s: f64,
}

/// The ranges a hand is drawn from, uniformly and independently, once per episode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HandRanges {
    pub reaction_s: [f64; 2],
    pub tremor: [f64; 2],
    pub hesitate_per_s: [f64; 2],
    pub hesitate_s: [f64; 2],
}

/// A uniform draw from `[lo, hi]` (either order), or `lo` when the range is a point.
pub fn draw(rng: &mut ChaCha8Rng, r: [f64; 2]) -> f64 {
    let (lo, hi) = (r[0].min(r[1]), r[0].max(r[1]));
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// The random stream of the style of episode `episode_seed`, salted with `salt` (each teacher
/// draws its own numbers from it after the hand's).
pub fn style_rng(episode_seed: u64, salt: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(episode_seed ^ STYLE_SALT ^ salt)
}

impl HandRanges {
    /// A hand that is always `style`.
    pub fn fixed(style: HandStyle) -> HandRanges {
        HandRanges {
            reaction_s: [style.reaction_s; 2],
            tremor: [style.tremor; 2],
            hesitate_per_s: [style.hesitate_per_s; 2],
            hesitate_s: [style.hesitate_s; 2],
        }
    }

    /// One episode's hand, drawn from `rng`.
    pub fn draw(&self, rng: &mut ChaCha8Rng) -> HandStyle {
        HandStyle {
            reaction_s: draw(rng, self.reaction_s),
            tremor: draw(rng, self.tremor),
            hesitate_per_s: draw(rng, self.hesitate_per_s),
            hesitate_s: draw(rng, self.hesitate_s),
        }
    }

    /// Whether `style` lies within the ranges.
    pub fn contains(&self, style: &HandStyle) -> bool {
        let within = |r: [f64; 2], v: f64| r[0].min(r[1]) <= v && v <= r[0].max(r[1]);
        within(self.reaction_s, style.reaction_s)
            && within(self.tremor, style.tremor)
            && within(self.hesitate_per_s, style.hesitate_per_s)
            && within(self.hesitate_s, style.hesitate_s)
    }
}

/// A hand during one episode: see the module docs.
#[derive(Clone, Debug)]
pub struct Hand {
    style: HandStyle,
    period_s: f64,
    stick: (f64, f64),
    tremor: (f64, f64),
    /// Control steps of the current pause still to go.
    paused: usize,
}

impl Hand {
    /// A hand at rest. Its randomness (tremor, hesitation) comes from the teacher's own stream,
    /// passed to [`Hand::track`].
    pub fn new(style: HandStyle, period_s: f64) -> Hand {
        Hand {
            style,
            period_s,
            stick: (0.0, 0.0),
            tremor: (0.0, 0.0),
            paused: 0,
        }
    }

    pub fn style(&self) -> &HandStyle {
        &self.style
    }

    /// Where the stick is (before tremor).
    pub fn stick(&self) -> (f64, f64) {
        self.stick
    }

    /// One control period: the stick moves toward `intent` (unless the person is pausing) and
    /// the command that reaches the robot, tremor included, comes back. Draws two normals from
    /// `rng` (the first of two pairs), then a uniform only when the hand can start a pause.
    pub fn track(&mut self, intent: (f64, f64), rng: &mut ChaCha8Rng) -> (f64, f64) {
        let dt = self.period_s;
        let (n1, n2) = (normal_pair(rng).0, normal_pair(rng).0);
        if self.paused > 0 {
            self.paused -= 1;
        } else if self.style.hesitate_per_s > 0.0
            && rng.random::<f64>() < self.style.hesitate_per_s * dt
        {
            self.paused = (self.style.hesitate_s / dt).round() as usize;
        } else {
            let alpha = 1.0 - (-dt / self.style.reaction_s.max(1e-6)).exp();
            self.stick.0 += alpha * (intent.0 - self.stick.0);
            self.stick.1 += alpha * (intent.1 - self.stick.1);
        }
        // Tremor: slow (AR(1), about a second of memory at 30 Hz) noise on each axis.
        let keep: f64 = 0.95;
        let kick = (1.0 - keep * keep).sqrt() * self.style.tremor;
        self.tremor = (
            keep * self.tremor.0 + kick * n1,
            keep * self.tremor.1 + kick * n2,
        );
        (self.stick.0 + self.tremor.0, self.stick.1 + self.tremor.1)
    }

    /// Let go of the stick: it decays to a clean zero through the lag, without tremor. Draws the
    /// same two normals as [`Hand::track`] (unused), so the stream does not depend on when the
    /// person let go.
    pub fn release(&mut self, rng: &mut ChaCha8Rng) -> (f64, f64) {
        let _ = (normal_pair(rng), normal_pair(rng));
        let alpha = 1.0 - (-self.period_s / self.style.reaction_s.max(1e-6)).exp();
        self.stick.0 *= 1.0 - alpha;
        self.stick.1 *= 1.0 - alpha;
        if self.stick.0.abs() < 0.005 && self.stick.1.abs() < 0.005 {
            self.stick = (0.0, 0.0);
        }
        self.stick
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn style(hesitate_per_s: f64) -> HandStyle {
        HandStyle {
            reaction_s: 0.3,
            tremor: 0.0,
            hesitate_per_s,
            hesitate_s: 0.5,
        }
    }

    #[test]
    fn the_stick_follows_the_intention_with_a_lag() {
        let rng = &mut style_rng(1, 0);
        let mut h = Hand::new(style(0.0), 1.0 / 30.0);
        let first = h.track((1.0, 0.5), rng);
        assert!(first.0 > 0.0 && first.0 < 0.2, "{first:?}");
        for _ in 0..90 {
            h.track((1.0, 0.5), rng);
        }
        let later = h.track((1.0, 0.5), rng);
        assert!((later.0 - 1.0).abs() < 0.01 && (later.1 - 0.5).abs() < 0.01);
    }

    #[test]
    fn a_hesitating_hand_holds_the_stick_for_a_while() {
        // Pauses often: over 3 s some steps leave the stick exactly where it was.
        let rng = &mut style_rng(7, 0);
        let mut h = Hand::new(style(2.0), 1.0 / 30.0);
        let mut held = 0;
        let mut prev = h.stick();
        for _ in 0..90 {
            h.track((1.0, 0.0), rng);
            if h.stick() == prev {
                held += 1;
            }
            prev = h.stick();
        }
        assert!(held >= 10, "{held}");
        // A hand that never hesitates always moves toward a distant intention.
        let mut h = Hand::new(style(0.0), 1.0 / 30.0);
        let mut prev = h.stick();
        for _ in 0..90 {
            h.track((1.0, 0.0), rng);
            assert_ne!(h.stick(), prev);
            prev = h.stick();
        }
    }

    #[test]
    fn styles_are_drawn_per_episode_within_range_and_reproducibly() {
        let r = HandRanges {
            reaction_s: [0.15, 0.45],
            tremor: [0.0, 0.05],
            hesitate_per_s: [0.0, 0.3],
            hesitate_s: [0.2, 0.6],
        };
        let a = r.draw(&mut style_rng(3, 0));
        assert_eq!(a, r.draw(&mut style_rng(3, 0)));
        assert_ne!(a, r.draw(&mut style_rng(4, 0)));
        for s in 0..100 {
            assert!(r.contains(&r.draw(&mut style_rng(s, 0))));
        }
    }
}
