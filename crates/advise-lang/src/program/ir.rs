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
    Sqrt,
    Hypot,
    Atan2,
    Cos,
    Sin,
    Wrap,
    If,
}

impl Func {
    pub const ALL: [Func; 12] = [
        Func::Min,
        Func::Max,
        Func::Abs,
        Func::Clamp,
        Func::Sign,
        Func::Sqrt,
        Func::Hypot,
        Func::Atan2,
        Func::Cos,
        Func::Sin,
        Func::Wrap,
        Func::If,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Func::Min => "min",
            Func::Max => "max",
            Func::Abs => "abs",
            Func::Clamp => "clamp",
            Func::Sign => "sign",
            Func::Sqrt => "sqrt",
            Func::Hypot => "hypot",
            Func::Atan2 => "atan2",
            Func::Cos => "cos",
            Func::Sin => "sin",
            Func::Wrap => "wrap",
            Func::If => "if",
        }
    }

    pub fn arity(self) -> usize {
        match self {
            Func::Min | Func::Max | Func::Hypot | Func::Atan2 => 2,
            Func::Abs | Func::Sign | Func::Sqrt | Func::Cos | Func::Sin | Func::Wrap => 1,
            Func::Clamp | Func::If => 3,
        }
    }

    pub fn signature(self) -> &'static str {
        match self {
            Func::Min => "min(a, b): the smaller of a and b",
            Func::Max => "max(a, b): the larger of a and b",
            Func::Abs => "abs(x): the magnitude of x",
            Func::Clamp => "clamp(x, lo, hi): x limited to [lo, hi]",
            Func::Sign => "sign(x): -1, 0 or 1",
            Func::Sqrt => "sqrt(x): the square root of x (NaN below 0)",
            Func::Hypot => "hypot(dx, dy): the length sqrt(dx^2 + dy^2), without overflow",
            Func::Atan2 => "atan2(y, x): the direction of (x, y), in (-pi, pi]",
            Func::Cos => "cos(a): the cosine of an angle in rad",
            Func::Sin => "sin(a): the sine of an angle in rad",
            Func::Wrap => "wrap(a): the angle a in (-pi, pi]",
            Func::If => "if(cond, a, b): a where the condition holds, else b",
        }
    }

    /// Whether argument `i` is a condition rather than a number.
    pub fn takes_condition(self, i: usize) -> bool {
        self == Func::If && i == 0
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
            Func::Sqrt => args[0].sqrt(),
            Func::Hypot => args[0].hypot(args[1]),
            Func::Atan2 => args[0].atan2(args[1]),
            Func::Cos => args[0].cos(),
            Func::Sin => args[0].sin(),
            Func::Wrap => {
                if args[0].is_finite() {
                    crate::geometry::wrap_angle(args[0])
                } else {
                    f64::NAN
                }
            }
            Func::If => {
                if args[0] != 0.0 {
                    args[1]
                } else {
                    args[2]
                }
            }
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
    /// A task's named value (the pose, a goal parameter, a `let`, an observation...): its slot in
    /// the task's environment. Only task declarations hold these.
    Slot(usize),
    /// A task's named value at the previous control step.
    Prev(usize),
}

impl Ir {
    /// Whether the value is the same for every point of one application (no `k`, no dimension).
    pub fn is_uniform(&self) -> bool {
        match self {
            Ir::Num(_) | Ir::Param(_) | Ir::N => true,
            Ir::K | Ir::Dim(..) | Ir::At(..) | Ir::Slot(_) | Ir::Prev(_) => false,
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
            Ir::Slot(_) | Ir::Prev(_) => false,
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
            Ir::K | Ir::Dim(..) | Ir::At(..) | Ir::Slot(_) | Ir::Prev(_) => f64::NAN,
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

    /// Evaluate a task expression over its environment: `env` holds this step's values by slot,
    /// `prev` the previous step's. Operator-only parts evaluate to NaN. Recursion is bounded by
    /// the parser's depth limit.
    pub fn eval_task(&self, env: &[f64], prev: &[f64]) -> f64 {
        match self {
            Ir::Num(v) => *v,
            Ir::Slot(i) => env.get(*i).copied().unwrap_or(f64::NAN),
            Ir::Prev(i) => prev.get(*i).copied().unwrap_or(f64::NAN),
            Ir::Param(_) | Ir::N | Ir::K | Ir::Dim(..) | Ir::At(..) => f64::NAN,
            Ir::Neg(e) => -e.eval_task(env, prev),
            Ir::Not(e) => {
                if e.eval_task(env, prev) != 0.0 {
                    0.0
                } else {
                    1.0
                }
            }
            Ir::Bin(op, a, b) => binop(*op, a.eval_task(env, prev), b.eval_task(env, prev)),
            Ir::Func(f, args) => {
                let mut vals = [0.0; 3];
                for (v, a) in vals.iter_mut().zip(args) {
                    *v = a.eval_task(env, prev);
                }
                f.eval(&vals[..args.len().min(3)])
            }
        }
    }

    /// Every slot the expression reads, this step's (`false`) and the previous step's (`true`).
    pub fn slots(&self, out: &mut Vec<(usize, bool)>) {
        match self {
            Ir::Slot(i) => out.push((*i, false)),
            Ir::Prev(i) => out.push((*i, true)),
            Ir::Num(_) | Ir::Param(_) | Ir::N | Ir::K | Ir::Dim(..) => {}
            Ir::At(_, _, e) | Ir::Neg(e) | Ir::Not(e) => e.slots(out),
            Ir::Bin(_, a, b) => {
                a.slots(out);
                b.slots(out);
            }
            Ir::Func(_, args) => args.iter().for_each(|a| a.slots(out)),
        }
    }

    /// The number of nodes: what compiling it costs in instructions and registers.
    pub fn size(&self) -> usize {
        1 + match self {
            Ir::Num(_) | Ir::Param(_) | Ir::N | Ir::K | Ir::Dim(..) => 0,
            Ir::Slot(_) | Ir::Prev(_) => 0,
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
            Ir::Slot(_) | Ir::Prev(_) => false,
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
