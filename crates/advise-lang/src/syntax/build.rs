//! The AST builder: pest pairs to spanned [`super::ast`] nodes, expressions by precedence
//! climbing with the depth bound [`MAX_DEPTH`].

use pest::iterators::Pair;

use super::ast::*;
use super::error::ParseError;
use super::{MAX_DEPTH, Rule};
use crate::diag::{Loc, SourceId};
use crate::domain::Space;

/// Builds AST nodes from pest pairs.
pub(super) struct Builder {
    /// Where errors point: the source being parsed is in a map under this id.
    pub(super) id: SourceId,
    /// Where the text pest parsed starts in the source (a file is parsed one item at a time, each
    /// from where the one before ended); spans are the source's.
    pub(super) base: usize,
}

/// The flat token stream of an `expr` pair, consumed by precedence climbing.
pub(super) enum Tok<'i> {
    Prefix(UnOp, Span),
    Infix(BinOp, Span),
    Operand(Pair<'i, Rule>),
}

impl Builder {
    /// A builder of spans of the source `id`, for text parsed from its start.
    pub(super) fn new(id: SourceId) -> Builder {
        Builder { id, base: 0 }
    }

    pub(super) fn span(&self, p: &Pair<'_, Rule>) -> Span {
        let s = p.as_span();
        Span::new(self.base + s.start(), self.base + s.end())
    }

    /// The place of `span` of this source, for an error.
    pub(super) fn loc(&self, span: Span) -> Loc {
        self.id.at(span.start..span.end)
    }

    pub(super) fn ident(&self, p: Pair<'_, Rule>) -> Ident {
        Ident {
            name: p.as_str().to_string(),
            span: self.span(&p),
        }
    }

    pub(super) fn number_text(&self, text: &str, span: Span) -> Result<f64, ParseError> {
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.too_large(text, span)),
        }
    }

    /// `text` does not fit a number; a number of a million digits is named by its first few.
    pub(super) fn too_large(&self, text: &str, span: Span) -> ParseError {
        const SHOWN: usize = 24;
        let (text, span) = match text.get(..SHOWN) {
            Some(head) if text.len() > SHOWN => (
                format!("{head}... ({} digits)", text.len()),
                Span::new(span.start, span.start + SHOWN.min(span.len())),
            ),
            _ => (text.to_string(), span),
        };
        ParseError::NumberTooLarge {
            text,
            span: self.loc(span),
        }
    }

    pub(super) fn item(&self, p: Pair<'_, Rule>) -> Result<Item, ParseError> {
        match p.as_rule() {
            Rule::domain => Ok(Item::Domain(self.domain(p)?)),
            Rule::operator => Ok(Item::Operator(self.operator(p)?)),
            r => unreachable!("the grammar has no item {r:?}"),
        }
    }

    pub(super) fn doc_line(&self, p: Pair<'_, Rule>) -> String {
        let text = p.into_inner().next().map_or("", |t| t.as_str());
        let text = text.strip_suffix('\r').unwrap_or(text);
        text.strip_prefix(' ').unwrap_or(text).to_string()
    }

    pub(super) fn domain(&self, p: Pair<'_, Rule>) -> Result<DomainDecl, ParseError> {
        let span = self.span(&p);
        let mut doc = Vec::new();
        let mut name = None;
        let mut dims = Vec::new();
        let mut clauses = Vec::new();
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::doc => doc.push(self.doc_line(part)),
                Rule::name => name = Some(self.ident(part)),
                Rule::dim_group => {
                    let mut inner = part.into_inner();
                    let kw = inner.next().expect("a group starts with its keyword");
                    let space = if kw.as_rule() == Rule::kw_observe {
                        Space::Observation
                    } else {
                        Space::Action
                    };
                    for d in inner.filter(|d| d.as_rule() == Rule::dim) {
                        dims.push(self.dim(space, d)?);
                    }
                }
                Rule::goal_group => {
                    let goal = part
                        .into_inner()
                        .filter(|d| d.as_rule() == Rule::dim)
                        .map(|d| self.dim(Space::Observation, d))
                        .collect::<Result<_, _>>()?;
                    clauses.push(Clause::Goal(goal));
                }
                Rule::let_group => clauses.push(Clause::Let(self.bindings(part)?)),
                Rule::score_group => clauses.push(Clause::Score(self.bindings(part)?)),
                Rule::recorded_group => clauses.push(Clause::Recorded(self.bindings(part)?)),
                Rule::draw_group => {
                    let drawings = part
                        .into_inner()
                        .filter(|d| d.as_rule() == Rule::drawing)
                        .map(|d| self.drawing(d))
                        .collect::<Result<_, _>>()?;
                    clauses.push(Clause::Draw(drawings));
                }
                Rule::success_rule => {
                    let span = self.span(&part);
                    let e = part.into_inner().find(|e| e.as_rule() == Rule::expr);
                    let cond = self.expr(e.expect("a success rule has a condition"), 0)?;
                    clauses.push(Clause::Success { cond, span });
                }
                Rule::end_rule => clauses.push(self.end_rule(part)?),
                Rule::flaw_rule => clauses.push(self.flaw_rule(part)?),
                Rule::test_set => {
                    let span = self.span(&part);
                    let mut nums = part.into_inner().filter(|e| e.as_rule() == Rule::number);
                    let count = nums.next().expect("a test set has a size");
                    let count = self.number_text(count.as_str(), self.span(&count))?;
                    let seed = match nums.next() {
                        Some(n) => Some(self.number_text(n.as_str(), self.span(&n))?),
                        None => None,
                    };
                    clauses.push(Clause::Test { count, seed, span });
                }
                Rule::teacher => {
                    let span = self.span(&part);
                    let mut stmts = Vec::new();
                    for st in part
                        .into_inner()
                        .filter(|s| s.as_rule() == Rule::teacher_stmt)
                    {
                        let mut is_let = false;
                        let mut binding = None;
                        for x in st.into_inner() {
                            match x.as_rule() {
                                Rule::kw_let => is_let = true,
                                Rule::binding => binding = Some(self.binding(x)?),
                                _ => {}
                            }
                        }
                        stmts.push(TeacherStmt {
                            is_let,
                            binding: binding.expect("a teacher statement binds a name"),
                        });
                    }
                    clauses.push(Clause::Teacher { stmts, span });
                }
                _ => {}
            }
        }
        Ok(DomainDecl {
            doc,
            name: name.expect("a domain has a name"),
            dims,
            clauses,
            span,
        })
    }

    fn bindings(&self, p: Pair<'_, Rule>) -> Result<Vec<Binding>, ParseError> {
        p.into_inner()
            .filter(|b| b.as_rule() == Rule::binding)
            .map(|b| self.binding(b))
            .collect()
    }

    /// `goal pose(x_g, y_g, theta_g)`: a name, a shape and its arguments.
    fn drawing(&self, p: Pair<'_, Rule>) -> Result<Drawing, ParseError> {
        let span = self.span(&p);
        let mut names = Vec::new();
        let mut args = Vec::new();
        for x in p.into_inner() {
            match x.as_rule() {
                Rule::name => names.push(self.ident(x)),
                Rule::expr => args.push(self.expr(x, 0)?),
                _ => {}
            }
        }
        let mut names = names.into_iter();
        let name = names.next().expect("a drawing has a name");
        let shape = names.next().expect("a drawing has a shape");
        Ok(Drawing {
            name,
            shape,
            args,
            span,
        })
    }

    fn binding(&self, p: Pair<'_, Rule>) -> Result<Binding, ParseError> {
        let span = self.span(&p);
        let mut name = None;
        let mut value = None;
        for x in p.into_inner() {
            match x.as_rule() {
                Rule::name => name = Some(self.ident(x)),
                Rule::expr => value = Some(self.expr(x, 0)?),
                _ => {}
            }
        }
        Ok(Binding {
            name: name.expect("a binding has a name"),
            value: value.expect("a binding has a value"),
            span,
        })
    }

    fn end_rule(&self, p: Pair<'_, Rule>) -> Result<Clause, ParseError> {
        let span = self.span(&p);
        let mut after = false;
        let mut exprs = Vec::new();
        for x in p.into_inner() {
            match x.as_rule() {
                Rule::kw_after => after = true,
                Rule::expr => exprs.push(self.expr(x, 0)?),
                _ => {}
            }
        }
        let mut exprs = exprs.into_iter();
        let first = exprs.next().expect("an end rule has an expression");
        Ok(if after {
            Clause::EndAfter { limit: first, span }
        } else {
            Clause::EndWhen {
                cond: first,
                hold: exprs.next(),
                span,
            }
        })
    }

    fn flaw_rule(&self, p: Pair<'_, Rule>) -> Result<Clause, ParseError> {
        let span = self.span(&p);
        let mut name = None;
        let mut exprs = Vec::new();
        for x in p.into_inner() {
            match x.as_rule() {
                Rule::name => name = Some(self.ident(x)),
                Rule::expr => exprs.push(self.expr(x, 0)?),
                _ => {}
            }
        }
        let mut exprs = exprs.into_iter();
        Ok(Clause::Flaw {
            name: name.expect("a flaw has a name"),
            cond: exprs.next().expect("a flaw has a condition"),
            hold: exprs.next(),
            span,
        })
    }

    pub(super) fn dim(&self, space: Space, p: Pair<'_, Rule>) -> Result<DimDecl, ParseError> {
        let span = self.span(&p);
        let mut name = None;
        let mut unit = None;
        let mut limits = None;
        let mut meaning = None;
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::name => name = Some(self.ident(part)),
                Rule::unit => {
                    unit = Some(
                        part.into_inner()
                            .find(|u| u.as_rule() == Rule::unit_text)
                            .map_or(String::new(), |u| u.as_str().to_string()),
                    )
                }
                Rule::limits => limits = Some(self.limits(part)?),
                Rule::dim_meaning => meaning = Some(self.dim_meaning(part)?),
                _ => {}
            }
        }
        Ok(DimDecl {
            space,
            name: name.expect("a dimension has a name"),
            unit,
            limits,
            meaning,
            span,
        })
    }

    fn dim_meaning(&self, p: Pair<'_, Rule>) -> Result<DimMeaning, ParseError> {
        let mut kind = Rule::assign;
        let mut expr = None;
        let mut axis = None;
        let mut limits = None;
        for x in p.into_inner() {
            match x.as_rule() {
                r @ (Rule::kw_drives | Rule::kw_changes) => kind = r,
                Rule::expr => expr = Some(self.expr(x, 0)?),
                Rule::name => axis = Some(self.ident(x)),
                Rule::limits => limits = Some(self.limits(x)?),
                _ => {}
            }
        }
        Ok(match kind {
            Rule::kw_drives => DimMeaning::Drives(axis.expect("`drives` names an axis")),
            Rule::kw_changes => DimMeaning::Changes(
                axis.expect("`changes` names an axis"),
                limits.expect("`changes` has limits"),
            ),
            _ => DimMeaning::Def(expr.expect("a definition has a value")),
        })
    }

    pub(super) fn limits(&self, p: Pair<'_, Rule>) -> Result<LimitsExpr, ParseError> {
        let span = self.span(&p);
        let mut exprs = p.into_inner().filter(|e| e.as_rule() == Rule::expr);
        let lo = self.expr(exprs.next().expect("limits have a low end"), 0)?;
        let hi = self.expr(exprs.next().expect("limits have a high end"), 0)?;
        Ok(LimitsExpr { lo, hi, span })
    }

    pub(super) fn operator(&self, p: Pair<'_, Rule>) -> Result<OperatorDecl, ParseError> {
        let span = self.span(&p);
        let mut doc = Vec::new();
        let mut names = Vec::new();
        let mut params = Vec::new();
        let mut space = None;
        let mut body = None;
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::doc => doc.push(self.doc_line(part)),
                Rule::name => names.push(self.ident(part)),
                Rule::params => {
                    for q in part.into_inner().filter(|q| q.as_rule() == Rule::param) {
                        params.push(self.param(q)?);
                    }
                }
                Rule::space => {
                    let s = self.span(&part);
                    let kw = part.into_inner().next().expect("a space is one keyword");
                    let sp = if kw.as_rule() == Rule::kw_action {
                        Space::Action
                    } else {
                        Space::Observation
                    };
                    space = Some((sp, s));
                }
                Rule::block_body => body = Some(self.block(part)?),
                Rule::pipeline_body => {
                    let mut calls = Vec::new();
                    for c in part.into_inner().filter(|c| c.as_rule() == Rule::call) {
                        calls.push(self.call(c)?);
                    }
                    body = Some(Body::Pipeline(calls));
                }
                _ => {}
            }
        }
        let mut names = names.into_iter();
        let (space, space_span) = space.expect("an operator names its space");
        Ok(OperatorDecl {
            doc,
            name: names.next().expect("an operator has a name"),
            params,
            domain: names.next().expect("an operator names its domain"),
            space,
            space_span,
            body: body.expect("an operator has a body"),
            span,
        })
    }

    pub(super) fn param(&self, p: Pair<'_, Rule>) -> Result<ParamDecl, ParseError> {
        let span = self.span(&p);
        let mut name = None;
        let mut default = None;
        let mut limits = None;
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::name => name = Some(self.ident(part)),
                Rule::expr => default = Some(self.expr(part, 0)?),
                Rule::limits => limits = Some(self.limits(part)?),
                _ => {}
            }
        }
        Ok(ParamDecl {
            name: name.expect("a parameter has a name"),
            default,
            limits,
            span,
        })
    }

    pub(super) fn block(&self, p: Pair<'_, Rule>) -> Result<Body, ParseError> {
        let mut guard = None;
        let mut stmts = Vec::new();
        for part in p.into_inner() {
            match part.as_rule() {
                Rule::guard => {
                    let e = part
                        .into_inner()
                        .find(|e| e.as_rule() == Rule::expr)
                        .expect("a guard holds an expression");
                    guard = Some(self.expr(e, 0)?);
                }
                Rule::stmt => {
                    let span = self.span(&part);
                    let mut inner = part.into_inner();
                    let target = self.ident(inner.next().expect("a statement has a target"));
                    let op = match inner.next().expect("a statement has an operator").as_str() {
                        "+=" => AssignOp::Add,
                        "-=" => AssignOp::Sub,
                        "*=" => AssignOp::Mul,
                        "/=" => AssignOp::Div,
                        _ => AssignOp::Set,
                    };
                    let value = self.expr(inner.next().expect("a statement has a value"), 0)?;
                    stmts.push(Stmt {
                        target,
                        op,
                        value,
                        span,
                    });
                }
                _ => {}
            }
        }
        Ok(Body::Block { guard, stmts })
    }

    pub(super) fn call(&self, p: Pair<'_, Rule>) -> Result<Call, ParseError> {
        let span = self.span(&p);
        let mut inner = p.into_inner();
        let name = self.ident(inner.next().expect("a call has a name"));
        let mut args = Vec::new();
        if let Some(list) = inner.next() {
            for a in list.into_inner().filter(|a| a.as_rule() == Rule::arg) {
                let aspan = self.span(&a);
                let mut aname = None;
                let mut value = None;
                for part in a.into_inner() {
                    match part.as_rule() {
                        Rule::name => aname = Some(self.ident(part)),
                        Rule::expr => value = Some(self.expr(part, 0)?),
                        _ => {}
                    }
                }
                args.push(Arg {
                    name: aname,
                    value: value.expect("an argument has a value"),
                    span: aspan,
                });
            }
        }
        Ok(Call { name, args, span })
    }

    pub(super) fn too_deep(&self, span: Span) -> ParseError {
        ParseError::TooDeep {
            what: "the expression is nested".into(),
            help: format!(
                "an expression may be at most {MAX_DEPTH} levels deep, and every term of a chain `a + b + c` is one more; split it into several operators or statements"
            ),
            span: self.loc(span),
        }
    }

    /// Build an `expr` pair; `depth` tree levels are already above it.
    pub(super) fn expr(&self, p: Pair<'_, Rule>, depth: usize) -> Result<Expr, ParseError> {
        self.expr_height(p, depth).map(|(e, _)| e)
    }

    /// Build an `expr` pair by precedence climbing over its flat token stream; also returns the
    /// height of the tree built, which with `depth` stays within [`MAX_DEPTH`].
    pub(super) fn expr_height(
        &self,
        p: Pair<'_, Rule>,
        depth: usize,
    ) -> Result<(Expr, usize), ParseError> {
        if depth >= MAX_DEPTH {
            return Err(self.too_deep(self.span(&p)));
        }
        let toks: Vec<Tok<'_>> = p
            .into_inner()
            .map(|t| {
                let infix = |op| Tok::Infix(op, self.span(&t));
                match t.as_rule() {
                    Rule::op_neg => Tok::Prefix(UnOp::Neg, self.span(&t)),
                    Rule::kw_not => Tok::Prefix(UnOp::Not, self.span(&t)),
                    Rule::kw_or => infix(BinOp::Or),
                    Rule::kw_and => infix(BinOp::And),
                    Rule::op_eq => infix(BinOp::Eq),
                    Rule::op_ne => infix(BinOp::Ne),
                    Rule::op_le => infix(BinOp::Le),
                    Rule::op_ge => infix(BinOp::Ge),
                    Rule::op_lt => infix(BinOp::Lt),
                    Rule::op_gt => infix(BinOp::Gt),
                    Rule::op_add => infix(BinOp::Add),
                    Rule::op_sub => infix(BinOp::Sub),
                    Rule::op_mul => infix(BinOp::Mul),
                    Rule::op_div => infix(BinOp::Div),
                    _ => Tok::Operand(t),
                }
            })
            .collect();
        let mut climb = Climb {
            b: self,
            toks,
            at: 0,
            depth,
        };
        climb.expr(0)
    }

    /// An operand and its height; `depth` levels are above it.
    pub(super) fn operand(
        &self,
        p: Pair<'_, Rule>,
        depth: usize,
    ) -> Result<(Expr, usize), ParseError> {
        let span = self.span(&p);
        match p.as_rule() {
            Rule::number => Ok((
                Expr::new(ExprKind::Num(self.number_text(p.as_str(), span)?), span),
                1,
            )),
            Rule::name => Ok((Expr::new(ExprKind::Var(p.as_str().to_string()), span), 1)),
            Rule::paren => {
                let e = p
                    .into_inner()
                    .find(|e| e.as_rule() == Rule::expr)
                    .expect("parentheses hold an expression");
                // Parentheses group; they add no level to the tree.
                self.expr_height(e, depth)
            }
            Rule::call_expr => {
                let mut inner = p.into_inner();
                let func = Box::new(self.ident(inner.next().expect("a call has a name")));
                let mut args = Vec::new();
                let mut height = 0;
                for e in inner.filter(|e| e.as_rule() == Rule::expr) {
                    let (a, h) = self.expr_height(e, depth + 1)?;
                    height = height.max(h);
                    args.push(a);
                }
                Ok((Expr::new(ExprKind::Call { func, args }, span), height + 1))
            }
            Rule::at_expr => {
                let mut inner = p.into_inner();
                let dim =
                    Box::new(self.ident(inner.next().expect("an offset read names a dimension")));
                let e = inner
                    .find(|e| e.as_rule() == Rule::expr)
                    .expect("an offset read has an offset");
                let (offset, h) = self.expr_height(e, depth + 1)?;
                let offset = Box::new(offset);
                Ok((Expr::new(ExprKind::At { dim, offset }, span), h + 1))
            }
            r => unreachable!("the grammar has no operand {r:?}"),
        }
    }
}

/// Precedence climbing over one expression's tokens. `depth` counts the tree levels above the
/// subtree being built; every node is refused once its level would pass [`MAX_DEPTH`], before
/// anything recurses deeper, so a hostile chain stops at the operator that passed the limit.
pub(super) struct Climb<'b, 'i> {
    b: &'b Builder,
    toks: Vec<Tok<'i>>,
    at: usize,
    depth: usize,
}

impl Climb<'_, '_> {
    pub(super) fn expr(&mut self, min: u8) -> Result<(Expr, usize), ParseError> {
        let (mut lhs, mut height) = self.unary()?;
        while let Some(Tok::Infix(op, op_span)) = self.toks.get(self.at) {
            let (op, op_span) = (*op, *op_span);
            if op.precedence() < min {
                break;
            }
            // The new node sits where `lhs` was; `lhs` moves one level down.
            if self.depth + height + 1 > MAX_DEPTH {
                return Err(self.b.too_deep(op_span));
            }
            self.at += 1;
            self.depth += 1;
            let rhs = self.expr(op.precedence() + 1);
            self.depth -= 1;
            let (rhs, rh) = rhs?;
            height = height.max(rh) + 1;
            if self.depth + height > MAX_DEPTH {
                return Err(self.b.too_deep(op_span));
            }
            let span = lhs.span.join(rhs.span);
            lhs = Expr::new(ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)), span);
        }
        Ok((lhs, height))
    }

    pub(super) fn unary(&mut self) -> Result<(Expr, usize), ParseError> {
        let at = self.at;
        self.at += 1;
        match self.toks.get(at) {
            Some(Tok::Prefix(op, span)) => {
                let (op, span) = (*op, *span);
                if self.depth + 1 >= MAX_DEPTH {
                    return Err(self.b.too_deep(span));
                }
                self.depth += 1;
                let e = self.expr(op.precedence());
                self.depth -= 1;
                let (e, h) = e?;
                let span = span.join(e.span);
                Ok((Expr::new(ExprKind::Unary(op, Box::new(e)), span), h + 1))
            }
            Some(Tok::Operand(p)) => {
                let p = p.clone();
                self.b.operand(p, self.depth)
            }
            _ => unreachable!("the grammar puts an operand after every operator"),
        }
    }
}
