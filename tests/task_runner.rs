//! The control loop: stopping rules, scoring on the true pose, sanitised actions, and what a
//! backend failure leaves behind.

use std::f64::consts::FRAC_PI_2;

use advise::backend::Backend;
use advise::backend::sim::{SimBackend, SimParams};
use advise::task::{Declared, Ending, Start, Task, TaskKind, episode_seed, run_episode, run_sim};
use advise::trace::Pose;
use common::Flaky;

mod common;

fn zero(_z: &[f64], a: &mut [f64]) {
    a.fill(0.0);
}

/// A run of the standard positioning task (its declaration) toward `goal`.
fn positioning(goal: Pose) -> Declared {
    Declared::new(
        advise::task::positioning_def(),
        &[goal.x_m, goal.y_m, goal.theta_rad],
    )
}

fn run_positioning(goal: Pose, policy: &dyn advise::policy::Policy) -> advise::task::Execution {
    let mut backend = SimBackend::new(SimParams::default(), 1);
    let mut task = positioning(goal);
    run_episode(&mut backend, &mut task, &mut &*policy, 1).unwrap()
}

#[test]
fn a_perfect_stop_at_the_goal_succeeds_and_a_point_1_01_m_away_does_not() {
    let at_goal = run_positioning(Pose::new(0.0, 0.0, 0.0), &zero);
    assert!(at_goal.outcome.success);
    assert_eq!(at_goal.outcome.ending, Ending::Rested);
    assert_eq!(at_goal.outcome.position_error_m, 0.0);
    assert_eq!(at_goal.outcome.heading_error_rad, Some(0.0));

    let far = run_positioning(Pose::new(1.01, 0.0, 0.0), &zero);
    assert!(!far.outcome.success);
    assert!((far.outcome.position_error_m - 1.01).abs() < 1e-12);

    let near = run_positioning(Pose::new(0.0, -0.99, 0.0), &zero);
    assert!(near.outcome.success);

    // Heading: pi/2 is the boundary.
    assert!(
        run_positioning(Pose::new(0.0, 0.0, FRAC_PI_2 - 0.01), &zero)
            .outcome
            .success
    );
    assert!(
        !run_positioning(Pose::new(0.0, 0.0, FRAC_PI_2 + 0.01), &zero)
            .outcome
            .success
    );
    // Headings wrap: -3.1 and 3.1 are 0.08 rad apart.
    let task = positioning(Pose::new(0.0, 0.0, -3.1));
    let s = task.score(Ending::Rested, Pose::new(0.0, 0.0, 3.1));
    assert!((s.heading_error_rad.unwrap() - (std::f64::consts::TAU - 6.2)).abs() < 1e-12);
}

#[test]
fn a_policy_at_rest_stops_after_half_a_second() {
    let e = run_positioning(Pose::new(2.0, 0.0, 0.0), &zero);
    assert_eq!(e.outcome.ending, Ending::Rested);
    assert_eq!(e.outcome.steps, 15);
    assert_eq!(e.trace.len(), 15);
    assert_eq!(e.outcome.length_m, 0.0);
}

#[test]
fn a_policy_that_never_rests_meets_the_time_limit() {
    let spin = |_z: &[f64], a: &mut [f64]| {
        a[0] = 0.0;
        a[1] = 0.5;
    };
    let e = run_positioning(Pose::new(2.0, 0.0, 0.0), &spin);
    assert_eq!(e.outcome.ending, Ending::TimeLimit);
    assert_eq!(e.outcome.steps, 1800);
    assert!((e.outcome.duration_s - 60.0).abs() < 1e-6);
}

/// The standard positioning declaration with another time limit, s.
fn positioning_with_limit(limit_s: u32) -> std::sync::Arc<advise::program::task::TaskDef> {
    let (name, text) = advise::check::STANDARD_SOURCES[0];
    let text = text.replace("end after 60", &format!("end after {limit_s}"));
    assert!(text.contains(&format!("end after {limit_s}")));
    let set = advise::check::check(&[advise::check::Source::new(name, text)]).unwrap();
    set.task("positioning").unwrap().clone()
}

#[test]
fn actions_are_clamped_and_nan_becomes_zero_as_recorded() {
    let wild = |_z: &[f64], a: &mut [f64]| {
        a[0] = 5.0;
        a[1] = f64::NAN;
    };
    let mut backend = SimBackend::new(SimParams::default(), 1);
    let mut task = Declared::new(positioning_with_limit(1), &[3.0, 0.0, 0.0]);
    let e = run_episode(&mut backend, &mut task, &mut &wild, 1).unwrap();
    assert_eq!(e.trace.a(0), &[1.0, 0.0]);
    assert!(e.outcome.length_m > 0.1);
}

#[test]
fn the_policy_sees_odometry_and_the_score_uses_the_true_pose() {
    // Drive a long curve: the odometry drifts, the trace keeps odometry poses, the outcome
    // the true one.
    let curve = |_z: &[f64], a: &mut [f64]| {
        a[0] = 0.8;
        a[1] = 0.3;
    };
    let mut backend = SimBackend::new(SimParams::default(), 3);
    let mut task = Declared::new(positioning_with_limit(20), &[3.0, 0.0, 0.0]);
    let e = run_episode(&mut backend, &mut task, &mut &curve, 3).unwrap();
    let odom = *e.trace.pose.as_ref().unwrap().last().unwrap();
    let truth = *e.true_poses.as_ref().unwrap().last().unwrap();
    assert_ne!(odom, truth);
    assert_eq!(e.outcome.final_pose, backend.true_pose().unwrap());
    let last_z = e.trace.z(e.trace.len() - 1);
    assert_eq!(
        last_z,
        &advise::task::positioning::observe(Pose::new(3.0, 0.0, 0.0), odom)
    );
}

#[test]
fn runs_are_deterministic_for_a_seed() {
    let kind = TaskKind::Positioning;
    let start = &kind.test_set()[3];
    let params = SimParams::default();
    let run = |seed| {
        let mut teacher = kind.teacher(params.period_s());
        run_sim(start, teacher.as_mut(), &params, seed)
    };
    let (a, b, c) = (run(9), run(9), run(10));
    assert_eq!(a.trace, b.trace);
    assert_eq!(a.outcome, b.outcome);
    assert_ne!(a.trace, c.trace);
    assert!(matches!(start, Start::Goal(_)));
}

#[test]
fn a_lost_link_returns_the_execution_so_far_and_stops_the_base() {
    let mut backend = Flaky::new(40);
    let kind = TaskKind::Positioning;
    let mut task = kind.test_set()[0].task();
    let mut teacher = kind.teacher(backend.period_s());
    let err = run_episode(
        &mut backend,
        task.as_mut(),
        teacher.as_mut(),
        episode_seed(0, 0),
    )
    .unwrap_err();
    assert!(backend.stopped);
    assert_eq!(err.execution.trace.len(), 41);
    assert_eq!(err.execution.outcome.ending, Ending::Interrupted);
    assert!(!err.execution.outcome.success);
    assert!(err.execution.outcome.length_m > 0.0);
    let out = advise::diag::render(&advise::diag::SourceMap::new(), &err, false);
    insta::assert_snapshot!(out);
}
