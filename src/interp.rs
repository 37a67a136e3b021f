//! Apply a checked operator to a chunk of a trace: the synthesized points and their provenance.
//!
//! Operators arrive compiled ([`Program`], built once by the checker and cached in the
//! [`OperatorSet`]): every name is already a register, a dimension index or a parameter slot, so
//! nothing is looked up per point. A program runs over batches of points, one instruction at a time
//! over the whole batch (an array interpreter), which keeps dispatch off the per-point path and lets
//! the inner loops vectorise. Compositions run their stages in sequence on the same chunk; a point
//! skipped by a stage's guard drops out of the stages after it. Every written value is clamped to
//! its dimension's limits. This module does no IO and prints nothing.
//!
//! Semantics, precisely:
//! - `k` is the point's index in the chunk (from 0), `n` the chunk length.
//! - All statements of one operator read the point as it was before that operator (simultaneous
//!   assignment); a later stage of a composition sees what the earlier stages wrote.
//! - `dim[off]` reads the point `round(off)` places away, clamped to the trace; inside the chunk
//!   it sees the current stage's input, outside it the executed trace.
//! - The synthesized points keep the executed time stamp and pose of the point they came from.

use miette::{Diagnostic, NamedSource, SourceSpan};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::check::ir::{BlockIr, Func, Ir, binop};
use crate::check::{OpBody, Operator, OperatorSet, hint};
use crate::domain::{Domain, Space};
use crate::syntax::ast::BinOp;
use crate::syntax::{self, Invocation};
use crate::trace::{Chunk, ChunkError, Trace, TraceError};

/// Points per batch: large enough to amortise dispatch, small enough that a program's registers
/// stay in L1.
const BATCH: usize = 256;

/// A compiled per-point operator body.
#[derive(Clone, Debug)]
pub struct Program {
    space: Space,
    /// Registers `0..uniforms.len()` hold values that are the same for every point of one
    /// application (parameters, `n`, constants), evaluated once and broadcast.
    uniforms: Vec<Ir>,
    /// Instruction `i` writes register `uniforms.len() + i`.
    code: Vec<Ins>,
    guard: Option<usize>,
    /// Instructions `..guard_code` compute the guard; the rest, the written values.
    guard_code: usize,
    /// `(dimension in the target space, register)`.
    writes: Vec<(usize, usize)>,
    /// Clamp interval of each target dimension (infinite when unbounded).
    limits: Vec<(f64, f64)>,
    /// The body reads the target space at other points, so it must read a copy of the stage's
    /// input rather than values it has already overwritten.
    snapshot: bool,
}

#[derive(Clone, Copy, Debug)]
enum Ins {
    K,
    Load(Space, usize),
    LoadAt(Space, usize, usize),
    Neg(usize),
    Not(usize),
    Bin(BinOp, usize, usize),
    Func1(Func, usize),
    Func2(Func, usize, usize),
    Clamp(usize, usize, usize),
}

/// Operand reference during compilation, before uniform registers are counted.
#[derive(Clone, Copy)]
enum R {
    U(usize),
    C(usize),
}

struct Compiler {
    uniforms: Vec<Ir>,
    code: Vec<InsR>,
}

#[derive(Clone, Copy)]
enum InsR {
    K,
    Load(Space, usize),
    LoadAt(Space, usize, R),
    Neg(R),
    Not(R),
    Bin(BinOp, R, R),
    Func1(Func, R),
    Func2(Func, R, R),
    Clamp(R, R, R),
}

impl Compiler {
    fn push(&mut self, i: InsR) -> R {
        self.code.push(i);
        R::C(self.code.len() - 1)
    }

    /// Compile `ir` into a register. Uniform parts become uniform registers, found bottom-up in
    /// one pass (asking `is_uniform` at every level would cost the tree's size times its depth).
    fn emit(&mut self, ir: &Ir) -> R {
        match self.emit_varying(ir) {
            Some(r) => r,
            None => self.uniform(ir),
        }
    }

    fn uniform(&mut self, ir: &Ir) -> R {
        self.uniforms.push(ir.clone());
        R::U(self.uniforms.len() - 1)
    }

    /// Emit `ir` when it varies from point to point; `None` (emitting nothing) when it is uniform.
    fn emit_varying(&mut self, ir: &Ir) -> Option<R> {
        Some(match ir {
            Ir::Num(_) | Ir::Param(_) | Ir::N => return None,
            Ir::K => self.push(InsR::K),
            Ir::Dim(s, d) => self.push(InsR::Load(*s, *d)),
            Ir::At(s, d, off) => {
                let o = self.emit(off);
                self.push(InsR::LoadAt(*s, *d, o))
            }
            Ir::Neg(e) => {
                let x = self.emit_varying(e)?;
                self.push(InsR::Neg(x))
            }
            Ir::Not(e) => {
                let x = self.emit_varying(e)?;
                self.push(InsR::Not(x))
            }
            Ir::Bin(op, a, b) => {
                let (x, y) = match (self.emit_varying(a), self.emit_varying(b)) {
                    (None, None) => return None,
                    (Some(x), None) => (x, self.uniform(b)),
                    (None, Some(y)) => (self.uniform(a), y),
                    (Some(x), Some(y)) => (x, y),
                };
                self.push(InsR::Bin(*op, x, y))
            }
            Ir::Func(f, args) => {
                let varying: Vec<Option<R>> = args.iter().map(|a| self.emit_varying(a)).collect();
                if varying.iter().all(Option::is_none) {
                    return None;
                }
                let rs: Vec<R> = varying
                    .into_iter()
                    .zip(args)
                    .map(|(r, a)| r.unwrap_or_else(|| self.uniform(a)))
                    .collect();
                match (f, rs.as_slice()) {
                    (Func::Clamp, [x, lo, hi]) => self.push(InsR::Clamp(*x, *lo, *hi)),
                    (_, [x, y]) => self.push(InsR::Func2(*f, *x, *y)),
                    (_, [x]) => self.push(InsR::Func1(*f, *x)),
                    _ => unreachable!("the checker verified the arity of `{}`", f.name()),
                }
            }
        })
    }
}

impl Program {
    /// Compile a checked body for `domain`.
    pub(crate) fn compile(block: &BlockIr, domain: &Domain) -> Program {
        let mut c = Compiler {
            uniforms: Vec::new(),
            code: Vec::new(),
        };
        let guard = block.guard.as_ref().map(|g| c.emit(g));
        let guard_code = c.code.len();
        let writes: Vec<(usize, R)> = block
            .writes
            .iter()
            .map(|(d, ir)| (*d, c.emit(ir)))
            .collect();
        let u = c.uniforms.len();
        let reg = |r: R| match r {
            R::U(i) => i,
            R::C(i) => u + i,
        };
        let code = c
            .code
            .iter()
            .map(|i| match *i {
                InsR::K => Ins::K,
                InsR::Load(s, d) => Ins::Load(s, d),
                InsR::LoadAt(s, d, o) => Ins::LoadAt(s, d, reg(o)),
                InsR::Neg(x) => Ins::Neg(reg(x)),
                InsR::Not(x) => Ins::Not(reg(x)),
                InsR::Bin(op, x, y) => Ins::Bin(op, reg(x), reg(y)),
                InsR::Func1(f, x) => Ins::Func1(f, reg(x)),
                InsR::Func2(f, x, y) => Ins::Func2(f, reg(x), reg(y)),
                InsR::Clamp(x, lo, hi) => Ins::Clamp(reg(x), reg(lo), reg(hi)),
            })
            .collect();
        let snapshot = block.guard.iter().any(|g| g.reads_offset(block.space))
            || block
                .writes
                .iter()
                .any(|(_, ir)| ir.reads_offset(block.space));
        Program {
            space: block.space,
            limits: domain
                .dims(block.space)
                .iter()
                .map(|d| {
                    d.limits
                        .map_or((f64::NEG_INFINITY, f64::INFINITY), |l| (l.lo, l.hi))
                })
                .collect(),
            uniforms: c.uniforms,
            code,
            guard: guard.map(reg),
            guard_code,
            writes: writes.into_iter().map(|(d, r)| (d, reg(r))).collect(),
            snapshot,
        }
    }

    fn n_regs(&self) -> usize {
        self.uniforms.len() + self.code.len()
    }

    /// Run one stage over the chunk held in `w`. Returns the first non-finite result, if any, as
    /// `(chunk index, target dimension, value)`.
    fn run(&self, w: &mut Work<'_>, params: &[f64]) -> Option<Fault> {
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
    fn run_single(
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
                Ins::Clamp(x, l, h) => {
                    for (((v, a), lo), hi) in d.iter_mut().zip(r(x)).zip(r(l)).zip(r(h)) {
                        *v = Func::Clamp.eval(&[*a, *lo, *hi]);
                    }
                }
            }
        }
    }
}

/// Why a stage stopped, at chunk point `k`.
#[derive(Clone, Copy, Debug)]
enum Fault {
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
struct Work<'t> {
    trace: &'t Trace,
    start: usize,
    n: usize,
    od: usize,
    ad: usize,
    z: Vec<f64>,
    a: Vec<f64>,
    alive: Vec<bool>,
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

/// The value given to one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamValue {
    pub name: String,
    pub value: f64,
}

/// What was applied, recorded with the points it produced: enough to re-synthesize them exactly
/// from the same trace ([`reapply`]), or to re-parameterise the advice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AppliedAdvice {
    pub operator: String,
    pub domain: String,
    /// Every parameter of the operator, defaults filled in, in declaration order.
    pub params: Vec<ParamValue>,
    pub chunk: Chunk,
    /// The space the operator modified.
    pub space: Space,
    /// The operator's definition in canonical text when it was applied, so a later change to the
    /// operator can be detected.
    pub definition: String,
}

impl AppliedAdvice {
    /// The invocation that reproduces this advice, every parameter named.
    pub fn invocation(&self) -> Invocation {
        let args: Vec<String> = self
            .params
            .iter()
            .map(|p| format!("{} = {}", p.name, syntax::print::number(p.value)))
            .collect();
        let text = if args.is_empty() {
            self.operator.clone()
        } else {
            format!("{}({})", self.operator, args.join(", "))
        };
        // Names and printed numbers always parse back; fall back to the bare name otherwise.
        syntax::parse_invocation(&text).unwrap_or_else(|_| Invocation::bare(&self.operator))
    }
}

/// The points an application synthesized.
#[derive(Clone, Debug, PartialEq)]
pub struct Synthesized {
    /// Only the synthesized points, in chunk order, same domain as the trace.
    pub points: Trace,
    /// For each synthesized point, the index of the executed point it came from (points skipped by
    /// a guard are absent).
    pub source_index: Vec<usize>,
    pub advice: AppliedAdvice,
}

/// Why advice could not be applied.
#[derive(Debug, Error, Diagnostic)]
pub enum ApplyError {
    #[error("there are no operators for the `{domain}` domain")]
    #[diagnostic(
        code(advise::apply::unknown_domain),
        help("the known domains are: {known}")
    )]
    UnknownDomain { domain: String, known: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Chunk(#[from] ChunkError),
    #[error("there is no operator `{name}` for the `{domain}` domain")]
    #[diagnostic(code(advise::apply::unknown_operator))]
    UnknownOperator {
        name: String,
        domain: String,
        #[help]
        help: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("unknown operator")]
        span: SourceSpan,
    },
    #[error("`{operator}` has no parameter `{name}`")]
    #[diagnostic(code(advise::apply::unknown_parameter))]
    UnknownParameter {
        name: String,
        operator: String,
        #[help]
        help: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("unknown parameter")]
        span: SourceSpan,
    },
    #[error("`{operator}` takes {expected} argument{}, found {found}", if *expected == 1 { "" } else { "s" })]
    #[diagnostic(code(advise::apply::wrong_arity), help("{signature}"))]
    TooManyArguments {
        operator: String,
        expected: usize,
        found: usize,
        signature: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("one too many")]
        span: SourceSpan,
    },
    #[error("`{name}` is given twice")]
    #[diagnostic(code(advise::apply::duplicate_argument), help("remove one of them"))]
    DuplicateArgument {
        name: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("given again here")]
        span: SourceSpan,
    },
    #[error("`{operator}` needs a value for `{param}`")]
    #[diagnostic(
        code(advise::apply::missing_argument),
        help("write `{operator}({param} = ...)`")
    )]
    MissingArgument {
        operator: String,
        param: String,
        #[source_code]
        src: NamedSource<String>,
        #[label("`{param}` is not given")]
        span: SourceSpan,
    },
    #[error("{value} is outside the limits of `{param}` of `{operator}`, [{lo}, {hi}]")]
    #[diagnostic(
        code(advise::apply::argument_out_of_range),
        help("give `{param}` a value in [{lo}, {hi}]")
    )]
    OutOfRange {
        operator: String,
        param: String,
        value: f64,
        lo: f64,
        hi: f64,
        #[source_code]
        src: NamedSource<String>,
        #[label("outside [{lo}, {hi}]")]
        span: SourceSpan,
    },
    #[error(
        "`{via}` gives `{operator}` the value {value} for `{param}`, outside its limits [{lo}, {hi}]"
    )]
    #[diagnostic(
        code(advise::apply::argument_out_of_range),
        help("choose the parameters of `{via}` so that `{param}` stays in [{lo}, {hi}]")
    )]
    BoundOutOfRange {
        via: String,
        operator: String,
        param: String,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(
        "`{operator}` computed {value} for `{dim}` at point {point}, which is not a finite number"
    )]
    #[diagnostic(
        code(advise::apply::not_finite),
        help(
            "a division by zero? guard the operator, e.g. `where rot != 0`, or give `{dim}` limits"
        )
    )]
    NotFinite {
        operator: String,
        dim: String,
        point: usize,
        value: f64,
    },
    #[error(
        "`{operator}` read another point at offset {value} from point {point}, which is not a finite number"
    )]
    #[diagnostic(
        code(advise::apply::offset_not_finite),
        help("an offset counts points, e.g. `bearing[-3]`; a division by zero in the offset?")
    )]
    OffsetNotFinite {
        operator: String,
        point: usize,
        value: f64,
    },
}

/// Apply the operator named by `inv` to `chunk` of `trace`.
pub fn apply(
    set: &OperatorSet,
    inv: &Invocation,
    trace: &Trace,
    chunk: Chunk,
) -> Result<Synthesized, ApplyError> {
    let mut out = Synthesized {
        points: Trace::with_dims(&trace.domain, 0, 0),
        source_index: Vec::new(),
        advice: AppliedAdvice {
            operator: String::new(),
            domain: String::new(),
            params: Vec::new(),
            chunk,
            space: Space::Action,
            definition: String::new(),
        },
    };
    apply_into(set, inv, trace, chunk, &mut out)?;
    Ok(out)
}

/// [`apply`], reusing the allocations of `out` (for loops that apply advice again and again, such
/// as previews or re-synthesizing a dataset). On error `out` holds no meaningful points.
pub fn apply_into(
    set: &OperatorSet,
    inv: &Invocation,
    trace: &Trace,
    chunk: Chunk,
    out: &mut Synthesized,
) -> Result<(), ApplyError> {
    let Some(domain) = set.domain(&trace.domain) else {
        let known: Vec<&str> = set.domains().iter().map(|d| d.name.as_str()).collect();
        return Err(ApplyError::UnknownDomain {
            domain: trace.domain.clone(),
            known: known.join(", "),
        });
    };
    trace.check_domain(domain)?;
    let chunk = Chunk::new(chunk.start, chunk.end, trace.len())?;
    let src = || NamedSource::new("advice", inv.text.clone());
    let Some(index) = set.find(&domain.name, &inv.name.name) else {
        let names = set.operator_names(&domain.name);
        let others = set.domains_with(&inv.name.name);
        let help = match others.first() {
            Some(o) => format!(
                "`{}` is an operator for the `{o}` domain; {}",
                inv.name.name,
                hint(
                    &inv.name.name,
                    &format!("operators for `{}`", domain.name),
                    &names
                )
            ),
            None => hint(
                &inv.name.name,
                &format!("operators for `{}`", domain.name),
                &names,
            ),
        };
        return Err(ApplyError::UnknownOperator {
            name: inv.name.name.clone(),
            domain: domain.name.clone(),
            help,
            src: src(),
            span: inv.name.span.into(),
        });
    };
    let op = set.op(index);
    let values = bind(op, inv)?;

    let n = chunk.len();
    let mut stages: Vec<(usize, Vec<f64>)> = Vec::new();
    flatten(set, index, values.clone(), n as f64, &mut stages)?;

    let (od, ad) = (domain.obs_dim(), domain.act_dim());
    let mut o = Out {
        z: std::mem::take(&mut out.points.z),
        a: std::mem::take(&mut out.points.a),
        t: std::mem::take(&mut out.points.t),
        idx: std::mem::take(&mut out.source_index),
    };
    o.z.clear();
    o.a.clear();
    o.t.clear();
    o.idx.clear();
    let not_finite = |stage: usize, fault: Fault| {
        let stage_op = set.op(stages[stage].0);
        let operator = stage_op.name().to_string();
        match fault {
            Fault::NotFinite { k, dim, value } => ApplyError::NotFinite {
                operator,
                dim: domain.dims(stage_op.space())[dim].name.clone(),
                point: chunk.start + k,
                value,
            },
            Fault::Offset { k, value } => ApplyError::OffsetNotFinite {
                operator,
                point: chunk.start + k,
                value,
            },
        }
    };
    let program = |i: usize| match &set.op(stages[i].0).body {
        OpBody::Block(prog) => prog,
        OpBody::Pipeline(_) => unreachable!("flatten yields only per-point programs"),
    };
    if n > 0 && stages.len() == 1 {
        // One stage reads the executed trace itself: stream it once, straight into the output.
        if let Some(bad) = program(0).run_single(trace, chunk, &stages[0].1, &mut o) {
            return Err(not_finite(0, bad));
        }
    } else if n > 0 {
        let r = chunk.range();
        let mut w = Work {
            trace,
            start: chunk.start,
            n,
            od,
            ad,
            z: trace.z[r.start * od..r.end * od].to_vec(),
            a: trace.a[r.start * ad..r.end * ad].to_vec(),
            alive: vec![true; n],
        };
        for (i, (_, params)) in stages.iter().enumerate() {
            if let Some(bad) = program(i).run(&mut w, params) {
                return Err(not_finite(i, bad));
            }
        }
        for k in (0..n).filter(|&k| w.alive[k]) {
            o.idx.push(chunk.start + k);
            o.t.push(trace.t[chunk.start + k]);
            o.z.extend_from_slice(&w.z[k * od..(k + 1) * od]);
            o.a.extend_from_slice(&w.a[k * ad..(k + 1) * ad]);
        }
    }

    let mut points = Trace::new(domain);
    points.pose = trace
        .pose
        .as_ref()
        .map(|p| o.idx.iter().map(|&i| p[i]).collect());
    points.t = o.t;
    points.z = o.z;
    points.a = o.a;
    out.points = points;
    out.source_index = o.idx;
    out.advice = AppliedAdvice {
        operator: op.name().to_string(),
        domain: domain.name.clone(),
        params: op
            .params()
            .iter()
            .zip(values)
            .map(|(p, value)| ParamValue {
                name: p.name.clone(),
                value,
            })
            .collect(),
        chunk,
        space: op.space(),
        definition: op.definition().to_string(),
    };
    Ok(())
}

/// The output buffers of an application.
struct Out {
    z: Vec<f64>,
    a: Vec<f64>,
    t: Vec<f64>,
    idx: Vec<usize>,
}

/// Re-synthesize the points of recorded advice from the trace it was given on.
pub fn reapply(
    set: &OperatorSet,
    advice: &AppliedAdvice,
    trace: &Trace,
) -> Result<Synthesized, ApplyError> {
    apply(set, &advice.invocation(), trace, advice.chunk)
}

/// The value of every parameter of `op` for `inv`: arguments bound by position or name, defaults
/// filled in, limits checked.
fn bind(op: &Operator, inv: &Invocation) -> Result<Vec<f64>, ApplyError> {
    let src = || NamedSource::new("advice", inv.text.clone());
    let params = op.params();
    let mut values: Vec<Option<f64>> = vec![None; params.len()];
    for (pos, a) in inv.args.iter().enumerate() {
        let slot = match &a.name {
            None if pos >= params.len() => {
                return Err(ApplyError::TooManyArguments {
                    operator: op.name().into(),
                    expected: params.len(),
                    found: inv.args.len(),
                    signature: format!("`{}`", op.signature()),
                    src: src(),
                    span: a.span.into(),
                });
            }
            None => pos,
            Some(n) => params
                .iter()
                .position(|p| p.name == n.name)
                .ok_or_else(|| {
                    let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
                    ApplyError::UnknownParameter {
                        name: n.name.clone(),
                        operator: op.name().into(),
                        help: hint(&n.name, &format!("parameters of `{}`", op.name()), &names),
                        src: src(),
                        span: n.span.into(),
                    }
                })?,
        };
        if values[slot].is_some() {
            return Err(ApplyError::DuplicateArgument {
                name: params[slot].name.clone(),
                src: src(),
                span: a.span.into(),
            });
        }
        if let Some(l) = params[slot].limits
            && !l.contains(a.value)
        {
            return Err(ApplyError::OutOfRange {
                operator: op.name().into(),
                param: params[slot].name.clone(),
                value: a.value,
                lo: l.lo,
                hi: l.hi,
                src: src(),
                span: a.span.into(),
            });
        }
        values[slot] = Some(a.value);
    }
    params
        .iter()
        .zip(values)
        .map(|(p, v)| {
            v.or(p.default).ok_or_else(|| ApplyError::MissingArgument {
                operator: op.name().into(),
                param: p.name.clone(),
                src: src(),
                span: inv.name.span.into(),
            })
        })
        .collect()
}

/// Expand a composition into its per-point stages with their parameter values, in order. The
/// checker bounds how many there are ([`crate::check::MAX_STAGES`]), not how deeply compositions
/// nest, so this walks with its own stack rather than recursing.
fn flatten(
    set: &OperatorSet,
    index: usize,
    values: Vec<f64>,
    n: f64,
    out: &mut Vec<(usize, Vec<f64>)>,
) -> Result<(), ApplyError> {
    // Each entry: a composition, its parameter values, and its next stage.
    let mut stack: Vec<(usize, Vec<f64>, usize)> = vec![(index, values, 0)];
    while let Some((index, values, next)) = stack.pop() {
        let op = set.op(index);
        let stages = match &op.body {
            OpBody::Block(_) => {
                out.push((index, values));
                continue;
            }
            OpBody::Pipeline(stages) => stages,
        };
        let Some(st) = stages.get(next) else {
            continue;
        };
        let callee = set.op(st.op);
        let mut vals = Vec::with_capacity(callee.params().len());
        for (p, arg) in callee.params().iter().zip(&st.args) {
            let v = match arg {
                Some(ir) => ir.eval_uniform(&values, n),
                // The checker guaranteed a default for every parameter left unbound.
                None => p.default.unwrap_or(f64::NAN),
            };
            let out_of_range = match p.limits {
                Some(l) => !l.contains(v),
                None => !v.is_finite(),
            };
            if out_of_range {
                let (lo, hi) = p
                    .limits
                    .map_or((f64::NEG_INFINITY, f64::INFINITY), |l| (l.lo, l.hi));
                return Err(ApplyError::BoundOutOfRange {
                    via: op.name().into(),
                    operator: callee.name().into(),
                    param: p.name.clone(),
                    value: v,
                    lo,
                    hi,
                });
            }
            vals.push(v);
        }
        stack.push((index, values, next + 1));
        stack.push((st.op, vals, 0));
    }
    Ok(())
}
