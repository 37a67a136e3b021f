//! The learners' speed, one query at a time as a robot loop makes them: 6-D observations,
//! N = 100,000 points of interception teacher demonstrations (data as the learners see it: dense
//! along trajectories; uniform noise in 6-D would leave every kernel empty or huge), queried with
//! the observations of 1,000 points from runs on other starts. `bc_query_100k`: weighted 1-NN after 1,000 critiqued points;
//! `lwr_query_100k`: truncated-kernel regression; `rederive_30`: add 30 advised points and bring
//! the policy up to date. Throughput is set so criterion prints queries (or advice points) per
//! second.

use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::interp;
use advise::policy::Policy;
use advise::policy::dataset::Dataset;
use advise::policy::learner::{Learner, LearnerKind};
use advise::syntax::parse_invocation;
use advise::task::{TaskKind, record_demos};
use advise::trace::{Chunk, Trace};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const N: usize = 100_000;

fn random_trace(d: &Domain, n: usize, rng: &mut ChaCha8Rng) -> Trace {
    let mut t = Trace::new(d);
    let mut z = vec![0.0; d.obs_dim()];
    for i in 0..n {
        for (v, dim) in z.iter_mut().zip(&d.observe) {
            let l = dim.limits.expect("interception dims are bounded");
            *v = rng.random_range(l.lo..l.hi);
        }
        // Actions are a smooth function of the observation plus a little noise, as a teacher's
        // are; pure noise would make cross-validation pick the widest kernel.
        let a = [
            0.08 * (z[0] / 4.0).sin() * z[2].cos() + rng.random_range(-0.005..0.005),
            0.15 * (z[1] / 2.0).tanh() + rng.random_range(-0.01..0.01),
        ];
        t.push(i as f64 / 30.0, &z, &a, None);
    }
    t
}

/// 100,000 points of teacher demonstrations (seed 1), and 1,000 query observations from
/// demonstrations on other starts (seed 2).
fn data() -> (Trace, Vec<Vec<f64>>) {
    let d = Domain::interception();
    let params = advise::backend::sim::SimParams::default();
    let mut all = Trace::new(&d);
    for (e, _) in record_demos(TaskKind::Interception, 600, 1, &params) {
        for i in 0..e.trace.len() {
            if all.len() < N {
                all.push(all.len() as f64, e.trace.z(i), e.trace.a(i), None);
            }
        }
    }
    assert_eq!(all.len(), N, "600 demonstrations hold 100,000 points");
    let mut qs = Vec::new();
    for (e, _) in record_demos(TaskKind::Interception, 20, 2, &params) {
        qs.extend((0..e.trace.len()).step_by(3).map(|i| e.trace.z(i).to_vec()));
    }
    qs.truncate(1000);
    (all, qs)
}

fn learner(kind: LearnerKind, data: &Trace, critique: &[Vec<f64>]) -> Learner {
    let d = Domain::interception();
    let mut ds = Dataset::new(&d);
    ds.add_demonstration("teacher", data).unwrap();
    let mut l = Learner::with_dataset(ds, kind, 0);
    if kind == LearnerKind::Bc {
        // 1,000 critiqued points: critique an execution of 1,000 points near the data.
        let mut exec = Trace::new(&d);
        for (i, z) in critique.iter().enumerate() {
            exec.push(i as f64, z, &[0.0, 0.0], None);
        }
        let id = l.add_execution(&exec);
        let n = exec.len();
        l.critique(id, &exec, Chunk::all(n), 1.0).unwrap();
    }
    l
}

fn bench(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (data, qs) = data();
    let critiqued: Vec<Vec<f64>> = (0..1000).map(|i| data.z(i * 97).to_vec()).collect();

    let bc = learner(LearnerKind::Bc, &data, &critiqued);
    let mut g = c.benchmark_group("policy");
    g.throughput(Throughput::Elements(qs.len() as u64));
    g.bench_function("bc_query_100k", |b| {
        let mut a = [0.0; 2];
        b.iter(|| {
            for q in &qs {
                bc.act(q, &mut a);
            }
            a
        })
    });

    let mut lwr = learner(LearnerKind::Lwr, &data, &critiqued);
    let mut a = [0.0; 2];
    let (mut neighbours, mut far) = (0usize, 0usize);
    for q in &qs {
        let ans = lwr.regress(q, &mut a);
        neighbours += ans.neighbours;
        far += usize::from(ans.total_weight == 0.0);
    }
    eprintln!(
        "lwr tuned: {:?}; {} distinct observations; {:.1} neighbours per query, {far} of {} queries far from data",
        lwr.lwr_params(),
        lwr.index().groups(),
        neighbours as f64 / qs.len() as f64,
        qs.len()
    );
    g.bench_function("lwr_query_100k", |b| {
        let mut a = [0.0; 2];
        b.iter(|| {
            for q in &qs {
                lwr.act(q, &mut a);
            }
            a
        })
    });

    // Advice: `speed_up` on a 30-point chunk of an execution, synthesized once; the measured part
    // is adding its points and making the policy ready. The dataset grows by 30 points per
    // iteration (a few percent over a run), as it does in a real session.
    let d = Domain::interception();
    let exec = random_trace(&d, 30, &mut rng);
    let set = advise::check::OperatorSet::standard();
    let inv = parse_invocation("speed_up(0.2)").unwrap();
    let call = advise::check::bind(&mut SourceMap::new(), &set, &exec.domain, &inv).unwrap();
    let syn = interp::apply(&call, &exec, Chunk::all(30)).unwrap();
    // A-OPI is the learner advice feeds: its points go into both the 1-NN and the LWR index.
    let l = &mut lwr;
    let id = l.add_execution(&exec);
    g.throughput(Throughput::Elements(syn.points.len() as u64));
    g.bench_function("rederive_30", |b| {
        b.iter(|| l.add_advice(id, &syn).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
