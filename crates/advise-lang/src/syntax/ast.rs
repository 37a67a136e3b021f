//! The spanned abstract syntax tree of the advice-operator language.
//!
//! Built only by [`crate::syntax`] from pest pairs, read by the checker and printed back to text by
//! [`crate::syntax::print`]. Names are not resolved here: a `Var("rot")` may name a dimension, a
//! parameter or nothing at all; that is the checker's business. Spans are byte ranges into the
//! source the item was parsed from.

use crate::domain::Space;

/// A byte range `start..end` in the source text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

impl Span {
    pub fn new(start: usize, end: usize) -> Span {
        Span { start, end }
    }

    /// The smallest span covering both.
    pub fn join(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }

    pub fn len(&self) -> usize {
        self.end - self.start
    }

    pub fn is_empty(&self) -> bool {
        self.start == self.end
    }
}

impl From<Span> for miette::SourceSpan {
    fn from(s: Span) -> Self {
        miette::SourceSpan::new(s.start.into(), s.len())
    }
}

/// A name as written, with where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

/// A parsed file: a sequence of items in source order.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct File {
    pub items: Vec<Item>,
}

/// One top-level item. Session commands will join this enum.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    Domain(DomainDecl),
    Operator(OperatorDecl),
}

impl Item {
    pub fn span(&self) -> Span {
        match self {
            Item::Domain(d) => d.span,
            Item::Operator(o) => o.span,
        }
    }
}

/// `domain NAME { observe ...  act ... }`
#[derive(Clone, Debug, PartialEq)]
pub struct DomainDecl {
    /// Doc comment lines without the leading `///` (one leading space removed).
    pub doc: Vec<String>,
    pub name: Ident,
    /// Dimensions in declaration order; each knows its space.
    pub dims: Vec<DimDecl>,
    /// The task clauses (goal, let, success, end, score, recorded, test, teacher) in source
    /// order; none for a domain that only declares shapes.
    pub clauses: Vec<Clause>,
    pub span: Span,
}

/// What a dimension is, in a domain that is also a task.
#[derive(Clone, Debug, PartialEq)]
pub enum DimMeaning {
    /// An observation's definition: `= hypot(dx, dy)`.
    Def(Expr),
    /// An action commanding the base directly: `drives speed`.
    Drives(Ident),
    /// An action whose value is added to the command each step, which is kept in the limits:
    /// `changes speed in [-1, 1]`.
    Changes(Ident, LimitsExpr),
}

/// `name = expr` in a `let`, `score`, `recorded` or teacher statement.
#[derive(Clone, Debug, PartialEq)]
pub struct Binding {
    pub name: Ident,
    pub value: Expr,
    pub span: Span,
}

/// A task clause of a domain.
#[derive(Clone, Debug, PartialEq)]
pub enum Clause {
    /// `goal x_g "m" in [-0.33, 4.5], ...`: the goal's parameters (their `space` is unused).
    Goal(Vec<DimDecl>),
    /// `let dx = x_g - x, ...`
    Let(Vec<Binding>),
    /// `success when COND`
    Success { cond: Expr, span: Span },
    /// `end when COND [for SECONDS]`
    EndWhen {
        cond: Expr,
        hold: Option<Expr>,
        span: Span,
    },
    /// `end after SECONDS`
    EndAfter { limit: Expr, span: Span },
    /// `flaw NAME when COND [for SECONDS]`: what a poor run looks like, for `suggest`.
    Flaw {
        name: Ident,
        cond: Expr,
        hold: Option<Expr>,
        span: Span,
    },
    /// `score error = ..., heading_error = ...`
    Score(Vec<Binding>),
    /// `recorded x_g = x, ...`
    Recorded(Vec<Binding>),
    /// `draw goal pose(x_g, y_g, theta_g), ...`
    Draw(Vec<Drawing>),
    /// `test COUNT [seed SEED]`
    Test {
        count: f64,
        seed: Option<f64>,
        span: Span,
    },
    /// `teacher { let d = ..  trans = .. }`
    Teacher { stmts: Vec<TeacherStmt>, span: Span },
}

impl Clause {
    /// The clause's keyword, as diagnostics name it.
    pub fn keyword(&self) -> &'static str {
        match self {
            Clause::Goal(_) => "goal",
            Clause::Let(_) => "let",
            Clause::Success { .. } => "success",
            Clause::EndWhen { .. } | Clause::EndAfter { .. } => "end",
            Clause::Flaw { .. } => "flaw",
            Clause::Score(_) => "score",
            Clause::Recorded(_) => "recorded",
            Clause::Draw(_) => "draw",
            Clause::Test { .. } => "test",
            Clause::Teacher { .. } => "teacher",
        }
    }
}

/// One shape of a `draw` clause: `goal pose(x_g, y_g, theta_g)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawing {
    /// What the legend calls it; `goal` is the goal.
    pub name: Ident,
    /// `pose`, `point` or `circle`.
    pub shape: Ident,
    pub args: Vec<Expr>,
    pub span: Span,
}

/// A statement of a teacher: `let d = sqrt(dist2)` (a local value) or `trans = d` (an action).
#[derive(Clone, Debug, PartialEq)]
pub struct TeacherStmt {
    pub is_let: bool,
    pub binding: Binding,
}

/// One dimension: `trans "m/s" in [-1, 1]`.
#[derive(Clone, Debug, PartialEq)]
pub struct DimDecl {
    pub space: Space,
    pub name: Ident,
    pub unit: Option<String>,
    pub limits: Option<LimitsExpr>,
    /// In a task: the observation's definition or how the action drives the base.
    pub meaning: Option<DimMeaning>,
    pub span: Span,
}

/// `in [lo, hi]`, both constant expressions (the checker evaluates them).
#[derive(Clone, Debug, PartialEq)]
pub struct LimitsExpr {
    pub lo: Expr,
    pub hi: Expr,
    pub span: Span,
}

/// `operator NAME(PARAMS) for DOMAIN on SPACE BODY`
#[derive(Clone, Debug, PartialEq)]
pub struct OperatorDecl {
    pub doc: Vec<String>,
    pub name: Ident,
    pub params: Vec<ParamDecl>,
    pub domain: Ident,
    pub space: Space,
    /// Span of the `observation`/`action` keyword.
    pub space_span: Span,
    pub body: Body,
    pub span: Span,
}

/// `rate = 0.2 in [0, 1]`
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDecl {
    pub name: Ident,
    pub default: Option<Expr>,
    pub limits: Option<LimitsExpr>,
    pub span: Span,
}

/// What an operator does.
#[derive(Clone, Debug, PartialEq)]
pub enum Body {
    /// Per-point assignments, all reading the point as it was before the operator; points that
    /// fail the guard are skipped.
    Block {
        guard: Option<Expr>,
        stmts: Vec<Stmt>,
    },
    /// `= a(..) then b(..)`: the operators applied in sequence on the same chunk.
    Pipeline(Vec<Call>),
}

/// `trans *= 1 + rate`
#[derive(Clone, Debug, PartialEq)]
pub struct Stmt {
    pub target: Ident,
    pub op: AssignOp,
    pub value: Expr,
    pub span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssignOp {
    Set,
    Add,
    Sub,
    Mul,
    Div,
}

impl AssignOp {
    pub fn text(self) -> &'static str {
        match self {
            AssignOp::Set => "=",
            AssignOp::Add => "+=",
            AssignOp::Sub => "-=",
            AssignOp::Mul => "*=",
            AssignOp::Div => "/=",
        }
    }
}

/// One step of a composition: `slow_down(rate = 0.5)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Call {
    pub name: Ident,
    pub args: Vec<Arg>,
    pub span: Span,
}

/// A positional (`0.5`) or named (`rate = 0.5`) argument.
#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    pub name: Option<Ident>,
    pub value: Expr,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A non-negative literal (`-1` is `Neg(Num(1))`).
    Num(f64),
    /// A dimension, a parameter, or one of the built-ins `k`, `n`, `pi`.
    Var(String),
    /// `bearing[-3]`: a dimension read at a relative offset from the point.
    At {
        dim: Box<Ident>,
        offset: Box<Expr>,
    },
    /// `min(a, b)` (the names boxed: they are rare, and an expression is as large as its largest
    /// kind; every node of a 50 MB file's trees is 56 bytes instead of 80)
    Call {
        func: Box<Ident>,
        args: Vec<Expr>,
    },
    Unary(UnOp, Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnOp {
    Neg,
    Not,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    Or,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Add,
    Sub,
    Mul,
    Div,
}

impl BinOp {
    pub fn text(self) -> &'static str {
        match self {
            BinOp::Or => "or",
            BinOp::And => "and",
            BinOp::Eq => "==",
            BinOp::Ne => "!=",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
        }
    }

    /// Binding strength; all binary operators associate to the left.
    pub fn precedence(self) -> u8 {
        match self {
            BinOp::Or => 1,
            BinOp::And => 2,
            BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => 4,
            BinOp::Add | BinOp::Sub => 5,
            BinOp::Mul | BinOp::Div => 6,
        }
    }

    /// Whether the result is a condition rather than a number.
    pub fn is_logical(self) -> bool {
        matches!(self, BinOp::Or | BinOp::And)
    }

    pub fn is_comparison(self) -> bool {
        matches!(
            self,
            BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge
        )
    }
}

impl UnOp {
    pub fn precedence(self) -> u8 {
        match self {
            UnOp::Not => 3,
            UnOp::Neg => 7,
        }
    }
}

impl Expr {
    pub fn new(kind: ExprKind, span: Span) -> Expr {
        Expr { kind, span }
    }

    /// Binding strength of the expression's outermost operator (atoms bind tightest).
    pub fn precedence(&self) -> u8 {
        match &self.kind {
            ExprKind::Binary(op, ..) => op.precedence(),
            ExprKind::Unary(op, _) => op.precedence(),
            _ => 8,
        }
    }
}

/// Replace every span by `0..0`, so that trees parsed from differently formatted text compare
/// equal when they mean the same (the print-then-parse round trip).
pub trait EraseSpans {
    fn erase_spans(&mut self);
}

impl EraseSpans for Span {
    fn erase_spans(&mut self) {
        *self = Span::default();
    }
}

impl EraseSpans for Ident {
    fn erase_spans(&mut self) {
        self.span.erase_spans();
    }
}

impl<T: EraseSpans> EraseSpans for Option<T> {
    fn erase_spans(&mut self) {
        if let Some(t) = self {
            t.erase_spans();
        }
    }
}

impl<T: EraseSpans> EraseSpans for Vec<T> {
    fn erase_spans(&mut self) {
        self.iter_mut().for_each(EraseSpans::erase_spans);
    }
}

impl EraseSpans for File {
    fn erase_spans(&mut self) {
        self.items.erase_spans();
    }
}

impl EraseSpans for Item {
    fn erase_spans(&mut self) {
        match self {
            Item::Domain(d) => d.erase_spans(),
            Item::Operator(o) => o.erase_spans(),
        }
    }
}

impl EraseSpans for DomainDecl {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.dims.erase_spans();
        self.clauses.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for DimDecl {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.limits.erase_spans();
        self.meaning.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for DimMeaning {
    fn erase_spans(&mut self) {
        match self {
            DimMeaning::Def(e) => e.erase_spans(),
            DimMeaning::Drives(a) => a.erase_spans(),
            DimMeaning::Changes(a, l) => {
                a.erase_spans();
                l.erase_spans();
            }
        }
    }
}

impl EraseSpans for Binding {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.value.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for Drawing {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.shape.erase_spans();
        self.args.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for TeacherStmt {
    fn erase_spans(&mut self) {
        self.binding.erase_spans();
    }
}

impl EraseSpans for Clause {
    fn erase_spans(&mut self) {
        match self {
            Clause::Goal(d) => d.erase_spans(),
            Clause::Let(b) | Clause::Score(b) | Clause::Recorded(b) => b.erase_spans(),
            Clause::Draw(d) => d.erase_spans(),
            Clause::Success { cond, span } => {
                cond.erase_spans();
                span.erase_spans();
            }
            Clause::EndWhen { cond, hold, span } => {
                cond.erase_spans();
                hold.erase_spans();
                span.erase_spans();
            }
            Clause::EndAfter { limit, span } => {
                limit.erase_spans();
                span.erase_spans();
            }
            Clause::Flaw {
                name,
                cond,
                hold,
                span,
            } => {
                name.erase_spans();
                cond.erase_spans();
                hold.erase_spans();
                span.erase_spans();
            }
            Clause::Test { span, .. } => span.erase_spans(),
            Clause::Teacher { stmts, span } => {
                stmts.erase_spans();
                span.erase_spans();
            }
        }
    }
}

impl EraseSpans for LimitsExpr {
    fn erase_spans(&mut self) {
        self.lo.erase_spans();
        self.hi.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for OperatorDecl {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.params.erase_spans();
        self.domain.erase_spans();
        self.space_span.erase_spans();
        self.body.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for ParamDecl {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.default.erase_spans();
        self.limits.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for Body {
    fn erase_spans(&mut self) {
        match self {
            Body::Block { guard, stmts } => {
                guard.erase_spans();
                stmts.erase_spans();
            }
            Body::Pipeline(calls) => calls.erase_spans(),
        }
    }
}

impl EraseSpans for Stmt {
    fn erase_spans(&mut self) {
        self.target.erase_spans();
        self.value.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for Call {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.args.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for Arg {
    fn erase_spans(&mut self) {
        self.name.erase_spans();
        self.value.erase_spans();
        self.span.erase_spans();
    }
}

impl EraseSpans for Expr {
    fn erase_spans(&mut self) {
        self.span.erase_spans();
        match &mut self.kind {
            ExprKind::Num(_) | ExprKind::Var(_) => {}
            ExprKind::At { dim, offset } => {
                dim.erase_spans();
                offset.erase_spans();
            }
            ExprKind::Call { func, args } => {
                func.erase_spans();
                args.erase_spans();
            }
            ExprKind::Unary(_, e) => e.erase_spans(),
            ExprKind::Binary(_, a, b) => {
                a.erase_spans();
                b.erase_spans();
            }
        }
    }
}

impl<T: EraseSpans> EraseSpans for Box<T> {
    fn erase_spans(&mut self) {
        (**self).erase_spans();
    }
}
