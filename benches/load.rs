//! Loading demonstrations: `load demos teacher:500` from the recorded episodes to the policy
//! ready. The 500 positioning demonstrations (about 110,000 points) are recorded once, outside the
//! timed part; each iteration adds them to a fresh LWR learner and derives it (range scaling, both
//! indexes, LWR tuned by cross-validation), which is what the session does after recording, and answers one query (the
//! first query builds the indexes' bulk trees).

use advise::backend::sim::SimParams;
use advise::policy::Policy;
use advise::policy::learner::Learner;
use advise::task::{TaskKind, record_demos};
use advise::trace::Episode;
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let kind = TaskKind::Positioning;
    let episodes: Vec<Episode> = record_demos(kind.clone(), 500, 0xD3E0, &SimParams::default())
        .into_iter()
        .map(|(e, _)| e)
        .collect();
    let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
    eprintln!("load_demos_500: {points} points");
    let domain = kind.domain();
    let mut g = c.benchmark_group("load");
    g.sample_size(10);
    g.bench_function("load_demos_500", |b| {
        b.iter(|| {
            let mut l = Learner::new(&domain, kind.learner(), 0);
            l.add_demonstrations(&episodes).unwrap();
            // Ready means answering: the first query builds the indexes' bulk trees.
            let mut a = [0.0; 2];
            l.act(episodes[0].trace.z(0), &mut a);
            (l, a)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
