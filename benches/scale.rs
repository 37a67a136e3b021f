//! The learners at a fleet's scale (issue 36): synthetic positioning demonstrations of 1,000 points
//! each (a simple controller driving to goals drawn from the domain's ranges, values rounded to
//! 1e-4 as a recording would keep them), `ADVISE_SCALE_POINTS` points in all (default 1,000,000;
//! a comma-separated list measures several sizes in turn).
//!
//! For each size it prints, on standard error: the time from the demonstrations in memory to a
//! ready LWR learner (dataset, range scaling, LWR tuning, both indexes, the first BC and LWR
//! queries that build the bulk trees); the bytes the learner holds per point
//! ([`Learner::held_bytes`]) and the process's resident memory then (VmRSS, with the
//! demonstrations dropped) and at its peak (VmHWM); BC and LWR query latency p50/p99 over
//! 10,000 queries from demonstrations to other goals (`ADVISE_SCALE_QUERIES=N` uses N of them,
//! spread evenly), and the points an LWR query sums on average. Criterion then measures both queries' rate at the last size.
//!
//! With `ADVISE_SCALE_CSV=DIR` it only writes each size's demonstrations as `DIR/demos-N.csv`
//! (the columns `advise` reads), for the end-to-end measurement of `benches/scale.sh`: `advise
//! run` loading the file, resident memory, journal and sidecar size, and `advise resume`.

use std::time::{Duration, Instant};

use advise::domain::Domain;
use advise::policy::Policy;
use advise::policy::learner::{Learner, LearnerKind};
use advise::trace::{Episode, Trace};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Points per demonstration.
const EPISODE: usize = 1000;

fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    a - t * ((a + std::f64::consts::PI) / t).floor()
}

fn round4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// One demonstration: from the origin to a goal drawn from the domain's ranges, steered by a
/// proportional controller with a little noise, 20 ms steps.
fn episode(d: &Domain, rng: &mut ChaCha8Rng) -> Trace {
    let (xg, yg, thg) = (
        rng.random_range(-0.33..4.5),
        rng.random_range(-4.0..0.17),
        rng.random_range(-3.1..1.1),
    );
    let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
    let dt = 0.02;
    let mut t = Trace::new(d);
    for k in 0..EPISODE {
        let (dx, dy) = (xg - x, yg - y);
        let dist2 = dx * dx + dy * dy;
        let bearing = if dx == 0.0 && dy == 0.0 {
            0.0
        } else {
            wrap(dy.atan2(dx) - th)
        };
        let dheading = wrap(thg - th);
        let dist = dist2.sqrt();
        let trans = (0.6 * dist * bearing.cos() + rng.random_range(-0.01..0.01)).clamp(-1.0, 1.0);
        let steer = if dist > 0.3 { bearing } else { dheading };
        let rot = (1.2 * steer + rng.random_range(-0.01..0.01)).clamp(-1.0, 1.0);
        let z = [round4(dist2), round4(bearing), round4(dheading)];
        let a = [round4(trans), round4(rot)];
        t.push(round4(k as f64 * dt), &z, &a, None);
        th = wrap(th + rot * dt);
        x += trans * th.cos() * dt;
        y += trans * th.sin() * dt;
    }
    t
}

fn demonstrations(d: &Domain, points: usize, seed: u64) -> Vec<Episode> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..points.div_ceil(EPISODE))
        .map(|e| Episode {
            name: format!("e{e}"),
            trace: episode(d, &mut rng),
        })
        .collect()
}

/// `VmRSS` and `VmHWM` of this process, in MB.
fn rss_mb() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<f64>().ok())
            .map_or(f64::NAN, |kb| kb / 1024.0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn write_csv(d: &Domain, episodes: &[Episode], dir: &str, points: usize) {
    use std::io::Write;
    let path = std::path::Path::new(dir).join(format!("demos-{points}.csv"));
    let mut w = std::io::BufWriter::new(std::fs::File::create(&path).expect("create the CSV"));
    let mut header = vec!["episode".to_string()];
    header.extend(episodes[0].trace.csv_header(d));
    writeln!(w, "{}", header.join(",")).expect("write");
    for e in episodes {
        let t = &e.trace;
        for i in 0..t.len() {
            let vals: Vec<String> = std::iter::once(t.t[i])
                .chain(t.z(i).iter().copied())
                .chain(t.a(i).iter().copied())
                .map(|v| format!("{v}"))
                .collect();
            writeln!(w, "{},{}", e.name, vals.join(",")).expect("write");
        }
    }
    w.flush().expect("write");
    eprintln!("wrote {}", path.display());
}

/// p50 and p99 of single-query latencies, in microseconds.
fn percentiles(mut ts: Vec<Duration>) -> (f64, f64) {
    ts.sort_unstable();
    let at = |q: f64| ts[((ts.len() - 1) as f64 * q) as usize].as_secs_f64() * 1e6;
    (at(0.5), at(0.99))
}

/// How many of the 10,000 query observations the latency percentiles use
/// (`ADVISE_SCALE_QUERIES`, default all; spread evenly over the ten query demonstrations). At 20M
/// points an LWR query sums about 1.9 million points on average even with the bandwidth scaled
/// for the density (`lwr::density_factor`; the synthetic demonstrations all start at the origin
/// and crowd their goals), so 10,000 of them take many CPU-minutes; 1,000 keep the run to minutes.
fn query_count() -> usize {
    std::env::var("ADVISE_SCALE_QUERIES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .filter(|&n: &usize| n > 0)
        .unwrap_or(10 * EPISODE)
}

/// A ready LWR learner on `points` synthetic points and up to 10,000 query observations
/// ([`query_count`]), with the figures printed.
fn measure(points: usize) -> (Learner, Vec<Vec<f64>>) {
    let d = Domain::positioning();
    let mut episodes = demonstrations(&d, points, 1);
    let n: usize = episodes.iter().map(|e| e.trace.len()).sum();
    let queries: Vec<Vec<f64>> = demonstrations(&d, 10 * EPISODE, 2)
        .iter()
        .flat_map(|e| {
            (0..e.trace.len())
                .map(|i| e.trace.z(i).to_vec())
                .collect::<Vec<_>>()
        })
        .collect();
    let stride = queries.len().div_ceil(query_count().min(queries.len()));
    let queries: Vec<Vec<f64>> = queries.into_iter().step_by(stride.max(1)).collect();
    let (before, _) = rss_mb();
    let started = Instant::now();
    let mut l = Learner::new(&d, LearnerKind::Lwr, 0);
    l.add_demonstrations(&episodes)
        .expect("synthetic demonstrations are valid");
    // What a session's run does first: both trees built, BC's first (`Learner::prepare`).
    l.prepare();
    let mut a = [0.0; 2];
    l.act(&queries[0], &mut a);
    let _ = l.support(&queries[0]);
    let ready = started.elapsed();
    episodes.clear();
    episodes.shrink_to_fit();
    let (rss, hwm) = rss_mb();
    let time = |f: &dyn Fn(&[f64])| {
        let ts: Vec<Duration> = queries
            .iter()
            .map(|q| {
                let t = Instant::now();
                f(q);
                t.elapsed()
            })
            .collect();
        percentiles(ts)
    };
    let bc = time(&|q| {
        std::hint::black_box(l.support(q));
    });
    let lwr = time(&|q| {
        let mut a = [0.0; 2];
        l.act(q, &mut a);
        std::hint::black_box(a);
    });
    // The points an LWR query sums, on average (the tuned bandwidth is the one tuning chose; the
    // learner's derivation note says the one it queries with when that differs).
    let neighbours: usize = queries
        .iter()
        .map(|q| l.regress(q, &mut [0.0; 2]).neighbours)
        .sum();
    eprintln!(
        "scale {n} points: ready in {:.1} s; held {:.1} bytes/point ({:.0} MB); resident {:.0} MB after ({:.0} MB with the demonstrations before), peak {:.0} MB; BC p50 {:.1} us p99 {:.1} us; LWR p50 {:.1} us p99 {:.1} us, {:.0} neighbours a query (tuned bandwidth {})",
        ready.as_secs_f64(),
        l.held_bytes() as f64 / n as f64,
        l.held_bytes() as f64 / 1e6,
        rss,
        before,
        hwm,
        bc.0,
        bc.1,
        lwr.0,
        lwr.1,
        neighbours as f64 / queries.len() as f64,
        l.lwr_params().bandwidth
    );
    (l, queries)
}

fn bench(c: &mut Criterion) {
    let sizes: Vec<usize> = std::env::var("ADVISE_SCALE_POINTS")
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .filter(|v: &Vec<usize>| !v.is_empty())
        .unwrap_or_else(|| vec![1_000_000]);
    if let Ok(dir) = std::env::var("ADVISE_SCALE_CSV") {
        let d = Domain::positioning();
        for &n in &sizes {
            write_csv(&d, &demonstrations(&d, n, 1), &dir, n);
        }
        return;
    }
    let mut last = None;
    for &n in &sizes {
        // The last size's learner is dropped before the next is built (peak memory is per size).
        drop(last.take());
        last = Some((n, measure(n)));
    }
    let Some((n, (l, queries))) = last else {
        return;
    };
    let mut g = c.benchmark_group(format!("scale_{n}"));
    g.throughput(Throughput::Elements(1));
    g.sample_size(20);
    let mut k = 0;
    g.bench_function("bc_query", |b| {
        b.iter(|| {
            k = (k + 1) % queries.len();
            l.support(&queries[k])
        })
    });
    g.bench_function("lwr_query", |b| {
        b.iter(|| {
            k = (k + 1) % queries.len();
            let mut a = [0.0; 2];
            l.act(&queries[k], &mut a);
            a
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
