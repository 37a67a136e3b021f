//! From typing `advise OP` to the re-derived policy being ready, with a dataset of about 10,000
//! points: parse the statement, apply the operator to the selection, add the points with their
//! provenance, update the policy. One advice statement per iteration (the dataset grows by a
//! chunk's worth each time, as in a session). Both learners: A-OPI's LWR on positioning (the
//! learner advice is for) and BC's 1-NN on interception.

use advise::session::{Session, SessionOptions};
use advise::task::TaskKind;
use criterion::{Criterion, criterion_group, criterion_main};

fn session(task: TaskKind, demos: usize, run: &str) -> Session {
    let mut s = Session::new(SessionOptions {
        task,
        default_demos: demos,
        ..SessionOptions::default()
    })
    .unwrap();
    let n = s.learner().len();
    assert!((9_000..13_000).contains(&n), "about 10,000 points, not {n}");
    s.execute(run, "<bench>").unwrap();
    s.execute("select 0..30", "<bench>").unwrap();
    s
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("session");
    let mut lwr = session(TaskKind::Positioning, 46, "run goal 2 -1 0");
    eprintln!("positioning: {} points", lwr.learner().len());
    g.bench_function("advise_to_ready_10k_lwr", |b| {
        b.iter(|| lwr.execute("advise speed_up(0.1)", "<bench>").unwrap())
    });
    let mut bc = session(TaskKind::Interception, 52, "run start 0");
    eprintln!("interception: {} points", bc.learner().len());
    g.bench_function("advise_to_ready_10k_bc", |b| {
        b.iter(|| bc.execute("advise speed_up(0.1)", "<bench>").unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
