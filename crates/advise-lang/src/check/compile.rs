//! Compile a checked body ([`BlockIr`]) to bytecode ([`Program`]): uniform parts (parameters,
//! `n`, constants) become registers evaluated once per application, the rest one instruction per
//! node over a batch of points. Part of the checker: a program exists only for a checked body.

use crate::domain::{Domain, Space};
use crate::program::code::{Ins, Program};
use crate::program::ir::{BlockIr, Func, Ir};
use crate::syntax::ast::BinOp;

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
    Func3(Func, R, R, R),
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
            // Task slots never reach an operator body; as uniforms they evaluate to NaN.
            Ir::Num(_) | Ir::Param(_) | Ir::N | Ir::Slot(_) | Ir::Prev(_) => return None,
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
                    (_, [x, y, z]) => self.push(InsR::Func3(*f, *x, *y, *z)),
                    (_, [x, y]) => self.push(InsR::Func2(*f, *x, *y)),
                    (_, [x]) => self.push(InsR::Func1(*f, *x)),
                    _ => unreachable!("the checker verified the arity of `{}`", f.name()),
                }
            }
        })
    }
}

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
            InsR::Func3(f, x, y, z) => Ins::Func3(f, reg(x), reg(y), reg(z)),
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
