//! Invariants of the tasks and of the evaluation summary.

use std::f64::consts::PI;

use advise::backend::BaseState;
use advise::eval::Report;
use advise::task::positioning::observe;
use advise::task::{BallStart, Ending, Interception, Outcome, Task, TaskKind};
use advise::trace::Pose;
use proptest::prelude::*;

fn pose() -> impl Strategy<Value = Pose> {
    (-10.0..10.0f64, -10.0..10.0f64, -20.0..20.0f64).prop_map(|(x, y, t)| Pose::new(x, y, t))
}

proptest! {
    /// The positioning observation is a squared distance and two wrapped angles; at the goal it is
    /// all zeros.
    #[test]
    fn positioning_observations_are_in_range(goal in pose(), at in pose()) {
        let z = observe(goal, at);
        prop_assert!(z[0] >= 0.0);
        prop_assert!(z[1] > -PI && z[1] <= PI);
        prop_assert!(z[2] > -PI && z[2] <= PI);
        let g = Pose::new(goal.x_m, goal.y_m, advise::backend::sim::wrap_angle(goal.theta_rad));
        prop_assert_eq!(observe(g, g), [0.0, 0.0, 0.0]);
    }

    /// Whatever the actions, the interception task's integrated command stays within its limits.
    #[test]
    fn interception_commands_stay_within_limits(
        actions in proptest::collection::vec((-3.0..3.0f64, -3.0..3.0f64), 1..200),
    ) {
        let mut task = Interception::new(BallStart::default());
        let state = BaseState::default();
        task.begin(&state);
        let r = task.rules().clone();
        for (dv, dw) in actions {
            let (v, w) = task.command(&state, &[dv, dw]);
            prop_assert!(v.abs() <= r.max_speed_mps && w.abs() <= r.max_rot_radps);
        }
    }
}

fn outcome(success: bool, err: f64, len: f64) -> Outcome {
    Outcome {
        success,
        ending: if success {
            Ending::Captured
        } else {
            Ending::BallOut
        },
        position_error_m: err,
        heading_error_rad: None,
        length_m: len,
        efficiency: None,
        steps: 10,
        duration_s: 1.0,
        final_pose: Pose::default(),
        non_finite: None,
        end_rule: None,
    }
}

/// A report counts the `end when` rules that ended its episodes, by their text, in its JSON; a
/// report or outcome written before the rule was kept (no `end_rule`, no `end_rules`) still reads.
#[test]
fn reports_name_the_rules_that_ended_episodes_and_older_reports_still_read() {
    let ruled = |rule: &str| Outcome {
        ending: Ending::Rule,
        end_rule: Some(rule.to_string()),
        ..outcome(false, 0.5, 1.0)
    };
    let report = Report::from_outcomes(
        TaskKind::Positioning,
        0,
        vec![
            ruled("end when range < 0.3"),
            ruled("end when t > 10"),
            ruled("end when t > 10"),
            outcome(true, 0.1, 1.0),
        ],
    );
    assert_eq!(report.endings["rule"], 3);
    assert_eq!(report.end_rules["end when t > 10"], 2);
    assert_eq!(report.end_rules["end when range < 0.3"], 1);
    assert!(
        report
            .render()
            .contains("ended by            `end when range < 0.3` 1, `end when t > 10` 2")
    );
    let mut json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["outcomes"][0]["end_rule"], "end when range < 0.3");
    json.as_object_mut().unwrap().remove("end_rules");
    for o in json["outcomes"].as_array_mut().unwrap() {
        o.as_object_mut().unwrap().remove("end_rule");
    }
    let old: Report = serde_json::from_value(json).unwrap();
    assert!(old.end_rules.is_empty() && old.outcomes.iter().all(|o| o.end_rule.is_none()));
    assert!(!old.render().contains("ended by"));
}

#[test]
fn reports_summarise_outcomes() {
    let r = Report::from_outcomes(
        TaskKind::Interception,
        7,
        vec![
            outcome(true, 0.2, 2.0),
            outcome(false, 1.0, 6.0),
            outcome(true, 0.3, 3.0),
            outcome(false, 2.5, 1.0),
        ],
    );
    assert_eq!((r.episodes, r.successes), (4, 2));
    assert_eq!(r.success_rate, 0.5);
    assert!((r.mean_position_error_m - 1.0).abs() < 1e-12);
    assert_eq!(r.mean_heading_error_rad, None);
    assert_eq!(r.mean_length_m, 3.0);
    assert_eq!(r.mean_length_success_m, Some(2.5));
    assert_eq!(r.endings["captured"], 2);
    assert_eq!(r.endings["ball_out"], 2);
    let json = serde_json::to_value(&r).unwrap();
    assert!(json.get("mean_heading_error_rad").is_none());

    let empty = Report::from_outcomes(TaskKind::Positioning, 0, vec![]);
    assert_eq!(empty.success_rate, 0.0);
    assert_eq!(empty.mean_length_success_m, None);
}
