//! Running bytecode over a chunk: one instruction at a time over a batch of points (an array
//! interpreter), so dispatch stays off the per-point path and the inner loops vectorise. What a
//! stage reads inside the chunk is the stage's input; outside it, the executed trace.

use crate::domain::Space;
use crate::program::code::{Ins, Program};
use crate::program::ir::binop;
use crate::syntax::ast::BinOp;
use crate::trace::{Chunk, Trace};

/// Points per batch: large enough to amortise dispatch, small enough that a program's registers
/// stay in L1.
const BATCH: usize = 256;

/// The output buffers of an application.
pub(super) struct Out {
    pub z: Vec<f64>,
    pub a: Vec<f64>,
    pub t: Vec<f64>,
    pub idx: Vec<usize>,
}

impl Program {
    /// Run one stage over the chunk held in `w`. Returns the first non-finite result, if any, as
    /// `(chunk index, target dimension, value)`.
    pub(super) fn run(&self, w: &mut Work<'_>, params: &[f64]) -> Option<Fault> {
        let n = w.n;
        let mut regs = vec![0.0; self.n_regs() * BATCH];
        for (i, u) in self.uniforms.iter().enumerate() {
            regs[i * BATCH..(i + 1) * BATCH].fill(u.eval_uniform(params, n as f64));
        }
        let snap = self.snapshot.then(|| w.buf(self.space).to_vec());
        let stride = w.dim(self.space);
        let mut offs = Vec::new();
        for bs in (0..n).step_by(BATCH) {
            let m = BATCH.min(n - bs);
            {
                let (z, a) = match (&snap, self.space) {
                    (Some(s), Space::Observation) => (s.as_slice(), w.a.as_slice()),
                    (Some(s), Space::Action) => (w.z.as_slice(), s.as_slice()),
                    (None, _) => (w.z.as_slice(), w.a.as_slice()),
                };
                let src = Src {
                    trace: w.trace,
                    start: w.start,
                    n,
                    z,
                    a,
                    od: w.od,
                    ad: w.ad,
                };
                self.eval_batch(&mut regs, &src, bs, m, &mut offs);
            }
            let alive = &mut w.alive[bs..bs + m];
            if let Some(f) = self.offset_fault(&offs, alive, bs, true) {
                return Some(f);
            }
            if let Some(g) = self.guard {
                for (al, gv) in alive.iter_mut().zip(&regs[g * BATCH..g * BATCH + m]) {
                    *al = *al && *gv != 0.0;
                }
            }
            if let Some(f) = self.offset_fault(&offs, alive, bs, false) {
                return Some(f);
            }
            let buf = match self.space {
                Space::Observation => &mut w.z,
                Space::Action => &mut w.a,
            };
            for &(d, r) in &self.writes {
                let (lo, hi) = self.limits[d];
                let vals = &regs[r * BATCH..r * BATCH + m];
                // Finiteness before clamping: a division by zero must not pass as a full-scale
                // value.
                let mut finite = true;
                for (i, (&v, &al)) in vals.iter().zip(alive.iter()).enumerate() {
                    if al {
                        finite &= v.is_finite();
                        buf[(bs + i) * stride + d] = v.clamp(lo, hi);
                    }
                }
                if !finite {
                    return Some(not_finite(vals, alive, bs, d));
                }
            }
        }
        None
    }

    /// Run as the only stage: read the executed trace, append the surviving points to `o`.
    pub(super) fn run_single(
        &self,
        trace: &Trace,
        chunk: Chunk,
        params: &[f64],
        o: &mut Out,
    ) -> Option<Fault> {
        let (start, n) = (chunk.start, chunk.len());
        let (od, ad) = (trace.obs_dim(), trace.act_dim());
        let zs = &trace.z[start * od..chunk.end * od];
        let as_ = &trace.a[start * ad..chunk.end * ad];
        let src = Src {
            trace,
            start,
            n,
            z: zs,
            a: as_,
            od,
            ad,
        };
        let mut regs = vec![0.0; self.n_regs() * BATCH];
        for (i, u) in self.uniforms.iter().enumerate() {
            regs[i * BATCH..(i + 1) * BATCH].fill(u.eval_uniform(params, n as f64));
        }
        o.z.reserve(n * od);
        o.a.reserve(n * ad);
        o.t.reserve(n);
        o.idx.reserve(n);
        let stride = match self.space {
            Space::Observation => od,
            Space::Action => ad,
        };
        let mut alive = [true; BATCH];
        let mut offs = Vec::new();
        for bs in (0..n).step_by(BATCH) {
            let m = BATCH.min(n - bs);
            self.eval_batch(&mut regs, &src, bs, m, &mut offs);
            let alive = &mut alive[..m];
            alive.fill(true);
            if let Some(f) = self.offset_fault(&offs, alive, bs, true) {
                return Some(f);
            }
            if let Some(g) = self.guard {
                for (al, gv) in alive.iter_mut().zip(&regs[g * BATCH..g * BATCH + m]) {
                    *al = *gv != 0.0;
                }
            }
            if let Some(f) = self.offset_fault(&offs, alive, bs, false) {
                return Some(f);
            }
            let first = o.idx.len();
            if alive.iter().all(|a| *a) {
                o.z.extend_from_slice(&zs[bs * od..(bs + m) * od]);
                o.a.extend_from_slice(&as_[bs * ad..(bs + m) * ad]);
                o.t.extend_from_slice(&trace.t[start + bs..start + bs + m]);
                o.idx.extend(start + bs..start + bs + m);
            } else {
                for i in (0..m).filter(|&i| alive[i]) {
                    let k = bs + i;
                    o.z.extend_from_slice(&zs[k * od..(k + 1) * od]);
                    o.a.extend_from_slice(&as_[k * ad..(k + 1) * ad]);
                    o.t.push(trace.t[start + k]);
                    o.idx.push(start + k);
                }
            }
            let buf = match self.space {
                Space::Observation => &mut o.z,
                Space::Action => &mut o.a,
            };
            let rows = &mut buf[first * stride..];
            for &(d, r) in &self.writes {
                let (lo, hi) = self.limits[d];
                let vals = &regs[r * BATCH..r * BATCH + m];
                let mut finite = true;
                let mut row = 0;
                for (&v, &al) in vals.iter().zip(alive.iter()) {
                    if al {
                        finite &= v.is_finite();
                        rows[row * stride + d] = v.clamp(lo, hi);
                        row += 1;
                    }
                }
                if !finite {
                    return Some(not_finite(vals, alive, bs, d));
                }
            }
        }
        None
    }

    /// The first point in play that read another point at an offset that is not a finite number:
    /// among the guard's own reads (`guard_part`, points in play before the guard) or the written
    /// values' (points the guard kept).
    fn offset_fault(
        &self,
        offs: &[(usize, usize, f64)],
        alive: &[bool],
        bs: usize,
        guard_part: bool,
    ) -> Option<Fault> {
        offs.iter()
            .find(|(i, ins, _)| (*ins < self.guard_code) == guard_part && alive[*i])
            .map(|&(i, _, value)| Fault::Offset { k: bs + i, value })
    }

    /// Evaluate every instruction for points `bs..bs + m` of the chunk. Offsets that are not
    /// finite numbers read NaN and are listed in `offs` as `(point in batch, instruction, offset)`
    /// for the caller to refuse if the point is in play.
    fn eval_batch(
        &self,
        regs: &mut [f64],
        src: &Src<'_>,
        bs: usize,
        m: usize,
        offs: &mut Vec<(usize, usize, f64)>,
    ) {
        offs.clear();
        let base = self.uniforms.len();
        for (ci, ins) in self.code.iter().enumerate() {
            let dst = base + ci;
            let (lo, hi) = regs.split_at_mut(dst * BATCH);
            let d = &mut hi[..m];
            let r = |x: usize| &lo[x * BATCH..x * BATCH + m];
            match *ins {
                Ins::K => {
                    for (i, v) in d.iter_mut().enumerate() {
                        *v = (bs + i) as f64;
                    }
                }
                Ins::Load(space, dim) => {
                    let (buf, stride) = src.space(space);
                    let rows = &buf[bs * stride..(bs + m) * stride];
                    for (v, row) in d.iter_mut().zip(rows.chunks_exact(stride)) {
                        *v = row[dim];
                    }
                }
                Ins::LoadAt(space, dim, off) => {
                    for (i, (v, o)) in d.iter_mut().zip(r(off)).enumerate() {
                        if o.is_finite() {
                            *v = src.at(space, dim, bs + i, *o);
                        } else {
                            offs.push((i, ci, *o));
                            *v = f64::NAN;
                        }
                    }
                }
                Ins::Neg(x) => {
                    for (v, a) in d.iter_mut().zip(r(x)) {
                        *v = -a;
                    }
                }
                Ins::Not(x) => {
                    for (v, a) in d.iter_mut().zip(r(x)) {
                        *v = if *a != 0.0 { 0.0 } else { 1.0 };
                    }
                }
                Ins::Bin(op, x, y) => {
                    let (a, b) = (r(x), r(y));
                    // One loop per operator so that each one vectorises.
                    macro_rules! lanes {
                        ($f:expr) => {
                            for ((v, p), q) in d.iter_mut().zip(a).zip(b) {
                                *v = $f(*p, *q);
                            }
                        };
                    }
                    match op {
                        BinOp::Add => lanes!(|p: f64, q: f64| p + q),
                        BinOp::Sub => lanes!(|p: f64, q: f64| p - q),
                        BinOp::Mul => lanes!(|p: f64, q: f64| p * q),
                        BinOp::Div => lanes!(|p: f64, q: f64| p / q),
                        _ => lanes!(|p, q| binop(op, p, q)),
                    }
                }
                Ins::Func1(f, x) => {
                    for (v, a) in d.iter_mut().zip(r(x)) {
                        *v = f.eval(&[*a]);
                    }
                }
                Ins::Func2(f, x, y) => {
                    for ((v, a), b) in d.iter_mut().zip(r(x)).zip(r(y)) {
                        *v = f.eval(&[*a, *b]);
                    }
                }
                Ins::Func3(f, x, y, z) => {
                    for (((v, a), b), c) in d.iter_mut().zip(r(x)).zip(r(y)).zip(r(z)) {
                        *v = f.eval(&[*a, *b, *c]);
                    }
                }
            }
        }
    }
}

/// Why a stage stopped, at chunk point `k`.
#[derive(Clone, Copy, Debug)]
pub(super) enum Fault {
    /// A written value (of target dimension `dim`) that is not a finite number.
    NotFinite { k: usize, dim: usize, value: f64 },
    /// A read of another point at an offset that is not a finite number.
    Offset { k: usize, value: f64 },
}

/// The fault for the first point in play whose value in `vals` is not finite.
fn not_finite(vals: &[f64], alive: &[bool], bs: usize, dim: usize) -> Fault {
    let i = (0..alive.len())
        .find(|&i| alive[i] && !vals[i].is_finite())
        .unwrap_or(0);
    Fault::NotFinite {
        k: bs + i,
        dim,
        value: vals[i],
    }
}

/// What a batch reads: the stage's input inside the chunk, the executed trace outside it.
struct Src<'a> {
    trace: &'a Trace,
    start: usize,
    n: usize,
    z: &'a [f64],
    a: &'a [f64],
    od: usize,
    ad: usize,
}

impl Src<'_> {
    #[inline]
    fn space(&self, s: Space) -> (&[f64], usize) {
        match s {
            Space::Observation => (self.z, self.od),
            Space::Action => (self.a, self.ad),
        }
    }

    /// Dimension `dim` of the point `round(off)` places from chunk point `k`, clamped to the trace.
    /// `off` is finite (the caller refuses the rest).
    fn at(&self, space: Space, dim: usize, k: usize, off: f64) -> f64 {
        let here = self.start + k;
        let last = self.trace.len() - 1; // the chunk is not empty, so neither is the trace
        let j = (here as f64 + off.round()).clamp(0.0, last as f64) as usize;
        if j >= self.start && j < self.start + self.n {
            let (buf, stride) = self.space(space);
            buf[(j - self.start) * stride + dim]
        } else {
            match space {
                Space::Observation => self.trace.z(j)[dim],
                Space::Action => self.trace.a(j)[dim],
            }
        }
    }
}

/// The chunk being advised: current values of its points and which are still in play.
pub(super) struct Work<'t> {
    pub(super) trace: &'t Trace,
    pub(super) start: usize,
    pub(super) n: usize,
    pub(super) od: usize,
    pub(super) ad: usize,
    pub(super) z: Vec<f64>,
    pub(super) a: Vec<f64>,
    pub(super) alive: Vec<bool>,
}

impl Work<'_> {
    fn buf(&self, s: Space) -> &[f64] {
        match s {
            Space::Observation => &self.z,
            Space::Action => &self.a,
        }
    }

    fn dim(&self, s: Space) -> usize {
        match s {
            Space::Observation => self.od,
            Space::Action => self.ad,
        }
    }
}
