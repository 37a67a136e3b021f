//! The paper's spatial positioning task (A-OPI on a Segway RMP), and its teleoperation teacher.
//!
//! The robot starts at the origin of the world frame, heading 0 (along +x), and must reach a goal
//! pose `(x_g, y_g, theta_g)` drawn uniformly from x in [-0.33, 4.5] m, y in [-4.0, 0.17] m,
//! theta in [-3.1, 1.1] rad (the bounds of the paper's demonstration data, which are relative to
//! the robot's start). Observation: squared distance to the goal, the angle between the goal
//! vector and the heading, and `theta_g - theta_r` (both angles wrapped to (-pi, pi]); all from
//! odometry. Action: translational and rotational speed, the command itself. The episode ends when
//! the controller comes to rest or at the time limit; it succeeds when the true final pose is
//! within 1.0 m and pi/2 rad of the goal. The observations, drives and rules are declared in
//! `operators/positioning.adv` and run by [`crate::task::declared`]; this module keeps the goal
//! sets, the Rust reference of the observation, and the teleoperation teacher (a model of a
//! person, with lag and misjudgement, which the language does not express).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::backend::sim::normal_pair;
use crate::domain::columns::positioning::{BEARING, DHEADING, DIST2, ROT, TRANS};
use crate::geometry::{Pose, bearing, wrap_angle};
use crate::task::Controller;
use crate::task::human::{Hand, HandStyle};

/// Goal bounds, from the paper.
pub const GOAL_X_M: (f64, f64) = (-0.33, 4.5);
pub const GOAL_Y_M: (f64, f64) = (-4.0, 0.17);
pub const GOAL_THETA_RAD: (f64, f64) = (-3.1, 1.1);

/// A positioning demonstration keeps every this many control steps: 15 Hz at the simulator's
/// 30 Hz (docs/protocol.md, point 7).
pub const RECORD_EVERY: usize = 2;

/// Size of the test set (the paper's 25 goals).
pub const TEST_GOALS: usize = 25;
/// Seed of the test set. The test set is drawn from stream 0 of this seed; practice goals come
/// from stream 1 of the user's seed, so the two never coincide.
pub const TEST_SEED: u64 = 0x7E57_2009;

/// The fixed test set: 25 goals.
pub fn test_goals() -> Vec<Pose> {
    let mut rng = ChaCha8Rng::seed_from_u64(TEST_SEED);
    rng.set_stream(0);
    sample_goals(&mut rng, TEST_GOALS)
}

/// `n` practice goals (for demonstrations and advice) drawn from `seed`.
pub fn practice_goals(seed: u64, n: usize) -> Vec<Pose> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    sample_goals(&mut rng, n)
}

/// Practice goal `index` of `seed`: `practice_goals(seed, index + 1)[index]`, computed directly.
/// A goal takes exactly `WORDS_PER_GOAL` words of the stream (rand's uniform `f64` range draws
/// one `u64` and never rejects), so goal `index` starts at word `index * WORDS_PER_GOAL`, and
/// ChaCha seeks there in constant time. Every `u64` index names a distinct stretch of the stream
/// (its period is 2^68 words).
pub fn practice_goal(seed: u64, index: u64) -> Pose {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    rng.set_word_pos(u128::from(index) * WORDS_PER_GOAL);
    sample_goal(&mut rng)
}

/// 32-bit words of the random stream one goal takes: three `u64` draws.
const WORDS_PER_GOAL: u128 = 6;

fn sample_goals(rng: &mut ChaCha8Rng, n: usize) -> Vec<Pose> {
    (0..n).map(|_| sample_goal(rng)).collect()
}

fn sample_goal(rng: &mut ChaCha8Rng) -> Pose {
    Pose::new(
        rng.random_range(GOAL_X_M.0..GOAL_X_M.1),
        rng.random_range(GOAL_Y_M.0..GOAL_Y_M.1),
        rng.random_range(GOAL_THETA_RAD.0..GOAL_THETA_RAD.1),
    )
}

/// The observation of `goal` from `pose`: `[dist2, bearing, dheading]`, written out in Rust. The
/// task runs by its declaration in `operators/positioning.adv`; this is the reference the tests
/// hold that declaration to, bit for bit. Exactly at the goal position the goal vector has no
/// direction and the bearing is 0.
pub fn observe(goal: Pose, pose: Pose) -> [f64; 3] {
    let (dx, dy) = (goal.x_m - pose.x_m, goal.y_m - pose.y_m);
    let bearing = if dx == 0.0 && dy == 0.0 {
        0.0
    } else {
        bearing(pose, goal.x_m, goal.y_m)
    };
    [
        dx * dx + dy * dy,
        bearing,
        wrap_angle(goal.theta_rad - pose.theta_rad),
    ]
}

/// How the positioning teacher drives: a human at a joystick, watching the robot.
///
/// The driver steers a smooth coupled turn-and-drive toward the goal (aiming at it from afar,
/// bending toward the goal heading over the last metre or so), drives forward only, slows down
/// near the goal, turns in place to the goal heading once close, and lets go of the stick when
/// satisfied. The human part: commands reach the stick
/// through a reaction lag and a slow hand tremor, and in each episode the driver misjudges where
/// the goal is by an error that grows with its distance (depth perception) and misjudges the goal
/// heading a little. So the teacher succeeds often but not always, and never the same way twice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TeacherStyle {
    /// Preferred cruising speed, m/s (drawn per episode in `[lo, hi]`).
    pub cruise_mps: (f64, f64),
    /// Largest turning speed the driver uses, rad/s.
    pub max_rot_radps: f64,
    /// Speed per metre of remaining distance, 1/s (the driver slows down near the goal).
    pub k_rho: f64,
    /// Turn rate per radian of aiming error, 1/s.
    pub k_alpha: f64,
    /// Within this distance the driver starts aiming along the goal heading, m.
    pub blend_m: f64,
    /// Turn-in-place gain near the goal.
    pub k_heading: f64,
    /// The driver considers the position reached within this distance, m.
    pub arrive_m: f64,
    /// ... and the heading reached within this angle, rad.
    pub heading_tol_rad: f64,
    /// Reaction lag: time constant between intention and stick, s.
    pub reaction_s: f64,
    /// Hand tremor: standard deviation of the slow noise on each stick axis (m/s and rad/s).
    pub tremor: f64,
    /// Hesitation: pauses a second, on average, in which the stick stays put, and how long one
    /// lasts, s ([`crate::task::human`]).
    #[serde(default)]
    pub hesitate_per_s: f64,
    #[serde(default)]
    pub hesitate_s: f64,
    /// Misjudged goal position: standard deviation per axis, as a fraction of the initial
    /// distance to the goal.
    pub perception_frac: f64,
    /// Misjudged goal heading: standard deviation, rad.
    pub heading_misjudge_rad: f64,
}

impl Default for TeacherStyle {
    fn default() -> Self {
        TeacherStyle {
            cruise_mps: (0.7, 1.0),
            max_rot_radps: 1.0,
            k_rho: 1.0,
            k_alpha: 1.5,
            blend_m: 1.2,
            k_heading: 2.0,
            arrive_m: 0.3,
            heading_tol_rad: 0.12,
            reaction_s: 0.25,
            tremor: 0.03,
            hesitate_per_s: 0.0,
            hesitate_s: 0.0,
            perception_frac: 0.15,
            heading_misjudge_rad: 0.25,
        }
    }
}

/// The positioning teacher; see [`TeacherStyle`]. A [`Controller`]: it keeps per-episode state.
#[derive(Clone, Debug)]
pub struct PositioningTeacher {
    style: TeacherStyle,
    period_s: f64,
    rng: ChaCha8Rng,
    episode: EpisodeState,
}

#[derive(Clone, Debug, Default)]
struct EpisodeState {
    started: bool,
    cruise_mps: f64,
    /// Standard normal draws for the misjudgements, scaled once the distance is seen.
    perception_draw: (f64, f64),
    /// Goal position error in the goal's frame, m.
    offset: (f64, f64),
    heading_offset_rad: f64,
    hand: Option<Hand>,
    turning_in_place: bool,
    done: bool,
}

impl PositioningTeacher {
    pub fn new(period_s: f64) -> PositioningTeacher {
        PositioningTeacher::with_style(period_s, TeacherStyle::default())
    }

    pub fn with_style(period_s: f64, style: TeacherStyle) -> PositioningTeacher {
        let mut t = PositioningTeacher {
            style,
            period_s,
            rng: ChaCha8Rng::seed_from_u64(0),
            episode: EpisodeState::default(),
        };
        t.begin(0);
        t
    }

    fn normal(&mut self) -> f64 {
        // The second draw of the pair is dropped: the stream of choices stays as it always was.
        normal_pair(&mut self.rng).0
    }

    /// What the driver means to command, before lag and tremor.
    fn intention(&mut self, z: &[f64]) -> (f64, f64) {
        let s = &self.style;
        let e = &mut self.episode;
        let (d, bearing, dheading) = (z[DIST2].max(0.0).sqrt(), z[BEARING], z[DHEADING]);
        // The perceived goal, in the robot frame: the true goal plus the misjudgement, which is
        // fixed in the goal's frame (rotate by theta_g - theta_r into the robot's). This is
        // `compose_pose`, written out: nalgebra adds the rotated offset as one vector, which moves
        // the last bit of the recorded demonstrations (and the saved datasets' text with them).
        let (c, sn) = (dheading.cos(), dheading.sin());
        let gx = d * bearing.cos() + c * e.offset.0 - sn * e.offset.1;
        let gy = d * bearing.sin() + sn * e.offset.0 + c * e.offset.1;
        let g_theta = wrap_angle(dheading + e.heading_offset_rad);
        let rho = gx.hypot(gy);
        if e.done {
            return (0.0, 0.0);
        }
        if rho < s.arrive_m || (e.turning_in_place && rho < 2.5 * s.arrive_m) {
            e.turning_in_place = true;
            if g_theta.abs() < s.heading_tol_rad {
                e.done = true;
                return (0.0, 0.0);
            }
            let w = (s.k_heading * g_theta).clamp(-0.8, 0.8);
            return (0.0, w);
        }
        e.turning_in_place = false;
        // Aim at the goal from afar; within `blend_m`, aim more and more along the goal heading,
        // so the robot arrives roughly facing it.
        let alpha = gy.atan2(gx);
        // Only while the goal is ahead: with the goal abeam, blending would balance the two aims
        // and leave the robot turning on the spot.
        let ahead = alpha.cos().max(0.0);
        let blend = (1.0 - rho / s.blend_m).clamp(0.0, 1.0) * ahead * ahead;
        let aim = wrap_angle(alpha + blend * wrap_angle(g_theta - alpha));
        let v = (s.k_rho * rho).min(e.cruise_mps) * alpha.cos().max(0.0);
        let w = (s.k_alpha * aim).clamp(-s.max_rot_radps, s.max_rot_radps);
        (v, w)
    }
}

impl Controller for PositioningTeacher {
    fn begin(&mut self, episode_seed: u64) {
        // Salted so the teacher's choices are not the simulator's noise.
        self.rng = ChaCha8Rng::seed_from_u64(episode_seed ^ 0x7EAC_4E55_0000_0001);
        let cruise = self
            .rng
            .random_range(self.style.cruise_mps.0..=self.style.cruise_mps.1);
        let perception_draw = (self.normal(), self.normal());
        let heading_offset_rad = self.normal() * self.style.heading_misjudge_rad;
        let hand = Hand::new(self.style.hand(), self.period_s);
        self.episode = EpisodeState {
            hand: Some(hand),
            cruise_mps: cruise,
            perception_draw,
            heading_offset_rad,
            ..EpisodeState::default()
        };
    }

    fn act(&mut self, z: &[f64], a: &mut [f64]) {
        if !self.episode.started {
            self.episode.started = true;
            let d0 = z[DIST2].max(0.0).sqrt();
            let sd = self.style.perception_frac * d0;
            let (n1, n2) = self.episode.perception_draw;
            self.episode.offset = (n1 * sd, n2 * sd);
        }
        let (v, w) = self.intention(z);
        let done = self.episode.done;
        let hand = self
            .episode
            .hand
            .get_or_insert_with(|| Hand::new(self.style.hand(), self.period_s));
        // The person's hand: lag, tremor, pauses; let go once satisfied.
        let (v, w) = if done {
            hand.release(&mut self.rng)
        } else {
            hand.track((v, w), &mut self.rng)
        };
        a[TRANS] = v;
        a[ROT] = w;
    }
}

impl TeacherStyle {
    /// The driver's hand ([`crate::task::human`]).
    pub fn hand(&self) -> HandStyle {
        HandStyle {
            reaction_s: self.reaction_s,
            tremor: self.tremor,
            hesitate_per_s: self.hesitate_per_s,
            hesitate_s: self.hesitate_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn observation_matches_the_paper() {
        let z = observe(Pose::new(3.0, 4.0, 1.0), Pose::new(0.0, 0.0, 0.5));
        assert!((z[0] - 25.0).abs() < 1e-12);
        assert!((z[1] - ((4.0f64).atan2(3.0) - 0.5)).abs() < 1e-12);
        assert!((z[2] - 0.5).abs() < 1e-12);
        // Angles wrap.
        let z = observe(Pose::new(-1.0, -0.01, -3.0), Pose::new(0.0, 0.0, 3.0));
        assert!(z[1].abs() <= PI && z[2].abs() <= PI);
    }

    #[test]
    fn goals_stay_in_the_paper_bounds_and_test_differs_from_practice() {
        let test = test_goals();
        assert_eq!(test.len(), 25);
        assert_eq!(test, test_goals());
        for g in test.iter().chain(&practice_goals(TEST_SEED, 50)) {
            assert!(g.x_m >= GOAL_X_M.0 && g.x_m < GOAL_X_M.1);
            assert!(g.y_m >= GOAL_Y_M.0 && g.y_m < GOAL_Y_M.1);
            assert!(g.theta_rad >= GOAL_THETA_RAD.0 && g.theta_rad < GOAL_THETA_RAD.1);
        }
        let practice = practice_goals(TEST_SEED, 25);
        assert!(test.iter().all(|g| !practice.contains(g)));
    }
}
