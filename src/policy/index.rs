//! The spatial index behind both learners: the only code that touches kiddo.
//!
//! Observations are stored scaled (each dimension multiplied by a fixed factor chosen when the
//! index is built), and identical scaled observations share one kd-tree entry: a *group* of
//! dataset points. Grouping matters twice: kiddo's mutable trees cannot hold more than a bucket's
//! worth of identical points, and advice routinely adds points whose observation repeats (advice on
//! the same chunk twice, a robot at rest). The tree's dimension is a const generic, so the index
//! dispatches over the dimensions it supports (1 to [`MAX_DIM`]).

use std::collections::HashMap;
use std::hash::{Hash, Hasher};

use kiddo::{KdTree, SquaredEuclidean};

/// The largest observation dimension the index supports.
pub const MAX_DIM: usize = 8;

enum Tree {
    D1(KdTree<f64, 1>),
    D2(KdTree<f64, 2>),
    D3(KdTree<f64, 3>),
    D4(KdTree<f64, 4>),
    D5(KdTree<f64, 5>),
    D6(KdTree<f64, 6>),
    D7(KdTree<f64, 7>),
    D8(KdTree<f64, 8>),
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
            1 => Tree::D1(KdTree::new()),
            2 => Tree::D2(KdTree::new()),
            3 => Tree::D3(KdTree::new()),
            4 => Tree::D4(KdTree::new()),
            5 => Tree::D5(KdTree::new()),
            6 => Tree::D6(KdTree::new()),
            7 => Tree::D7(KdTree::new()),
            8 => Tree::D8(KdTree::new()),
            _ => return None,
        })
    }

    fn add(&mut self, q: &[f64], item: u64) {
        each_tree!(self, t => t.add(q.try_into().expect("dimension checked at construction"), item))
    }

    fn nearest_one(&self, q: &[f64]) -> (f64, u64) {
        each_tree!(self, t => {
            let n = t.nearest_one::<SquaredEuclidean>(q.try_into().expect("dimension checked at construction"));
            (n.distance, n.item)
        })
    }

    fn nearest_n(&self, q: &[f64], n: usize, out: &mut Vec<(f64, u64)>) {
        out.clear();
        each_tree!(self, t => {
            let found = t.nearest_n::<SquaredEuclidean>(q.try_into().expect("dimension checked at construction"), n);
            out.extend(found.into_iter().map(|n| (n.distance, n.item)));
        })
    }

    fn within(&self, q: &[f64], r2: f64, out: &mut Vec<(f64, u64)>) {
        out.clear();
        each_tree!(self, t => {
            let found = t.within_unsorted::<SquaredEuclidean>(q.try_into().expect("dimension checked at construction"), r2);
            out.extend(found.into_iter().map(|n| (n.distance, n.item)));
        })
    }
}

/// A kd-tree over scaled observations, grouping identical ones.
pub struct Index {
    dim: usize,
    scale: Vec<f64>,
    tree: Tree,
    /// Dataset point indices of each group.
    groups: Vec<Members>,
    /// Scaled observation of each group (row after row).
    group_z: Vec<f64>,
    /// Hash of a scaled observation's bits -> the newest group with that hash; `same_hash[g]` is
    /// the group before `g` with the same hash (`u32::MAX`: none). A fixed-size key and a chain,
    /// instead of a map keyed by each observation's bits, keep a group's bookkeeping to a few
    /// dozen bytes: an index holds one group per distinct observation, millions of them for
    /// 10,000 demonstrations.
    by_key: HashMap<u64, u32>,
    same_hash: Vec<u32>,
    /// Per group, the sum of its points' actions (`act_dim` values) and their count, when the
    /// index was built with [`Index::with_action_sums`]. A kernel weight is the same for every
    /// point of a group, so LWR reads one contiguous row per neighbour instead of chasing each
    /// point's action through the dataset.
    sums: Option<ActionSums>,
}

/// The points of a group: almost always one (no heap allocation), several for repeated
/// observations.
enum Members {
    One(u32),
    Many(Vec<u32>),
}

impl Members {
    fn as_slice(&self) -> &[u32] {
        match self {
            Members::One(p) => std::slice::from_ref(p),
            Members::Many(v) => v,
        }
    }

    fn push(&mut self, point: u32) {
        match self {
            Members::One(p) => *self = Members::Many(vec![*p, point]),
            Members::Many(v) => v.push(point),
        }
    }
}

/// The bits that identify a scaled value (-0.0 and 0.0 are the same place).
fn key_bits(v: f64) -> u64 {
    (v + 0.0).to_bits()
}

struct ActionSums {
    act_dim: usize,
    a: Vec<f64>,
    n: Vec<u32>,
}

impl Index {
    /// An empty index for `dim`-dimensional observations multiplied by `scale`; `None` if the
    /// dimension is unsupported.
    pub fn new(scale: Vec<f64>) -> Option<Index> {
        let dim = scale.len();
        Some(Index {
            dim,
            tree: Tree::new(dim)?,
            scale,
            groups: Vec::new(),
            group_z: Vec::new(),
            by_key: HashMap::new(),
            same_hash: Vec::new(),
            sums: None,
        })
    }

    /// Like [`Index::new`], also keeping each group's action sum; add points with
    /// [`Index::add_with_action`].
    pub fn with_action_sums(scale: Vec<f64>, act_dim: usize) -> Option<Index> {
        let mut idx = Index::new(scale)?;
        idx.sums = Some(ActionSums {
            act_dim,
            a: Vec::new(),
            n: Vec::new(),
        });
        Some(idx)
    }

    /// Add dataset point `point` with raw observation `z` and action `a` (kept in the group's
    /// action sum when the index keeps sums).
    pub fn add_with_action(&mut self, point: u32, z: &[f64], a: &[f64]) {
        let g = self.add(point, z) as usize;
        if let Some(s) = &mut self.sums {
            if s.n.len() <= g {
                s.n.push(0);
                s.a.resize(s.a.len() + s.act_dim, 0.0);
            }
            s.n[g] += 1;
            for (t, v) in s.a[g * s.act_dim..(g + 1) * s.act_dim].iter_mut().zip(a) {
                *t += v;
            }
        }
    }

    /// Group `g`'s action sum and point count, when the index keeps sums.
    #[inline]
    pub fn action_sum(&self, g: u64) -> Option<(&[f64], u32)> {
        let s = self.sums.as_ref()?;
        let g = g as usize;
        Some((&s.a[g * s.act_dim..(g + 1) * s.act_dim], s.n[g]))
    }

    /// Whether the index keeps action sums.
    pub fn has_action_sums(&self) -> bool {
        self.sums.is_some()
    }

    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    pub fn is_empty(&self) -> bool {
        self.groups.is_empty()
    }

    /// Scale a raw observation into `out`.
    #[inline]
    pub fn scaled(&self, z: &[f64], out: &mut [f64]) {
        for ((o, v), s) in out.iter_mut().zip(z).zip(&self.scale) {
            *o = v * s;
        }
    }

    /// Add dataset point `point` with raw observation `z`; returns its group.
    pub fn add(&mut self, point: u32, z: &[f64]) -> u32 {
        let mut q = [0.0; MAX_DIM];
        let q = &mut q[..self.dim];
        self.scaled(z, q);
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        for v in q.iter() {
            key_bits(*v).hash(&mut hasher);
        }
        let hash = hasher.finish();
        let mut next = self.by_key.get(&hash).copied().unwrap_or(u32::MAX);
        while next != u32::MAX {
            let g = next as usize;
            let same = self.group_z[g * self.dim..(g + 1) * self.dim]
                .iter()
                .zip(q.iter())
                .all(|(a, b)| key_bits(*a) == key_bits(*b));
            if same {
                self.groups[g].push(point);
                return next;
            }
            next = self.same_hash[g];
        }
        let g = self.groups.len() as u32;
        self.groups.push(Members::One(point));
        self.group_z.extend_from_slice(q);
        self.same_hash
            .push(self.by_key.insert(hash, g).unwrap_or(u32::MAX));
        self.tree.add(q, g as u64);
        g
    }

    /// The points of group `g`.
    #[inline]
    pub fn group(&self, g: u64) -> &[u32] {
        self.groups[g as usize].as_slice()
    }

    /// Nearest group to scaled query `q`: (squared distance, group). `None` when empty.
    #[inline]
    pub fn nearest(&self, q: &[f64]) -> Option<(f64, u64)> {
        if self.is_empty() {
            return None;
        }
        Some(self.tree.nearest_one(q))
    }

    /// The `n` nearest groups to scaled query `q`, nearest first: (squared distance, group).
    #[inline]
    pub fn nearest_n(&self, q: &[f64], n: usize, out: &mut Vec<(f64, u64)>) {
        if self.is_empty() {
            out.clear();
            return;
        }
        self.tree.nearest_n(q, n, out)
    }

    /// How many groups (distinct observations) the index holds.
    pub fn groups(&self) -> usize {
        self.groups.len()
    }

    /// Every group within squared distance `r2` of scaled query `q`, unsorted.
    #[inline]
    pub fn within(&self, q: &[f64], r2: f64, out: &mut Vec<(f64, u64)>) {
        if self.is_empty() {
            out.clear();
            return;
        }
        self.tree.within(q, r2, out)
    }

    /// Scaled observation of group `g`.
    #[inline]
    pub fn group_z(&self, g: u64) -> &[f64] {
        let g = g as usize;
        &self.group_z[g * self.dim..(g + 1) * self.dim]
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
        let groups: Vec<u32> = zs
            .iter()
            .enumerate()
            .map(|(i, z)| idx.add(i as u32, z))
            .collect();
        assert_eq!(groups, [0, 0, 1, 0, 2, 1]);
        assert_eq!(idx.groups(), 3);
        assert_eq!(idx.group(0), [0, 1, 3]);
        assert_eq!(idx.group(1), [2, 5]);
        assert_eq!(idx.group(2), [4]);
        assert_eq!(idx.group_z(2), [2.0, 0.5]);
        let mut found = Vec::new();
        idx.within(&[1.0, 0.0], 1e-12, &mut found);
        assert_eq!(found, [(0.0, 0)]);
    }
}
