//! The language server's latency on a large file: one change of a 1,000-operator document (every
//! tenth with a doc comment, every tenth a composition; one misspelt dimension so there is a
//! diagnostic to publish) re-checked on top of the standard library and converted to protocol
//! diagnostics, as `advise lsp` does on each `didChange`. Target: well under 100 ms. Also the
//! completion list inside the last operator and a hover on a dimension there, each asked of the
//! document's analysis as the server keeps it (built once per version, not per request), and the
//! same hover with the document analysed for it (`hover_1000_operators_cold`, what every hover
//! cost before the server kept its analyses).

use std::hint::black_box;

use advise_lsp::{analysis, publish};
use criterion::{Criterion, criterion_group, criterion_main};

const OPERATORS: usize = 1_000;

fn document() -> String {
    let mut text: String = (0..OPERATORS)
        .map(|i| match i % 10 {
            0 => format!(
                "/// Op {i}: a little faster.\noperator op{i}(f = 1.01 in [1, 2]) for positioning on action where trans != 0 {{\n  trans *= f\n}}\n\n"
            ),
            9 => format!(
                "operator op{i} for positioning on action = op{} then op{}\n\n",
                i - 1,
                i - 1
            ),
            _ => format!("operator op{i} for positioning on action {{\n  trans *= 1.01\n}}\n\n"),
        })
        .collect();
    text.push_str("operator last for positioning on action {\n  rott = 0\n}\n");
    text
}

fn bench(c: &mut Criterion) {
    let text = document();
    let d = publish("file:///bench/many.adv", &text);
    assert_eq!(d.len(), 1, "one diagnostic: {d:?}");
    eprintln!(
        "lsp: a {}-byte document of {} operators",
        text.len(),
        OPERATORS + 1
    );
    let mut g = c.benchmark_group("lsp");
    g.bench_function("diagnostics_1000_operators", |b| {
        b.iter(|| black_box(publish("file:///bench/many.adv", black_box(&text)).len()))
    });
    let kept = analysis::Analysis::new("many.adv", text.clone());
    let at = text.rfind("rott").unwrap();
    g.bench_function("completion_1000_operators", |b| {
        b.iter(|| black_box(kept.completion(black_box(at)).len()))
    });
    let hover_at = text.rfind("trans *= 1.01").unwrap() + 1;
    assert!(kept.hover(hover_at).is_some());
    g.bench_function("hover_1000_operators", |b| {
        b.iter(|| black_box(kept.hover(black_box(hover_at)).is_some()))
    });
    g.bench_function("hover_1000_operators_cold", |b| {
        b.iter(|| black_box(analysis::hover(black_box(&text), hover_at).is_some()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
