//! The teachers: good enough to learn from, imperfect enough to improve on, and learnable: a
//! 1-NN policy over their demonstrations drives exactly as they did from the same starts.

use advise::backend::sim::SimParams;
use advise::eval::{EvalOptions, evaluate_teacher};
use advise::policy::Policy;
use advise::task::{Ending, TaskKind, episode_seed, record_demos, recorded_at, run_sim};
use advise::trace::Episode;

/// Brute-force 1-NN over observations scaled inversely with each dimension's data range.
struct OneNn {
    od: usize,
    ad: usize,
    z: Vec<f64>,
    a: Vec<f64>,
    scale: Vec<f64>,
}

impl OneNn {
    fn new(episodes: &[Episode]) -> OneNn {
        let od = episodes[0].trace.obs_dim();
        let ad = episodes[0].trace.act_dim();
        let z: Vec<f64> = episodes.iter().flat_map(|e| e.trace.z.clone()).collect();
        let a: Vec<f64> = episodes.iter().flat_map(|e| e.trace.a.clone()).collect();
        let scale = (0..od)
            .map(|j| {
                let col = z.iter().skip(j).step_by(od);
                let lo = col.clone().copied().fold(f64::INFINITY, f64::min);
                let hi = col.copied().fold(f64::NEG_INFINITY, f64::max);
                if hi > lo { 1.0 / (hi - lo) } else { 1.0 }
            })
            .collect();
        OneNn {
            od,
            ad,
            z,
            a,
            scale,
        }
    }
}

impl Policy for OneNn {
    fn act(&self, q: &[f64], out: &mut [f64]) {
        let mut best = (f64::INFINITY, 0);
        for i in 0..self.z.len() / self.od {
            let d: f64 = (0..self.od)
                .map(|j| ((self.z[i * self.od + j] - q[j]) * self.scale[j]).powi(2))
                .sum();
            if d < best.0 {
                best = (d, i);
            }
        }
        out.copy_from_slice(&self.a[best.1 * self.ad..(best.1 + 1) * self.ad]);
    }
}

fn often_but_not_always(kind: TaskKind) -> (f64, f64) {
    let test = evaluate_teacher(
        kind.clone(),
        &EvalOptions {
            seed: 0,
            ..Default::default()
        },
    );
    let demos = record_demos(kind.clone(), 100, 11, &SimParams::default());
    let demo_rate = demos.iter().filter(|(_, o)| o.success).count() as f64 / 100.0;
    (test.success_rate, demo_rate)
}

#[test]
fn the_positioning_teacher_succeeds_often_but_not_always() {
    let (test, demos) = often_but_not_always(TaskKind::Positioning);
    // Measured: 96% on the test set (seed 0), 82% over 100 practice goals (seed 11).
    assert!((0.7..1.0).contains(&test), "test set: {test}");
    assert!((0.7..1.0).contains(&demos), "practice goals: {demos}");
}

#[test]
fn the_interception_teacher_succeeds_often_but_not_always() {
    let (test, demos) = often_but_not_always(TaskKind::Interception);
    // Calibrated to the paper's 62% (`advise calibrate bc`); measured: 66% on the test set
    // (seed 0), 55% over 100 practice starts (seed 11).
    assert!((0.45..0.8).contains(&test), "test set: {test}");
    assert!((0.45..0.8).contains(&demos), "practice starts: {demos}");
}

#[test]
fn the_interception_teacher_loops_and_overshoots() {
    // Suboptimal on purpose: some captures take far longer paths than the straight-line
    // distance, and some runs orbit the ball until the time limit.
    let r = evaluate_teacher(TaskKind::Interception, &EvalOptions::default());
    let starts = advise::task::interception::test_starts();
    let detours = r
        .outcomes
        .iter()
        .zip(&starts)
        .filter(|(o, s)| o.success && o.length_m > 2.0 * s.x_m.hypot(s.y_m))
        .count();
    assert!(detours >= 5, "{detours} detours");
    assert!(r.outcomes.iter().any(|o| o.ending == Ending::TimeLimit));
}

fn reproduces(kind: TaskKind) {
    let params = SimParams::default();
    let seed = 21;
    let demos = record_demos(kind.clone(), 12, seed, &params);
    let episodes: Vec<Episode> = demos.iter().map(|(e, _)| e.clone()).collect();
    let policy = OneNn::new(&episodes);
    let stand_in = advise::eval::derive_policy(
        advise::policy::learner::LearnerKind::Bc,
        &kind.domain(),
        &episodes,
    )
    .unwrap();
    let starts = kind.practice_set(seed, 12);
    for (i, ((demo, outcome), start)) in demos.iter().zip(&starts).enumerate() {
        for p in [&policy as &dyn Policy, stand_in.as_ref()] {
            let exec = run_sim(start, &mut &*p, &params, episode_seed(seed, i as u64));
            assert_eq!(exec.trace, demo.trace, "{kind} demo {i}");
            assert_eq!(&exec.outcome, outcome, "{kind} demo {i}");
        }
    }
}

/// Positioning demonstrations are recorded at 15 Hz (every second control step, issue 33), so the
/// odd steps' actions are not in the data and a 1-NN policy cannot replay the teacher step for
/// step as it does for interception. What must hold instead: each demonstration is exactly the
/// teacher's own drive from its start, every second point of it, outcome and all.
#[test]
fn positioning_demos_are_the_teachers_own_drives_recorded_at_15_hz() {
    let kind = TaskKind::Positioning;
    assert_eq!(kind.record_every(), 2);
    let params = SimParams::default();
    let seed = 21;
    let demos = record_demos(kind.clone(), 12, seed, &params);
    let starts = kind.practice_set(seed, 12);
    for (i, ((demo, outcome), start)) in demos.iter().zip(&starts).enumerate() {
        let mut teacher = kind.teacher(params.period_s());
        let exec = run_sim(
            start,
            teacher.as_mut(),
            &params,
            episode_seed(seed, i as u64),
        );
        assert_eq!(
            recorded_at(&exec.trace, 2).len(),
            exec.trace.len().div_ceil(2)
        );
        assert_eq!(recorded_at(&exec.trace, 2), demo.trace, "demo {i}");
        assert_eq!(&exec.outcome, outcome, "demo {i}");
    }
}

#[test]
fn one_nn_on_interception_demos_reproduces_the_teacher_on_its_starts() {
    reproduces(TaskKind::Interception);
}
