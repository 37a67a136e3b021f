//! Bytecode: a per-point operator body as a flat list of instructions over registers, each register
//! a batch of points. The checker compiles it once per operator (`check::compile`); the
//! interpreter runs it (`interp::run`). This module only describes it.

use crate::domain::Space;
use crate::syntax::ast::BinOp;

use super::ir::{Func, Ir};

/// A compiled per-point operator body.
#[derive(Clone, Debug)]
pub struct Program {
    pub(crate) space: Space,
    /// Registers `0..uniforms.len()` hold values that are the same for every point of one
    /// application (parameters, `n`, constants), evaluated once and broadcast.
    pub(crate) uniforms: Vec<Ir>,
    /// Instruction `i` writes register `uniforms.len() + i`.
    pub(crate) code: Vec<Ins>,
    pub(crate) guard: Option<usize>,
    /// Instructions `..guard_code` compute the guard; the rest, the written values.
    pub(crate) guard_code: usize,
    /// `(dimension in the target space, register)`.
    pub(crate) writes: Vec<(usize, usize)>,
    /// Clamp interval of each target dimension (infinite when unbounded).
    pub(crate) limits: Vec<(f64, f64)>,
    /// The body reads the target space at other points, so it must read a copy of the stage's
    /// input rather than values it has already overwritten.
    pub(crate) snapshot: bool,
}

/// One instruction; operands are register numbers.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Ins {
    /// The point's index in the chunk.
    K,
    /// A dimension of the point.
    Load(Space, usize),
    /// A dimension of the point at the offset in a register.
    LoadAt(Space, usize, usize),
    Neg(usize),
    Not(usize),
    Bin(BinOp, usize, usize),
    Func1(Func, usize),
    Func2(Func, usize, usize),
    Func3(Func, usize, usize, usize),
}

impl Program {
    /// How many registers a run needs (each a batch of points).
    pub(crate) fn n_regs(&self) -> usize {
        self.uniforms.len() + self.code.len()
    }
}
