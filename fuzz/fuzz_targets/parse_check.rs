//! Arbitrary bytes through parse and check (on top of the standard operators), rendering every
//! diagnostic, through every operator that checks, and through a few control steps of every task
//! a file declares (goal draws, values, end rules, scores): nothing may panic. The proptests in
//! `tests/props.rs` run the same exercise over random text in CI, and
//! `tests/hostile_tasks.rs` over mutated task files.
#![no_main]

use advise::check::{OperatorSet, Source, render_all};
use advise::domain::Domain;
use advise::interp;
use advise::syntax::{self, Invocation};
use advise::trace::{Chunk, Trace};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let (map, id) = advise::diag::SourceMap::single("line", text);
    let _ = syntax::parse_item(map.src(id));
    let _ = syntax::parse_invocation(text);
    match OperatorSet::standard().merge(&[Source::new("fuzz.adv", text)]) {
        Err(e) => {
            let _ = render_all(&e);
        }
        Ok(set) => {
            let d = Domain::positioning();
            let mut tr = Trace::new(&d);
            for i in 0..6 {
                let rot = if i % 2 == 0 { 0.0 } else { 0.2 };
                tr.push(i as f64, &[1.0, 0.1, -0.1], &[0.5, rot], None);
            }
            for name in set.operator_names("positioning") {
                let mut map = advise::diag::SourceMap::new();
                if let Ok(call) =
                    advise::check::bind(&mut map, &set, &tr.domain, &Invocation::bare(name))
                {
                    let _ = interp::apply(&call, &tr, Chunk::all(6));
                }
            }
            run_tasks(&set);
        }
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
