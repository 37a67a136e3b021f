//! A-OPI's learner: locally weighted regression, `a = sum_i w_i a_i / sum_i w_i` with Gaussian
//! weights `w_i = exp(-d_i^2 / (2 h^2))` on a scaled Euclidean distance.
//!
//! Distances are measured on range-scaled observations further multiplied per dimension by
//! [`LwrParams::scales`]; `h` is [`LwrParams::bandwidth`]. The kernel is truncated where a weight
//! would fall below [`LwrParams::tolerance`], so a query is one radius search of the kd-tree. A
//! query far from all data finds no neighbour: the answer says so (`total_weight == 0`) and falls
//! back to the nearest point's action rather than silently averaging nothing. [`tune`] chooses the
//! scales and bandwidth by seeded k-fold cross-validation.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::policy::dataset::Dataset;
use crate::policy::index::Index;

/// The regression's parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LwrParams {
    /// Multiplier per observation dimension on top of range scaling.
    pub scales: Vec<f64>,
    /// Kernel bandwidth `h` in scaled units.
    pub bandwidth: f64,
    /// Weights below this are cut off (sets the search radius).
    pub tolerance: f64,
}

impl LwrParams {
    pub fn default_for(dim: usize) -> LwrParams {
        LwrParams {
            scales: vec![1.0; dim],
            bandwidth: 0.05,
            tolerance: 1e-3,
        }
    }

    /// Squared search radius in the weighted space.
    fn r2(&self) -> f64 {
        -2.0 * self.bandwidth * self.bandwidth * self.tolerance.ln()
    }
}

/// How a query was answered.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LwrAnswer {
    /// Sum of kernel weights in the neighbourhood (0: far from all data).
    pub total_weight: f64,
    /// Data points that contributed.
    pub neighbours: usize,
}

/// Reusable buffers for queries.
#[derive(Default)]
pub struct Scratch {
    q: Vec<f64>,
    found: Vec<(f64, u64)>,
}

/// Predict the action for `z` into `a`.
pub fn query(
    index: &Index,
    ds: &Dataset,
    params: &LwrParams,
    z: &[f64],
    a: &mut [f64],
    scratch: &mut Scratch,
) -> LwrAnswer {
    a.iter_mut().for_each(|v| *v = 0.0);
    scratch.q.resize(z.len(), 0.0);
    index.scaled(z, &mut scratch.q);
    let wmin = params
        .scales
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(1e-12);
    let r2 = params.r2();
    index.within(&scratch.q, r2 / (wmin * wmin), &mut scratch.found);
    let inv = 1.0 / (2.0 * params.bandwidth * params.bandwidth);
    let mut total = 0.0;
    let mut count = 0;
    if index.has_action_sums() && params.scales.iter().all(|s| *s == 1.0) {
        // The index already measures the kernel's distance (its scale includes the tuned
        // multipliers): kiddo's squared distance is the kernel's, and each group's action sum
        // stands for its points.
        for &(d2, g) in &scratch.found {
            if d2 > r2 {
                continue;
            }
            let w = (-d2 * inv).exp();
            if let Some((sum, n)) = index.action_sum(g) {
                for (out, v) in a.iter_mut().zip(sum) {
                    *out += w * v;
                }
                total += w * f64::from(n);
                count += n as usize;
            }
        }
    } else {
        for &(_, g) in &scratch.found {
            let gz = index.group_z(g);
            let d2: f64 = gz
                .iter()
                .zip(&scratch.q)
                .zip(&params.scales)
                .map(|((p, q), s)| {
                    let d = (p - q) * s;
                    d * d
                })
                .sum();
            if d2 > r2 {
                continue;
            }
            let w = (-d2 * inv).exp();
            for &i in index.group(g) {
                for (out, v) in a.iter_mut().zip(ds.a(i as usize)) {
                    *out += w * v;
                }
                total += w;
                count += 1;
            }
        }
    }
    if total > 0.0 {
        a.iter_mut().for_each(|v| *v /= total);
    } else if let Some((_, g)) = index.nearest(&scratch.q) {
        a.copy_from_slice(ds.a(index.group(g)[0] as usize));
    }
    LwrAnswer {
        total_weight: total,
        neighbours: count,
    }
}

/// Choose scales and bandwidth by k-fold cross-validation (seeded): a grid over the bandwidth
/// (the smallest within 5% of the best loss wins), then one pass of coordinate descent over each
/// dimension's multiplier (kept only when it gains more than 1%). The loss is the mean
/// squared action error, each action dimension divided by its data range. At most 2,000 held-out
/// points are scored per fold, so tuning stays fast on large datasets.
pub fn tune(ds: &Dataset, range_scale: &[f64], k: usize, seed: u64) -> LwrParams {
    let n = ds.len();
    let dim = range_scale.len();
    let mut params = LwrParams::default_for(dim);
    if n < 2 * k.max(2) {
        return params;
    }
    let k = k.max(2);
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let folds: Vec<Vec<usize>> = (0..k)
        .map(|f| order.iter().copied().skip(f).step_by(k).collect())
        .collect();
    let act_dim = ds.domain().act_dim();
    let mut act_range = vec![1.0; act_dim];
    for (j, r) in act_range.iter_mut().enumerate() {
        let (lo, hi) = (0..n).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
            (lo.min(ds.a(i)[j]), hi.max(ds.a(i)[j]))
        });
        *r = if hi - lo > 1e-12 { hi - lo } else { 1.0 };
    }
    // One index per fold, built once: the fold's training points.
    let indexes: Vec<Index> = (0..k)
        .map(|f| {
            let mut idx =
                Index::new(range_scale.to_vec()).expect("dimension checked by the learner");
            for (g, fold) in folds.iter().enumerate() {
                if g != f {
                    for &i in fold {
                        idx.add(i as u32, ds.z(i));
                    }
                }
            }
            idx
        })
        .collect();
    let loss = |p: &LwrParams| -> f64 {
        let mut scratch = Scratch::default();
        let mut a = vec![0.0; act_dim];
        let mut total = 0.0;
        let mut count = 0usize;
        for (f, fold) in folds.iter().enumerate() {
            for &i in fold.iter().take(2000 / k + 1) {
                query(&indexes[f], ds, p, ds.z(i), &mut a, &mut scratch);
                for j in 0..act_dim {
                    let e = (a[j] - ds.a(i)[j]) / act_range[j];
                    total += e * e;
                }
                count += 1;
            }
        }
        total / count.max(1) as f64
    };
    // Prefer locality: the smallest bandwidth whose loss is within 5% of the best, and a scale
    // change only when it gains more than 1%. A wider kernel that is barely better costs a
    // neighbourhood many times larger on every query (the volume grows as h^dim) and blurs the
    // local corrections advice adds.
    let grid = [0.01, 0.02, 0.035, 0.05, 0.08, 0.12, 0.2];
    let losses: Vec<f64> = grid
        .iter()
        .map(|&h| {
            loss(&LwrParams {
                bandwidth: h,
                ..params.clone()
            })
        })
        .collect();
    let min = losses.iter().copied().fold(f64::INFINITY, f64::min);
    if let Some(i) = losses.iter().position(|l| *l <= min * 1.05) {
        params.bandwidth = grid[i];
    }
    let mut best = loss(&params);
    for d in 0..dim {
        for m in [0.5, 2.0] {
            let mut cand = params.clone();
            cand.scales[d] *= m;
            let l = loss(&cand);
            if l < best * 0.99 {
                best = l;
                params = cand;
            }
        }
    }
    params
}

/// Query `learner`'s data with other parameters (for tests and tuning experiments).
pub fn query_with(
    learner: &crate::policy::learner::Learner,
    params: &LwrParams,
    z: &[f64],
    a: &mut [f64],
) -> LwrAnswer {
    query(
        learner.index(),
        learner.dataset(),
        params,
        z,
        a,
        &mut Scratch::default(),
    )
}
