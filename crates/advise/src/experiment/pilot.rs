//! A model of the paper's human teleoperator for spatial positioning: the hand-written
//! [`PositioningTeacher`], but with a driving style that changes from one episode to the next.
//!
//! The paper's demonstrations were a person driving a Segway RMP with a joystick, and people are
//! not consistent: on one run they are satisfied half a metre from the mark, on the next they
//! creep in to within a hand's breadth; sometimes they judge the goal well, sometimes the depth
//! of a far goal fools them; some runs they bend onto the goal heading early, others late. The
//! paper's point about teleoperation ("a demonstrated training set is inherently limited by the
//! demonstrator's performance") is about exactly this: more teleoperation adds more of the
//! same imprecision, where advice corrects the learner's own executions against the outcome the
//! advisor sees. A teacher that drives the same careful way every time leaves advice nothing to
//! do that teleoperation would not do better.
//!
//! Each episode draws, from its own seeded stream (apart from the simulator's noise and from the
//! teacher's own in-episode draws), independently and uniformly within [`PilotStyle`]'s ranges:
//! - `arrive_m`: how close the driver must feel to the goal before turning onto its heading;
//! - `heading_tol_rad`: how close to the goal heading counts as done;
//! - `perception_frac`: how badly the goal position is misjudged (per axis, a fraction of the
//!   initial distance);
//! - `heading_misjudge_rad`: how badly the goal heading is misjudged;
//! - `blend_m`: from how far the driver starts bending onto the goal heading;
//! - `k_alpha`: how hard the driver steers toward the goal;
//! - `hand`: the person's hand ([`crate::task::human`], the same model as the BC teacher's):
//!   reaction lag, tremor, and how often and how long they hesitate.
//!
//! Within an episode the driver is a fixed [`PositioningTeacher`] driving through that hand: the
//! variation of style is between runs. The A-OPI study uses this one model for every
//! teleoperated demonstration alike: the 9 seed demonstrations, the hybrid arm's and the
//! teleoperation arm's, with the same draw for the same goal in both arms.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::task::calibration::Shipped;
use crate::task::episode_seed;
use crate::task::human::{HandRanges, draw};
use crate::task::positioning::{PositioningTeacher, TeacherStyle};

/// Salt of the style stream, apart from the simulator's noise.
const STYLE_SALT: u64 = 0x9170_0000_0000_0004;

/// The ranges a driver's style is drawn from, one draw per episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PilotStyle {
    pub arrive_m: [f64; 2],
    pub heading_tol_rad: [f64; 2],
    pub perception_frac: [f64; 2],
    pub heading_misjudge_rad: [f64; 2],
    pub blend_m: [f64; 2],
    pub k_alpha: [f64; 2],
    /// The cruising speed's range, m/s (drawn by the driver within each episode, as the
    /// hand-written teacher does), and the speed per metre of remaining distance, 1/s.
    pub cruise_mps: [f64; 2],
    pub k_rho: f64,
    /// The hand's ranges (drawn after the others, so the earlier draws keep their values).
    pub hand: HandRanges,
}

impl Default for PilotStyle {
    /// The calibrated driver: `calibration/aopi.json`, written by `advise calibrate aopi`.
    fn default() -> Self {
        calibrated().pilot.clone()
    }
}

/// The constants `advise calibrate aopi` fitted to the paper's starting conditions, as shipped
/// in `calibration/aopi.json` (which also records what they were fitted to and how closely).
#[derive(Clone, Debug, Deserialize)]
pub struct Calibrated {
    pub pilot: PilotStyle,
    /// Test-set evaluations without improvement before an arm stops, and the practice goals an
    /// arm may run at most.
    pub patience: usize,
    pub max_practice: usize,
}

/// The shipped A-OPI calibration.
pub fn calibrated() -> &'static Calibrated {
    static CALIBRATED: std::sync::LazyLock<Calibrated> = std::sync::LazyLock::new(|| {
        Shipped::Aopi
            .read()
            .expect("the shipped calibration/aopi.json holds a pilot (a test reads it)")
    });
    &CALIBRATED
}

impl PilotStyle {
    /// The values `advise calibrate aopi --from-bootstrap` starts from: the first guesses before
    /// any calibration, and a person's hand from human-factors figures.
    pub fn bootstrap() -> PilotStyle {
        PilotStyle {
            arrive_m: [0.2, 0.6],
            heading_tol_rad: [0.08, 0.35],
            perception_frac: [0.05, 0.25],
            heading_misjudge_rad: [0.1, 0.4],
            blend_m: [0.6, 1.8],
            k_alpha: [0.9, 2.0],
            cruise_mps: [0.7, 1.0],
            k_rho: 1.0,
            hand: HandRanges {
                reaction_s: [0.15, 0.45],
                tremor: [0.0, 0.05],
                hesitate_per_s: [0.0, 0.2],
                hesitate_s: [0.2, 0.6],
            },
        }
    }

    /// No variation: every episode is the hand-written teacher.
    pub fn consistent() -> PilotStyle {
        let t = TeacherStyle::default();
        PilotStyle {
            arrive_m: [t.arrive_m; 2],
            heading_tol_rad: [t.heading_tol_rad; 2],
            perception_frac: [t.perception_frac; 2],
            heading_misjudge_rad: [t.heading_misjudge_rad; 2],
            blend_m: [t.blend_m; 2],
            k_alpha: [t.k_alpha; 2],
            cruise_mps: [t.cruise_mps.0, t.cruise_mps.1],
            k_rho: t.k_rho,
            hand: HandRanges::fixed(t.hand()),
        }
    }

    /// The style of the person driving episode `index` of the stream seeded with `seed`.
    pub fn style(&self, seed: u64, index: u64) -> TeacherStyle {
        let mut rng = ChaCha8Rng::seed_from_u64(episode_seed(seed ^ STYLE_SALT, index));
        let rng = &mut rng;
        let arrive_m = draw(rng, self.arrive_m);
        let heading_tol_rad = draw(rng, self.heading_tol_rad);
        let perception_frac = draw(rng, self.perception_frac);
        let heading_misjudge_rad = draw(rng, self.heading_misjudge_rad);
        let blend_m = draw(rng, self.blend_m);
        let k_alpha = draw(rng, self.k_alpha);
        let hand = self.hand.draw(rng);
        TeacherStyle {
            arrive_m,
            heading_tol_rad,
            perception_frac,
            heading_misjudge_rad,
            blend_m,
            k_alpha,
            cruise_mps: (self.cruise_mps[0], self.cruise_mps[1]),
            k_rho: self.k_rho,
            reaction_s: hand.reaction_s,
            tremor: hand.tremor,
            hesitate_per_s: hand.hesitate_per_s,
            hesitate_s: hand.hesitate_s,
            ..TeacherStyle::default()
        }
    }

    /// The person driving episode `index` of the stream seeded with `seed`.
    pub fn teacher(&self, seed: u64, index: u64, period_s: f64) -> PositioningTeacher {
        PositioningTeacher::with_style(period_s, self.style(seed, index))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn styles_are_seeded_vary_between_episodes_and_stay_in_range() {
        let s = PilotStyle::default();
        let a = s.style(7, 3);
        assert_eq!(a, s.style(7, 3));
        assert_ne!(a.arrive_m, s.style(7, 4).arrive_m);
        assert_ne!(a.arrive_m, s.style(8, 3).arrive_m);
        for i in 0..200 {
            let t = s.style(1, i);
            assert!((s.arrive_m[0]..=s.arrive_m[1]).contains(&t.arrive_m));
            assert!((s.heading_tol_rad[0]..=s.heading_tol_rad[1]).contains(&t.heading_tol_rad));
            assert!((s.perception_frac[0]..=s.perception_frac[1]).contains(&t.perception_frac));
            assert!(
                (s.heading_misjudge_rad[0]..=s.heading_misjudge_rad[1])
                    .contains(&t.heading_misjudge_rad)
            );
            assert!((s.blend_m[0]..=s.blend_m[1]).contains(&t.blend_m));
            assert!((s.k_alpha[0]..=s.k_alpha[1]).contains(&t.k_alpha));
            assert!(s.hand.contains(&t.hand()));
        }
    }

    #[test]
    fn a_consistent_style_is_the_hand_written_teacher() {
        assert_eq!(
            PilotStyle::consistent().style(5, 9),
            TeacherStyle::default()
        );
    }
}
