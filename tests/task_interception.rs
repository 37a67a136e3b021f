//! The interception task: the ball's world, the difference observations, integrated actions.

use advise::backend::sim::{SimBackend, SimParams};
use advise::backend::{Backend, BackendError, BaseState};
use advise::task::interception::{TEST_STARTS, practice_starts, test_starts};
use advise::task::{BallStart, Ending, Interception, InterceptionRules, Task, run_episode};
use advise::trace::Pose;

fn zero(_z: &[f64], a: &mut [f64]) {
    a.fill(0.0);
}

fn run(start: BallStart, policy: &dyn advise::policy::Policy) -> advise::task::Execution {
    let mut backend = SimBackend::new(SimParams::default(), 1);
    let mut task = Interception::new(start);
    run_episode(&mut backend, &mut task, &mut &*policy, 1).unwrap()
}

#[test]
fn a_ball_within_the_threshold_is_captured_and_one_outside_is_not() {
    let capture = InterceptionRules::default().capture_m;
    let near = run(
        BallStart {
            x_m: capture - 0.01,
            y_m: 0.0,
            vx_mps: 0.0,
            vy_mps: 0.0,
        },
        &zero,
    );
    assert_eq!(near.outcome.ending, Ending::Captured);
    assert!(near.outcome.success);
    assert_eq!(near.outcome.steps, 1);

    let far = run(
        BallStart {
            x_m: capture + 0.01,
            y_m: 0.0,
            vx_mps: 0.0,
            vy_mps: 0.0,
        },
        &zero,
    );
    assert_eq!(far.outcome.ending, Ending::TimeLimit);
    assert!(!far.outcome.success);
}

#[test]
fn a_ball_rolling_out_of_the_arena_ends_the_episode_as_a_failure() {
    let world = InterceptionRules::default();
    let x0 = world.arena_half_m - 0.5;
    let e = run(
        BallStart {
            x_m: x0,
            y_m: 0.0,
            vx_mps: 0.8,
            vy_mps: 0.0,
        },
        &zero,
    );
    assert_eq!(e.outcome.ending, Ending::BallOut);
    assert!(!e.outcome.success);
    // 0.5 m at 0.8 m/s slowing by `ball_decel_mps2`: 0.625 s without friction, a little more
    // with it, and whole control periods.
    let a = world.ball_decel_mps2;
    let exact = (0.8 - (0.64 - 2.0 * a * 0.5_f64).sqrt()) / a;
    let t = e.outcome.duration_s;
    let period = SimParams::default().period_s();
    assert!(
        t >= exact - 1e-9 && t < exact + 2.0 * period,
        "{t} vs {exact}"
    );
    let ball = e.ball.unwrap();
    assert_eq!(ball.len(), e.trace.len());
    assert_eq!(ball[0], [x0, 0.0]);
}

#[test]
fn a_rolling_ball_slows_and_stops() {
    let mut task = Interception::new(BallStart {
        x_m: 1.0,
        y_m: 0.0,
        vx_mps: 0.0,
        vy_mps: 0.5,
    });
    let state = BaseState::default();
    task.begin(&state);
    let mut t = 0.0;
    while t < 12.0 {
        task.advance(0.1, &state, None);
        t += 0.1;
    }
    // v^2 / (2 a) = 0.25 / 0.1 = 2.5 m.
    let b = task.ball_xy().unwrap();
    assert!((b[1] - 2.5).abs() < 1e-6, "{b:?}");
}

#[test]
fn observations_are_the_papers_six() {
    let mut task = Interception::new(BallStart {
        x_m: 0.0,
        y_m: 2.0,
        vx_mps: 0.3,
        vy_mps: 0.0,
    });
    let mut s = BaseState::default();
    task.begin(&s);
    let mut z = [0.0; 6];
    task.observe(&s, &mut z);
    assert_eq!(z[0], 2.0);
    assert!((z[1] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert_eq!(&z[2..], &[0.0; 4], "no differences before the first step");
    task.command(&s, &[0.0, 0.0]);
    // The robot moves 0.1 m forward and turns 0.05 rad; the ball rolls.
    s.pose = Pose::new(0.1, 0.0, 0.05);
    task.advance(0.1, &s, None);
    task.observe(&s, &mut z);
    let b = task.ball_xy().unwrap();
    let d = (b[0] - 0.1).hypot(b[1]);
    assert!((z[0] - d).abs() < 1e-12);
    assert!((z[2] - (d - 2.0)).abs() < 1e-12);
    assert!((z[4] - 0.1).abs() < 1e-12);
    assert!((z[5] - 0.05).abs() < 1e-12);
    let phi = (b[1]).atan2(b[0] - 0.1) - 0.05;
    assert!((z[1] - phi).abs() < 1e-12);
    assert!((z[3] - (phi - std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
}

/// Records the commands the loop sends.
struct Spy {
    inner: SimBackend,
    commands: Vec<(f64, f64)>,
}

impl Backend for Spy {
    fn name(&self) -> String {
        "spy".into()
    }
    fn period_s(&self) -> f64 {
        self.inner.period_s()
    }
    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        self.inner.reset(start)
    }
    fn command(&mut self, v: f64, w: f64) -> Result<(), BackendError> {
        self.commands.push((v, w));
        self.inner.command(v, w)
    }
    fn step(&mut self) -> Result<BaseState, BackendError> {
        self.inner.step()
    }
    fn stop(&mut self) -> Result<(), BackendError> {
        self.inner.stop()
    }
    fn true_pose(&self) -> Option<Pose> {
        self.inner.true_pose()
    }
}

#[test]
fn actions_are_changes_of_speed_integrated_and_clamped() {
    let push = |_z: &[f64], a: &mut [f64]| {
        a[0] = 0.1;
        a[1] = -0.2;
    };
    let mut spy = Spy {
        inner: SimBackend::new(SimParams::default(), 1),
        commands: Vec::new(),
    };
    let mut task = Interception::with_rules(
        // A still ball far behind, inside the calibrated arena (half-width 3 m): the run lasts
        // its whole second.
        BallStart {
            x_m: -2.9,
            y_m: -2.9,
            vx_mps: 0.0,
            vy_mps: 0.0,
        },
        InterceptionRules {
            time_limit_s: 1.0,
            ..Default::default()
        },
    );
    run_episode(&mut spy, &mut task, &mut &push, 0).unwrap();
    let c = &spy.commands;
    assert!((c[0].0 - 0.1).abs() < 1e-12 && (c[0].1 + 0.2).abs() < 1e-12);
    assert!((c[2].0 - 0.3).abs() < 1e-12 && (c[2].1 + 0.6).abs() < 1e-12);
    assert_eq!(c[20], (1.0, -1.0));
}

#[test]
fn test_and_practice_starts_are_uniform_in_the_documented_ranges_and_disjoint() {
    let r = InterceptionRules::default();
    let test = test_starts();
    assert_eq!(test.len(), TEST_STARTS);
    assert_eq!(test, test_starts());
    let practice = practice_starts(advise::task::interception::TEST_SEED, 200);
    for s in test.iter().chain(&practice) {
        let d = s.x_m.hypot(s.y_m);
        let v = s.vx_mps.hypot(s.vy_mps);
        assert!(d >= r.ball_dist_m.0 - 1e-12 && d <= r.ball_dist_m.1 + 1e-12);
        assert!(v >= r.ball_speed_mps.0 - 1e-12 && v <= r.ball_speed_mps.1 + 1e-12);
    }
    assert!(test.iter().all(|s| !practice.contains(s)));
    // Uniform bearing: every quadrant is visited.
    for q in 0..4 {
        assert!(practice.iter().any(|s| {
            let b = s.y_m.atan2(s.x_m);
            ((b + std::f64::consts::PI) / std::f64::consts::FRAC_PI_2) as usize == q
        }));
    }
}
