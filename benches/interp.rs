//! Applying an operator to a long chunk: 1,000,000 points through `translational_acceleration`
//! (the target is under 20 ms on one core), plus a guarded operator, a composition and an
//! observation-side operator with offset reads for comparison.

use std::hint::black_box;

use advise::check::{self, OperatorSet};
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::interp;
use advise::syntax::parse_invocation;
use advise::trace::{Chunk, Trace};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const POINTS: usize = 1_000_000;

fn long_trace() -> Trace {
    let d = Domain::positioning();
    let mut tr = Trace::new(&d);
    for i in 0..POINTS {
        let f = i as f64;
        let rot = if i % 7 == 0 {
            0.0
        } else {
            0.3 * (f * 0.001).sin()
        };
        tr.push(
            f / 30.0,
            &[(f * 1e-4) % 100.0, (f * 0.01).sin(), (f * 0.02).cos()],
            &[0.4 + 0.1 * (f * 0.003).sin(), rot],
            None,
        );
    }
    tr
}

fn bench(c: &mut Criterion) {
    let set = OperatorSet::standard();
    let tr = long_trace();
    let chunk = Chunk::all(tr.len());
    let mut g = c.benchmark_group("apply_1M_points");
    g.throughput(Throughput::Elements(POINTS as u64));
    g.sample_size(20);
    for op in [
        "translational_acceleration",
        "no_turning",
        "brake_straight",
        "start_turning_earlier(steps = 10)",
    ] {
        let inv = parse_invocation(op).unwrap();
        // Binding is part of what a teacher's `advise` costs, so it stays inside the loop.
        g.bench_function(op, |b| {
            b.iter(|| {
                let call =
                    check::bind(&mut SourceMap::new(), &set, &tr.domain, black_box(&inv)).unwrap();
                interp::apply(&call, black_box(&tr), chunk).unwrap()
            })
        });
    }
    // The same with the output buffers reused (no fresh pages to fault in).
    let inv = parse_invocation("translational_acceleration").unwrap();
    let call = check::bind(&mut SourceMap::new(), &set, &tr.domain, &inv).unwrap();
    let mut out = interp::apply(&call, &tr, chunk).unwrap();
    g.bench_function("translational_acceleration, reused output", |b| {
        b.iter(|| {
            let call =
                check::bind(&mut SourceMap::new(), &set, &tr.domain, black_box(&inv)).unwrap();
            interp::apply_into(&call, black_box(&tr), chunk, &mut out).unwrap()
        })
    });
    // The floor: copying the bytes a 1M-point result holds (t, z, a, indices), nothing computed.
    g.bench_function("memcpy floor (t, z, a, indices)", |b| {
        b.iter(|| {
            let t = black_box(&tr.t).clone();
            let z = black_box(&tr.z).clone();
            let a = black_box(&tr.a).clone();
            let i: Vec<usize> = (0..POINTS).collect();
            black_box((t, z, a, i))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
