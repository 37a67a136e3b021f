//! The paper's ball interception task (BC, simulated differential drive), and its hand-written,
//! deliberately suboptimal teacher.
//!
//! All the numbers the paper leaves open are in [`InterceptionRules`], documented there in one
//! place. In short: the robot starts at the origin heading 0 (along +x) at rest; the ball starts
//! 1 to 3 m away in any direction, rolling at up to 0.6 m/s in any direction and slowing under
//! rolling friction; both must stay in the 8 m x 8 m arena centred on the start. The episode ends
//! when the ball comes within the capture distance of the robot's centre (success, if both are in
//! bounds), when either leaves the arena, or at the time limit. Efficiency is the robot's path
//! length.
//!
//! The ball is simulated by the task itself, in the frame where the robot started, so the same
//! task runs on a real base (against a virtual ball). Observation (the paper's 6 dimensions, from
//! odometry): distance and angle to the ball in the robot frame, their changes since the previous
//! step, the signed distance driven since the previous step (along the previous heading) and the
//! change of heading. Action: the change of translational and rotational speed; the task
//! integrates the changes into the speed command and clamps it.

use std::f64::consts::PI;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::backend::BaseState;
use crate::domain::Domain;
use crate::domain::columns::interception::{
    BALL_ANGLE, BALL_ANGLE_DELTA, BALL_DIST, BALL_DIST_DELTA, HEADING_DELTA, ROT_DELTA,
    TRANS_DELTA, TRAVEL_DELTA,
};
use crate::geometry::{Pose, bearing, distance, polar, relative_pose, wrap_angle};
use crate::policy::Policy;
use crate::task::calibration::Shipped;
use crate::task::{Controller, Ending, Score, Task};

/// Size of the test set (the paper's 100 initial conditions).
pub const TEST_STARTS: usize = 100;
/// Seed of the test set (stream 0); practice starts use stream 1 of the user's seed.
pub const TEST_SEED: u64 = 0xBA11_2007;

/// Every number of the interception world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InterceptionRules {
    /// The arena is the square `[-arena_half_m, arena_half_m]^2` around the robot's start, m.
    pub arena_half_m: f64,
    /// Capture: the ball's centre within this distance of the robot's centre, m (the RMP's
    /// half-width plus a ball radius).
    pub capture_m: f64,
    /// The episode ends at this time, s.
    pub time_limit_s: f64,
    /// Initial ball distance from the robot, m, uniform in `[lo, hi]`; bearing uniform.
    pub ball_dist_m: (f64, f64),
    /// Initial ball speed, m/s, uniform in `[lo, hi]`; direction uniform.
    pub ball_speed_mps: (f64, f64),
    /// Rolling friction: the ball's speed drops by this much per second until it stops, m/s^2.
    pub ball_decel_mps2: f64,
    /// The integrated speed command is clamped to `+-max_speed_mps` and `+-max_rot_radps`.
    pub max_speed_mps: f64,
    pub max_rot_radps: f64,
}

impl Default for InterceptionRules {
    /// The calibrated world: `calibration/bc.json`, written by `advise calibrate bc`.
    fn default() -> Self {
        calibrated().world.clone()
    }
}

/// The constants `advise calibrate bc` fitted to the paper's starting conditions, as shipped in
/// `calibration/bc.json` (the file also records what they were fitted to and how closely; only
/// the values are read here).
#[derive(Deserialize)]
struct Calibrated {
    world: InterceptionRules,
    teacher: InterceptionTeacher,
}

fn calibrated() -> &'static Calibrated {
    static CALIBRATED: std::sync::LazyLock<Calibrated> = std::sync::LazyLock::new(|| {
        Shipped::Bc
            .read()
            .expect("the shipped calibration/bc.json holds a world and a teacher (a test reads it)")
    });
    &CALIBRATED
}

/// An initial condition: the ball's position and velocity relative to the robot, which starts at
/// the origin heading along +x.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BallStart {
    pub x_m: f64,
    pub y_m: f64,
    pub vx_mps: f64,
    pub vy_mps: f64,
}

impl Default for BallStart {
    fn default() -> Self {
        BallStart {
            x_m: 2.0,
            y_m: 0.0,
            vx_mps: 0.0,
            vy_mps: 0.0,
        }
    }
}

/// The fixed test set: 100 starts.
pub fn test_starts() -> Vec<BallStart> {
    test_starts_in(&InterceptionRules::default())
}

/// The fixed test set drawn from `world`'s ranges.
pub fn test_starts_in(world: &InterceptionRules) -> Vec<BallStart> {
    let mut rng = ChaCha8Rng::seed_from_u64(TEST_SEED);
    rng.set_stream(0);
    sample_starts(&mut rng, TEST_STARTS, world)
}

/// `n` practice/demonstration starts drawn uniformly from `seed`.
pub fn practice_starts(seed: u64, n: usize) -> Vec<BallStart> {
    practice_starts_in(seed, n, &InterceptionRules::default())
}

/// [`practice_starts`] drawn from `world`'s ranges (the same stream: a world that differs only
/// in its ranges draws its starts from the same random words).
pub fn practice_starts_in(seed: u64, n: usize, world: &InterceptionRules) -> Vec<BallStart> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    sample_starts(&mut rng, n, world)
}

/// Practice start `index` of `seed`: `practice_starts(seed, index + 1)[index]`, computed
/// directly. A start takes exactly `WORDS_PER_START` words of the stream (rand's uniform `f64`
/// ranges draw one `u64` each and never reject), so start `index` begins at word
/// `index * WORDS_PER_START`, and ChaCha seeks there in constant time. Every `u64` index names a
/// distinct stretch of the stream (its period is 2^68 words).
pub fn practice_start(seed: u64, index: u64) -> BallStart {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    rng.set_word_pos(u128::from(index) * WORDS_PER_START);
    sample_start(&mut rng, &InterceptionRules::default())
}

/// 32-bit words of the random stream one start takes: four `u64` draws.
const WORDS_PER_START: u128 = 8;

fn sample_starts(rng: &mut ChaCha8Rng, n: usize, r: &InterceptionRules) -> Vec<BallStart> {
    (0..n).map(|_| sample_start(rng, r)).collect()
}

fn sample_start(rng: &mut ChaCha8Rng, r: &InterceptionRules) -> BallStart {
    let d = rng.random_range(r.ball_dist_m.0..=r.ball_dist_m.1);
    let bearing = rng.random_range(-PI..PI);
    let s = rng.random_range(r.ball_speed_mps.0..=r.ball_speed_mps.1);
    let dir = rng.random_range(-PI..PI);
    let (position, velocity) = (polar(d, bearing), polar(s, dir));
    BallStart {
        x_m: position.x,
        y_m: position.y,
        vx_mps: velocity.x,
        vy_mps: velocity.y,
    }
}

/// What the robot remembers of the previous step, for the difference observations.
#[derive(Clone, Copy, Debug)]
struct Prev {
    dist_m: f64,
    angle_rad: f64,
    pose: Pose,
}

/// One interception episode.
#[derive(Clone, Debug)]
pub struct Interception {
    domain: Domain,
    start: BallStart,
    rules: InterceptionRules,
    ball: [f64; 2],
    ball_v: [f64; 2],
    prev: Option<Prev>,
    command: (f64, f64),
}

impl Interception {
    pub fn new(start: BallStart) -> Interception {
        Interception::with_rules(start, InterceptionRules::default())
    }

    pub fn with_rules(start: BallStart, rules: InterceptionRules) -> Interception {
        Interception {
            domain: Domain::interception(),
            start,
            rules,
            ball: [start.x_m, start.y_m],
            ball_v: [start.vx_mps, start.vy_mps],
            prev: None,
            command: (0.0, 0.0),
        }
    }

    pub fn rules(&self) -> &InterceptionRules {
        &self.rules
    }

    /// Distance and angle (robot frame) from `pose` to the ball.
    fn relative(&self, pose: Pose) -> (f64, f64) {
        let [x, y] = self.ball;
        (distance(pose.x_m, pose.y_m, x, y), bearing(pose, x, y))
    }

    fn in_bounds(&self, x: f64, y: f64) -> bool {
        x.abs() <= self.rules.arena_half_m && y.abs() <= self.rules.arena_half_m
    }
}

impl Task for Interception {
    fn domain(&self) -> &Domain {
        &self.domain
    }

    fn start(&self) -> Pose {
        Pose::default()
    }

    fn begin(&mut self, _state: &BaseState) {
        self.ball = [self.start.x_m, self.start.y_m];
        self.ball_v = [self.start.vx_mps, self.start.vy_mps];
        self.prev = None;
        self.command = (0.0, 0.0);
    }

    fn observe(&self, state: &BaseState, z: &mut [f64]) {
        let (d, phi) = self.relative(state.pose);
        let p = self.prev.unwrap_or(Prev {
            dist_m: d,
            angle_rad: phi,
            pose: state.pose,
        });
        z[BALL_DIST] = d;
        z[BALL_ANGLE] = phi;
        z[BALL_DIST_DELTA] = d - p.dist_m;
        z[BALL_ANGLE_DELTA] = wrap_angle(phi - p.angle_rad);
        // How far the robot moved along its previous heading, and how much it turned.
        let moved = relative_pose(p.pose, state.pose);
        z[TRAVEL_DELTA] = moved.x_m;
        z[HEADING_DELTA] = moved.theta_rad;
    }

    fn command(&mut self, state: &BaseState, a: &[f64]) -> (f64, f64) {
        let (d, phi) = self.relative(state.pose);
        self.prev = Some(Prev {
            dist_m: d,
            angle_rad: phi,
            pose: state.pose,
        });
        let r = &self.rules;
        self.command = (
            (self.command.0 + a[TRANS_DELTA]).clamp(-r.max_speed_mps, r.max_speed_mps),
            (self.command.1 + a[ROT_DELTA]).clamp(-r.max_rot_radps, r.max_rot_radps),
        );
        self.command
    }

    fn advance(&mut self, dt_s: f64, state: &BaseState, true_pose: Option<Pose>) -> Option<Ending> {
        let speed = self.ball_v[0].hypot(self.ball_v[1]);
        if speed > 0.0 {
            let slower = (speed - self.rules.ball_decel_mps2 * dt_s).max(0.0);
            let k = slower / speed;
            // Trapezoid over the period: average of the old and new velocity.
            let avg = 0.5 * (1.0 + k);
            self.ball[0] += self.ball_v[0] * avg * dt_s;
            self.ball[1] += self.ball_v[1] * avg * dt_s;
            self.ball_v = [self.ball_v[0] * k, self.ball_v[1] * k];
        }
        let robot = true_pose.unwrap_or(state.pose);
        let ball_in = self.in_bounds(self.ball[0], self.ball[1]);
        let robot_in = self.in_bounds(robot.x_m, robot.y_m);
        let dist = distance(robot.x_m, robot.y_m, self.ball[0], self.ball[1]);
        if !ball_in {
            Some(Ending::BallOut)
        } else if !robot_in {
            Some(Ending::RobotOut)
        } else if dist < self.rules.capture_m {
            Some(Ending::Captured)
        } else if state.t_s >= self.rules.time_limit_s - 1e-9 {
            Some(Ending::TimeLimit)
        } else {
            None
        }
    }

    fn score(&self, ending: Ending, pose: Pose) -> Score {
        Score {
            success: ending == Ending::Captured,
            position_error_m: distance(pose.x_m, pose.y_m, self.ball[0], self.ball[1]),
            heading_error_rad: None,
            efficiency: None,
        }
    }

    fn ball_xy(&self) -> Option<[f64; 2]> {
        Some(self.ball)
    }
}

/// The hand-written interception teacher: pure pursuit of where the ball is now.
///
/// It is deliberately suboptimal, as the paper's was, so that critique has something to fix:
/// it aims at the ball's current position instead of leading it; it keeps rolling forward while
/// it turns, so a ball behind or beside it is reached by a loop; and it regulates speed by
/// integrating changes against *measured* speeds that lag the command, so it overshoots and weaves.
/// It is a pure function of the observation (it reads its own speeds from the travel and heading
/// changes), hence a stateless [`Policy`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InterceptionTeacher {
    /// The control period the observations' differences span, s.
    pub period_s: f64,
    /// Cruising speed, m/s, and the fraction of it kept while the ball is behind.
    pub cruise_mps: f64,
    pub behind_frac: f64,
    /// Turn rate per radian of ball angle, 1/s, and its cap, rad/s.
    pub k_turn: f64,
    pub max_rot_radps: f64,
    /// Integral gains: fraction of the speed error added to the command each step.
    pub gain_speed: f64,
    pub gain_rot: f64,
}

impl InterceptionTeacher {
    /// The calibrated teacher (`calibration/bc.json`) at control period `period_s`.
    pub fn new(period_s: f64) -> InterceptionTeacher {
        InterceptionTeacher {
            period_s,
            ..calibrated().teacher.clone()
        }
    }
}

impl Policy for InterceptionTeacher {
    fn act(&self, z: &[f64], a: &mut [f64]) {
        let phi = z[BALL_ANGLE];
        let speed_mps = z[TRAVEL_DELTA] / self.period_s;
        let rot_radps = z[HEADING_DELTA] / self.period_s;
        let want_rot = (self.k_turn * phi).clamp(-self.max_rot_radps, self.max_rot_radps);
        let want_speed = if phi.abs() > PI / 2.0 {
            self.cruise_mps * self.behind_frac
        } else {
            self.cruise_mps
        };
        a[TRANS_DELTA] = self.gain_speed * (want_speed - speed_mps);
        a[ROT_DELTA] = self.gain_rot * (want_rot - rot_radps);
    }
}

/// The teacher needs no per-episode state; as a [`Controller`] it simply acts.
impl Controller for InterceptionTeacher {
    fn act(&mut self, z: &[f64], a: &mut [f64]) {
        Policy::act(self, z, a)
    }
}
