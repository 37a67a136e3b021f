//! From typing `advise OP` to the re-derived policy being ready, with a dataset of about 10,000
//! points: parse the statement, apply the operator to the selection, add the points with their
//! provenance, update the policy. One advice statement per iteration (the dataset grows by a
//! chunk's worth each time, as in a session).

use advise::session::{Session, SessionOptions};
use advise::task::TaskKind;
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Interception,
        default_demos: 52,
        ..SessionOptions::default()
    })
    .unwrap();
    let n = s.learner().len();
    assert!((9_000..12_000).contains(&n), "about 10,000 points, not {n}");
    s.execute("run start 0", "<bench>").unwrap();
    s.execute("select 0..30", "<bench>").unwrap();
    c.bench_function("advise_to_ready_10k", |b| {
        b.iter(|| s.execute("advise speed_up(0.1)", "<bench>").unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
