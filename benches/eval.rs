//! The evaluation harness's speed: a BC (1-NN) policy of 10,000 points from teacher
//! demonstrations, run over the 100 interception test starts in parallel.
//!
//! Target: under 2 s on the project's 2-core machine. `interception_100_starts_bc_10k` runs the
//! real BC learner (kd-tree, weighted 1-NN) that `advise eval --policy bc` derives;
//! `..._brute_force` runs the linear-scan reference 1-NN, the same answers at a scan's cost.

use std::hint::black_box;

use advise::backend::sim::SimParams;
use advise::eval::{EvalOptions, NearestNeighbour, evaluate};
use advise::policy::learner::LearnerKind;
use advise::task::{TaskKind, record_demos};
use advise::trace::{Chunk, Episode};
use criterion::{Criterion, criterion_group, criterion_main};

/// Teacher demonstrations cut to exactly `points` points.
fn dataset(kind: TaskKind, points: usize) -> Vec<Episode> {
    let mut eps: Vec<Episode> = record_demos(kind, 200, 1, &SimParams::default())
        .into_iter()
        .map(|(e, _)| e)
        .collect();
    let mut total = 0;
    eps.retain_mut(|e| {
        if total >= points {
            return false;
        }
        let keep = e.trace.len().min(points - total);
        e.trace = e.trace.slice(Chunk::all(keep));
        total += keep;
        true
    });
    assert_eq!(
        total, points,
        "not enough demonstrations for {points} points"
    );
    eps
}

fn bench(c: &mut Criterion) {
    let kind = TaskKind::Interception;
    let eps = dataset(kind.clone(), 10_000);
    let policy = NearestNeighbour::new(&kind.domain(), &eps).unwrap();
    assert_eq!(policy.len(), 10_000);
    let opts = EvalOptions::default();
    let report = evaluate(kind.clone(), &policy, &opts);
    let steps: usize = report.outcomes.iter().map(|o| o.steps).sum();
    eprintln!(
        "1-NN (10,000 points) on {} interception starts: {} policy queries, success {:.0}%",
        report.episodes,
        steps,
        100.0 * report.success_rate
    );
    let mut g = c.benchmark_group("eval");
    g.sample_size(10);
    let learner = advise::eval::derive_policy(LearnerKind::Bc, &kind.domain(), &eps).unwrap();
    g.bench_function("interception_100_starts_bc_10k", |b| {
        b.iter(|| black_box(evaluate(kind.clone(), black_box(learner.as_ref()), &opts)))
    });
    g.bench_function("interception_100_starts_bc_10k_brute_force", |b| {
        b.iter(|| black_box(evaluate(kind.clone(), black_box(&policy), &opts)))
    });
    let teacher_opts = opts.clone();
    g.bench_function("interception_100_starts_teacher", |b| {
        b.iter(|| black_box(advise::eval::evaluate_teacher(kind.clone(), &teacher_opts)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
