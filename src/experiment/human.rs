//! A model of the paper's human teleoperator for ball interception: the hand-written
//! [`InterceptionTeacher`], but with a style that changes from one episode to the next.
//!
//! The paper's teacher was a person with a joystick, and people are not consistent: on one run
//! they turn hard toward the ball, on the next they keep rolling and swing round in a wide loop;
//! sometimes they hurry, sometimes they creep. That inconsistency is what Binary Critiquing
//! exploits: the demonstrations hold good and poor behaviour for similar situations, critique
//! penalises the data behind the poor executions, and the 1-NN learner is left answering from
//! the good data, so it can end up better than the person who taught it (the paper's Table 1).
//! A perfectly consistent teacher leaves critique nothing better to fall back on.
//!
//! Each episode draws, from its own seeded stream, independently and uniformly:
//! - the turn gain `k_turn` in [`HumanStyle::k_turn`] (1/s): low values are the lazy turns that
//!   end in loops;
//! - the cruising speed in [`HumanStyle::cruise_mps`];
//! - the fraction of it kept while the ball is behind, in [`HumanStyle::behind_frac`]: high
//!   values keep rolling forward through the turn;
//! - the rotational integral gain in [`HumanStyle::gain_rot`]: low values are slow hands.
//!
//! Within an episode the person is a fixed [`InterceptionTeacher`]: the variation is between
//! runs, not jitter within one (which the simulator's own noise already gives). The same model,
//! with the same per-start draws, is the "teacher" line of Table 1.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::task::episode_seed;
use crate::task::interception::InterceptionTeacher;

/// Salt of the style stream, apart from the simulator's noise.
const STYLE_SALT: u64 = 0x57E1_0000_0000_0003;

/// The ranges a person's style is drawn from, one draw per episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HumanStyle {
    pub k_turn: [f64; 2],
    pub cruise_mps: [f64; 2],
    pub behind_frac: [f64; 2],
    pub gain_rot: [f64; 2],
}

impl Default for HumanStyle {
    fn default() -> Self {
        HumanStyle {
            k_turn: [0.6, 2.5],
            cruise_mps: [0.6, 0.95],
            behind_frac: [0.4, 1.0],
            gain_rot: [0.25, 0.6],
        }
    }
}

impl HumanStyle {
    /// No variation: every episode is the hand-written teacher.
    pub fn consistent() -> HumanStyle {
        let t = InterceptionTeacher::new(1.0);
        HumanStyle {
            k_turn: [t.k_turn; 2],
            cruise_mps: [t.cruise_mps; 2],
            behind_frac: [t.behind_frac; 2],
            gain_rot: [t.gain_rot; 2],
        }
    }

    /// The person driving episode `index` of the stream seeded with `seed`.
    pub fn teacher(&self, seed: u64, index: u64, period_s: f64) -> InterceptionTeacher {
        let mut rng = ChaCha8Rng::seed_from_u64(episode_seed(seed ^ STYLE_SALT, index));
        let mut draw = |r: [f64; 2]| {
            let (lo, hi) = (r[0].min(r[1]), r[0].max(r[1]));
            if hi > lo {
                rng.random_range(lo..=hi)
            } else {
                lo
            }
        };
        InterceptionTeacher {
            k_turn: draw(self.k_turn),
            cruise_mps: draw(self.cruise_mps),
            behind_frac: draw(self.behind_frac),
            gain_rot: draw(self.gain_rot),
            ..InterceptionTeacher::new(period_s)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn styles_are_seeded_vary_between_episodes_and_stay_in_range() {
        let s = HumanStyle::default();
        let a = s.teacher(7, 3, 1.0 / 30.0);
        assert_eq!(a, s.teacher(7, 3, 1.0 / 30.0));
        assert_ne!(a.k_turn, s.teacher(7, 4, 1.0 / 30.0).k_turn);
        assert_ne!(a.k_turn, s.teacher(8, 3, 1.0 / 30.0).k_turn);
        for i in 0..200 {
            let t = s.teacher(1, i, 1.0 / 30.0);
            assert!((s.k_turn[0]..=s.k_turn[1]).contains(&t.k_turn));
            assert!((s.cruise_mps[0]..=s.cruise_mps[1]).contains(&t.cruise_mps));
            assert!((s.behind_frac[0]..=s.behind_frac[1]).contains(&t.behind_frac));
            assert!((s.gain_rot[0]..=s.gain_rot[1]).contains(&t.gain_rot));
        }
    }

    #[test]
    fn a_consistent_style_is_the_hand_written_teacher() {
        let p = 1.0 / 30.0;
        assert_eq!(
            HumanStyle::consistent().teacher(5, 9, p),
            InterceptionTeacher::new(p)
        );
    }
}
