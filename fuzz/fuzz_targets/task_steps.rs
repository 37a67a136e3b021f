//! Arbitrary bytes through parse and check, then a few control steps of every task the file
//! declares, its teacher driving (goal draws, values, end rules, scores): nothing may panic. The
//! application's half of what `parse_check` does for the language; `tests/hostile_tasks.rs` runs
//! the same exercise over mutated task files in CI.
#![no_main]

use advise::check::{OperatorSet, Source};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(set) = OperatorSet::standard().merge(&[Source::new("fuzz.adv", text)]) {
        run_tasks(&set);
    }
});

/// A few control steps of each task a file declares, its teacher driving, on made-up states that
/// move: goal draws, values, end rules and scores must not panic.
fn run_tasks(set: &advise::program::OperatorSet) {
    use advise::backend::BaseState;
    use advise::task::{Controller, Declared, Ending, Task, TaskKind, declared};
    for def in set.tasks() {
        let goal = declared::practice_goal(def, 1, 0);
        let _ = declared::test_goals(def);
        let mut task = Declared::new(def.clone(), &goal);
        let mut teacher = TaskKind::Declared(def.clone()).teacher(1.0 / 30.0);
        let mut state = BaseState::default();
        task.begin(&state);
        teacher.begin(0);
        let mut z = vec![0.0; def.domain.obs_dim()];
        let mut a = vec![0.0; def.domain.act_dim()];
        for i in 0..5 {
            task.observe(&state, &mut z);
            teacher.act(&z, &mut a);
            let (v, w) = task.command(&state, &a);
            state.t_s = f64::from(i + 1) / 30.0;
            state.speed_mps = v;
            state.rot_radps = w;
            state.pose.x_m += v / 30.0;
            state.pose.theta_rad += w / 30.0;
            if task.advance(1.0 / 30.0, &state, None).is_some() {
                break;
            }
        }
        let _ = task.score(Ending::TimeLimit, state.pose);
    }
}
