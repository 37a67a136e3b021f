//! Whole experiments at the paper's protocol and length, one seed each: the BC study (100
//! demonstrations, 120 critique rounds, 100 test starts every 20 rounds) and the A-OPI study (9
//! seed demonstrations, three arms of up to 120 practice goals stopped by the calibrated
//! patience, so they run about as long as the paper's 60-69 executions, 25 test goals every 5),
//! with the arms re-tuning LWR warm after each advised execution (`Retune::Warm`).
//!
//! Targets (issue 22): the A-OPI study under 15 s a seed on the project's 2-core machine; BC well
//! under it. Few samples: one iteration is a whole study.

use std::hint::black_box;
use std::time::Duration;

use advise::experiment::{aopi, bc};
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("experiment");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(5));
    let bc_params = bc::BcParams::default();
    g.bench_function("bc_seed0", |b| {
        b.iter(|| black_box(bc::run(0, &bc_params, false)))
    });
    // The paper's study: baseline and its three arms, as the README's speed row has measured it
    // (the takeover arm, issue 53, is ours and would add a fourth).
    let aopi_params = aopi::AopiParams {
        takeover_arm: false,
        ..aopi::AopiParams::default()
    };
    g.bench_function("aopi_seed0", |b| {
        b.iter(|| black_box(aopi::run(0, &aopi_params, false)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
