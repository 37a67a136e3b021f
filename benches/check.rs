//! Checking long input: 40,000 operators (2.6 MB; every tenth with a doc comment, every tenth a
//! composition of the one before) on top of the standard library, which must stay linear (the
//! target is under 1 s); a 50 MB file of the standard operators renamed over and over, without
//! their doc comments (issue 31: the target is under 5 s, and under 1 GB, which
//! `/usr/bin/time -v advise check` measures on the file `benches/large_operators.py --bare`
//! writes); and splitting a script of 8,000 lines inside one unclosed `{`.

use std::hint::black_box;

use advise::check::{OperatorSet, Source};
use advise::session::script;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// The binary's allocator (see `src/main.rs`), so the figures are the command's.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

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

/// The standard operators (each with its `///` lines unless `bare`), domains left out: an item
/// starts at its doc comment or `operator` line and ends at the first blank or comment line.
fn standard_operators(bare: bool) -> Vec<String> {
    let mut items = Vec::new();
    for (_, text) in advise::check::STANDARD_SOURCES {
        let (mut docs, mut current): (Vec<&str>, Option<Vec<&str>>) = (Vec::new(), None);
        for line in text.lines().chain([""]) {
            let starts = line.starts_with("operator ") || line.starts_with("domain ");
            let ends = starts
                || line.starts_with("///")
                || line.trim().is_empty()
                || line.starts_with("// ");
            if ends
                && let Some(c) = current
                    .take()
                    .filter(|c| c.iter().any(|l| l.starts_with("operator ")))
            {
                items.push(c.join("\n") + "\n");
            }
            if line.starts_with("///") {
                if !bare {
                    docs.push(line);
                }
            } else if starts {
                current = Some(docs.drain(..).chain([line]).collect());
            } else if let Some(c) = current.as_mut() {
                c.push(line);
            } else {
                docs.clear();
            }
        }
    }
    items
}

/// The standard operators renamed `NAME_k` for k = 0, 1, ... until the text holds `bytes`
/// (what `benches/large_operators.py` writes).
fn large_operators(bytes: usize, bare: bool) -> String {
    let items = standard_operators(bare);
    let mut out = String::new();
    for k in 0.. {
        if out.len() >= bytes {
            break;
        }
        for item in &items {
            let at = item.find("\noperator ").map_or(0, |i| i + 1) + "operator ".len();
            let end = at
                + item[at..]
                    .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .unwrap_or(0);
            out.push_str(&item[..end]);
            out.push_str(&format!("_{k}"));
            out.push_str(&item[end..]);
        }
    }
    out
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
    let large = large_operators(50_000_000, true);
    g.throughput(Throughput::Bytes(large.len() as u64));
    g.bench_function("50mb_standard_operators_renamed", |b| {
        b.iter(|| {
            let set = std
                .merge(&[Source::new("large.adv", large.as_str())])
                .expect("the renamed operators check");
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
