//! The spatial index behind both learners: the only code that touches kiddo.
//!
//! Observations are stored scaled (each dimension multiplied by a fixed factor chosen when the
//! index is built), and identical scaled observations share one entry: a *group* of dataset
//! points. Grouping matters twice: kiddo's mutable trees cannot hold more than a bucket's worth of
//! identical points, and advice routinely adds points whose observation repeats (advice on the
//! same chunk twice, a robot at rest).
//!
//! Two trees answer together. The groups planned for the *bulk* are in a balanced kd-tree of this
//! module's own, built once at the first query that needs it (so a load of many points builds it
//! once, not point by point); the few added since are in kiddo's mutable tree. When those pass
//! `max(RECENT_MIN, planned / RECENT_FRACTION)`, the bulk is planned anew over every group. The
//! plan follows from the sequence of additions alone, never from when queries came, so the order
//! a radius query reports its groups in (and the last bits of a kernel sum) depends on the data's
//! history only. Every query is exact: the bulk's boxes and a radius query's coarse `f32` test
//! only prune. The tree's dimension is a const generic, so the index dispatches over the
//! dimensions it supports (1 to [`MAX_DIM`]).

use std::sync::OnceLock;

use kiddo::{KdTree, SquaredEuclidean};

use crate::exp;

/// The largest observation dimension the index supports.
pub const MAX_DIM: usize = 8;

/// Groups added since the bulk tree was last planned that a small kiddo tree answers for, at
/// least; past `max(RECENT_MIN, planned / RECENT_FRACTION)` the bulk tree is planned anew over
/// every group (and built at the next query).
const RECENT_MIN: usize = 1024;
const RECENT_FRACTION: usize = 64;

/// Points per leaf of the bulk tree, at most.
const LEAF: usize = 64;

/// The most groups a bulk tree keeps an exact `f64` copy of in leaf order ([`Bulk::points`]):
/// `8 * D` bytes a group (at most 16 MiB a tree at this size and [`MAX_DIM`]), for the speed of
/// small datasets' queries: the copy is read in leaf order, where [`Exact`] follows the group's
/// id to its first point and scales its row (BC's 1-NN at 100,000 points: 455,000 queries per
/// CPU second without the copy, 630,000 with it; LWR 58,000 and 68,000), and laid out a
/// dimension at a time within a leaf, so a radius or k-nearest search measures a whole leaf's
/// exact distances in vector arithmetic. A larger tree computes its exact rows from the
/// dataset's, so the memory held per point at millions of points is unchanged. Either way the
/// same bits.
const EXACT_COPY_MAX: usize = 1 << 18;

/// The size of the parts the points' order is split down to, below a leaf's: the order within
/// a leaf (and so the order a radius query reports points in, and the last bits of a kernel
/// sum) is the one a tree with leaves of this size has.
const SPLIT: usize = 16;

/// The squared Euclidean distance, summed in dimension order from zero exactly as kiddo's
/// `SquaredEuclidean` does, so either tree reports the same bits for the same pair.
#[inline(always)]
fn dist2<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut s = 0.0;
    for k in 0..D {
        let d = a[k] - b[k];
        s += d * d;
    }
    s
}

/// The squared distance from `q` to the box `[lo, hi]` (zero inside).
#[inline(always)]
fn box_dist2<const D: usize>(q: &[f64; D], lo: &[f32; D], hi: &[f32; D]) -> f64 {
    let mut s = 0.0;
    for k in 0..D {
        let d = gap(f64::from(lo[k]), q[k], f64::from(hi[k]));
        s += d * d;
    }
    s
}

/// How far `q` lies outside `[lo, hi]` along one dimension (zero inside; zero for NaN, so a NaN
/// query prunes nothing and matches nothing). Written with comparisons, which compile to one
/// vector max each (`f64::max`'s NaN rules take three instructions).
#[inline(always)]
fn gap(lo: f64, q: f64, hi: f64) -> f64 {
    let (below, above) = (lo - q, q - hi);
    let d = if below > above { below } else { above };
    if d > 0.0 { d } else { 0.0 }
}

/// `(distance, group)` ordered by distance, then by group (ties to the lower group).
#[inline(always)]
fn before(a: (f64, u64), b: (f64, u64)) -> bool {
    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
}

/// A node of the bulk tree: a box around its points, and either its children (the left one
/// follows it) or, for a leaf, its points' range. The box is kept in `f32`, rounded outwards: it
/// only prunes, so a slightly larger box changes no answer, and a 6-D node fits one cache line
/// (the queries are bound by memory, not arithmetic).
#[repr(align(64))]
struct Node<const D: usize> {
    lo: [f32; D],
    hi: [f32; D],
    /// A leaf's first point, or an inner node's right child.
    first_or_right: u32,
    /// A leaf's end; [`INNER`] for an inner node.
    end: u32,
}

const INNER: u32 = u32::MAX;

/// How many points are under binary node `at`.
fn span<const D: usize>(nodes: &[Node<D>], at: usize) -> u32 {
    // The leftmost leaf follows its ancestors; the rightmost is reached by right children.
    let (mut left, mut right) = (at, at);
    while nodes[left].end == INNER {
        left += 1;
    }
    while nodes[right].end == INNER {
        right = nodes[right].first_or_right as usize;
    }
    nodes[right].end - nodes[left].first_or_right
}

/// Lanes of a leaf's exact distances computed together ([`Bulk::leaf_dist2`]): one AVX-512
/// vector, two AVX2 ones.
const CHUNK: usize = 8;

/// Children of a wide node, at most.
const WIDE: usize = 8;

/// A node of the bulk tree's radius-query form: up to [`WIDE`] children (the binary tree's
/// descendants three levels down, or leaves met sooner) with their boxes side by side, one
/// dimension's lower bounds for every child together, so the children are tested in one pass
/// of vector arithmetic, and a pruned child costs no visit. An unused slot's box is empty
/// (lower bound +inf), which no query passes. The nearest searches keep the binary nodes: they
/// descend nearest child first, which a wide node would have to sort.
#[repr(align(64))]
struct Wide<const D: usize> {
    lo: [[f32; WIDE]; D],
    hi: [[f32; WIDE]; D],
    /// Each child: an inner child's wide node, or a leaf's number (`true`).
    child: [(u32, bool); WIDE],
}

/// `x` as an `f32` no greater (`down`) or no smaller than it.
fn f32_outwards(x: f64, down: bool) -> f32 {
    let f = x as f32;
    if down && f64::from(f) > x {
        f.next_down()
    } else if !down && f64::from(f) < x {
        f.next_up()
    } else {
        f
    }
}

/// A balanced kd-tree built once over a fixed set of groups: each node split at the median of
/// its widest dimension, every node keeping the tight box of its points, the points' groups in
/// leaf order. The tight boxes matter on trajectory data: points lie along curves, so a cell's
/// points fill a sliver of it, and a query prunes on the sliver. Queries allocate nothing.
struct Bulk<const D: usize> {
    nodes: Vec<Node<D>>,
    /// The same tree with levels merged, for radius queries: see [`Wide`].
    wide: Vec<Wide<D>>,
    /// Each leaf's points' range, by leaf number (leaves numbered in leaf order).
    leaves: Vec<[u32; 2]>,
    /// Up to [`EXACT_COPY_MAX`] groups, their exact scaled observations in leaf order (the
    /// same bits [`Exact`] computes, read without its indirections), laid out as
    /// [`Bulk::coarse`] is (leaf by leaf, one dimension after another within a leaf, [`LEAF`]
    /// lanes of +inf after the last leaf); empty above that.
    points: Vec<f64>,
    /// The points again in `f32`, leaf by leaf, one dimension after another within a leaf: the
    /// leaf of points `first..first + len` has dimension `k` of its `j`-th point at
    /// `coarse[first * D + k * len + j]` (no padding between leaves; [`LEAF`] lanes of +inf
    /// after the last). A radius query computes a leaf's distances from these, [`LEAF`] lanes at
    /// a time (those past the leaf's points read its neighbour's values and are masked off) from
    /// one contiguous block of half the bytes, and measures exactly only the points they cannot
    /// rule out (see [`Coarse`]).
    coarse: Vec<f32>,
    /// The largest magnitude of any coordinate, for [`Coarse`]'s error bound.
    max_abs: f64,
    ids: Vec<u32>,
    /// With action sums: each point's group's sum and count (`act_dim + 1` values) in leaf
    /// order, so a kernel sum reads the rows beside the points it found instead of one scattered
    /// row per neighbour; `at[g]` is group `g`'s position, to keep the copy current.
    sums: Vec<f64>,
    at: Vec<u32>,
}

impl<const D: usize> Bulk<D> {
    /// The tree over groups `0..n` of `idx`, their scaled observations computed from `pts` (the
    /// points the index refers to), with their action sums when the index keeps them.
    ///
    /// Above [`EXACT_COPY_MAX`] groups the tree keeps no copy of the points' exact observations
    /// (its queries compute them from the points, [`Exact`]): the `(group, point)` pairs the
    /// splits order are dropped once the ids and the `f32` copy are taken out, before the action
    /// sums are made, so the build's peak is the pairs and the tree's own size.
    fn build(idx: &Index, pts: Points, n: usize) -> Bulk<D> {
        let mut order: Vec<(u32, [f64; D])> = Vec::with_capacity(n);
        order.extend((0..n).map(|g| {
            let mut row = [0.0; D];
            idx.group_scaled(g, pts, &mut row);
            (g as u32, row)
        }));
        let mut nodes = Vec::with_capacity(4 * n / LEAF + 1);
        if n > 0 {
            Self::build_node(&mut nodes, &mut order, 0);
        }
        // Leaves numbered in leaf order (the nodes are in depth-first order, left first).
        let mut leaf_of = vec![u32::MAX; nodes.len()];
        let mut leaves = Vec::new();
        for (at, node) in nodes.iter().enumerate() {
            if node.end != INNER {
                leaf_of[at] = leaves.len() as u32;
                leaves.push([node.first_or_right, node.end]);
            }
        }
        leaves.shrink_to_fit();
        let copy = n <= idx.exact_copy_max;
        // Each leaf's block of `D * len` values from `first * D` on; [`LEAF`] lanes past the
        // last block so that every leaf can be read [`LEAF`] lanes at a time.
        let mut coarse = vec![f32::INFINITY; n * D + LEAF];
        let mut points = if copy {
            vec![f64::INFINITY; n * D + LEAF]
        } else {
            Vec::new()
        };
        for &[first, end] in &leaves {
            let (first, len) = (first as usize, (end - first) as usize);
            for (j, (_, p)) in order[first..first + len].iter().enumerate() {
                for k in 0..D {
                    coarse[first * D + k * len + j] = p[k] as f32;
                    if copy {
                        points[first * D + k * len + j] = p[k];
                    }
                }
            }
        }
        let max_abs = order
            .iter()
            .flat_map(|(_, p)| p.iter())
            .fold(0.0, |m: f64, v| m.max(v.abs()));
        let mut wide = Vec::with_capacity(nodes.len() / 3 + 1);
        if n > 0 {
            Self::build_wide(&nodes, &leaf_of, &mut wide, 0);
        }
        drop(leaf_of);
        let ids: Vec<u32> = order.iter().map(|(g, _)| *g).collect();
        drop(order);
        let (mut sums, mut at) = (Vec::new(), Vec::new());
        if let Some(act_dim) = idx.act_dim {
            sums.resize(n * (act_dim + 1), 0.0);
            at.resize(n, 0);
            for (i, &g) in ids.iter().enumerate() {
                idx.group_sum(
                    g as usize,
                    pts,
                    &mut sums[i * (act_dim + 1)..][..act_dim + 1],
                );
                at[g as usize] = i as u32;
            }
        }
        Bulk {
            nodes,
            wide,
            leaves,
            points,
            coarse,
            max_abs,
            ids,
            sums,
            at,
        }
    }

    /// The bytes the tree holds.
    fn held_bytes(&self) -> usize {
        use std::mem::size_of;
        self.nodes.capacity() * size_of::<Node<D>>()
            + self.wide.capacity() * size_of::<Wide<D>>()
            + self.leaves.capacity() * 8
            + self.points.capacity() * 8
            + self.coarse.capacity() * 4
            + self.ids.capacity() * 4
            + self.sums.capacity() * 8
            + self.at.capacity() * 4
    }

    /// The bytes of the exact copy (none above [`EXACT_COPY_MAX`] groups).
    #[cfg(test)]
    fn exact_copy_bytes(&self) -> usize {
        self.points.capacity() * 8
    }

    fn build_node(nodes: &mut Vec<Node<D>>, part: &mut [(u32, [f64; D])], start: usize) {
        let (lo, hi) = Self::bounds(part);
        let me = nodes.len();
        nodes.push(Node {
            lo: lo.map(|v| f32_outwards(v, true)),
            hi: hi.map(|v| f32_outwards(v, false)),
            first_or_right: start as u32,
            end: (start + part.len()) as u32,
        });
        // A leaf holds at most LEAF points, which its scan relies on: a part is split even
        // without spread (groups are distinct, so that is one point, or NaN coordinates).
        if part.len() <= LEAF {
            Self::order(part);
            return;
        }
        let mid = Self::split(part, &lo, &hi);
        let (left, right) = part.split_at_mut(mid);
        nodes[me].end = INNER;
        Self::build_node(nodes, left, start);
        nodes[me].first_or_right = nodes.len() as u32;
        Self::build_node(nodes, right, start + mid);
    }

    /// The wide node over binary node `at`'s descendants: its children, then (when inner) their
    /// children, the largest first, until there are [`WIDE`] or only leaves, kept in leaf order.
    /// A leaf as the root is a wide node with that one child.
    fn build_wide(nodes: &[Node<D>], leaf_of: &[u32], wide: &mut Vec<Wide<D>>, at: usize) -> u32 {
        let mut kids: Vec<usize> = if nodes[at].end == INNER {
            vec![at + 1, nodes[at].first_or_right as usize]
        } else {
            vec![at]
        };
        while kids.len() < WIDE {
            let Some(c) = (0..kids.len())
                .filter(|&c| nodes[kids[c]].end == INNER)
                .max_by_key(|&c| (span(nodes, kids[c]), std::cmp::Reverse(c)))
            else {
                break;
            };
            let n = kids[c];
            kids.splice(c..=c, [n + 1, nodes[n].first_or_right as usize]);
        }
        let me = wide.len();
        wide.push(Wide {
            lo: [[f32::INFINITY; WIDE]; D],
            hi: [[f32::NEG_INFINITY; WIDE]; D],
            child: [(0, false); WIDE],
        });
        for (c, &n) in kids.iter().enumerate() {
            for k in 0..D {
                wide[me].lo[k][c] = nodes[n].lo[k];
                wide[me].hi[k][c] = nodes[n].hi[k];
            }
            wide[me].child[c] = if nodes[n].end == INNER {
                (Self::build_wide(nodes, leaf_of, wide, n), false)
            } else {
                (leaf_of[n], true)
            };
        }
        me as u32
    }

    /// The box around `part`'s points.
    fn bounds(part: &[(u32, [f64; D])]) -> ([f64; D], [f64; D]) {
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        for (_, p) in part.iter() {
            for k in 0..D {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }

    /// Split `part` (inside `[lo, hi]`) at the median of its widest dimension; the left part's
    /// length.
    fn split(part: &mut [(u32, [f64; D])], lo: &[f64; D], hi: &[f64; D]) -> usize {
        let (split, _) = (0..D)
            .map(|k| (k, hi[k] - lo[k]))
            .fold((0, 0.0), |best, c| if c.1 > best.1 { c } else { best });
        let mid = part.len() / 2;
        part.select_nth_unstable_by(mid, |a, b| a.1[split].total_cmp(&b.1[split]));
        mid
    }

    /// Order a leaf's points as splits down to [`SPLIT`] points would.
    fn order(part: &mut [(u32, [f64; D])]) {
        if part.len() <= SPLIT {
            return;
        }
        let (lo, hi) = Self::bounds(part);
        let mid = Self::split(part, &lo, &hi);
        let (left, right) = part.split_at_mut(mid);
        Self::order(left);
        Self::order(right);
    }

    /// The exact scaled observation at leaf position `i` of the leaf of points `first..first +
    /// len`: from the copy when the tree keeps one, else computed from the points (the same
    /// bits).
    #[inline(always)]
    fn row(&self, i: usize, [first, len]: [usize; 2], ex: &Exact<D>) -> [f64; D] {
        if self.points.is_empty() {
            ex.row(self.ids[i])
        } else {
            let block = &self.points[first * D + i - first..];
            std::array::from_fn(|k| block[k * len])
        }
    }

    /// The exact squared distances from `q` of the leaf of points `first..first + len`, as
    /// [`dist2`] sums them (the same bits), into `out[..len]` (lanes after `len` are garbage).
    /// With the exact copy, a leaf's lanes [`CHUNK`] at a time in vector arithmetic.
    #[inline(always)]
    fn leaf_dist2(
        &self,
        q: &[f64; D],
        [first, len]: [usize; 2],
        ex: &Exact<D>,
        out: &mut [f64; LEAF],
    ) {
        if self.points.is_empty() {
            for (j, o) in out[..len].iter_mut().enumerate() {
                *o = dist2(q, &ex.row(self.ids[first + j]));
            }
            return;
        }
        let block = &self.points[first * D..];
        for (c, out) in out
            .chunks_exact_mut(CHUNK)
            .take(len.div_ceil(CHUNK))
            .enumerate()
        {
            let mut s = [0.0f64; CHUNK];
            for (k, qk) in q.iter().enumerate() {
                let col: &[f64; CHUNK] = block[k * len + c * CHUNK..][..CHUNK]
                    .try_into()
                    .expect("a block is followed by LEAF lanes");
                for (s, v) in s.iter_mut().zip(col) {
                    let d = qk - v;
                    *s += d * d;
                }
            }
            out.copy_from_slice(&s);
        }
    }

    fn nearest_one(&self, q: &[f64; D], best: &mut (f64, u64), ex: &Exact<D>) {
        if !self.nodes.is_empty() {
            self.nearest_one_in(0, q, best, ex);
        }
    }

    fn nearest_one_in(&self, at: usize, q: &[f64; D], best: &mut (f64, u64), ex: &Exact<D>) {
        let node = &self.nodes[at];
        if node.end != INNER {
            let (first, end) = (node.first_or_right as usize, node.end as usize);
            let mut d2 = [0.0; LEAF];
            self.leaf_dist2(q, [first, end - first], ex, &mut d2);
            for (i, d) in (first..end).zip(d2) {
                let c = (d, u64::from(self.ids[i]));
                if before(c, *best) {
                    *best = c;
                }
            }
            return;
        }
        for (d, next) in self.children_nearest_first(at, q) {
            if d <= best.0 {
                self.nearest_one_in(next, q, best, ex);
            }
        }
    }

    /// Inner node `at`'s two children with the squared distance from `q` to each one's box,
    /// the nearer first (the left one on a tie): the order the nearest searches descend in.
    #[inline(always)]
    fn children_nearest_first(&self, at: usize, q: &[f64; D]) -> [(f64, usize); 2] {
        let (l, r) = (at + 1, self.nodes[at].first_or_right as usize);
        let dl = box_dist2(q, &self.nodes[l].lo, &self.nodes[l].hi);
        let dr = box_dist2(q, &self.nodes[r].lo, &self.nodes[r].hi);
        if dl <= dr {
            [(dl, l), (dr, r)]
        } else {
            [(dr, r), (dl, l)]
        }
    }

    /// The `n` nearest into `heap`, a max-heap under [`before`] holding at most `n`.
    fn nearest_n(&self, q: &[f64; D], n: usize, heap: &mut Vec<(f64, u64)>, ex: &Exact<D>) {
        if !self.nodes.is_empty() && n > 0 {
            self.nearest_n_in(0, q, n, heap, ex);
        }
    }

    /// The `n` nearest points within squared distance `r2` of `q` (ties to the lower group):
    /// `found` holds them in no set order, at most `n`; returns the `n`-th one's distance when
    /// there are `n`, else `r2`. Unlike [`Bulk::nearest_n`]'s heap, which pays a sift of `log n`
    /// unpredictable steps a candidate (the k-limited kernel's `n` is in the thousands), the
    /// candidates are appended to `found`, and when it holds `2 n` it is cut to its `n` nearest
    /// (a selection, linear), whose farthest bounds the rest of the search: the same points.
    fn nearest_n_within(
        &self,
        q: &[f64; D],
        n: usize,
        r2: f64,
        found: &mut Vec<(f64, u64)>,
        ex: &Exact<D>,
    ) -> f64 {
        found.clear();
        if self.nodes.is_empty() || n == 0 {
            return r2;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: this processor has AVX-512F, checked just above.
            return unsafe { self.nearest_n_within_avx512(q, n, r2, found, ex) };
        } else if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: this processor has AVX2, checked just above.
            return unsafe { self.nearest_n_within_avx2(q, n, r2, found, ex) };
        }
        self.nearest_n_within_any(q, n, r2, found, ex)
    }

    /// [`Bulk::nearest_n_within`] compiled for AVX2 (the same bits: see [`Bulk::within_dispatch`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn nearest_n_within_avx2(
        &self,
        q: &[f64; D],
        n: usize,
        r2: f64,
        found: &mut Vec<(f64, u64)>,
        ex: &Exact<D>,
    ) -> f64 {
        self.nearest_n_within_any(q, n, r2, found, ex)
    }

    /// [`Bulk::nearest_n_within`] compiled for AVX-512.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn nearest_n_within_avx512(
        &self,
        q: &[f64; D],
        n: usize,
        r2: f64,
        found: &mut Vec<(f64, u64)>,
        ex: &Exact<D>,
    ) -> f64 {
        self.nearest_n_within_any(q, n, r2, found, ex)
    }

    #[inline(always)]
    fn nearest_n_within_any(
        &self,
        q: &[f64; D],
        n: usize,
        r2: f64,
        found: &mut Vec<(f64, u64)>,
        ex: &Exact<D>,
    ) -> f64 {
        let mut bound = r2;
        // Nodes to visit with their boxes' squared distances, the next one last: the nearer
        // child before the farther (the left one on a tie), each tested against the bound when
        // its turn comes. Median splits bound the depth by 32, one pending sibling a level.
        let mut stack = [(0usize, 0.0f64); 64];
        let mut top = 1;
        let mut d2 = [0.0; LEAF];
        while top > 0 {
            top -= 1;
            let (at, d) = stack[top];
            if d > bound {
                continue;
            }
            let node = &self.nodes[at];
            if node.end == INNER {
                let [near, far] = self.children_nearest_first(at, q);
                stack[top] = (far.1, far.0);
                stack[top + 1] = (near.1, near.0);
                top += 2;
                continue;
            }
            let (first, end) = (node.first_or_right as usize, node.end as usize);
            self.leaf_dist2(q, [first, end - first], ex, &mut d2);
            for (i, d) in (first..end).zip(d2) {
                if d <= bound {
                    found.push((d, u64::from(self.ids[i])));
                }
            }
            if found.len() >= 2 * n {
                bound = keep_nearest(found, n);
            }
        }
        if found.len() > n {
            bound = keep_nearest(found, n);
        }
        if found.len() < n { r2 } else { bound }
    }

    fn nearest_n_in(
        &self,
        at: usize,
        q: &[f64; D],
        n: usize,
        heap: &mut Vec<(f64, u64)>,
        ex: &Exact<D>,
    ) {
        let node = &self.nodes[at];
        if node.end != INNER {
            let (first, end) = (node.first_or_right as usize, node.end as usize);
            let mut d2 = [0.0; LEAF];
            self.leaf_dist2(q, [first, end - first], ex, &mut d2);
            for (i, d) in (first..end).zip(d2) {
                heap_offer(heap, n, (d, u64::from(self.ids[i])));
            }
            return;
        }
        for (d, next) in self.children_nearest_first(at, q) {
            if heap.len() < n || d <= heap[0].0 {
                self.nearest_n_in(next, q, n, heap, ex);
            }
        }
    }

    /// Every point within squared distance `r2` of `q`: `f(squared distance, leaf position)`, in
    /// leaf order (the wide tree walked depth first, left before right, with its own stack), the
    /// order the binary tree with [`SPLIT`]-point leaves reported them in, so kernel sums keep
    /// their bits. A leaf's points are first tested coarsely ([`Coarse`]); the few it cannot
    /// rule out are measured exactly (with the exact copy, [`CHUNK`] lanes at a time in vector
    /// arithmetic).
    fn within(&self, q: &[f64; D], r2: f64, f: &mut impl FnMut(f64, usize), ex: &Exact<D>) {
        self.within_dispatch(q, r2, &mut EachPoint(f), ex)
    }

    /// The Gaussian kernel's sums over the points within `r2` of `q` (the tree keeps action
    /// sums, `acc.len()` values a row): `acc[c] += exp(-d2 * inv) * sums[c]`, in leaf order, a
    /// batch's weights computed in one loop that vectorizes ([`exp::exp_in_place`]). Returns the
    /// points summed (the rows' last values).
    fn kernel(&self, q: &[f64; D], r2: f64, inv: f64, acc: &mut [f64], ex: &Exact<D>) -> f64 {
        // Rows of a fixed width keep the sums in registers: actions of 1 to 4 dimensions.
        match acc.len() {
            2 => self.kernel_w::<2>(q, r2, inv, acc, ex),
            3 => self.kernel_w::<3>(q, r2, inv, acc, ex),
            4 => self.kernel_w::<4>(q, r2, inv, acc, ex),
            5 => self.kernel_w::<5>(q, r2, inv, acc, ex),
            _ => {
                let mut k = KernelSum::new(&self.sums, inv, r2, acc.to_vec());
                self.within_dispatch(q, r2, &mut k, ex);
                acc.copy_from_slice(&k.acc);
                k.points
            }
        }
    }

    fn kernel_w<const W: usize>(
        &self,
        q: &[f64; D],
        r2: f64,
        inv: f64,
        acc: &mut [f64],
        ex: &Exact<D>,
    ) -> f64 {
        let acc_w = <[f64; W]>::try_from(&*acc).expect("a row of W values");
        let mut k = KernelSum::new(&self.sums, inv, r2, acc_w);
        self.within_dispatch(q, r2, &mut k, ex);
        acc.copy_from_slice(&k.acc);
        k.points
    }

    /// [`Bulk::within_any_visit`] for a visitor of batches, compiled for AVX-512 or AVX2 where
    /// the processor has it.
    fn within_dispatch(&self, q: &[f64; D], r2: f64, f: &mut impl VisitBatch, ex: &Exact<D>) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("popcnt")
        {
            // SAFETY: this processor has AVX-512F and POPCNT, checked just above.
            return unsafe { self.within_visit_avx512(q, r2, f, ex) };
        } else if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: this processor has AVX2, checked just above.
            return unsafe { self.within_visit_avx2(q, r2, f, ex) };
        }
        self.within_any_visit(q, r2, f, ex, Scalar)
    }

    /// [`Bulk::within_dispatch`] compiled for AVX-512: eight `f64` lanes at a time, the points
    /// inside kept with one `vcompresspd` per [`CHUNK`] lanes. The same bits as every other copy
    /// (the tests compare them).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    fn within_visit_avx512(&self, q: &[f64; D], r2: f64, f: &mut impl VisitBatch, ex: &Exact<D>) {
        // SAFETY: this function runs only where the processor has AVX-512F.
        let chunks = unsafe { Avx512::new() };
        self.within_any_visit(q, r2, f, ex, chunks)
    }

    /// [`Bulk::within_dispatch`] compiled for AVX2: eight `f32` lanes of a leaf's coarse
    /// distances and four boxes at a time instead of four and two (a third of the query's time,
    /// measured), and a kernel sum's exponentials four lanes at a time (the visitor is inlined,
    /// so compiled for AVX2 too). Without fused multiply-adds (Rust never contracts them), so
    /// the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn within_visit_avx2(&self, q: &[f64; D], r2: f64, f: &mut impl VisitBatch, ex: &Exact<D>) {
        self.within_any_visit(q, r2, f, ex, Scalar)
    }

    /// The radius search: the wide tree walked depth first, left before right; each leaf's
    /// points inside the radius appended to a [`Batch`], which the visitor gets when it holds
    /// [`BATCH`] points or [`SEGMENTS`] leaves, and at the end.
    ///
    /// A child whose box lies wholly inside the radius (its corner farthest from `q` is), and
    /// everything under it, skips the box and coarse tests: every point is measured exactly,
    /// and kept by the exact test as every other point is (the box only spares the work; a point
    /// it would wrongly include, a NaN's, fails the exact test).
    #[inline(always)]
    fn within_any_visit(
        &self,
        q: &[f64; D],
        r2: f64,
        f: &mut impl VisitBatch,
        ex: &Exact<D>,
        chunks: impl Chunks,
    ) {
        if self.wide.is_empty() {
            return;
        }
        let coarse = Coarse::new(q, r2, self.max_abs);
        // Pending children, the next one last: (node or leaf, a leaf, wholly inside). Each wide
        // node adds at most WIDE - 1 pending siblings, and median splits bound the depth by 32.
        let mut stack = [(0u32, false, false); 32 * WIDE];
        let mut top = 1;
        let mut batch = Batch::new();
        let exact_copy = !self.points.is_empty();
        while top > 0 {
            top -= 1;
            let (at, leaf, inside) = stack[top];
            if leaf {
                let [first, end] = self.leaves[at as usize];
                let (first, end) = (first as usize, end as usize);
                let len = end - first;
                // Candidates as bits (a branch per point inside the radius or not was
                // mispredicted about as often as not). A leaf holds 1 to LEAF <= 64 points.
                let mut maybe = match (&coarse, inside) {
                    (Some(c), false) => chunks.candidates(c, &self.coarse[first * D..], len),
                    _ => u64::MAX,
                };
                maybe &= u64::MAX >> (64 - len);
                let mut kept = 0u64;
                // The batch's length in a local: kept in the field, each chunk's update went
                // through memory (a store and its reload on the next chunk's path).
                let mut n = batch.len;
                if exact_copy {
                    // The exact distances CHUNK lanes at a time (the exact copy), chunks without
                    // a candidate skipped; the lanes inside appended in order.
                    let block = &self.points[first * D..];
                    for c in 0..len.div_ceil(CHUNK) {
                        let cand = (maybe >> (c * CHUNK)) as u8;
                        if cand == 0 {
                            continue;
                        }
                        let out = (&mut batch.d2[n..n + CHUNK])
                            .try_into()
                            .expect("a batch has room for a leaf past BATCH");
                        let m = chunks.keep(q, block, [len, c], r2, cand, out);
                        n += m.count_ones() as usize;
                        kept |= u64::from(m) << (c * CHUNK);
                    }
                } else {
                    while maybe != 0 {
                        let j = maybe.trailing_zeros() as usize;
                        let d = dist2(q, &self.row(first + j, [first, len], ex));
                        // Written unconditionally, kept when inside: no branch to mispredict.
                        let inside = d <= r2;
                        batch.d2[n] = d;
                        n += usize::from(inside);
                        kept |= u64::from(inside) << j;
                        maybe &= maybe - 1;
                    }
                }
                batch.len = n;
                if kept != 0 {
                    batch.segments[batch.leaves] = (first as u32, kept);
                    batch.leaves += 1;
                    if batch.len >= BATCH || batch.leaves == SEGMENTS {
                        f.batch(&batch);
                        batch.clear();
                    }
                }
                continue;
            }
            let node = &self.wide[at as usize];
            // Each child's box's squared distance from `q`, as `box_dist2` sums it, and its
            // farthest corner's, as `dist2` would sum a point's there: the exact distance of
            // every point in the box is at most that (each difference is rounded monotonically).
            let mut to_box = [0.0f64; WIDE];
            let mut to_far = [0.0f64; WIDE];
            for ((qk, lo), hi) in q.iter().zip(&node.lo).zip(&node.hi) {
                for (((s, t), lo), hi) in to_box.iter_mut().zip(&mut to_far).zip(lo).zip(hi) {
                    let (lo, hi) = (f64::from(*lo), f64::from(*hi));
                    let d = gap(lo, *qk, hi);
                    *s += d * d;
                    let (below, above) = (*qk - lo, hi - *qk);
                    let e = if below > above { below } else { above };
                    *t += e * e;
                }
            }
            for c in (0..WIDE).rev() {
                if to_box[c] <= r2 {
                    let (child, leaf) = node.child[c];
                    stack[top] = (child, leaf, inside || to_far[c] <= r2);
                    top += 1;
                }
            }
        }
        if batch.leaves > 0 {
            f.batch(&batch);
        }
    }
}

/// Points inside the radius a batch holds at most before its visitor is called (the last leaf
/// may take it past, by [`LEAF`] at most).
const BATCH: usize = 256;
/// Leaves a batch holds at most.
const SEGMENTS: usize = 64;

/// Points inside a radius from consecutive leaves, in leaf order: their squared distances side
/// by side, and each leaf's first position with the mask of its points inside. A kernel sum
/// computes the weights of a whole batch in one loop: a leaf's few points inside no longer
/// cost a vector of exponentials each, and no positions are copied.
struct Batch {
    /// `d2[..len]`: the points' squared distances (the lanes after them are garbage).
    d2: [f64; BATCH + LEAF + CHUNK],
    len: usize,
    segments: [(u32, u64); SEGMENTS],
    leaves: usize,
}

impl Batch {
    fn new() -> Batch {
        Batch {
            d2: [0.0; BATCH + LEAF + CHUNK],
            len: 0,
            segments: [(0, 0); SEGMENTS],
            leaves: 0,
        }
    }

    fn clear(&mut self) {
        self.len = 0;
        self.leaves = 0;
    }

    /// The points' leaf positions in order, with their squared distances.
    #[inline(always)]
    fn points(&self) -> impl Iterator<Item = (f64, usize)> + '_ {
        self.segments[..self.leaves]
            .iter()
            .flat_map(|&(first, mask)| Bits(mask).map(move |j| first as usize + j))
            .zip(&self.d2[..self.len])
            .map(|(i, d)| (*d, i))
    }
}

/// The set bits of a mask, lowest first.
struct Bits(u64);

impl Iterator for Bits {
    type Item = usize;
    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let j = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(j)
    }
}

/// How a radius search measures a leaf's points [`CHUNK`] lanes at a time with the exact copy:
/// `keep(q, block, [len, c], r2, cand, out)` computes the exact squared distances of lanes
/// `c * CHUNK..` of the leaf of `len` points whose block of the copy starts `block`, as [`dist2`]
/// sums them (the same bits), writes those of the lanes whose bit of `cand` is set that are
/// inside `r2` to the start of `out`, in order, and returns their mask (the rest of `out` is
/// garbage).
trait Chunks: Copy {
    /// [`Coarse::candidates`].
    #[inline(always)]
    fn candidates<const D: usize>(&self, c: &Coarse<D>, block: &[f32], len: usize) -> u64 {
        c.candidates(block, len)
    }

    fn keep<const D: usize>(
        &self,
        q: &[f64; D],
        block: &[f64],
        len_chunk: [usize; 2],
        r2: f64,
        cand: u8,
        out: &mut [f64; CHUNK],
    ) -> u8;
}

/// Plain arithmetic the compiler vectorizes; each lane written and kept or not without a branch.
#[derive(Clone, Copy)]
struct Scalar;

impl Chunks for Scalar {
    #[inline(always)]
    fn keep<const D: usize>(
        &self,
        q: &[f64; D],
        block: &[f64],
        [len, c]: [usize; 2],
        r2: f64,
        cand: u8,
        out: &mut [f64; CHUNK],
    ) -> u8 {
        let mut s = [0.0f64; CHUNK];
        for (k, qk) in q.iter().enumerate() {
            let col: &[f64; CHUNK] = block[k * len + c * CHUNK..][..CHUNK]
                .try_into()
                .expect("a block is followed by LEAF lanes");
            for (s, v) in s.iter_mut().zip(col) {
                let d = qk - v;
                *s += d * d;
            }
        }
        let mut m = 0u8;
        for (j, s) in s.iter().enumerate() {
            m |= u8::from(*s <= r2) << j;
        }
        m &= cand;
        let mut n = 0;
        for (j, v) in s.iter().enumerate() {
            // `n <= j < CHUNK`: the mask only spares a bounds check.
            out[n & (CHUNK - 1)] = *v;
            n += usize::from((m >> j) & 1 == 1);
        }
        m
    }
}

/// AVX-512: a chunk is one vector a dimension, its comparison a mask, and the lanes inside kept
/// with `vcompresspd` (its register form: the memory form is microcoded and slow on some
/// processors), then one store. Multiplications and additions apart (no fused multiply-add), in
/// [`dist2`]'s order: the same bits.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx512(());

#[cfg(target_arch = "x86_64")]
impl Avx512 {
    /// # Safety
    /// The processor has AVX-512F.
    unsafe fn new() -> Avx512 {
        Avx512(())
    }
}

#[cfg(target_arch = "x86_64")]
impl Chunks for Avx512 {
    /// [`Coarse::candidates`]'s arithmetic (the same bits) in four vectors of sixteen lanes,
    /// whose comparisons are the mask's four quarters.
    #[inline(always)]
    fn candidates<const D: usize>(&self, c: &Coarse<D>, block: &[f32], len: usize) -> u64 {
        use std::arch::x86_64::*;
        const { assert!(LEAF == 64) };
        // SAFETY: an `Avx512` exists only where the processor has AVX-512F (`Avx512::new`);
        // every pointer is to sixteen `f32`s (a quarter of a slice of LEAF, checked).
        unsafe {
            let mut s = [_mm512_setzero_ps(); 4];
            for (k, qk) in c.q.iter().enumerate() {
                let col: &[f32; LEAF] = block[k * len..][..LEAF]
                    .try_into()
                    .expect("a block holds LEAF lanes of each dimension");
                let qv = _mm512_set1_ps(*qk);
                for (v, s) in s.iter_mut().enumerate() {
                    let d = _mm512_sub_ps(qv, _mm512_loadu_ps(col[16 * v..].as_ptr()));
                    *s = _mm512_add_ps(*s, _mm512_mul_ps(d, d));
                }
            }
            let r2 = _mm512_set1_ps(c.r2);
            let mut maybe = 0u64;
            for (v, s) in s.iter().enumerate() {
                maybe |= u64::from(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(*s, r2)) << (16 * v);
            }
            maybe
        }
    }

    #[inline(always)]
    fn keep<const D: usize>(
        &self,
        q: &[f64; D],
        block: &[f64],
        [len, c]: [usize; 2],
        r2: f64,
        cand: u8,
        out: &mut [f64; CHUNK],
    ) -> u8 {
        use std::arch::x86_64::*;
        // SAFETY: an `Avx512` exists only where the processor has AVX-512F (`Avx512::new`);
        // every pointer is to eight `f64`s (checked by the slices' conversions).
        unsafe {
            let mut s = _mm512_setzero_pd();
            for (k, qk) in q.iter().enumerate() {
                let col: &[f64; CHUNK] = block[k * len + c * CHUNK..][..CHUNK]
                    .try_into()
                    .expect("a block is followed by LEAF lanes");
                let d = _mm512_sub_pd(_mm512_set1_pd(*qk), _mm512_loadu_pd(col.as_ptr()));
                s = _mm512_add_pd(s, _mm512_mul_pd(d, d));
            }
            let m = _mm512_mask_cmp_pd_mask::<_CMP_LE_OQ>(cand, s, _mm512_set1_pd(r2));
            _mm512_storeu_pd(out.as_mut_ptr(), _mm512_maskz_compress_pd(m, s));
            m
        }
    }
}

/// What a radius search does with the points inside the radius, a [`Batch`] at a time (at least
/// one point, in leaf order). A trait rather than a closure so that [`KernelSum`]'s
/// `#[inline(always)]` reaches into the AVX2- and AVX-512-compiled searches.
trait VisitBatch {
    fn batch(&mut self, b: &Batch);
}

/// A closure of `(squared distance, leaf position)` as a [`VisitBatch`].
struct EachPoint<'f, F>(&'f mut F);

impl<F: FnMut(f64, usize)> VisitBatch for EachPoint<'_, F> {
    #[inline(always)]
    fn batch(&mut self, b: &Batch) {
        for (d, i) in b.points() {
            (self.0)(d, i)
        }
    }
}

/// A Gaussian kernel sum over the bulk tree's action sums, rows of `acc.len()` values: a
/// batch's weights in one loop, then added row by row in leaf order.
struct KernelSum<'a, A> {
    sums: &'a [f64],
    inv: f64,
    /// Every exponent `-d2 * inv` of a point inside the radius is in [`exp::exp_in_range`]'s
    /// range (see [`KernelSum::new`]).
    in_range: bool,
    acc: A,
    points: f64,
    /// A batch's weights (kept here so that a batch costs no clearing of a fresh array).
    weights: [f64; BATCH + LEAF + CHUNK],
}

impl<'a, A> KernelSum<'a, A> {
    /// The sum of `exp(-d2 * inv) * row` over points within `r2`. When `r2` and `inv` are finite,
    /// `inv` positive and `r2 * inv` at most `-IN_RANGE_MIN`, every point's exponent is in
    /// [`exp::exp_in_range`]'s range: `0 <= d2 <= r2` (a point inside), so `d2 * inv <= r2 *
    /// inv` (rounding is monotonic), and the weights skip [`exp::exp`]'s handling of the ends
    /// (the same bits).
    fn new(sums: &'a [f64], inv: f64, r2: f64, acc: A) -> Self {
        let in_range =
            r2.is_finite() && inv.is_finite() && inv > 0.0 && r2 * inv <= -exp::IN_RANGE_MIN;
        KernelSum {
            sums,
            inv,
            in_range,
            acc,
            points: 0.0,
            weights: [0.0; BATCH + LEAF + CHUNK],
        }
    }

    /// The batch's weights, `exp(-d2 * inv)`, in one loop that vectorizes: over its length
    /// rounded up to [`CHUNK`] lanes (the ones past it are garbage and unused), so that no
    /// weight is left to a scalar remainder loop (a scalar `exp` is a chain of a dozen dependent
    /// multiply-adds).
    #[inline(always)]
    fn weights(&mut self, b: &Batch) -> &[f64] {
        let lanes = b.len.div_ceil(CHUNK) * CHUNK;
        for (x, d) in self.weights[..lanes].iter_mut().zip(&b.d2[..lanes]) {
            *x = -d * self.inv;
        }
        if self.in_range {
            exp::exp_in_place_in_range(&mut self.weights[..lanes]);
        } else {
            exp::exp_in_place(&mut self.weights[..lanes]);
        }
        &self.weights[..b.len]
    }
}

impl<const W: usize> VisitBatch for KernelSum<'_, [f64; W]> {
    #[inline(always)]
    fn batch(&mut self, b: &Batch) {
        // The sums in locals for the batch: kept in the fields, they went through memory at
        // every term (a store and its reload on each addition's path).
        let (mut acc, mut points) = (self.acc, self.points);
        let sums = self.sums;
        let mut xs = self.weights(b).iter();
        for &(first, mask) in &b.segments[..b.leaves] {
            let (rows, _) = sums[first as usize * W..].as_chunks::<W>();
            for j in Bits(mask) {
                let x = xs.next().expect("a weight for each point");
                let row = &rows[j];
                for (a, v) in acc.iter_mut().zip(row) {
                    *a += x * v;
                }
                points += row[W - 1];
            }
        }
        (self.acc, self.points) = (acc, points);
    }
}

impl VisitBatch for KernelSum<'_, Vec<f64>> {
    #[inline(always)]
    fn batch(&mut self, b: &Batch) {
        let w = self.acc.len();
        let (sums, mut points) = (self.sums, self.points);
        let mut acc = std::mem::take(&mut self.acc);
        let mut xs = self.weights(b).iter();
        for (_, i) in b.points() {
            let x = xs.next().expect("a weight for each point");
            let row = &sums[i * w..][..w];
            for (a, v) in acc.iter_mut().zip(row) {
                *a += x * v;
            }
            points += row[w - 1];
        }
        (self.acc, self.points) = (acc, points);
    }
}

/// The exact scaled observations the bulk tree's queries measure, computed from the points the
/// index refers to (the tree keeps no copy of them): group `g`'s first point's observation times
/// the scale, the same product [`Index::scaled`] makes, so the same bits as a stored copy.
struct Exact<'a, const D: usize> {
    idx: &'a Index,
    z: &'a [f64],
    scale: [f64; D],
}

impl<'a, const D: usize> Exact<'a, D> {
    fn new(idx: &'a Index, pts: Points<'a>) -> Self {
        Exact {
            idx,
            z: pts.z,
            scale: std::array::from_fn(|k| idx.scale[k]),
        }
    }

    /// Group `g`'s scaled observation.
    #[inline(always)]
    fn row(&self, g: u32) -> [f64; D] {
        let p = self.idx.group(u64::from(g))[0] as usize;
        let z = &self.z[p * D..][..D];
        std::array::from_fn(|k| z[k] * self.scale[k])
    }
}

/// A radius query's first, coarse test in `f32`: a point it rules out is certainly outside the
/// radius; the rest are measured exactly. Its radius is widened by a bound on the `f32`
/// arithmetic's error (below), so it never rules out a point inside.
///
/// With `u = 2^-24` and every coordinate (query or point) at most `M` in magnitude: rounding to
/// `f32` moves each coordinate by at most `u M`, so each difference by at most `2 u M` before its
/// own rounding; by Minkowski the computed distance is at most `(d + 2 u M sqrt(D))` before the
/// roundings of the difference, the square and the `D` additions, which multiply it (all terms
/// being positive) by at most `(1 + u)^(D + 3)`. Coordinates too large for `f32` squares, or a
/// query that is not finite, skip the coarse test.
struct Coarse<const D: usize> {
    q: [f32; D],
    r2: f32,
}

impl<const D: usize> Coarse<D> {
    #[inline(always)]
    fn new(q: &[f64; D], r2: f64, max_abs: f64) -> Option<Coarse<D>> {
        let m = q.iter().fold(max_abs, |m, v| m.max(v.abs()));
        if m.is_nan() || m > 1e17 || r2.is_nan() || r2 < 0.0 {
            return None;
        }
        let u = f64::from(f32::EPSILON) / 2.0;
        let reach = r2.sqrt() + 2.0 * u * m * (D as f64).sqrt() + 1e-30;
        // The last factor covers the rounding of this bound's own f64 arithmetic.
        let wide = reach * reach * (1.0 + u).powi(D as i32 + 3) * (1.0 + 1e-12);
        Some(Coarse {
            q: q.map(|v| v as f32),
            r2: f32_outwards(wide, false),
        })
    }

    /// Bit `j` set unless the leaf's `j`-th point (of a block of [`Bulk::coarse`], `len` lanes
    /// a dimension) is certainly outside the radius; bits from `len` on are the caller's to mask.
    #[inline(always)]
    fn candidates(&self, block: &[f32], len: usize) -> u64 {
        let mut s = [0.0f32; LEAF];
        for (k, qk) in self.q.iter().enumerate() {
            let c: &[f32; LEAF] = block[k * len..][..LEAF]
                .try_into()
                .expect("a block holds LEAF lanes of each dimension");
            for (s, c) in s.iter_mut().zip(c) {
                let d = qk - c;
                *s += d * d;
            }
        }
        let mut maybe = 0u64;
        for (j, s) in s.iter().enumerate() {
            maybe |= u64::from(*s <= self.r2) << j;
        }
        maybe
    }
}

/// `(distance, group)` as one integer pair ordered as [`before`] orders them (`f64::total_cmp`'s
/// key, then the group): a sort on it compares integers.
#[inline(always)]
fn order_key((d, g): (f64, u64)) -> (i64, u64) {
    let b = d.to_bits() as i64;
    (b ^ (((b >> 63) as u64) >> 1) as i64, g)
}

/// Sort `(distance, group)` pairs as [`before`] orders them, as `sort_unstable_by_key` on
/// [`order_key`] would (the order is total: the same result). A k-limited kernel sorts its
/// thousands of neighbours a query, and a comparison sort's unpredictable branches were a
/// third of its time: a least-significant-digit radix sort on the distance's bits (a byte at a
/// time, skipping the bytes every distance shares), then each run of equal distances by group.
fn sort_nearest_first(v: &mut Vec<(f64, u64)>) {
    let n = v.len();
    if n <= 64 {
        v.sort_unstable_by_key(|c| order_key(*c));
        return;
    }
    // `f64::total_cmp`'s order as an unsigned integer's.
    let key = |d: f64| -> u64 {
        let b = d.to_bits();
        if b >> 63 == 1 { !b } else { b | 1 << 63 }
    };
    let mut counts = [[0usize; 256]; 8];
    for &(d, _) in v.iter() {
        let k = key(d);
        for (byte, c) in counts.iter_mut().enumerate() {
            c[(k >> (8 * byte)) as usize & 255] += 1;
        }
    }
    let mut from = std::mem::take(v);
    let mut to = vec![(0.0, 0); n];
    for (byte, c) in counts.iter().enumerate() {
        if c.contains(&n) {
            continue;
        }
        let mut at = [0usize; 256];
        let mut sum = 0;
        for (a, c) in at.iter_mut().zip(c) {
            *a = sum;
            sum += c;
        }
        for &e in &from {
            let digit = (key(e.0) >> (8 * byte)) as usize & 255;
            to[at[digit]] = e;
            at[digit] += 1;
        }
        std::mem::swap(&mut from, &mut to);
    }
    *v = from;
    let mut i = 0;
    while i < n {
        let bits = v[i].0.to_bits();
        let run = v[i..].iter().take_while(|e| e.0.to_bits() == bits).count();
        if run > 1 {
            v[i..i + run].sort_unstable_by_key(|e| e.1);
        }
        i += run;
    }
}

/// Cut `found` (more than `n > 0` entries) to its `n` first under [`before`], in no set order;
/// returns the distance of the `n`-th.
fn keep_nearest(found: &mut Vec<(f64, u64)>, n: usize) -> f64 {
    found.select_nth_unstable_by_key(n - 1, |c| order_key(*c));
    found.truncate(n);
    found[n - 1].0
}

/// Offer `c` to the max-heap `heap` (under [`before`]) of at most `n` entries.
fn heap_offer(heap: &mut Vec<(f64, u64)>, n: usize, c: (f64, u64)) {
    if heap.len() < n {
        heap.push(c);
        let mut i = heap.len() - 1;
        while i > 0 {
            let parent = (i - 1) / 2;
            if before(heap[parent], heap[i]) {
                heap.swap(parent, i);
                i = parent;
            } else {
                break;
            }
        }
    } else if before(c, heap[0]) {
        heap[0] = c;
        let mut i = 0;
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut top = i;
            if l < heap.len() && before(heap[top], heap[l]) {
                top = l;
            }
            if r < heap.len() && before(heap[top], heap[r]) {
                top = r;
            }
            if top == i {
                break;
            }
            heap.swap(i, top);
            i = top;
        }
    }
}

/// The trees of one dimension: the bulk tree over the groups planned for it (built at the first
/// query that needs it), and kiddo's mutable tree over the groups added since, while they are few.
struct Trees<const D: usize> {
    bulk: OnceLock<Bulk<D>>,
    recent: KdTree<f64, D>,
}

impl<const D: usize> Trees<D> {
    fn new() -> Self {
        Trees {
            bulk: OnceLock::new(),
            recent: KdTree::new(),
        }
    }

    /// The bytes both trees hold, about (kiddo's counted as its points and items).
    fn held_bytes(&self) -> usize {
        let recent = self.recent.size() as usize * (D * 8 + 8);
        recent + self.bulk.get().map_or(0, Bulk::held_bytes)
    }
}

enum Tree {
    D1(Trees<1>),
    D2(Trees<2>),
    D3(Trees<3>),
    D4(Trees<4>),
    D5(Trees<5>),
    D6(Trees<6>),
    D7(Trees<7>),
    D8(Trees<8>),
}

macro_rules! each_tree {
    ($tree:expr, $t:ident => $body:expr) => {
        match $tree {
            Tree::D1($t) => $body,
            Tree::D2($t) => $body,
            Tree::D3($t) => $body,
            Tree::D4($t) => $body,
            Tree::D5($t) => $body,
            Tree::D6($t) => $body,
            Tree::D7($t) => $body,
            Tree::D8($t) => $body,
        }
    };
}

impl Tree {
    fn new(dim: usize) -> Option<Tree> {
        Some(match dim {
            1 => Tree::D1(Trees::new()),
            2 => Tree::D2(Trees::new()),
            3 => Tree::D3(Trees::new()),
            4 => Tree::D4(Trees::new()),
            5 => Tree::D5(Trees::new()),
            6 => Tree::D6(Trees::new()),
            7 => Tree::D7(Trees::new()),
            8 => Tree::D8(Trees::new()),
            _ => return None,
        })
    }

    /// Forget both trees: the bulk is now planned over every group (`Plan::planned`).
    fn replan(&mut self) {
        each_tree!(self, t => *t = Trees::new())
    }

    fn add_recent(&mut self, q: &[f64], item: u64) {
        each_tree!(self, t => t.recent.add(q.try_into().expect("dimension checked at construction"), item))
    }

    fn nearest_one(&self, plan: &Plan, q: &[f64]) -> (f64, u64) {
        each_tree!(self, t => {
            let q = q.try_into().expect("dimension checked at construction");
            let mut best = (f64::INFINITY, u64::MAX);
            plan.bulk(t).nearest_one(q, &mut best, &plan.exact());
            if plan.recent > 0 {
                // Only groups at most as far as the bulk's nearest can change the answer: a
                // radius search that small visits a few of kiddo's leaves.
                for n in t.recent.within_unsorted::<SquaredEuclidean>(q, best.0) {
                    if before((n.distance, n.item), best) {
                        best = (n.distance, n.item);
                    }
                }
            }
            best
        })
    }

    fn nearest_n(&self, plan: &Plan, q: &[f64], n: usize, out: &mut Vec<(f64, u64)>) {
        out.clear();
        each_tree!(self, t => {
            let q = q.try_into().expect("dimension checked at construction");
            plan.bulk(t).nearest_n(q, n, out, &plan.exact());
            if plan.recent > 0 {
                if out.len() < n {
                    out.extend(t.recent.nearest_n::<SquaredEuclidean>(q, n).into_iter().map(|n| (n.distance, n.item)));
                } else {
                    // As in `nearest_one`: only groups within the bulk's n-th can take part.
                    let bound = out[0].0;
                    out.extend(t.recent.within_unsorted::<SquaredEuclidean>(q, bound).into_iter().map(|n| (n.distance, n.item)));
                }
            }
        });
        out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out.truncate(n);
    }

    /// The `n` nearest groups within `r2` of `q`, nearest first (ties to the lower group).
    fn nearest_n_within(
        &self,
        plan: &Plan,
        q: &[f64],
        n: usize,
        r2: f64,
        out: &mut Vec<(f64, u64)>,
    ) {
        out.clear();
        each_tree!(self, t => {
            let q = q.try_into().expect("dimension checked at construction");
            // The bulk's `n` nearest and the distance of its `n`-th (`r2` with fewer).
            let bound = plan.bulk(t).nearest_n_within(q, n, r2, out, &plan.exact());
            if plan.recent > 0 {
                // As in `nearest_one`: only groups within the bulk's n-th can take part.
                out.extend(t.recent.within_unsorted::<SquaredEuclidean>(q, bound.min(r2)).into_iter().map(|n| (n.distance, n.item)));
            }
        });
        if out.len() > n {
            keep_nearest(out, n);
        }
        sort_nearest_first(out);
    }

    fn within(&self, plan: &Plan, q: &[f64], r2: f64, out: &mut Vec<(f64, u64)>) {
        out.clear();
        each_tree!(self, t => {
            let q = q.try_into().expect("dimension checked at construction");
            let bulk = plan.bulk(t);
            bulk.within(q, r2, &mut |d, i| out.push((d, u64::from(bulk.ids[i]))), &plan.exact());
            if plan.recent > 0 {
                let found = t.recent.within_unsorted::<SquaredEuclidean>(q, r2);
                out.extend(found.into_iter().map(|n| (n.distance, n.item)));
            }
        })
    }

    /// `f(squared distance, action sum, count)` for every group within `r2` of `q`.
    fn sums_within(&self, plan: &Plan, q: &[f64], r2: f64, f: &mut impl FnMut(f64, &[f64], f64)) {
        let Some(act_dim) = plan.idx.act_dim else {
            return;
        };
        each_tree!(self, t => {
            let q = q.try_into().expect("dimension checked at construction");
            let bulk = plan.bulk(t);
            let w = act_dim + 1;
            bulk.within(q, r2, &mut |d, i| {
                let row = &bulk.sums[i * w..(i + 1) * w];
                f(d, &row[..act_dim], row[act_dim]);
            }, &plan.exact());
            if plan.recent > 0 {
                // A recent group's sum is made from its points here, as the bulk's copy is
                // when it is built: the same additions in the same order, so the same bits.
                let mut stack = [0.0; 16];
                let mut heap = Vec::new();
                let row: &mut [f64] = if w <= stack.len() {
                    &mut stack[..w]
                } else {
                    heap.resize(w, 0.0);
                    &mut heap
                };
                for n in t.recent.within_unsorted::<SquaredEuclidean>(q, r2) {
                    plan.idx.group_sum(n.item as usize, plan.pts, row);
                    f(n.distance, &row[..act_dim], row[act_dim]);
                }
            }
        })
    }

    /// The Gaussian kernel's sums over every group within `r2` of `q`: `acc[c] += w * sum[c]`
    /// for the `act_dim + 1` values of each group's row (its action sum, then its count), with
    /// `w = exp(-d2 * inv)` ([`crate::exp::exp`]); returns the points summed. In the order
    /// [`Tree::sums_within`] reports the groups, one leaf's weights computed together.
    fn kernel_within(&self, plan: &Plan, q: &[f64], r2: f64, inv: f64, acc: &mut [f64]) -> f64 {
        let Some(act_dim) = plan.idx.act_dim else {
            return 0.0;
        };
        let w = act_dim + 1;
        let acc = &mut acc[..w];
        let mut points = 0.0;
        each_tree!(self, t => {
            let q = q.try_into().expect("dimension checked at construction");
            let bulk = plan.bulk(t);
            points += bulk.kernel(q, r2, inv, acc, &plan.exact());
            if plan.recent > 0 {
                let mut stack = [0.0; 16];
                let mut heap = Vec::new();
                let row: &mut [f64] = if w <= stack.len() {
                    &mut stack[..w]
                } else {
                    heap.resize(w, 0.0);
                    &mut heap
                };
                for n in t.recent.within_unsorted::<SquaredEuclidean>(q, r2) {
                    plan.idx.group_sum(n.item as usize, plan.pts, row);
                    let x = exp::exp(-n.distance * inv);
                    for (a, v) in acc.iter_mut().zip(row.iter()) {
                        *a += x * v;
                    }
                    points += row[act_dim];
                }
            }
        });
        points
    }

    /// Group `g`'s action sum row (`act_dim + 1` values) in the bulk tree, if the tree holds `g`
    /// (`g < planned`) and is built.
    fn bulk_sum_row(&mut self, planned: usize, g: usize, act_dim: usize) -> Option<&mut [f64]> {
        each_tree!(self, t => {
            let bulk = t.bulk.get_mut().filter(|_| g < planned)?;
            let w = act_dim + 1;
            let i = bulk.at[g] as usize;
            Some(&mut bulk.sums[i * w..(i + 1) * w])
        })
    }

    /// The bytes both trees hold (kiddo's counted by its points).
    fn held_bytes(&self) -> usize {
        each_tree!(self, t => t.held_bytes())
    }

    /// The bytes of the bulk tree's exact copy ([`Bulk::points`]), when built.
    #[cfg(test)]
    fn exact_copy_bytes(&self) -> usize {
        each_tree!(self, t => t.bulk.get().map_or(0, Bulk::exact_copy_bytes))
    }
}

/// Which groups each tree holds: the bulk tree groups `0..planned`, kiddo's the `recent` after.
/// Decided by the sequence of additions alone (never by when queries came), so the trees, and
/// the order a radius query reports its groups in, are a function of the data's history.
struct Plan<'a> {
    idx: &'a Index,
    pts: Points<'a>,
    recent: usize,
}

impl<'a> Plan<'a> {
    fn exact<const D: usize>(&self) -> Exact<'a, D> {
        Exact::new(self.idx, self.pts)
    }

    fn bulk<'t, const D: usize>(&self, t: &'t Trees<D>) -> &'t Bulk<D> {
        t.bulk
            .get_or_init(|| Bulk::build(self.idx, self.pts, self.idx.planned))
    }
}

/// The points an index refers to, borrowed for each call: the dataset's own arrays, so the index
/// keeps no copy of the exact observations (its bulk tree keeps an `f32` copy in leaf order, for
/// a radius query's first test, and computes the exact ones from these; a tree of at most
/// [`EXACT_COPY_MAX`] groups also keeps them in leaf order). Point `p`'s observation is
/// `z[p * obs_dim..][..obs_dim]` and its action `a[p * act_dim..][..act_dim]` (the actions are
/// read only by an index with action sums). Every call on one index must pass the same points,
/// or more of them (points added since): an index holds point numbers, not values.
#[derive(Clone, Copy, Debug)]
pub struct Points<'a> {
    pub z: &'a [f64],
    pub a: &'a [f64],
}

/// A kd-tree over scaled observations, grouping identical ones. It holds, per group, its first
/// point's number (4 bytes; the few groups of several points keep theirs apart) and a slot of the
/// table that finds a group by its observation; the observations themselves are the dataset's
/// ([`Points`]).
pub struct Index {
    dim: usize,
    scale: Vec<f64>,
    tree: Tree,
    /// Groups `0..planned` are the bulk tree's; the rest are in kiddo's.
    planned: usize,
    /// Each group's point, or with [`MANY`] set, the position in `many` of its points.
    first: Vec<u32>,
    /// The points of the groups of more than one, in the order they were added.
    many: Vec<Vec<u32>>,
    /// Open addressing (linear probing) of groups by the hash of their scaled observation's bits:
    /// a group number per slot, [`FREE`] when free, at most [`LOAD_PERCENT`] full. A probe
    /// compares observations computed from the points, so a slot costs 4 bytes.
    slots: Vec<u32>,
    /// Eight bits of each slot's hash, beside it: a probe reads the points of a group only when
    /// these match (a new observation's probe passes several full slots, and reading each one's
    /// point would be a cache miss).
    tags: Vec<u8>,
    /// With action sums ([`Index::with_action_sums`]), the action dimension. A kernel weight is
    /// the same for every point of a group, so LWR reads one sum per group found, kept by the
    /// bulk tree beside its points in leaf order (made from the points when it is built).
    act_dim: Option<usize>,
    /// The most groups a bulk tree keeps an exact copy of: [`EXACT_COPY_MAX`], lowered by the
    /// tests to exercise both ways of reading the exact rows.
    exact_copy_max: usize,
}

/// In [`Index::first`]: the value is a position in [`Index::many`]. Point numbers stay below it
/// (a dataset of 2^31 points would not fit in memory).
const MANY: u32 = 1 << 31;

/// A free slot of [`Index::slots`].
const FREE: u32 = u32::MAX;

/// How full the group table may be, in percent, before it doubles.
const LOAD_PERCENT: usize = 70;

/// The bits that identify a scaled value (-0.0 and 0.0 are the same place).
fn key_bits(v: f64) -> u64 {
    (v + 0.0).to_bits()
}

/// The hash of a scaled observation's bits (splitmix64's finaliser over each value in turn):
/// where a group's probe starts.
fn key_hash(q: &[f64]) -> u64 {
    let mut h: u64 = 0x9E37_79B9_7F4A_7C15;
    for v in q {
        h ^= key_bits(*v);
        h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        h ^= h >> 31;
    }
    h
}

impl Index {
    /// An empty index for `dim`-dimensional observations multiplied by `scale`; `None` if the
    /// dimension is unsupported.
    pub fn new(scale: Vec<f64>) -> Option<Index> {
        let dim = scale.len();
        Some(Index {
            dim,
            tree: Tree::new(dim)?,
            planned: 0,
            scale,
            first: Vec::new(),
            many: Vec::new(),
            slots: Vec::new(),
            tags: Vec::new(),
            act_dim: None,
            exact_copy_max: EXACT_COPY_MAX,
        })
    }

    /// Like [`Index::new`], also keeping each group's action sum; add points with
    /// [`Index::add_with_action`].
    pub fn with_action_sums(scale: Vec<f64>, act_dim: usize) -> Option<Index> {
        let mut idx = Index::new(scale)?;
        idx.act_dim = Some(act_dim);
        Some(idx)
    }

    /// Add point `point` of `pts` (its action joins its group's sum when the index keeps sums).
    pub fn add_with_action(&mut self, point: u32, pts: Points) {
        let g = self.add(point, pts) as usize;
        let Some(act_dim) = self.act_dim else { return };
        // A group the built bulk tree holds: its copy of the sum follows.
        if g < self.planned && self.tree.bulk_sum_row(self.planned, g, act_dim).is_some() {
            let mut row = vec![0.0; act_dim + 1];
            self.group_sum(g, pts, &mut row);
            if let Some(dst) = self.tree.bulk_sum_row(self.planned, g, act_dim) {
                dst.copy_from_slice(&row);
            }
        }
    }

    /// Group `g`'s action sum and point count into `out` (`act_dim + 1` values): its points'
    /// actions added in the order the points joined it, from zero.
    fn group_sum(&self, g: usize, pts: Points, out: &mut [f64]) {
        let act_dim = out.len() - 1;
        out.iter_mut().for_each(|v| *v = 0.0);
        let members = self.group(g as u64);
        for &p in members {
            let a = &pts.a[p as usize * act_dim..][..act_dim];
            for (t, v) in out.iter_mut().zip(a) {
                *t += v;
            }
        }
        out[act_dim] = f64::from(members.len() as u32);
    }

    /// The same index, its bulk trees keeping an exact copy up to `n` groups instead of
    /// [`EXACT_COPY_MAX`].
    #[cfg(test)]
    fn keeping_exact_copies_up_to(mut self, n: usize) -> Index {
        self.exact_copy_max = n;
        self
    }

    /// Whether the index keeps action sums.
    pub fn has_action_sums(&self) -> bool {
        self.act_dim.is_some()
    }

    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// Scale a raw observation into `out`.
    #[inline]
    pub fn scaled(&self, z: &[f64], out: &mut [f64]) {
        for ((o, v), s) in out.iter_mut().zip(z).zip(&self.scale) {
            *o = v * s;
        }
    }

    /// Group `g`'s scaled observation (its first point's, scaled) into `out`.
    #[inline]
    fn group_scaled(&self, g: usize, pts: Points, out: &mut [f64]) {
        let p = self.group(g as u64)[0] as usize;
        self.scaled(&pts.z[p * self.dim..][..self.dim], out);
    }

    /// Add point `point` of `pts`; returns its group.
    pub fn add(&mut self, point: u32, pts: Points) -> u32 {
        debug_assert!(point < MANY, "point numbers stay below 2^31");
        let mut q = [0.0; MAX_DIM];
        let q = &mut q[..self.dim];
        self.scaled(&pts.z[point as usize * self.dim..][..self.dim], q);
        if (self.first.len() + 1) * 100 > self.slots.len() * LOAD_PERCENT {
            self.grow(pts);
        }
        let mask = self.slots.len() - 1;
        let hash = key_hash(q);
        let tag = (hash >> 56) as u8;
        let mut at = hash as usize & mask;
        let mut row = [0.0; MAX_DIM];
        while self.slots[at] != FREE {
            let g = self.slots[at];
            if self.tags[at] == tag {
                let row = &mut row[..self.dim];
                self.group_scaled(g as usize, pts, row);
                if row
                    .iter()
                    .zip(q.iter())
                    .all(|(a, b)| key_bits(*a) == key_bits(*b))
                {
                    self.join(g as usize, point);
                    return g;
                }
            }
            at = (at + 1) & mask;
        }
        let g = self.first.len() as u32;
        self.slots[at] = g;
        self.tags[at] = tag;
        self.first.push(point);
        let recent = g as usize - self.planned;
        if recent >= RECENT_MIN.max(self.planned / RECENT_FRACTION) {
            self.planned = self.first.len();
            self.tree.replan();
        } else {
            self.tree.add_recent(q, g as u64);
        }
        g
    }

    /// Point `point` joins group `g` (after its other points).
    fn join(&mut self, g: usize, point: u32) {
        let f = self.first[g];
        if f & MANY == 0 {
            self.first[g] = MANY | self.many.len() as u32;
            self.many.push(vec![f, point]);
        } else {
            self.many[(f & !MANY) as usize].push(point);
        }
    }

    /// Room for `points` more points (so at most that many new groups), reserved exactly, with
    /// the group table sized for them at once: a bulk load then grows neither again (no
    /// doubling slack kept, no table rebuilt at each doubling). Where a group's slot is does not
    /// number it, so no answer changes.
    pub fn reserve(&mut self, points: usize, pts: Points) {
        self.first.reserve_exact(points);
        let want = self.first.len() + points;
        let mut size = self.slots.len().max(16);
        while want * 100 > size * LOAD_PERCENT {
            size *= 2;
        }
        if size > self.slots.len() {
            self.grow_to(size, pts);
        }
    }

    /// Double the group table (16 slots at first) and place every group anew.
    fn grow(&mut self, pts: Points) {
        self.grow_to((self.slots.len() * 2).max(16), pts);
    }

    /// The group table at `size` slots (a power of two), every group placed anew.
    fn grow_to(&mut self, size: usize, pts: Points) {
        // The old table goes before the new one is made: only one is held at a time.
        self.slots = Vec::new();
        self.tags = Vec::new();
        self.slots = vec![FREE; size];
        self.tags = vec![0; size];
        let mut q = [0.0; MAX_DIM];
        for g in 0..self.first.len() {
            let q = &mut q[..self.dim];
            self.group_scaled(g, pts, q);
            let hash = key_hash(q);
            let mut at = hash as usize & (size - 1);
            while self.slots[at] != FREE {
                at = (at + 1) & (size - 1);
            }
            self.slots[at] = g as u32;
            self.tags[at] = (hash >> 56) as u8;
        }
    }

    /// The points of group `g`.
    #[inline]
    pub fn group(&self, g: u64) -> &[u32] {
        let f = &self.first[g as usize];
        if f & MANY == 0 {
            std::slice::from_ref(f)
        } else {
            &self.many[(f & !MANY) as usize]
        }
    }

    /// Nearest group to scaled query `q`: (squared distance, group). `None` when empty.
    #[inline]
    pub fn nearest(&self, q: &[f64], pts: Points) -> Option<(f64, u64)> {
        if self.is_empty() {
            return None;
        }
        Some(self.tree.nearest_one(&self.plan(pts), q))
    }

    /// The `n` nearest groups to scaled query `q`, nearest first: (squared distance, group).
    #[inline]
    pub fn nearest_n(&self, q: &[f64], n: usize, out: &mut Vec<(f64, u64)>, pts: Points) {
        if self.is_empty() {
            out.clear();
            return;
        }
        self.tree.nearest_n(&self.plan(pts), q, n, out)
    }

    fn plan<'a>(&'a self, pts: Points<'a>) -> Plan<'a> {
        Plan {
            idx: self,
            pts,
            recent: self.first.len() - self.planned,
        }
    }

    /// Build the bulk tree now if it is not built (the first query that needs it would).
    pub fn build_bulk(&self, pts: Points) {
        if !self.is_empty() {
            let plan = self.plan(pts);
            each_tree!(&self.tree, t => {
                plan.bulk(t);
            });
        }
    }

    /// How many groups the bulk tree holds (the rest are in the small mutable tree).
    pub fn bulk_groups(&self) -> usize {
        self.planned
    }

    /// How many groups (distinct observations) the index holds.
    pub fn groups(&self) -> usize {
        self.first.len()
    }

    /// Every group within squared distance `r2` of scaled query `q`, unsorted.
    #[inline]
    pub fn within(&self, q: &[f64], r2: f64, out: &mut Vec<(f64, u64)>, pts: Points) {
        if self.is_empty() {
            out.clear();
            return;
        }
        self.tree.within(&self.plan(pts), q, r2, out)
    }

    /// `f(squared distance, action sum, point count)` for every group within squared distance `r2`
    /// of scaled query `q`, in no set order (nothing when the index keeps no action sums).
    #[inline]
    pub fn sums_within(
        &self,
        q: &[f64],
        r2: f64,
        pts: Points,
        mut f: impl FnMut(f64, &[f64], f64),
    ) {
        if !self.is_empty() {
            self.tree.sums_within(&self.plan(pts), q, r2, &mut f)
        }
    }

    /// The nearest `k` points within squared distance `r2` of scaled query `q`, as groups:
    /// `f(squared distance, action sum, points)` nearest first (ties to the lower group; a
    /// group's points are at one distance), `k` points in all at most. When the `k`-th point
    /// falls inside a group, that group's sum is of its first points only (in the order they
    /// joined it, as its whole sum is made). An index with action sums; nothing otherwise.
    /// `found` is a buffer.
    pub fn nearest_sums(
        &self,
        q: &[f64],
        k: usize,
        r2: f64,
        pts: Points,
        found: &mut Vec<(f64, u64)>,
        mut f: impl FnMut(f64, &[f64], f64),
    ) {
        let Some(act_dim) = self.act_dim else {
            return;
        };
        if self.is_empty() || k == 0 {
            found.clear();
            return;
        }
        // Every group holds at least one point: the `k` nearest groups hold the `k` nearest
        // points.
        self.tree.nearest_n_within(&self.plan(pts), q, k, r2, found);
        let mut row = vec![0.0; act_dim + 1];
        let mut left = k;
        for &(d, g) in found.iter() {
            if left == 0 {
                break;
            }
            let members = self.group(g);
            let take = members.len().min(left);
            row.iter_mut().for_each(|v| *v = 0.0);
            for &p in &members[..take] {
                let a = &pts.a[p as usize * act_dim..][..act_dim];
                for (t, v) in row.iter_mut().zip(a) {
                    *t += v;
                }
            }
            row[act_dim] = f64::from(take as u32);
            f(d, &row[..act_dim], row[act_dim]);
            left -= take;
        }
    }

    /// The Gaussian kernel's sums around scaled query `q` (an index with action sums; nothing
    /// otherwise): for every group within squared distance `r2`, `acc[c] += exp(-d2 * inv) *
    /// sum[c]` over its row of `act_dim + 1` values (its points' action sum, then their count);
    /// returns the points summed. The weights are [`crate::exp::exp`]'s, a leaf's computed in one
    /// vectorized loop; the groups are added in a fixed order (the data's history decides it), so
    /// the same bits on every run and thread.
    #[inline]
    pub fn kernel_within(&self, q: &[f64], r2: f64, inv: f64, pts: Points, acc: &mut [f64]) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        self.tree.kernel_within(&self.plan(pts), q, r2, inv, acc)
    }

    /// Scaled observation of group `g` (computed from its first point), in the first `dim`
    /// values.
    #[inline]
    pub fn group_z(&self, g: u64, pts: Points) -> [f64; MAX_DIM] {
        let mut out = [0.0; MAX_DIM];
        self.group_scaled(g as usize, pts, &mut out[..self.dim]);
        out
    }

    /// The bytes of the exact copy the bulk tree keeps when it holds at most [`EXACT_COPY_MAX`]
    /// groups (part of [`Index::held_bytes`]).
    #[cfg(test)]
    pub(crate) fn exact_copy_bytes(&self) -> usize {
        self.tree.exact_copy_bytes()
    }

    /// The bytes this index holds (its tables and built trees, not the points it refers to):
    /// what the scale benchmark reports.
    pub fn held_bytes(&self) -> usize {
        let many: usize = self.many.iter().map(|v| v.capacity() * 4 + 24).sum();
        self.first.capacity() * 4
            + self.slots.capacity() * 4
            + self.tags.capacity()
            + many
            + self.tree.held_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_observations_share_a_group_in_insertion_order() {
        let mut idx = Index::new(vec![2.0, 1.0]).unwrap();
        let zs: [[f64; 2]; 6] = [
            [0.5, 0.0],
            [0.5, -0.0],
            [0.25, 1.0],
            [0.5, 0.0],
            [1.0, 0.5],
            [0.25, 1.0],
        ];
        let flat: Vec<f64> = zs.concat();
        let pts = Points { z: &flat, a: &[] };
        let groups: Vec<u32> = (0..zs.len()).map(|i| idx.add(i as u32, pts)).collect();
        assert_eq!(groups, [0, 0, 1, 0, 2, 1]);
        assert_eq!(idx.groups(), 3);
        assert_eq!(idx.group(0), [0, 1, 3]);
        assert_eq!(idx.group(1), [2, 5]);
        assert_eq!(idx.group(2), [4]);
        assert_eq!(idx.group_z(2, pts)[..2], [2.0, 0.5]);
        let mut found = Vec::new();
        idx.within(&[1.0, 0.0], 1e-12, &mut found, pts);
        assert_eq!(found, [(0.0, 0)]);
    }
}

#[cfg(test)]
mod tree_tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn pts(z: &[f64]) -> Points<'_> {
        Points { z, a: &[] }
    }

    fn scan(idx: &Index, q: &[f64], zs: &[f64]) -> Vec<(f64, u64)> {
        let mut all: Vec<(f64, u64)> = (0..idx.groups() as u64)
            .map(|g| {
                let d = idx
                    .group_z(g, pts(zs))
                    .iter()
                    .zip(q)
                    .map(|(a, b)| (a - b) * (a - b))
                    .fold(0.0, |s, v| s + v);
                (d, g)
            })
            .collect();
        all.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        all
    }

    /// `idx.within(q, r2)` reports exactly the groups of `want` (a [`scan`] of `q`) within `r2`.
    fn assert_within_is_the_scan(
        (idx, zs): (&Index, &[f64]),
        q: &[f64],
        r2: f64,
        want: &[(f64, u64)],
        what: &str,
    ) {
        let mut found = Vec::new();
        idx.within(q, r2, &mut found, pts(zs));
        found.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let inside: Vec<(f64, u64)> = want.iter().copied().filter(|w| w.0 <= r2).collect();
        assert_eq!(found, inside, "{what}");
    }

    /// Through several re-plans (the bulk tree over the first groups, kiddo's over the rest),
    /// every query equals a linear scan: nearest (ties to the lower group), the n nearest in
    /// order, and the groups within a radius. Points on a coarse grid make ties and repeated
    /// observations common. The bulk trees of up to 2,048 groups keep their exact copy, the
    /// larger ones read the points.
    #[test]
    fn queries_equal_a_linear_scan_across_replans() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut idx = Index::new(vec![1.0, 0.5, 2.0])
            .unwrap()
            .keeping_exact_copies_up_to(2048);
        let mut zs = Vec::new();
        let mut found = Vec::new();
        for i in 0..6000u32 {
            let z: Vec<f64> = (0..3)
                .map(|_| f64::from(rng.random_range(0..40u8)) / 8.0)
                .collect();
            zs.extend_from_slice(&z);
            idx.add(i, pts(&zs));
            if i % 397 != 0 && i != 1024 && i != 1025 {
                continue;
            }
            for _ in 0..20 {
                let q: Vec<f64> = (0..3).map(|_| rng.random_range(-0.5..5.5)).collect();
                let want = scan(&idx, &q, &zs);
                assert_eq!(idx.nearest(&q, pts(&zs)), Some(want[0]), "after {i} points");
                for n in [1, 4, 17] {
                    idx.nearest_n(&q, n, &mut found, pts(&zs));
                    assert_eq!(found, want[..n.min(want.len())], "n {n} after {i} points");
                }
                // The k-limited kernel's search: the `n` nearest within a radius, nearest
                // first, with `n` large enough that its candidates are cut more than once.
                let r2 = rng.random_range(0.0..4.0);
                for n in [1, 17, 150, 700] {
                    idx.tree
                        .nearest_n_within(&idx.plan(pts(&zs)), &q, n, r2, &mut found);
                    let inside: Vec<(f64, u64)> =
                        want.iter().copied().filter(|w| w.0 <= r2).take(n).collect();
                    assert_eq!(found, inside, "n {n} within {r2} after {i} points");
                }
                let r2 = rng.random_range(0.0..0.6);
                assert_within_is_the_scan(
                    (&idx, &zs),
                    &q,
                    r2,
                    &want,
                    &format!("r2 {r2} after {i} points"),
                );
            }
        }
    }

    /// The radius query's coarse `f32` test never rules out a point inside: radii set to a
    /// point's exact distance (the boundary, where rounding bites), coordinates far from zero
    /// (where `f32` keeps few bits of the differences), and coordinates too large for it (the
    /// exact path). Also a NaN query, and a radius of zero on points in three groups. Each with
    /// the bulk tree's exact copy and without.
    #[test]
    fn radius_queries_at_the_boundary_and_far_from_zero_equal_a_linear_scan() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut found = Vec::new();
        let offsets = [0.0f64, 1e3, 1e8, 1e16, 1e18, -1e30];
        for (offset, copy_max) in offsets
            .into_iter()
            .flat_map(|o| [(o, EXACT_COPY_MAX), (o, 0)])
        {
            let mut idx = Index::new(vec![1.0; 6])
                .unwrap()
                .keeping_exact_copies_up_to(copy_max);
            let mut zs = Vec::new();
            let spread = if offset == 0.0 {
                1.0
            } else {
                offset.abs() * 1e-6
            };
            for i in 0..3000u32 {
                let z: Vec<f64> = (0..6)
                    .map(|_| offset + spread * f64::from(rng.random_range(0..50u8)) / 50.0)
                    .collect();
                zs.extend_from_slice(&z);
                idx.add(i, pts(&zs));
            }
            for _ in 0..40 {
                let q: Vec<f64> = (0..6)
                    .map(|_| offset + spread * rng.random_range(-0.1..1.1))
                    .collect();
                let want = scan(&idx, &q, &zs);
                // Radii exactly at the 1st, 10th, 100th and 1000th nearest.
                for n in [0, 9, 99, 999] {
                    let r2 = want[n.min(want.len() - 1)].0;
                    let what = format!("offset {offset}, copy {copy_max}, radius at the {n}th");
                    assert_within_is_the_scan((&idx, &zs), &q, r2, &want, &what);
                }
            }
        }
        let mut idx = Index::new(vec![1.0, 1.0]).unwrap();
        let zs: Vec<f64> = (0..200u32).flat_map(|i| [f64::from(i % 3), 0.5]).collect();
        for i in 0..200u32 {
            idx.add(i, pts(&zs));
        }
        idx.within(&[f64::NAN, 0.5], 10.0, &mut found, pts(&zs));
        assert_eq!(found, []);
        idx.within(&[1.0, 0.5], 0.0, &mut found, pts(&zs));
        assert_eq!(found, [(0.0, 1)]);
    }
}

#[cfg(test)]
mod sums_tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The kernel sums' view (`sums_within`) reports each group within the radius once, with its
    /// current action sum and count, through re-plans and while points keep joining groups the
    /// built bulk tree already holds (its copy of the sums must follow). With the bulk tree's
    /// exact copy and without.
    #[test]
    fn sums_within_equal_a_scan_of_the_groups() {
        for copy_max in [EXACT_COPY_MAX, 0] {
            sums_within_equal_a_scan_with(copy_max);
        }
    }

    fn sums_within_equal_a_scan_with(copy_max: usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let mut idx = Index::with_action_sums(vec![1.0, 2.0], 2)
            .unwrap()
            .keeping_exact_copies_up_to(copy_max);
        let (mut zs, mut acts) = (Vec::new(), Vec::new());
        for i in 0..5000u32 {
            let z = [
                f64::from(rng.random_range(0..60u8)) / 10.0,
                f64::from(rng.random_range(0..30u8)) / 10.0,
            ];
            let a = [rng.random_range(-1.0..1.0), f64::from(i)];
            zs.extend_from_slice(&z);
            acts.extend_from_slice(&a);
            let pts = Points { z: &zs, a: &acts };
            idx.add_with_action(i, pts);
            if i % 211 != 0 {
                continue;
            }
            for _ in 0..10 {
                let q = [rng.random_range(-0.5..6.5), rng.random_range(-0.5..6.5)];
                let r2 = rng.random_range(0.0..0.8);
                let mut got: Vec<(u64, f64, Vec<f64>, f64)> = Vec::new();
                idx.sums_within(&q, r2, pts, |d, sum, n| {
                    got.push((sum[1].to_bits(), d, sum.to_vec(), n))
                });
                got.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
                let mut want: Vec<(u64, f64, Vec<f64>, f64)> = (0..idx.groups() as u64)
                    .filter_map(|g| {
                        let z = idx.group_z(g, pts);
                        let d = (z[0] - q[0]) * (z[0] - q[0]) + (z[1] - q[1]) * (z[1] - q[1]);
                        // The sum made point by point in the order they joined.
                        let (mut sum, mut n) = (vec![0.0; 2], 0.0);
                        for &p in idx.group(g) {
                            sum[0] += acts[p as usize * 2];
                            sum[1] += acts[p as usize * 2 + 1];
                            n += 1.0;
                        }
                        (d <= r2).then(|| (sum[1].to_bits(), d, sum, n))
                    })
                    .collect();
                want.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
                assert_eq!(got, want, "after {i} points, copy {copy_max}");
                // The batched kernel sum: the per-group sum in `sums_within`'s order, to the bit.
                let inv = rng.random_range(0.5..20.0);
                let (mut acc, mut points) = (vec![0.0; 3], 0.0);
                idx.sums_within(&q, r2, pts, |d, sum, n| {
                    let w = crate::exp::exp(-d * inv);
                    acc[0] += w * sum[0];
                    acc[1] += w * sum[1];
                    acc[2] += w * n;
                    points += n;
                });
                let mut batched = vec![0.0; 3];
                let got_points = idx.kernel_within(&q, r2, inv, pts, &mut batched);
                assert_eq!((batched, got_points), (acc, points), "after {i} points");
            }
        }
    }
}

#[cfg(test)]
mod compiled_copies_tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The radius and k-nearest searches are compiled three times (the baseline, AVX2 and
    /// AVX-512, chosen at run time): every copy gives the same bits, kernel sums and neighbours,
    /// on this processor's copies (the baseline always). Points along random walks (trajectory
    /// data: many leaves wholly or partly inside a kernel), in 3 and 6 dimensions, with the
    /// exact copy and without.
    #[test]
    fn every_compiled_copy_gives_the_same_bits() {
        for copy_max in [EXACT_COPY_MAX, 0] {
            same_bits::<3>(copy_max);
            same_bits::<6>(copy_max);
        }
    }

    fn bulk_of<const D: usize>(tree: &Tree) -> &Trees<D> {
        let any: &dyn std::any::Any = match tree {
            Tree::D3(t) => t,
            Tree::D6(t) => t,
            _ => unreachable!("the test's dimensions"),
        };
        any.downcast_ref().expect("the index's dimension")
    }

    fn same_bits<const D: usize>(copy_max: usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(48 + D as u64);
        let mut idx = Index::with_action_sums(vec![1.0; D], 2)
            .unwrap()
            .keeping_exact_copies_up_to(copy_max);
        let (mut zs, mut acts) = (Vec::new(), Vec::new());
        let mut z = [0.0f64; D];
        for i in 0..6000u32 {
            if i % 300 == 0 {
                z = std::array::from_fn(|_| rng.random_range(0.0..1.0));
            }
            z.iter_mut()
                .for_each(|v| *v += rng.random_range(-0.01..0.01));
            zs.extend_from_slice(&z);
            acts.extend_from_slice(&[rng.random_range(-1.0..1.0), z[0]]);
        }
        let pts = Points { z: &zs, a: &acts };
        for i in 0..6000 {
            idx.add_with_action(i, pts);
        }
        let plan = idx.plan(pts);
        let bulk = plan.bulk(bulk_of::<D>(&idx.tree));
        let ex = plan.exact();
        let mut copies: Vec<(&str, KernelFn<D>, NearestFn<D>)> =
            vec![("baseline", kernel_any::<D>, nearest_any::<D>)];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                copies.push(("avx2", kernel_avx2::<D>, nearest_avx2::<D>));
            }
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("popcnt")
            {
                copies.push(("avx512", kernel_avx512::<D>, nearest_avx512::<D>));
            }
        }
        for _ in 0..60 {
            let at = rng.random_range(0..6000);
            let q: [f64; D] =
                std::array::from_fn(|k| zs[at * D + k] + rng.random_range(-0.02..0.02));
            // Narrow kernels (leaves partly inside), and wide ones (whole subtrees inside the
            // radius, which skip the box and coarse tests).
            let reach: f64 = [0.05, 0.05, 0.4][at % 3];
            let r2 = rng.random_range(0.0..reach).powi(2) * D as f64;
            let inv = rng.random_range(10.0..5000.0);
            let n = [1, 40, 500][at % 3];
            let mut answers = Vec::new();
            for (name, kernel, nearest) in &copies {
                let (acc, points) = kernel(bulk, &q, r2, inv, &ex);
                let mut found = Vec::new();
                let bound = nearest(bulk, &q, n, r2, &mut found, &ex);
                found.sort_unstable_by_key(|c| order_key(*c));
                let bits: Vec<u64> = acc.iter().map(|v| v.to_bits()).collect();
                answers.push((*name, bits, points.to_bits(), found, bound.to_bits()));
            }
            let (_, bits, points, found, bound) = &answers[0];
            assert!(!found.is_empty() || *points == 0.0f64.to_bits());
            for (name, b, p, f, n) in &answers[1..] {
                assert_eq!(
                    (b, p, f, n),
                    (bits, points, found, bound),
                    "{name} against the baseline"
                );
            }
        }
    }

    type KernelFn<const D: usize> = fn(&Bulk<D>, &[f64; D], f64, f64, &Exact<D>) -> ([f64; 3], f64);
    type NearestFn<const D: usize> =
        fn(&Bulk<D>, &[f64; D], usize, f64, &mut Vec<(f64, u64)>, &Exact<D>) -> f64;

    fn leaf_of<'a, const D: usize>(
        bulk: &'a Bulk<D>,
        inv: f64,
        r2: f64,
    ) -> KernelSum<'a, [f64; 3]> {
        KernelSum::new(&bulk.sums, inv, r2, [0.0; 3])
    }

    fn kernel_any<const D: usize>(
        b: &Bulk<D>,
        q: &[f64; D],
        r2: f64,
        inv: f64,
        ex: &Exact<D>,
    ) -> ([f64; 3], f64) {
        let mut k = leaf_of(b, inv, r2);
        b.within_any_visit(q, r2, &mut k, ex, Scalar);
        (k.acc, k.points)
    }

    fn nearest_any<const D: usize>(
        b: &Bulk<D>,
        q: &[f64; D],
        n: usize,
        r2: f64,
        found: &mut Vec<(f64, u64)>,
        ex: &Exact<D>,
    ) -> f64 {
        found.clear();
        b.nearest_n_within_any(q, n, r2, found, ex)
    }

    /// The test's entry points into one vector copy of the searches: the kernel sum and the
    /// k-nearest search, each after asserting the processor has the copy's feature.
    macro_rules! vector_copy {
        ($kernel:ident, $nearest:ident, [$($feature:tt),+], $visit:ident, $within:ident) => {
            #[cfg(target_arch = "x86_64")]
            fn $kernel<const D: usize>(
                b: &Bulk<D>,
                q: &[f64; D],
                r2: f64,
                inv: f64,
                ex: &Exact<D>,
            ) -> ([f64; 3], f64) {
                let mut k = leaf_of(b, inv, r2);
                $(assert!(std::arch::is_x86_feature_detected!($feature));)+
                // SAFETY: this processor has the copy's feature, asserted just above.
                unsafe { b.$visit(q, r2, &mut k, ex) };
                (k.acc, k.points)
            }

            #[cfg(target_arch = "x86_64")]
            fn $nearest<const D: usize>(
                b: &Bulk<D>,
                q: &[f64; D],
                n: usize,
                r2: f64,
                found: &mut Vec<(f64, u64)>,
                ex: &Exact<D>,
            ) -> f64 {
                found.clear();
                $(assert!(std::arch::is_x86_feature_detected!($feature));)+
                // SAFETY: this processor has the copy's feature, asserted just above.
                unsafe { b.$within(q, n, r2, found, ex) }
            }
        };
    }

    vector_copy!(
        kernel_avx2,
        nearest_avx2,
        ["avx2"],
        within_visit_avx2,
        nearest_n_within_avx2
    );
    vector_copy!(
        kernel_avx512,
        nearest_avx512,
        ["avx512f", "popcnt"],
        within_visit_avx512,
        nearest_n_within_avx512
    );
}

#[cfg(test)]
mod sort_tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The radix sort orders as a comparison sort on [`order_key`]: distances with many ties, a
    /// narrow range (bytes shared by all), a wide one, zeros of both signs, infinities and NaNs.
    #[test]
    fn the_radix_sort_orders_as_the_comparison_sort() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let special = [
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NAN,
            -f64::NAN,
            1e-300,
            5e-324,
        ];
        for len in [0, 1, 63, 64, 65, 200, 3000] {
            for kind in 0..4 {
                let mut v: Vec<(f64, u64)> = (0..len)
                    .map(|_| {
                        let d = match kind {
                            0 => f64::from(rng.random_range(0..20u8)) / 8.0,
                            1 => 0.25 + rng.random_range(0.0..1e-9),
                            2 => rng.random_range(-300.0..300.0f64).exp2(),
                            _ => special[rng.random_range(0..special.len())],
                        };
                        (d, rng.random_range(0..1000))
                    })
                    .collect();
                let mut want = v.clone();
                want.sort_unstable_by_key(|c| order_key(*c));
                sort_nearest_first(&mut v);
                let bits =
                    |v: &[(f64, u64)]| v.iter().map(|e| (e.0.to_bits(), e.1)).collect::<Vec<_>>();
                assert_eq!(bits(&v), bits(&want), "len {len}, kind {kind}");
            }
        }
    }
}
