//! A-OPI's learner: locally weighted regression, `a = sum_i w_i a_i / sum_i w_i` with Gaussian
//! weights `w_i = exp(-d_i^2 / (2 h^2))` on a scaled Euclidean distance.
//!
//! Distances are measured on range-scaled observations further multiplied per dimension by
//! [`LwrParams::scales`]; `h` is [`LwrParams::bandwidth`]. The kernel is truncated where a weight
//! would fall below [`LwrParams::tolerance`], so a query is one radius search of the kd-tree. A
//! query far from all data finds no neighbour: the answer says so (`total_weight == 0`) and falls
//! back to the nearest point's action rather than silently averaging nothing. [`tune`] chooses the
//! scales and bandwidth by seeded k-fold cross-validation, at a cost bounded whatever the data's
//! size.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use std::collections::HashMap;

use crate::dataset::{Dataset, Provenance};
use crate::index::{Index, Points};

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
    // A non-finite observation is near no data point: the answer is zero with no neighbours,
    // rather than a kernel sum of NaNs or an index computed from one.
    if !z.iter().all(|v| v.is_finite()) {
        return LwrAnswer {
            total_weight: 0.0,
            neighbours: 0,
        };
    }
    let r2 = params.r2();
    let mut total = 0.0;
    let mut count = 0;
    if index.has_action_sums() && params.scales.iter().all(|s| *s == 1.0) {
        // The index already measures the kernel's distance (its scale includes the tuned
        // multipliers): its squared distance is the kernel's, the radius search is the kernel's
        // support, and each group's action sum stands for its points.
        scratch.q.resize(z.len(), 0.0);
        index.scaled(z, &mut scratch.q);
        let inv = 1.0 / (2.0 * params.bandwidth * params.bandwidth);
        // Counted as the sums store it (a whole f64, exact), converted once.
        let mut points = 0.0;
        index.sums_within(&scratch.q, r2, ds.points(), |d2, sum, n| {
            let w = (-d2 * inv).exp();
            for (out, v) in a.iter_mut().zip(sum) {
                *out += w * v;
            }
            total += w * n;
            points += n;
        });
        count = points as usize;
    } else {
        let inv = gather(index, ds.points(), params, z, scratch);
        for &(_, g) in &scratch.found {
            let Some(w) = group_weight(index, ds.points(), g, &scratch.q, params, r2, inv) else {
                continue;
            };
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
    } else if let Some(i) = nearest_in_kernel_space(index, ds.points(), params, scratch) {
        a.copy_from_slice(ds.a(i as usize));
    }
    LwrAnswer {
        total_weight: total,
        neighbours: count,
    }
}

/// Held-out points scored per loss evaluation, at most (spread evenly over the folds).
pub const TUNE_QUERIES: usize = 2000;

/// Points that take part in tuning, at most: a seeded sample of larger datasets.
pub const TUNE_POINTS: usize = 20_000;

/// The factor on a bandwidth tuned on `sample` points for a learner that holds `n` points in
/// `dim` input dimensions: `(sample / n)^(1 / (dim + 4))` when the tuning saw a sample of a larger
/// dataset, exactly 1 when it saw every point.
///
/// The protocol decision (issue 36), from statistics and written down before measuring: the
/// mean-squared-error-optimal bandwidth of kernel regression in `d` dimensions shrinks as
/// `n^(-1/(d+4))`. [`tune`] sees at most [`TUNE_POINTS`] points, so at 20 million points the
/// bandwidth it picks is about 2.4 times (d = 4) what the full density calls for, and a query
/// sums some 300,000 neighbours. Every dataset of up to [`TUNE_POINTS`] points (every study) is
/// tuned on all its points and answered unchanged to the bit. The fold hold-out (tuning answers
/// from (k-1)/k of its sample) is not corrected for: that is within a step of
/// [`BANDWIDTH_GRID`], where the sampling at 20 million is several steps.
pub fn density_factor(sample: usize, n: usize, dim: usize) -> f64 {
    if sample == 0 || sample >= n {
        return 1.0;
    }
    (sample as f64 / n as f64).powf(1.0 / (dim as f64 + 4.0))
}

/// The bandwidth grid [`tune`] searches, smallest first.
pub const BANDWIDTH_GRID: [f64; 7] = [0.01, 0.02, 0.035, 0.05, 0.08, 0.12, 0.2];

/// Choose scales and bandwidth by k-fold cross-validation (seeded): a grid over the bandwidth
/// (the smallest within 5% of the best loss wins), then one pass of coordinate descent over each
/// dimension's multiplier (kept only when it gains more than 1%). The loss is the mean squared
/// action error, each action dimension divided by its data range.
///
/// The cost is bounded whatever the size of the data, and so is the memory:
/// - At most [`TUNE_POINTS`] points take part: all of them in smaller datasets, whole
///   demonstrations and pieces of advice in larger ones (see [`tuning_sample`]), in one index built
///   here under `range_scale`. The folds are a seeded shuffle of those points; a held-out point is
///   answered from the points of the other folds, found in that index by skipping its own fold's.
/// - At most [`TUNE_QUERIES`] held-out points are scored per evaluation (the first of each fold).
/// - The bandwidth grid is searched upwards and stops once the loss has risen twice in a row
///   above 1.05 times the best so far (the loss is taken to be unimodal in the bandwidth): wider
///   kernels than that cannot be chosen, and on dense data each of their queries would sum a large
///   part of the data.
///
/// Deterministic for a seed: per-query errors are computed in parallel and summed in order.
pub fn tune(ds: &Dataset, range_scale: &[f64], k: usize, seed: u64) -> LwrParams {
    tune_from(ds, range_scale, k, seed, None)
}

/// [`tune`], warm-started from `start` (the parameters of the last tuning) when given: the same
/// folds and loss, but only the bandwidths next to `start`'s on [`BANDWIDTH_GRID`] are tried (the
/// smallest within 5% of the best of those wins), and `start`'s per-dimension scales are kept.
/// Three loss evaluations instead of about thirteen: what a learner re-derived after every
/// advised execution needs, since a few dozen added points move the optimum by a grid step at
/// most. A bandwidth off the grid (a loaded parameter set) starts from the nearest grid value.
pub fn tune_from(
    ds: &Dataset,
    range_scale: &[f64],
    k: usize,
    seed: u64,
    start: Option<&LwrParams>,
) -> LwrParams {
    tune_sized(ds, range_scale, k, seed, start).0
}

/// [`tune_from`] (or [`tune`] when `start` is `None`), with the number of points the tuning
/// saw: all of them up to [`TUNE_POINTS`], a sample of larger datasets ([`density_factor`]).
pub fn tune_sized(
    ds: &Dataset,
    range_scale: &[f64],
    k: usize,
    seed: u64,
    start: Option<&LwrParams>,
) -> (LwrParams, usize) {
    let n = ds.len();
    let dim = range_scale.len();
    let mut params = LwrParams::default_for(dim);
    let k = k.clamp(2, 255);
    let Some(mut index) = Index::new(range_scale.to_vec()) else {
        return (params, n);
    };
    if n < 2 * k {
        return (params, n);
    }
    let mut order = tuning_sample(ds, seed);
    let sampled = order.len();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    // Fold f is order[f], order[f + k], ...; its first `per_fold` members are scored.
    let mut fold = vec![u8::MAX; n];
    for (r, &i) in order.iter().enumerate() {
        fold[i] = (r % k) as u8;
        index.add(i as u32, ds.points());
    }
    let per_fold = TUNE_QUERIES / k + 1;
    let queries: Vec<(usize, u8)> = (0..k)
        .flat_map(|f| {
            order
                .iter()
                .copied()
                .skip(f)
                .step_by(k)
                .take(per_fold)
                .map(move |i| (i, f as u8))
        })
        .collect();
    drop(order);
    let act_dim = ds.domain().act_dim();
    let mut act_range = vec![1.0; act_dim];
    for (j, r) in act_range.iter_mut().enumerate() {
        let (lo, hi) = (0..n).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
            (lo.min(ds.a(i)[j]), hi.max(ds.a(i)[j]))
        });
        *r = if hi - lo > 1e-12 { hi - lo } else { 1.0 };
    }
    let cv = CrossValidation {
        ds,
        index: &index,
        fold: &fold,
    };
    let loss = |p: &LwrParams| -> f64 {
        let errors: Vec<f64> = queries
            .par_iter()
            .map_init(
                || (Scratch::default(), vec![0.0; act_dim]),
                |(scratch, a), &(i, f)| {
                    cv.query(p, ds.z(i), f, a, scratch);
                    (0..act_dim)
                        .map(|j| {
                            let e = (a[j] - ds.a(i)[j]) / act_range[j];
                            e * e
                        })
                        .sum::<f64>()
                },
            )
            .collect();
        errors.iter().sum::<f64>() / errors.len().max(1) as f64
    };
    if let Some(start) = start.filter(|s| s.scales.len() == dim) {
        let at = BANDWIDTH_GRID
            .iter()
            .enumerate()
            .min_by(|(_, a), (_, b)| {
                (*a - start.bandwidth)
                    .abs()
                    .total_cmp(&(*b - start.bandwidth).abs())
            })
            .map_or(0, |(i, _)| i);
        let near = &BANDWIDTH_GRID[at.saturating_sub(1)..(at + 2).min(BANDWIDTH_GRID.len())];
        params.scales = start.scales.clone();
        params.tolerance = start.tolerance;
        let losses: Vec<f64> = near
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
            params.bandwidth = near[i];
        }
        return (params, sampled);
    }
    // Prefer locality: the smallest bandwidth whose loss is within 5% of the best, and a scale
    // change only when it gains more than 1%. A wider kernel that is barely better costs a
    // neighbourhood many times larger on every query (the volume grows as h^dim) and blurs the
    // local corrections advice adds.
    let mut losses: Vec<f64> = Vec::with_capacity(BANDWIDTH_GRID.len());
    let mut rises = 0;
    for &h in &BANDWIDTH_GRID {
        let l = loss(&LwrParams {
            bandwidth: h,
            ..params.clone()
        });
        let min = losses.iter().copied().fold(l, f64::min);
        rises = match losses.last() {
            Some(&prev) if l > prev && l > 1.05 * min => rises + 1,
            _ => 0,
        };
        losses.push(l);
        if rises == 2 {
            break;
        }
    }
    let min = losses.iter().copied().fold(f64::INFINITY, f64::min);
    if let Some(i) = losses.iter().position(|l| *l <= min * 1.05) {
        params.bandwidth = BANDWIDTH_GRID[i];
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
    (params, sampled)
}

/// The points that take part in tuning: all of them up to [`TUNE_POINTS`]; beyond, whole
/// demonstrations and pieces of advice in a seeded order, as many as fit in [`TUNE_POINTS`]
/// points. Whole ones, because consecutive points of a trajectory are close in observation space:
/// a sample of single points would leave each held-out point without its trajectory neighbours,
/// and tune the kernel for a sparser dataset than the learner has.
fn tuning_sample(ds: &Dataset, seed: u64) -> Vec<usize> {
    let n = ds.len();
    if n <= TUNE_POINTS {
        return (0..n).collect();
    }
    let mut sources: Vec<Vec<u32>> = Vec::new();
    let mut by_key: HashMap<(bool, u32), usize> = HashMap::new();
    for i in 0..n {
        let key = match ds.provenance(i) {
            Provenance::Demonstration { demo, .. } => (false, demo),
            Provenance::Advice { advice, .. } => (true, advice),
        };
        let s = *by_key.entry(key).or_insert_with(|| {
            sources.push(Vec::new());
            sources.len() - 1
        });
        sources[s].push(i as u32);
    }
    let mut picks: Vec<usize> = (0..sources.len()).collect();
    picks.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ SAMPLE_SALT));
    let mut sample: Vec<usize> = Vec::with_capacity(TUNE_POINTS);
    for s in picks {
        if sample.len() + sources[s].len() <= TUNE_POINTS {
            sample.extend(sources[s].iter().map(|&i| i as usize));
        }
    }
    if sample.is_empty() {
        // Every source alone is larger than the sample: the start of the first one.
        sample.extend((0..TUNE_POINTS).map(|r| sources[0][r] as usize));
    }
    sample.sort_unstable();
    sample
}

/// Salt of the seed that orders the sources of [`tuning_sample`] (the folds use the seed itself).
const SAMPLE_SALT: u64 = 0x5A3F_1E00;

/// The data of a cross-validation: one index over the points that take part, and each point's
/// fold (`u8::MAX` for points that take no part; they are not in the index).
struct CrossValidation<'a> {
    ds: &'a Dataset,
    index: &'a Index,
    fold: &'a [u8],
}

/// Scale `z` into `s.q` and collect into `s.found` every group within the kernel's support (a
/// box inflated by the smallest tuned scale, since the index measures range-scaled distance);
/// returns `1 / (2 h^2)`, the kernel's exponent factor.
fn gather(index: &Index, pts: Points, params: &LwrParams, z: &[f64], s: &mut Scratch) -> f64 {
    s.q.resize(z.len(), 0.0);
    index.scaled(z, &mut s.q);
    let wmin = params
        .scales
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(1e-12);
    index.within(&s.q, params.r2() / (wmin * wmin), &mut s.found, pts);
    1.0 / (2.0 * params.bandwidth * params.bandwidth)
}

/// Far from all data: the point nearest to the scaled query `scratch.q` in the kernel's own space
/// (range scaling times the tuned `params.scales`), ties to the lowest point index. So the answer
/// is the same whether the index was built in range space (the general query) or already holds
/// the tuned scales (the learner's own index, queried with unit scales); they disagreed before.
/// Nearest groups are searched in widening rounds of the index's space until no unseen group can
/// be nearer: a group at distance `d` in the index's space is at least `min(scales) * d` away in
/// the kernel's.
fn nearest_in_kernel_space(
    index: &Index,
    pts: Points,
    params: &LwrParams,
    scratch: &mut Scratch,
) -> Option<u32> {
    let groups = index.groups();
    let wmin = params.scales.iter().copied().fold(f64::INFINITY, f64::min);
    let mut m = 4.min(groups);
    loop {
        index.nearest_n(&scratch.q, m, &mut scratch.found, pts);
        let mut best: Option<(f64, u32)> = None;
        for &(_, g) in &scratch.found {
            let d2: f64 = index
                .group_z(g, pts)
                .iter()
                .zip(&scratch.q)
                .zip(&params.scales)
                .map(|((p, q), s)| ((p - q) * s).powi(2))
                .sum();
            let first = index.group(g)[0];
            if best.is_none_or(|(bd, bi)| d2 < bd || (d2 == bd && first < bi)) {
                best = Some((d2, first));
            }
        }
        let farthest = scratch.found.last().map_or(0.0, |f| f.0);
        match best {
            Some((d2, point)) if farthest * wmin * wmin > d2 => return Some(point),
            _ if m >= groups => return best.map(|(_, point)| point),
            _ => m = (m * 4).min(groups),
        }
    }
}

/// The kernel weight of group `g` for the scaled query `q`, under the tuned per-dimension scales;
/// `None` outside the kernel's support (`r2`).
fn group_weight(
    index: &Index,
    pts: Points,
    g: u64,
    q: &[f64],
    params: &LwrParams,
    r2: f64,
    inv: f64,
) -> Option<f64> {
    let d2: f64 = index
        .group_z(g, pts)
        .iter()
        .zip(q)
        .zip(&params.scales)
        .map(|((p, q), s)| {
            let d = (p - q) * s;
            d * d
        })
        .sum();
    (d2 <= r2).then(|| (-d2 * inv).exp())
}

impl CrossValidation<'_> {
    /// [`query`]'s answer for `z` from the points outside fold `held_out`: the same kernel sum
    /// (general path), skipping the held-out fold's points; far from them all, the action of the
    /// first other-fold point of the nearest group that has one.
    fn query(&self, params: &LwrParams, z: &[f64], held_out: u8, a: &mut [f64], s: &mut Scratch) {
        let (index, ds) = (self.index, self.ds);
        a.iter_mut().for_each(|v| *v = 0.0);
        let inv = gather(index, ds.points(), params, z, s);
        let r2 = params.r2();
        let mut total = 0.0;
        for &(_, g) in &s.found {
            let Some(w) = group_weight(index, ds.points(), g, &s.q, params, r2, inv) else {
                continue;
            };
            for &i in index.group(g) {
                if self.fold[i as usize] == held_out {
                    continue;
                }
                for (out, v) in a.iter_mut().zip(ds.a(i as usize)) {
                    *out += w * v;
                }
                total += w;
            }
        }
        if total > 0.0 {
            a.iter_mut().for_each(|v| *v /= total);
            return;
        }
        // Far from the other folds: widen a nearest-groups search until one holds such a point
        // (there is one: every fold has at least two points and `index` holds them all). This
        // is the nearest in range space, where `query` now answers with the nearest in the
        // kernel's space. Aligning the two was tried with the calibration (issue 22): it moved
        // one tuned scale on the default session's demonstrations (its policy from 14/25 to 9/25)
        // and changed none of eight other demonstration sets: noise, not worth moving every
        // figure measured with the tuned parameters.
        let mut m = 4;
        loop {
            index.nearest_n(&s.q, m, &mut s.found, ds.points());
            let other = s.found.iter().find_map(|&(_, g)| {
                index
                    .group(g)
                    .iter()
                    .find(|&&i| self.fold[i as usize] != held_out)
            });
            if let Some(&i) = other {
                a.copy_from_slice(ds.a(i as usize));
                return;
            }
            if m >= index.groups() {
                return;
            }
            m = (m * 4).min(index.groups());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use advise_lang::domain::{Dim, Domain};
    use advise_lang::trace::Trace;
    use rand::Rng;

    fn domain() -> Domain {
        Domain {
            name: "test".into(),
            observe: vec![Dim::new("x", "", None), Dim::new("y", "", None)],
            act: vec![Dim::new("u", "", None)],
        }
    }

    /// `demos` random-walk demonstrations of `len` points each, with a smooth action and noise;
    /// some observations repeat (a base at rest), as in real data.
    fn dataset(demos: usize, len: usize, seed: u64) -> Dataset {
        let d = domain();
        let mut ds = Dataset::new(&d);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for k in 0..demos {
            let mut t = Trace::new(&d);
            let (mut x, mut y): (f64, f64) =
                (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            for i in 0..len {
                if i % 7 != 0 {
                    x += rng.random_range(-0.02..0.02);
                    y += rng.random_range(-0.02..0.02);
                }
                let u = (3.0 * x).sin() + y * y + rng.random_range(-0.05..0.05);
                t.push(i as f64, &[x, y], &[u], None);
            }
            ds.add_demonstration(&format!("d{k}"), &t).unwrap();
        }
        ds
    }

    fn range_scale(ds: &Dataset) -> Vec<f64> {
        (0..2)
            .map(|j| {
                let (lo, hi) = (0..ds.len())
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), i| {
                        (l.min(ds.z(i)[j]), h.max(ds.z(i)[j]))
                    });
                1.0 / (hi - lo)
            })
            .collect()
    }

    /// The cross-validation's answer from the shared index, skipping the held-out fold, equals
    /// [`query`] on an index of the other folds' points alone (what tuning used to build), far
    /// from the data included.
    #[test]
    fn skipping_a_fold_equals_an_index_without_it() {
        let ds = dataset(12, 40, 1);
        let scale = range_scale(&ds);
        let k = 5u8;
        let fold: Vec<u8> = (0..ds.len()).map(|i| ((i * 7 + i / 3) % 5) as u8).collect();
        let mut all = Index::new(scale.clone()).unwrap();
        for i in 0..ds.len() {
            all.add(i as u32, ds.points());
        }
        let cv = CrossValidation {
            ds: &ds,
            index: &all,
            fold: &fold,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for f in 0..k {
            let mut others = Index::new(scale.clone()).unwrap();
            for i in (0..ds.len()).filter(|&i| fold[i] != f) {
                others.add(i as u32, ds.points());
            }
            for params in [
                LwrParams::default_for(2),
                LwrParams {
                    scales: vec![0.5, 2.0],
                    bandwidth: 0.01,
                    tolerance: 1e-3,
                },
            ] {
                for q in 0..60 {
                    // Data points of the fold, and points anywhere (some far from all data).
                    let z = if q % 2 == 0 {
                        ds.z((q * 13) % ds.len()).to_vec()
                    } else {
                        vec![rng.random_range(-2.0..3.0), rng.random_range(-2.0..3.0)]
                    };
                    let (mut a, mut b) = ([0.0], [0.0]);
                    let mut s = Scratch::default();
                    cv.query(&params, &z, f, &mut a, &mut s);
                    let ans = query(&others, &ds, &params, &z, &mut b, &mut s);
                    if ans.total_weight == 0.0 {
                        // Far from the other folds, tuning answers with the nearest point in
                        // range space (see `CrossValidation::query`), not the kernel's.
                        let mut q = vec![0.0; 2];
                        others.scaled(&z, &mut q);
                        let (_, g) = others.nearest(&q, ds.points()).unwrap();
                        b[0] = ds.a(others.group(g)[0] as usize)[0];
                    }
                    let tol = if ans.total_weight > 0.0 { 1e-9 } else { 0.0 };
                    assert!((a[0] - b[0]).abs() <= tol, "fold {f} z {z:?}: {a:?} {b:?}");
                }
            }
        }
    }

    /// A warm start tries only the bandwidths beside the last one and keeps its scales; without
    /// one, `tune_from` is `tune`.
    #[test]
    fn a_warm_start_moves_a_grid_step_at_most_and_keeps_the_scales() {
        let ds = dataset(40, 60, 5);
        let scale = range_scale(&ds);
        assert_eq!(tune_from(&ds, &scale, 5, 3, None), tune(&ds, &scale, 5, 3));
        for (at, scales) in [
            (0, vec![1.0, 1.0]),
            (3, vec![2.0, 0.5]),
            (6, vec![0.5, 1.0]),
        ] {
            let start = LwrParams {
                scales: scales.clone(),
                bandwidth: BANDWIDTH_GRID[at],
                tolerance: 1e-3,
            };
            let warm = tune_from(&ds, &scale, 5, 3, Some(&start));
            assert_eq!(warm.scales, scales);
            let i = BANDWIDTH_GRID
                .iter()
                .position(|&h| h == warm.bandwidth)
                .expect("a grid bandwidth");
            assert!(i.abs_diff(at) <= 1, "{at} -> {i}");
            assert_eq!(warm, tune_from(&ds, &scale, 5, 3, Some(&start)));
        }
        // Off the grid: the nearest grid value's neighbourhood.
        let off = LwrParams {
            bandwidth: 0.3,
            ..LwrParams::default_for(2)
        };
        let warm = tune_from(&ds, &scale, 5, 3, Some(&off));
        assert!([0.12, 0.2].contains(&warm.bandwidth), "{warm:?}");
    }

    #[test]
    fn large_datasets_are_sampled_by_whole_demonstrations() {
        let ds = dataset(300, 100, 3);
        assert!(ds.len() > TUNE_POINTS);
        let sample = tuning_sample(&ds, 9);
        assert!(sample.len() <= TUNE_POINTS && sample.len() > TUNE_POINTS - 100);
        assert!(sample.windows(2).all(|w| w[0] < w[1]));
        // Whole demonstrations: every point of a demonstration, or none.
        let mut per_demo = HashMap::new();
        for &i in &sample {
            if let Provenance::Demonstration { demo, .. } = ds.provenance(i) {
                *per_demo.entry(demo).or_insert(0) += 1;
            }
        }
        assert!(per_demo.values().all(|&c| c == 100), "{per_demo:?}");
        assert_eq!(tuning_sample(&ds, 9), sample, "deterministic per seed");
        assert_ne!(
            tuning_sample(&ds, 10),
            sample,
            "another seed, another sample"
        );
        let small = dataset(10, 100, 3);
        assert_eq!(
            tuning_sample(&small, 9),
            (0..small.len()).collect::<Vec<_>>()
        );
    }

    /// Tuning a dataset past the sample size is deterministic per seed, and it does tune: the
    /// data's noise scale is far from the default kernel's.
    #[test]
    fn tuning_is_deterministic_per_seed() {
        let ds = dataset(260, 80, 4);
        let scale = range_scale(&ds);
        let a = tune(&ds, &scale, 5, 11);
        assert_eq!(a, tune(&ds, &scale, 5, 11));
        assert!(BANDWIDTH_GRID.contains(&a.bandwidth), "{a:?}");
        assert_ne!(
            a,
            LwrParams::default_for(2),
            "the data's kernel is not the default"
        );
    }
}
