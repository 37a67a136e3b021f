//! Binary Critiquing's learner: 1-nearest-neighbour over range-scaled observations, each data point
//! `i` with a weight `m_i >= 1` that multiplies its distance (the paper's equation 1).
//!
//! The query is exact under the weights without a linear scan. Groups are visited nearest first,
//! `k` at a time (4, then 16, 64, ...): since every `m_i >= 1`, a point whose raw distance is at
//! least the best weighted distance found so far cannot win, so the search stops as soon as the
//! `k`-th nearest is that far. When the nearest point is unpenalised the first group settles it;
//! a heavily penalised neighbourhood costs a few more rounds, never a scan of the data (a single
//! radius query of `m * d` would be one whenever `m` is large). Ties go to the lower point index.
//!
//! Under the directional rule (the paper's proposed improvement: "take into account query point
//! orientation"), a point's weight depends on where it is queried from:
//! `m_i(q) = m_i + sum_j inc_j * max(0, cos angle(q - z_i, z_tj - z_i))`, over the point's
//! directional increments `j`, each made when observation `z_tj` was flagged, angles measured in
//! the index's range-scaled space. A query from the flagged side meets the penalty (in full from
//! exactly the flagged direction), one from the other half-space does not; where either direction
//! is undefined (`q = z_i` or `z_tj = z_i`) the penalty counts in full. Since `m_i(q) >= m_i >= 1`
//! still, the stopping rule above stays exact.

use crate::dataset::Dataset;
use crate::index::{Index, MAX_DIM};

/// The data point that supported an action.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Support {
    /// Index of the point in the dataset.
    pub point: usize,
    /// Raw scaled distance `||z_t - z_i||`.
    pub distance: f64,
    /// The point's weight for this query: `m_i`, plus its directional increments as seen from
    /// the query's side.
    pub m: f64,
    /// `m * distance`, what the 1-NN minimised.
    pub weighted: f64,
}

/// The weighted 1-NN query over `index` (built on `ds`'s points).
pub fn query(index: &Index, ds: &Dataset, z: &[f64], scratch: &mut Scratch) -> Option<Support> {
    // A non-finite observation has no nearest point (every distance is NaN or infinite): no
    // support, rather than an index computed from a NaN.
    if !z.iter().all(|v| v.is_finite()) {
        return None;
    }
    scratch.q.resize(z.len(), 0.0);
    index.scaled(z, &mut scratch.q);
    let (d2, g) = index.nearest(&scratch.q, ds.points())?;
    let mut best = best_in_group(index, ds, &scratch.q, g, d2.sqrt(), None);
    if best.weighted <= best.distance {
        return Some(best);
    }
    let mut k = 4;
    loop {
        index.nearest_n(&scratch.q, k, &mut scratch.found, ds.points());
        for &(d2, g) in &scratch.found {
            best = best_in_group(index, ds, &scratch.q, g, d2.sqrt(), Some(best));
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
    q: &[f64],
    g: u64,
    d: f64,
    mut best: Option<Support>,
) -> Support {
    for &i in index.group(g) {
        let i = i as usize;
        let m = weight(ds, i, q, index.scale());
        let w = m * d;
        let better = match best {
            None => true,
            Some(b) => w < b.weighted || (w == b.weighted && i < b.point),
        };
        if better {
            best = Some(Support {
                point: i,
                distance: d,
                m,
                weighted: w,
            });
        }
    }
    best.expect("a group is never empty")
}

/// Point `i`'s weight for a query at `q` (already range-scaled by `scale`): `m_i` plus each
/// directional increment times the cosine factor of [`directional_factor`]. A point without
/// directional increments (most) costs one comparison.
#[inline]
pub fn weight(ds: &Dataset, i: usize, q: &[f64], scale: &[f64]) -> f64 {
    let (incs, flagged) = ds.directional(i);
    if incs.is_empty() {
        return ds.m(i);
    }
    let zi = ds.z(i);
    let dim = zi.len().min(MAX_DIM);
    let mut zs = [0.0; MAX_DIM];
    let mut u = [0.0; MAX_DIM];
    for k in 0..dim {
        zs[k] = zi[k] * scale[k];
        u[k] = q[k] - zs[k];
    }
    let (zs, u) = (&zs[..dim], &u[..dim]);
    let mut m = ds.m(i);
    for (inc, zt) in incs.iter().zip(flagged.chunks_exact(zi.len())) {
        m += inc * directional_factor(u, zs, zt, scale);
    }
    m
}

/// `max(0, cos angle(u, v))` with `v = z_t - z_i` in the scaled space (`zs` is `z_i` scaled,
/// `zt` raw); 1 when either vector is zero (no direction known: the penalty counts in full).
#[inline]
fn directional_factor(u: &[f64], zs: &[f64], zt: &[f64], scale: &[f64]) -> f64 {
    let (mut uv, mut uu, mut vv) = (0.0, 0.0, 0.0);
    for k in 0..u.len() {
        let v = zt[k] * scale[k] - zs[k];
        uv += u[k] * v;
        uu += u[k] * u[k];
        vv += v * v;
    }
    if uu == 0.0 || vv == 0.0 {
        return 1.0;
    }
    let cos = uv / (uu.sqrt() * vv.sqrt());
    // NaN (from an overflowing, astronomically far query) counts as no penalty; rounding never
    // lifts the factor above 1.
    if cos.is_nan() {
        0.0
    } else {
        cos.clamp(0.0, 1.0)
    }
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
/// supporting data point (under the weights before the critique), `kappa / max(d, MIN)`, and the
/// flagged observation itself (what the directional rule keeps).
pub fn critique_increments(
    index: &Index,
    ds: &Dataset,
    zs: impl Iterator<Item = Vec<f64>>,
    kappa: f64,
) -> Vec<(usize, f64, Vec<f64>)> {
    let mut scratch = Scratch::default();
    zs.filter_map(|z| {
        let s = query(index, ds, &z, &mut scratch)?;
        Some((s.point, kappa / s.distance.max(MIN_CRITIQUE_DISTANCE), z))
    })
    .collect()
}
