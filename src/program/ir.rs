//! The resolved form of an operator body: every name is already a slot (a dimension index, a
//! parameter index, `k`, `n`), and compound assignments are spelled out. The checker produces it
//! and compiles it to bytecode ([`super::code`]); the interpreter only evaluates the parts that are
//! the same for every point (parameters, `n`). Nothing else builds one, so an `Ir` has always passed
//! the checker.

use crate::domain::Space;
use crate::syntax::ast::BinOp;

/// A built-in function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    Min,
    Max,
    Abs,
    Clamp,
    Sign,
}

impl Func {
    pub const ALL: [Func; 5] = [Func::Min, Func::Max, Func::Abs, Func::Clamp, Func::Sign];

    pub fn name(self) -> &'static str {
        match self {
            Func::Min => "min",
            Func::Max => "max",
            Func::Abs => "abs",
            Func::Clamp => "clamp",
            Func::Sign => "sign",
        }
    }

    pub fn arity(self) -> usize {
        match self {
            Func::Min | Func::Max => 2,
            Func::Abs | Func::Sign => 1,
            Func::Clamp => 3,
        }
    }

    pub fn signature(self) -> &'static str {
        match self {
            Func::Min => "min(a, b): the smaller of a and b",
            Func::Max => "max(a, b): the larger of a and b",
            Func::Abs => "abs(x): the magnitude of x",
            Func::Clamp => "clamp(x, lo, hi): x limited to [lo, hi]",
            Func::Sign => "sign(x): -1, 0 or 1",
        }
    }

    pub fn by_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The function on scalars; total (NaN in, NaN out; `clamp` with `lo > hi` gives `lo`).
    #[inline]
    pub fn eval(self, args: &[f64]) -> f64 {
        match self {
            Func::Min => args[0].min(args[1]),
            Func::Max => args[0].max(args[1]),
            Func::Abs => args[0].abs(),
            Func::Clamp => args[0].min(args[2]).max(args[1]),
            Func::Sign => sign(args[0]),
        }
    }
}

/// -1, 0 or 1 (0 for both zeros, NaN for NaN), unlike `f64::signum` which gives 1 for +0.
#[inline]
pub fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        x * 0.0
    }
}

/// Apply a binary operator to scalars; conditions are 1.0 (true) and 0.0 (false).
#[inline]
pub fn binop(op: BinOp, a: f64, b: f64) -> f64 {
    let t = |c: bool| if c { 1.0 } else { 0.0 };
    match op {
        BinOp::Or => t(a != 0.0 || b != 0.0),
        BinOp::And => t(a != 0.0 && b != 0.0),
        BinOp::Eq => t(a == b),
        BinOp::Ne => t(a != b),
        BinOp::Lt => t(a < b),
        BinOp::Le => t(a <= b),
        BinOp::Gt => t(a > b),
        BinOp::Ge => t(a >= b),
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Mul => a * b,
        BinOp::Div => a / b,
    }
}

/// A resolved expression.
#[derive(Clone, Debug, PartialEq)]
pub enum Ir {
    Num(f64),
    /// The operator's parameter with this index.
    Param(usize),
    /// Index of the point in the chunk, from 0.
    K,
    /// Number of points in the chunk.
    N,
    /// A dimension of the point.
    Dim(Space, usize),
    /// A dimension of the point at a relative offset (rounded, clamped to the trace).
    At(Space, usize, Box<Ir>),
    Neg(Box<Ir>),
    Not(Box<Ir>),
    Bin(BinOp, Box<Ir>, Box<Ir>),
    Func(Func, Vec<Ir>),
}

impl Ir {
    /// Whether the value is the same for every point of one application (no `k`, no dimension).
    pub fn is_uniform(&self) -> bool {
        match self {
            Ir::Num(_) | Ir::Param(_) | Ir::N => true,
            Ir::K | Ir::Dim(..) | Ir::At(..) => false,
            Ir::Neg(e) | Ir::Not(e) => e.is_uniform(),
            Ir::Bin(_, a, b) => a.is_uniform() && b.is_uniform(),
            Ir::Func(_, args) => args.iter().all(Ir::is_uniform),
        }
    }

    /// Whether the value is known without any application (only numbers).
    pub fn is_constant(&self) -> bool {
        match self {
            Ir::Num(_) => true,
            Ir::Param(_) | Ir::N | Ir::K | Ir::Dim(..) | Ir::At(..) => false,
            Ir::Neg(e) | Ir::Not(e) => e.is_constant(),
            Ir::Bin(_, a, b) => a.is_constant() && b.is_constant(),
            Ir::Func(_, args) => args.iter().all(Ir::is_constant),
        }
    }

    /// Evaluate a uniform expression; per-point parts (which a caller should have ruled out with
    /// [`Ir::is_uniform`]) evaluate to NaN rather than panicking.
    pub fn eval_uniform(&self, params: &[f64], n: f64) -> f64 {
        match self {
            Ir::Num(v) => *v,
            Ir::Param(i) => params.get(*i).copied().unwrap_or(f64::NAN),
            Ir::N => n,
            Ir::K | Ir::Dim(..) | Ir::At(..) => f64::NAN,
            Ir::Neg(e) => -e.eval_uniform(params, n),
            Ir::Not(e) => {
                if e.eval_uniform(params, n) != 0.0 {
                    0.0
                } else {
                    1.0
                }
            }
            Ir::Bin(op, a, b) => binop(*op, a.eval_uniform(params, n), b.eval_uniform(params, n)),
            Ir::Func(f, args) => {
                let vals: Vec<f64> = args.iter().map(|a| a.eval_uniform(params, n)).collect();
                f.eval(&vals)
            }
        }
    }

    /// The number of nodes: what compiling it costs in instructions and registers.
    pub fn size(&self) -> usize {
        1 + match self {
            Ir::Num(_) | Ir::Param(_) | Ir::N | Ir::K | Ir::Dim(..) => 0,
            Ir::At(_, _, e) | Ir::Neg(e) | Ir::Not(e) => e.size(),
            Ir::Bin(_, a, b) => a.size() + b.size(),
            Ir::Func(_, args) => args.iter().map(Ir::size).sum(),
        }
    }

    /// Whether the expression reads a dimension of `space` at an offset (another point).
    pub fn reads_offset(&self, space: Space) -> bool {
        match self {
            Ir::At(s, _, off) => *s == space || off.reads_offset(space),
            Ir::Num(_) | Ir::Param(_) | Ir::N | Ir::K | Ir::Dim(..) => false,
            Ir::Neg(e) | Ir::Not(e) => e.reads_offset(space),
            Ir::Bin(_, a, b) => a.reads_offset(space) || b.reads_offset(space),
            Ir::Func(_, args) => args.iter().any(|a| a.reads_offset(space)),
        }
    }
}

/// A checked per-point body: guard and assignments (dimension index in the target space, value).
#[derive(Clone, Debug, PartialEq)]
pub struct BlockIr {
    pub space: Space,
    pub guard: Option<Ir>,
    pub writes: Vec<(usize, Ir)>,
}
