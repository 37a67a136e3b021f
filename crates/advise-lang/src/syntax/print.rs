//! The pretty-printer: AST back to source text.
//!
//! The output is the canonical layout of the language (two-space indents, one statement per line,
//! the fewest parentheses that keep the meaning) and parses back to the same tree; a property test
//! holds it to that. It also gives provenance records a stable text for an operator's definition.
//! It must not resolve names or evaluate anything.

use std::fmt::{self, Display, Formatter, Write};

use super::ast::*;
use crate::domain::Space;

impl Display for File {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        for (i, item) in self.items.iter().enumerate() {
            if i > 0 {
                f.write_char('\n')?;
            }
            writeln!(f, "{item}")?;
        }
        Ok(())
    }
}

impl Display for Item {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Item::Domain(d) => d.fmt(f),
            Item::Operator(o) => o.fmt(f),
        }
    }
}

fn write_doc(f: &mut Formatter<'_>, doc: &[String]) -> fmt::Result {
    for line in doc {
        if line.is_empty() {
            writeln!(f, "///")?;
        } else {
            writeln!(f, "/// {line}")?;
        }
    }
    Ok(())
}

impl Display for DomainDecl {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write_doc(f, &self.doc)?;
        writeln!(f, "domain {} {{", self.name.name)?;
        // Consecutive dimensions of one space share a line, as they are usually written.
        let mut i = 0;
        while i < self.dims.len() {
            let space = self.dims[i].space;
            let word = match space {
                Space::Observation => "observe",
                Space::Action => "act",
            };
            write!(f, "  {word} ")?;
            let mut first = true;
            while i < self.dims.len() && self.dims[i].space == space {
                if !first {
                    // A defined observation has a line of its own.
                    if matches!(self.dims[i].meaning, Some(DimMeaning::Def(_)))
                        || matches!(self.dims[i - 1].meaning, Some(DimMeaning::Def(_)))
                    {
                        break;
                    }
                    f.write_str(", ")?;
                }
                first = false;
                self.dims[i].fmt(f)?;
                i += 1;
            }
            f.write_char('\n')?;
        }
        for c in &self.clauses {
            writeln!(f, "  {c}")?;
        }
        f.write_char('}')
    }
}

impl Display for DimDecl {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name.name)?;
        if let Some(u) = &self.unit {
            write!(f, " \"{u}\"")?;
        }
        if let Some(l) = &self.limits {
            write!(f, " {l}")?;
        }
        match &self.meaning {
            None => {}
            Some(DimMeaning::Def(e)) => write!(f, " = {e}")?,
            Some(DimMeaning::Drives(a)) => write!(f, " drives {}", a.name)?,
            Some(DimMeaning::Changes(a, l)) => write!(f, " changes {} {l}", a.name)?,
        }
        Ok(())
    }
}

impl Display for Binding {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {}", self.name.name, self.value)
    }
}

fn write_list<T: Display>(f: &mut Formatter<'_>, items: &[T]) -> fmt::Result {
    for (i, x) in items.iter().enumerate() {
        if i > 0 {
            f.write_str(", ")?;
        }
        x.fmt(f)?;
    }
    Ok(())
}

impl Display for Drawing {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}(", self.name.name, self.shape.name)?;
        write_list(f, &self.args)?;
        f.write_char(')')
    }
}

impl Display for Clause {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Clause::Goal(dims) => {
                f.write_str("goal ")?;
                write_list(f, dims)
            }
            Clause::Let(b) | Clause::Score(b) | Clause::Recorded(b) => {
                write!(f, "{} ", self.keyword())?;
                write_list(f, b)
            }
            Clause::Draw(d) => {
                f.write_str("draw ")?;
                write_list(f, d)
            }
            Clause::Success { cond, .. } => write!(f, "success when {cond}"),
            Clause::EndWhen { cond, hold, .. } => {
                write!(f, "end when {cond}")?;
                match hold {
                    Some(h) => write!(f, " for {h}"),
                    None => Ok(()),
                }
            }
            Clause::EndAfter { limit, .. } => write!(f, "end after {limit}"),
            Clause::Flaw {
                name, cond, hold, ..
            } => {
                write!(f, "flaw {} when {cond}", name.name)?;
                match hold {
                    Some(h) => write!(f, " for {h}"),
                    None => Ok(()),
                }
            }
            Clause::Test { count, seed, .. } => {
                write!(f, "test {}", number(*count))?;
                match seed {
                    Some(s) => write!(f, " seed {}", number(*s)),
                    None => Ok(()),
                }
            }
            Clause::Teacher { stmts, .. } => {
                f.write_str("teacher {\n")?;
                for st in stmts {
                    let kw = if st.is_let { "let " } else { "" };
                    writeln!(f, "    {kw}{}", st.binding)?;
                }
                f.write_str("  }")
            }
        }
    }
}

impl Display for LimitsExpr {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "in [{}, {}]", self.lo, self.hi)
    }
}

impl Display for OperatorDecl {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write_doc(f, &self.doc)?;
        write!(f, "operator {}", self.name.name)?;
        if !self.params.is_empty() {
            f.write_char('(')?;
            for (i, p) in self.params.iter().enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                p.fmt(f)?;
            }
            f.write_char(')')?;
        }
        write!(f, " for {} on {}", self.domain.name, self.space)?;
        match &self.body {
            Body::Block { guard, stmts } => {
                if let Some(g) = guard {
                    write!(f, " where {g}")?;
                }
                if stmts.is_empty() {
                    return f.write_str(" {}");
                }
                f.write_str(" {\n")?;
                for s in stmts {
                    writeln!(f, "  {s}")?;
                }
                f.write_char('}')
            }
            Body::Pipeline(calls) => {
                f.write_str(" =")?;
                for (i, c) in calls.iter().enumerate() {
                    if i > 0 {
                        f.write_str(" then")?;
                    }
                    write!(f, " {c}")?;
                }
                Ok(())
            }
        }
    }
}

impl Display for ParamDecl {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name.name)?;
        if let Some(d) = &self.default {
            write!(f, " = {d}")?;
        }
        if let Some(l) = &self.limits {
            write!(f, " {l}")?;
        }
        Ok(())
    }
}

impl Display for Stmt {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {}", self.target.name, self.op.text(), self.value)
    }
}

impl Display for Call {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name.name)?;
        if !self.args.is_empty() {
            f.write_char('(')?;
            for (i, a) in self.args.iter().enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                if let Some(n) = &a.name {
                    write!(f, "{} = ", n.name)?;
                }
                a.value.fmt(f)?;
            }
            f.write_char(')')?;
        }
        Ok(())
    }
}

/// Shortest decimal text that reads back as the same `f64` (never an exponent, never `-0`).
pub fn number(v: f64) -> String {
    crate::number::fmt_num(v)
}

impl Display for Expr {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match &self.kind {
            ExprKind::Num(v) => f.write_str(&number(*v)),
            ExprKind::Var(name) => f.write_str(name),
            ExprKind::At { dim, offset } => write!(f, "{}[{offset}]", dim.name),
            ExprKind::Call { func, args } => {
                write!(f, "{}(", func.name)?;
                for (i, a) in args.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    a.fmt(f)?;
                }
                f.write_char(')')
            }
            ExprKind::Unary(op, e) => {
                f.write_str(match op {
                    UnOp::Neg => "-",
                    UnOp::Not => "not ",
                })?;
                operand(f, e, e.precedence() < op.precedence())
            }
            ExprKind::Binary(op, a, b) => {
                let p = op.precedence();
                // Left-associative: the left operand needs parentheses only when it binds looser,
                // the right one also when it binds equally (`a - (b - c)`).
                operand(f, a, a.precedence() < p)?;
                write!(f, " {} ", op.text())?;
                operand(f, b, b.precedence() <= p)
            }
        }
    }
}

fn operand(f: &mut Formatter<'_>, e: &Expr, parens: bool) -> fmt::Result {
    if parens { write!(f, "({e})") } else { e.fmt(f) }
}
