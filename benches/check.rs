//! Checking long input: 40,000 operators (2.6 MB; every tenth with a doc comment, every tenth a
//! composition of the one before) on top of the standard library, which must stay linear (the
//! target is under 1 s); and splitting a script of 8,000 lines inside one unclosed `{`.

use std::hint::black_box;

use advise::check::{OperatorSet, Source};
use advise::session::script;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const OPERATORS: usize = 40_000;

fn many_operators() -> String {
    (0..OPERATORS)
        .map(|i| match i % 10 {
            0 => format!(
                "/// Op {i}: a little faster.\noperator op{i} for positioning on action {{ trans *= 1.01 }}\n"
            ),
            9 => format!(
                "operator op{i} for positioning on action = op{} then op{}\n",
                i - 1,
                i - 1
            ),
            _ => format!("operator op{i} for positioning on action {{ trans *= 1.01 }}\n"),
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let std = OperatorSet::standard();
    let text = many_operators();
    let mut g = c.benchmark_group("check");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.bench_function("40k_operators", |b| {
        b.iter(|| {
            let set = std
                .merge(&[Source::new("many.adv", text.as_str())])
                .expect("the generated operators check");
            black_box(set.operator_count())
        })
    });
    let unclosed = format!(
        "operator creep for positioning on action {{\n{}",
        "  trans = 0.1\n".repeat(8000)
    );
    g.throughput(Throughput::Bytes(unclosed.len() as u64));
    g.bench_function("split_unclosed_8k_lines", |b| {
        b.iter(|| black_box(script::statements(&unclosed).len()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
