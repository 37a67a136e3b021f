//! Apply a checked operator to a chunk of a trace: the synthesized points and their provenance.
//!
//! What arrives is a [`Call`], bound by the checker (`check::bind`): the operator, compiled to
//! bytecode ([`crate::program::code::Program`]) in which every name is already a register, a
//! dimension index or a parameter slot, and every parameter's value. This module imports nothing
//! of the checker and binds nothing; what can go wrong here is what only a run can show (a value
//! that is not a finite number, a chunk outside the trace, a composition's argument that leaves
//! its limits for this chunk's length). Programs run over batches of points (`interp/run.rs`).
//! Compositions run their stages in sequence on the same chunk; a point skipped by a stage's guard
//! drops out of the stages after it. Every written value is clamped to its dimension's limits.
//! This module does no IO and prints nothing.
//!
//! Semantics, precisely:
//! - `k` is the point's index in the chunk (from 0), `n` the chunk length.
//! - All statements of one operator read the point as it was before that operator (simultaneous
//!   assignment); a later stage of a composition sees what the earlier stages wrote.
//! - `dim[off]` reads the point `round(off)` places away, clamped to the trace; inside the chunk
//!   it sees the current stage's input, outside it the executed trace.
//! - The synthesized points keep the executed time stamp and pose of the point they came from.

pub mod flaws;
mod run;

use miette::Diagnostic;
use thiserror::Error;

use crate::program::{Call, OpBody, Operator};
use crate::trace::{Chunk, ChunkError, Trace, TraceError};
use run::{Fault, Out, Work};

pub use crate::program::{AppliedAdvice, ParamValue};

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
    #[error(transparent)]
    #[diagnostic(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Chunk(#[from] ChunkError),
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

/// Apply a bound call to `chunk` of `trace`.
pub fn apply(call: &Call, trace: &Trace, chunk: Chunk) -> Result<Synthesized, ApplyError> {
    let mut out = Synthesized {
        points: Trace::with_dims(&trace.domain, 0, 0),
        source_index: Vec::new(),
        advice: call.applied_to(chunk),
    };
    apply_into(call, trace, chunk, &mut out)?;
    Ok(out)
}

/// [`apply`], reusing the allocations of `out` (for loops that apply advice again and again, such
/// as previews or re-synthesizing a dataset). On error `out` holds no meaningful points.
pub fn apply_into(
    call: &Call,
    trace: &Trace,
    chunk: Chunk,
    out: &mut Synthesized,
) -> Result<(), ApplyError> {
    let domain = call.op.domain_decl();
    trace.check_domain(domain)?;
    let chunk = Chunk::new(chunk.start, chunk.end, trace.len())?;
    let n = chunk.len();
    let stages = stage_values(call, n as f64)?;

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
        let stage_op = stages[stage].0;
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
    let program = |i: usize| match &stages[i].0.body {
        OpBody::Block(prog) => prog,
        OpBody::Pipeline(_) => unreachable!("stage_values yields only per-point programs"),
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
    out.advice = call.applied_to(chunk);
    Ok(())
}

/// The per-point stages of `call` with their parameter values for a chunk of `n` points, in order.
/// A composition's arguments may use `n`, so only here are their values known; the checker has
/// refused every constant one outside its limits, and this refuses the rest. The frames are in
/// order (parents first), so one pass computes every value.
fn stage_values(call: &Call, n: f64) -> Result<Vec<(&Operator, Vec<f64>)>, ApplyError> {
    let mut values: Vec<Vec<f64>> = Vec::with_capacity(call.frames.len());
    let mut stages = Vec::new();
    for (i, frame) in call.frames.iter().enumerate() {
        let vals = if i == 0 {
            call.params.clone()
        } else {
            let parent = &call.frames[frame.parent].op;
            let OpBody::Pipeline(parent_stages) = &parent.body else {
                unreachable!("only a composition has stages")
            };
            let args = &parent_stages[frame.stage].args;
            let mut vals = Vec::with_capacity(frame.op.params().len());
            for (p, arg) in frame.op.params().iter().zip(args) {
                let v = match arg {
                    Some(ir) => ir.eval_uniform(&values[frame.parent], n),
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
                        via: parent.name().into(),
                        operator: frame.op.name().into(),
                        param: p.name.clone(),
                        value: v,
                        lo,
                        hi,
                    });
                }
                vals.push(v);
            }
            vals
        };
        if matches!(frame.op.body, OpBody::Block(_)) {
            stages.push((&*frame.op, vals.clone()));
        }
        values.push(vals);
    }
    Ok(stages)
}
