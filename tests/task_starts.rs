//! Practice starts: start N is computed directly (no list of N starts is built), it is the same
//! start the sequential generator draws, and numbers past the documented maximum are refused with
//! a coded diagnostic.

use advise::task::{MAX_PRACTICE_START, Start, TaskKind};

#[test]
fn start_n_is_the_nth_of_the_practice_set() {
    for kind in [TaskKind::Positioning, TaskKind::Interception] {
        for seed in [0, 1, 7, 0xD3E0, u64::MAX] {
            let set = kind.practice_set(seed, 300);
            for (i, want) in set.iter().enumerate() {
                let got = kind.practice_start(seed, i as u64).unwrap();
                assert_eq!(&got, want, "{kind} seed {seed} start {i}");
            }
        }
    }
}

#[test]
fn the_last_start_is_drawn_at_once_and_in_range() {
    use advise::task::positioning::{GOAL_THETA_RAD, GOAL_X_M, GOAL_Y_M};
    for kind in [TaskKind::Positioning, TaskKind::Interception] {
        let last = kind.practice_start(3, MAX_PRACTICE_START).unwrap();
        let before = kind.practice_start(3, MAX_PRACTICE_START - 1).unwrap();
        assert_ne!(last, before);
        match last {
            Start::Goal(g) => {
                assert!((GOAL_X_M.0..GOAL_X_M.1).contains(&g.x_m), "{g:?}");
                assert!((GOAL_Y_M.0..GOAL_Y_M.1).contains(&g.y_m), "{g:?}");
                assert!((GOAL_THETA_RAD.0..GOAL_THETA_RAD.1).contains(&g.theta_rad));
            }
            Start::Ball(b) => {
                let w = advise::task::InterceptionRules::default();
                let d = b.x_m.hypot(b.y_m);
                let (lo, hi) = w.ball_dist_m;
                assert!((lo - 1e-12..=hi + 1e-12).contains(&d), "{b:?}");
                assert!(
                    b.vx_mps.hypot(b.vy_mps) <= w.ball_speed_mps.1 + 1e-12,
                    "{b:?}"
                );
            }
            other => panic!("not a start of the paper's tasks: {other:?}"),
        }
    }
}

#[test]
fn starts_past_the_maximum_are_refused() {
    for index in [MAX_PRACTICE_START + 1, u64::MAX] {
        let e = TaskKind::Interception.practice_start(0, index).unwrap_err();
        let code = miette::Diagnostic::code(&e).unwrap().to_string();
        assert_eq!(code, "advise::task::practice_start_out_of_range");
        assert_eq!(
            e.to_string(),
            format!(
                "there is no practice start {index}: practice starts are numbered 0 to 999999999"
            )
        );
    }
}

/// Positioning runs by its declaration: the goals it draws from `goal ... in [..]` and `test 25
/// seed ...` are the paper task's goals as the Rust reference draws them, bit for bit.
#[test]
fn the_declared_positioning_goals_are_the_reference_goals() {
    use advise::task::positioning;
    let as_starts =
        |goals: Vec<advise::geometry::Pose>| goals.into_iter().map(Start::Goal).collect::<Vec<_>>();
    let kind = TaskKind::Positioning;
    assert_eq!(kind.test_set(), as_starts(positioning::test_goals()));
    for seed in [0, 1, 7, u64::MAX] {
        assert_eq!(
            kind.practice_set(seed, 40),
            as_starts(positioning::practice_goals(seed, 40))
        );
        for i in [0, 1, 39, 1_000_000] {
            assert_eq!(
                kind.practice_start(seed, i).unwrap(),
                Start::Goal(positioning::practice_goal(seed, i))
            );
        }
    }
}
