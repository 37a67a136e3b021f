//! Binary Critiquing's learner: 1-nearest-neighbour over range-scaled observations, each data point
//! `i` with a weight `m_i >= 1` that multiplies its distance (the paper's equation 1).
//!
//! The query is exact under the weights without a linear scan. Groups are visited nearest first,
//! `k` at a time (4, then 16, 64, ...): since every `m_i >= 1`, a point whose raw distance is at
//! least the best weighted distance found so far cannot win, so the search stops as soon as the
//! `k`-th nearest is that far. When the nearest point is unpenalised the first group settles it;
//! a heavily penalised neighbourhood costs a few more rounds, never a scan of the data (a single
//! radius query of `m * d` would be one whenever `m` is large). Ties go to the lower point index.

use crate::policy::dataset::Dataset;
use crate::policy::index::Index;

/// The data point that supported an action.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Support {
    /// Index of the point in the dataset.
    pub point: usize,
    /// Raw scaled distance `||z_t - z_i||`.
    pub distance: f64,
    /// `m_i * distance`, what the 1-NN minimised.
    pub weighted: f64,
}

/// The weighted 1-NN query over `index` (built on `ds`'s points).
pub fn query(index: &Index, ds: &Dataset, z: &[f64], scratch: &mut Scratch) -> Option<Support> {
    scratch.q.resize(z.len(), 0.0);
    index.scaled(z, &mut scratch.q);
    let (d2, g) = index.nearest(&scratch.q)?;
    let mut best = best_in_group(index, ds, g, d2.sqrt(), None);
    if best.weighted <= best.distance {
        return Some(best);
    }
    let mut k = 4;
    loop {
        index.nearest_n(&scratch.q, k, &mut scratch.found);
        for &(d2, g) in &scratch.found {
            best = best_in_group(index, ds, g, d2.sqrt(), Some(best));
        }
        let exhausted = scratch.found.len() < k;
        let farthest = scratch
            .found
            .last()
            .map_or(f64::INFINITY, |(d2, _)| d2.sqrt());
        if exhausted || farthest >= best.weighted {
            return Some(best);
        }
        k *= 4;
    }
}

fn best_in_group(
    index: &Index,
    ds: &Dataset,
    g: u64,
    d: f64,
    mut best: Option<Support>,
) -> Support {
    for &i in index.group(g) {
        let i = i as usize;
        let w = ds.m(i) * d;
        let better = match best {
            None => true,
            Some(b) => w < b.weighted || (w == b.weighted && i < b.point),
        };
        if better {
            best = Some(Support {
                point: i,
                distance: d,
                weighted: w,
            });
        }
    }
    best.expect("a group is never empty")
}

/// Reusable buffers for queries.
#[derive(Default)]
pub struct Scratch {
    q: Vec<f64>,
    found: Vec<(f64, u64)>,
}

/// The smallest distance a critique divides by, in range-scaled units: a flagged observation that
/// coincides with its data point raises `m` by at most `kappa / MIN_CRITIQUE_DISTANCE`, a strong but
/// finite penalty (the paper's `kappa / ||z_t - z_i||` is infinite there).
pub const MIN_CRITIQUE_DISTANCE: f64 = 0.01;

/// The increments a critique of observations `zs` with `kappa` makes: for each flagged point, the
/// supporting data point (under the weights before the critique) and `kappa / max(d, MIN)`.
pub fn critique_increments(
    index: &Index,
    ds: &Dataset,
    zs: impl Iterator<Item = Vec<f64>>,
    kappa: f64,
) -> Vec<(usize, f64)> {
    let mut scratch = Scratch::default();
    zs.filter_map(|z| query(index, ds, &z, &mut scratch))
        .map(|s| (s.point, kappa / s.distance.max(MIN_CRITIQUE_DISTANCE)))
        .collect()
}
