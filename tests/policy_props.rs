//! The learners' invariants: the kd-tree answers equal brute force, undo is exact, save/load is the
//! identity; and the paper's BC update worked by hand on three points.

use advise::domain::{Dim, Domain};
use advise::interp::{AppliedAdvice, ParamValue};
use advise::policy::Policy;
use advise::policy::dataset::{Critique, CritiqueRule, Dataset};
use advise::policy::learner::{Learner, LearnerKind};
use advise::policy::lwr::LwrParams;
use advise::trace::{Chunk, Trace};
use proptest::prelude::*;

fn domain(obs: usize) -> Domain {
    Domain {
        name: "test".into(),
        observe: (0..obs)
            .map(|i| Dim::new(&format!("z{i}"), "", None))
            .collect(),
        act: vec![Dim::new("u", "", None), Dim::new("v", "", None)],
    }
}

fn trace(d: &Domain, rows: &[(Vec<f64>, [f64; 2])]) -> Trace {
    let mut t = Trace::new(d);
    for (i, (z, a)) in rows.iter().enumerate() {
        t.push(i as f64, z, a, None);
    }
    t
}

fn applied(chunk: Chunk, rate: f64) -> AppliedAdvice {
    AppliedAdvice {
        operator: "scale".into(),
        domain: "test".into(),
        params: vec![ParamValue {
            name: "rate".into(),
            value: rate,
        }],
        chunk,
        space: advise::domain::Space::Action,
        definition: "test".into(),
        hash: None,
    }
}

/// Range scaling as the learner does it.
fn scale(ds: &Dataset, dim: usize) -> Vec<f64> {
    (0..dim)
        .map(|j| {
            let (lo, hi) = (0..ds.len()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
                (lo.min(ds.z(i)[j]), hi.max(ds.z(i)[j]))
            });
            if hi - lo > 1e-12 {
                1.0 / (hi - lo)
            } else {
                1.0
            }
        })
        .collect()
}

fn sq_dist(a: &[f64], b: &[f64], s: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(s)
        .map(|((x, y), s)| (x * s - y * s).powi(2))
        .sum()
}

/// Dataset of `rows` with weights raised by `raises` (point index, increment).
fn weighted(d: &Domain, rows: &[(Vec<f64>, [f64; 2])], raises: &[(usize, f64)]) -> Dataset {
    let mut ds = Dataset::new(d);
    ds.add_demonstration("demo", &trace(d, rows)).unwrap();
    let ex = ds.add_execution(&trace(d, &rows[..1])).unwrap();
    let raises: Vec<_> = raises
        .iter()
        .map(|(i, m)| (ds.provenance(i % rows.len()), *m))
        .collect();
    ds.add_critique(ex, Critique::paper(Chunk { start: 0, end: 0 }, 1.0, raises))
        .unwrap();
    ds
}

/// [`weighted`], then a directional critique of `flags` (point index, increment, flagged
/// observation): each penalises its point only for queries from the flagged side.
fn directional(
    d: &Domain,
    rows: &[(Vec<f64>, [f64; 2])],
    raises: &[(usize, f64)],
    flags: &[(usize, f64, Vec<f64>)],
) -> Dataset {
    let mut ds = weighted(d, rows, raises);
    let ex = ds.add_execution(&trace(d, &rows[..1])).unwrap();
    let incs = flags
        .iter()
        .map(|(i, inc, _)| (ds.provenance(i % rows.len()), *inc))
        .collect();
    let flagged = flags.iter().map(|(_, _, z)| z.clone()).collect();
    ds.add_critique(
        ex,
        Critique::directional(Chunk { start: 0, end: 0 }, 1.0, incs, flagged),
    )
    .unwrap();
    ds
}

/// The directional weight written out from its definition: `m_i` plus each directional increment
/// times `max(0, cos angle(q - z_i, z_t - z_i))` in the range-scaled space, 1 where a direction is
/// undefined.
fn directional_weight(ds: &Dataset, i: usize, q: &[f64], s: &[f64]) -> f64 {
    let (incs, zs) = ds.directional(i);
    let zi = ds.z(i);
    let dim = zi.len();
    let mut m = ds.m(i);
    for (inc, zt) in incs.iter().zip(zs.chunks(dim)) {
        let u: Vec<f64> = (0..dim).map(|k| q[k] * s[k] - zi[k] * s[k]).collect();
        let v: Vec<f64> = (0..dim).map(|k| zt[k] * s[k] - zi[k] * s[k]).collect();
        let norm = |w: &[f64]| w.iter().map(|x| x * x).sum::<f64>().sqrt();
        let factor = if norm(&u) == 0.0 || norm(&v) == 0.0 {
            1.0
        } else {
            let dot: f64 = u.iter().zip(&v).map(|(a, b)| a * b).sum();
            (dot / (norm(&u) * norm(&v))).max(0.0)
        };
        m += inc * factor;
    }
    m
}

fn rows_strategy(dim: usize) -> impl Strategy<Value = Vec<(Vec<f64>, [f64; 2])>> {
    prop::collection::vec(
        (
            // Coarse values so that ties and identical points occur.
            prop::collection::vec((-20i32..20).prop_map(|v| v as f64 * 0.25), dim),
            [-1.0f64..1.0, -1.0f64..1.0],
        ),
        1..120,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn directional_weighted_nearest_neighbour_equals_a_linear_scan(
        rows in rows_strategy(3),
        raises in prop::collection::vec((0usize..1000, 0.0f64..5.0), 0..20),
        flags in prop::collection::vec(
            (
                0usize..1000,
                0.0f64..40.0,
                // Coarse, like the rows, so flagged observations often sit on data points.
                prop::collection::vec((-20i32..20).prop_map(|v| v as f64 * 0.25), 3),
            ),
            0..60,
        ),
        queries in prop::collection::vec(
            prop::collection::vec((-24i32..24).prop_map(|v| v as f64 * 0.25), 3),
            1..20,
        ),
    ) {
        let d = domain(3);
        let ds = directional(&d, &rows, &raises, &flags);
        let s = scale(&ds, 3);
        let learner = Learner::with_dataset(ds.clone(), LearnerKind::Bc, 0);
        for q in &queries {
            let got = learner.support(q).unwrap();
            let scan = |i: usize| directional_weight(&ds, i, q, &s) * sq_dist(q, ds.z(i), &s).sqrt();
            let best = (0..ds.len()).map(scan).fold(f64::INFINITY, f64::min);
            prop_assert!((got.weighted - best).abs() <= 1e-9 * best.max(1.0), "tree {} scan {}", got.weighted, best);
            prop_assert!((scan(got.point) - got.weighted).abs() <= 1e-9 * best.max(1.0));
            prop_assert!(got.m >= ds.m(got.point) && got.m <= ds.max_weight(got.point) + 1e-12);
            let mut a = [0.0; 2];
            learner.act(q, &mut a);
            prop_assert_eq!(&a[..], ds.a(got.point));
        }
    }

    #[test]
    fn a_directional_critique_undone_leaves_the_weights_bit_for_bit(
        rows in rows_strategy(2),
        raises in prop::collection::vec((0usize..1000, 0.0f64..5.0), 0..10),
        flags in prop::collection::vec(
            (0usize..1000, 0.0f64..40.0, prop::collection::vec(-6.0f64..6.0, 2)),
            1..20,
        ),
    ) {
        let d = domain(2);
        let ds0 = directional(&d, &rows, &raises, &flags);
        let mut ds = ds0.clone();
        // Another directional critique, and a paper's one after it; both undone.
        let ex = ds.add_execution(&trace(&d, &rows[..1])).unwrap();
        let (p0, z0) = (ds.provenance(0), rows[0].0.clone());
        let a = ds.add_critique(ex, Critique::directional(Chunk { start: 0, end: 0 }, 1.0, vec![(p0, 3.0)], vec![z0])).unwrap();
        ds.add_critique(ex, Critique::paper(Chunk { start: 0, end: 0 }, 1.0, vec![(p0, 2.0)])).unwrap();
        ds.remove_critique(ds.critiques().last().unwrap().id).unwrap();
        ds.remove_critique(a).unwrap();
        for i in 0..ds.len() {
            prop_assert_eq!(ds.m(i).to_bits(), ds0.m(i).to_bits());
            let (x, y) = (ds.directional(i), ds0.directional(i));
            prop_assert_eq!(x.0.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), y.0.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
            prop_assert_eq!(x.1, y.1);
        }
        prop_assert_eq!(ds.critiques(), ds0.critiques());
        // Saved and loaded, the same dataset (records, weights and directional penalties).
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.json");
        ds.save(&path).unwrap();
        prop_assert_eq!(Dataset::load(&mut advise::diag::SourceMap::new(), &path).unwrap(), ds);
    }

    #[test]
    fn weighted_nearest_neighbour_equals_a_linear_scan(
        rows in rows_strategy(3),
        raises in prop::collection::vec((0usize..1000, 0.0f64..20.0), 0..40),
        queries in prop::collection::vec(prop::collection::vec(-6.0f64..6.0, 3), 1..20),
    ) {
        let d = domain(3);
        let ds = weighted(&d, &rows, &raises);
        let s = scale(&ds, 3);
        let learner = Learner::with_dataset(ds.clone(), LearnerKind::Bc, 0);
        for q in &queries {
            let got = learner.support(q).unwrap();
            let best = (0..ds.len())
                .map(|i| ds.m(i) * sq_dist(q, ds.z(i), &s).sqrt())
                .fold(f64::INFINITY, f64::min);
            prop_assert!((got.weighted - best).abs() <= 1e-9 * best.max(1.0), "tree {} scan {}", got.weighted, best);
            let mut a = [0.0; 2];
            learner.act(q, &mut a);
            prop_assert_eq!(&a[..], ds.a(got.point));
        }
    }

    #[test]
    fn lwr_equals_a_brute_force_kernel_sum(
        rows in rows_strategy(2),
        queries in prop::collection::vec(prop::collection::vec(-6.0f64..6.0, 2), 1..20),
        bandwidth in 0.02f64..0.5,
        s0 in 0.5f64..2.0,
    ) {
        let d = domain(2);
        let mut ds = Dataset::new(&d);
        ds.add_demonstration("demo", &trace(&d, &rows)).unwrap();
        let s = scale(&ds, 2);
        let learner = Learner::with_dataset(ds.clone(), LearnerKind::Bc, 0);
        let params = LwrParams { scales: vec![s0, 1.0], bandwidth, tolerance: 1e-3, k: None };
        let r2 = -2.0 * bandwidth * bandwidth * params.tolerance.ln();
        for q in &queries {
            let (mut num, mut den) = ([0.0; 2], 0.0);
            for i in 0..ds.len() {
                let d2: f64 = (0..2).map(|j| ((q[j] * s[j] - ds.z(i)[j] * s[j]) * params.scales[j]).powi(2)).sum();
                if d2 <= r2 {
                    let w = (-d2 / (2.0 * bandwidth * bandwidth)).exp();
                    den += w;
                    for (n, v) in num.iter_mut().zip(ds.a(i)) { *n += w * v; }
                }
            }
            let mut a = [0.0; 2];
            let ans = learner.query_lwr_with(&params, q, &mut a);
            prop_assert!((ans.total_weight - den).abs() < 1e-9);
            if den > 0.0 {
                for j in 0..2 { prop_assert!((a[j] - num[j] / den).abs() < 1e-9); }
            }
        }
    }

    #[test]
    fn the_lwr_learner_answers_as_the_kernel_sum_with_its_tuned_parameters(
        rows in rows_strategy(3),
        extra in rows_strategy(3),
        queries in prop::collection::vec(prop::collection::vec(-6.0f64..6.0, 3), 1..20),
    ) {
        // The LWR learner queries its own index in the kernel's space; after tuning and after
        // incremental additions it must answer as the general query with its parameters does.
        let d = domain(3);
        let mut ds = Dataset::new(&d);
        ds.add_demonstration("demo", &trace(&d, &rows)).unwrap();
        let mut learner = Learner::with_dataset(ds, LearnerKind::Lwr, 7);
        let exec = learner.add_execution(&trace(&d, &extra));
        let chunk = Chunk::new(0, extra.len(), extra.len()).unwrap();
        let source: Vec<usize> = chunk.range().collect();
        let syn = advise::interp::Synthesized {
            points: trace(&d, &extra),
            source_index: source,
            advice: applied(chunk, 0.5),
        };
        learner.add_advice(exec, &syn).unwrap();
        let params = learner.lwr_params().clone();
        for q in &queries {
            let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
            let got = learner.regress(q, &mut a);
            let want = learner.query_lwr_with(&params, q, &mut b);
            prop_assert_eq!(got.neighbours, want.neighbours);
            prop_assert!((got.total_weight - want.total_weight).abs() <= 1e-9 * want.total_weight.max(1.0));
            for j in 0..2 { prop_assert!((a[j] - b[j]).abs() < 1e-9, "{:?} vs {:?}", a, b); }
        }
    }

    #[test]
    fn undoing_advice_restores_the_dataset_exactly(
        rows in rows_strategy(3),
        raises in prop::collection::vec((0usize..1000, 0.0f64..5.0), 0..10),
        start in 0usize..50, len in 0usize..50, rate in 0.0f64..1.0,
    ) {
        let d = domain(3);
        let ds0 = weighted(&d, &rows, &raises);
        let mut ds = ds0.clone();
        let exec = ds.add_execution(&trace(&d, &rows)).unwrap();
        let end = (start + len).min(rows.len());
        let chunk = Chunk::new(start.min(end), end, rows.len()).unwrap();
        let mut pts = Trace::new(&d);
        for i in chunk.range() {
            let a = [rows[i].1[0] * (1.0 + rate), rows[i].1[1]];
            pts.push(i as f64, &rows[i].0, &a, None);
        }
        let source: Vec<usize> = chunk.range().collect();
        let id = ds.add_advice(exec, applied(chunk, rate), &pts, &source).unwrap();
        // A critique that touches the advised points, then the advice is undone.
        let n = ds.len();
        let ex2 = ds.add_execution(&trace(&d, &rows[..1])).unwrap();
        ds.add_critique(ex2, Critique::paper(Chunk { start: 0, end: 0 }, 1.0, vec![(ds.provenance(n - 1), 2.5), (ds.provenance(0), 1.5)])).unwrap();
        ds.remove_advice(id).unwrap();
        ds.remove_critique(ds.critiques().last().unwrap().id).unwrap();
        prop_assert_eq!(ds.len(), ds0.len());
        for i in 0..ds.len() {
            prop_assert_eq!(ds.z(i), ds0.z(i));
            prop_assert_eq!(ds.a(i), ds0.a(i));
            prop_assert_eq!(ds.provenance(i), ds0.provenance(i));
            prop_assert_eq!(ds.m(i).to_bits(), ds0.m(i).to_bits());
        }
        prop_assert_eq!(ds.advice(), ds0.advice());
        prop_assert_eq!(ds.critiques(), ds0.critiques());
    }

    #[test]
    fn save_then_load_is_the_identity(
        rows in rows_strategy(2),
        raises in prop::collection::vec((0usize..1000, 0.0f64..5.0), 0..10),
    ) {
        let d = domain(2);
        let ds = weighted(&d, &rows, &raises);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.json");
        ds.save(&path).unwrap();
        prop_assert_eq!(Dataset::load(&mut advise::diag::SourceMap::new(), &path).unwrap(), ds);
    }
}

/// The paper's update, by hand: points at 0, 1 and 3 (range 3, so scaled by 1/3); the execution
/// point 0.9 is flagged with kappa 1. Its nearest point is z = 1 at scaled distance 0.1/3, so
/// m_1 = 1 + 1 / (0.1/3) = 31. Afterwards the weighted distances from 0.9 are 0.3 (z = 0),
/// 31 * 0.0333 = 1.0333 (z = 1) and 0.7 (z = 3): the point at 0 now answers.
#[test]
fn bc_update_by_hand_on_three_points() {
    let d = domain(1);
    let rows = vec![
        (vec![0.0], [0.0, 0.0]),
        (vec![1.0], [1.0, 0.0]),
        (vec![3.0], [3.0, 0.0]),
    ];
    let mut ds = Dataset::new(&d);
    ds.add_demonstration("demo", &trace(&d, &rows)).unwrap();
    let mut learner = Learner::with_dataset(ds, LearnerKind::Bc, 0);
    assert_eq!(learner.support(&[0.9]).unwrap().point, 1);
    let exec = trace(&d, &[(vec![0.9], [1.0, 0.0])]);
    let id = learner.add_execution(&exec);
    learner
        .critique(id, &exec, Chunk { start: 0, end: 1 }, 1.0)
        .unwrap();
    let m = learner.dataset().weights();
    assert_eq!(m[0], 1.0);
    assert!((m[1] - 31.0).abs() < 1e-9, "m_1 = {}", m[1]);
    assert_eq!(m[2], 1.0);
    let s = learner.support(&[0.9]).unwrap();
    assert_eq!(s.point, 0);
    assert!((s.weighted - 0.3).abs() < 1e-12);
}

#[test]
fn a_query_far_from_all_data_is_detected() {
    let d = domain(2);
    let rows = vec![(vec![0.0, 0.0], [1.0, 0.0]), (vec![1.0, 1.0], [2.0, 0.0])];
    let mut ds = Dataset::new(&d);
    ds.add_demonstration("demo", &trace(&d, &rows)).unwrap();
    let learner = Learner::with_dataset(ds, LearnerKind::Lwr, 0);
    let mut a = [0.0; 2];
    let ans = learner.regress(&[50.0, 50.0], &mut a);
    assert_eq!(ans.total_weight, 0.0);
    assert_eq!(ans.neighbours, 0);
    assert_eq!(a, [2.0, 0.0], "falls back to the nearest point's action");
}

/// The paper's example of what its rule misses: "two query points located at identical distances,
/// but orthogonal directions ... to a given training point. The training point's recommended
/// action might be appropriate for one but not the other." Point P at the origin is critiqued from
/// (0.1, 0); queries at distance 0.2 from P along +x (the critiqued side), +y (orthogonal) and -x
/// (opposite). The paper's rule penalises P for all three; the directional rule only for +x.
#[test]
fn a_directional_critique_penalises_only_queries_from_the_critiqued_side() {
    let d = domain(2);
    let rows = vec![
        (vec![0.0, 0.0], [1.0, 0.0]), // P
        (vec![1.0, 1.0], [2.0, 0.0]), // Q, the alternative (scaled range 1 in each dimension)
    ];
    let queries = [[0.2, 0.0], [0.0, 0.2], [-0.2, 0.0]];
    let answer = |rule: CritiqueRule| {
        let mut ds = Dataset::new(&d);
        ds.add_demonstration("demo", &trace(&d, &rows)).unwrap();
        let mut learner = Learner::with_dataset(ds, LearnerKind::Bc, 0);
        let exec = trace(&d, &[(vec![0.1, 0.0], [1.0, 0.0])]);
        let id = learner.add_execution(&exec);
        let done = learner
            .critique_with(id, &exec, Chunk { start: 0, end: 1 }, 2.0, rule)
            .unwrap();
        // kappa / distance = 2 / 0.1 on P, whichever the rule.
        assert_eq!(done.critique.increments.len(), 1);
        assert!((done.critique.increments[0].1 - 20.0).abs() < 1e-9);
        queries.map(|q| learner.support(&q).unwrap())
    };
    let paper = answer(CritiqueRule::Paper);
    for s in &paper {
        assert_eq!(s.point, 1, "the paper's rule penalises P from every side");
        assert!((s.m - 1.0).abs() < 1e-12, "Q is not penalised");
    }
    let [side, orthogonal, opposite] = answer(CritiqueRule::Directional);
    assert_eq!(side.point, 1, "from the critiqued side Q answers");
    assert_eq!(orthogonal.point, 0, "orthogonally P still answers");
    assert_eq!(orthogonal.m, 1.0, "and is not penalised at all");
    assert!((orthogonal.distance - 0.2).abs() < 1e-12);
    assert_eq!(opposite.point, 0, "from the other side P answers");
    assert_eq!(opposite.m, 1.0);
    // P's weight seen from the critiqued side is the paper's m = 1 + 20.
    let mut ds = Dataset::new(&d);
    ds.add_demonstration("demo", &trace(&d, &rows)).unwrap();
    let ex = ds.add_execution(&trace(&d, &rows[..1])).unwrap();
    let p = ds.provenance(0);
    ds.add_critique(
        ex,
        Critique::directional(
            Chunk { start: 0, end: 0 },
            2.0,
            vec![(p, 20.0)],
            vec![vec![0.1, 0.0]],
        ),
    )
    .unwrap();
    assert_eq!(ds.m(0), 1.0, "the isotropic weight is untouched");
    assert_eq!(ds.max_weight(0), 21.0);
    let s = [1.0, 1.0];
    assert_eq!(directional_weight(&ds, 0, &[0.2, 0.0], &s), 21.0);
    assert_eq!(directional_weight(&ds, 0, &[0.0, 0.2], &s), 1.0);
    // 45 degrees: half the square root of two of the increment.
    let diag = directional_weight(&ds, 0, &[0.2, 0.2], &s);
    assert!((diag - (1.0 + 20.0 * std::f64::consts::FRAC_1_SQRT_2)).abs() < 1e-12);
    // At P itself no direction is known: the penalty counts in full.
    assert_eq!(directional_weight(&ds, 0, &[0.0, 0.0], &s), 21.0);
}
