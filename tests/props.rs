//! Property tests, one invariant each: only chunk points are synthesized and the other space is
//! untouched; an empty chunk is the identity; the guard of `no_turning` decides exactly which
//! points are skipped and its postcondition holds; print-then-parse gives back the same tree;
//! arbitrary text never makes parse+check panic.

use advise::check::{self, OperatorSet, Source, render, render_all};
use advise::diag::SourceMap;
use advise::domain::{Domain, Space};
use advise::interp;
use advise::syntax::ast::*;
use advise::syntax::{self, Invocation, parse_invocation};
use advise::trace::{Chunk, Trace};
use proptest::prelude::*;

mod common;
use common::parse;

/// A trace of `domain` with values inside the limits, some of them exactly zero.
fn trace(domain: Domain, max_len: usize) -> impl Strategy<Value = Trace> {
    let width = domain.obs_dim() + domain.act_dim();
    let dims: Vec<(f64, f64)> = domain
        .observe
        .iter()
        .chain(&domain.act)
        .map(|d| d.limits.map_or((-10.0, 10.0), |l| (l.lo, l.hi)))
        .collect();
    prop::collection::vec(
        prop::collection::vec((0.0..1.0f64, 0..4u8), width),
        0..max_len,
    )
    .prop_map(move |rows| {
        let mut tr = Trace::new(&domain);
        for (i, row) in rows.iter().enumerate() {
            let vals: Vec<f64> = row
                .iter()
                .zip(&dims)
                .map(|((u, zero), (lo, hi))| if *zero == 0 { 0.0 } else { lo + u * (hi - lo) })
                .collect();
            let (z, a) = vals.split_at(domain.obs_dim());
            tr.push(i as f64 / 30.0, z, a, None);
        }
        tr
    })
}

/// A chunk of a trace of `len` points (possibly empty).
fn chunk_of(len: usize, a: f64, b: f64) -> Chunk {
    let x = (a * (len + 1) as f64) as usize;
    let y = (b * (len + 1) as f64) as usize;
    let (s, e) = (x.min(y).min(len), x.max(y).min(len));
    Chunk::new(s, e, len).unwrap()
}

/// An invocation of the `i`th standard operator of `domain` with parameters drawn inside their
/// limits.
fn invocation(set: &OperatorSet, domain: &str, i: usize, u: &[f64]) -> Invocation {
    let ops: Vec<_> = set.operators(domain).collect();
    let op = ops[i % ops.len()];
    let args: Vec<String> = op
        .params()
        .iter()
        .zip(u.iter().cycle())
        .map(|(p, u)| {
            let (lo, hi) = p.limits.map_or((0.0, 1.0), |l| (l.lo, l.hi));
            format!("{} = {}", p.name, lo + u * (hi - lo))
        })
        .collect();
    let text = if args.is_empty() {
        op.name().to_string()
    } else {
        format!("{}({})", op.name(), args.join(", "))
    };
    parse_invocation(&text).unwrap()
}

fn both_domains() -> impl Strategy<Value = Trace> {
    prop_oneof![
        trace(Domain::positioning(), 60),
        trace(Domain::interception(), 60)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn only_chunk_points_are_synthesized_and_the_other_space_is_untouched(
        tr in both_domains(),
        a in 0.0..1.0f64,
        b in 0.0..1.0f64,
        which in 0..64usize,
        u in prop::collection::vec(0.0..1.0f64, 1..3),
    ) {
        let set = OperatorSet::standard();
        let chunk = chunk_of(tr.len(), a, b);
        let inv = invocation(&set, &tr.domain, which, &u);
        let before = tr.clone();
        let call = check::bind(&mut SourceMap::new(), &set, &tr.domain, &inv).map_err(|e| TestCaseError::fail(render(&e)))?;
        let out = interp::apply(&call, &tr, chunk).map_err(|e| TestCaseError::fail(render(&e)))?;
        prop_assert_eq!(&tr, &before);
        prop_assert_eq!(out.points.len(), out.source_index.len());
        prop_assert!(out.source_index.windows(2).all(|w| w[0] < w[1]), "in chunk order");
        let domain = set.domain(&tr.domain).unwrap();
        for (p, &i) in out.source_index.iter().enumerate() {
            prop_assert!(chunk.range().contains(&i), "point {} outside {}", i, chunk);
            prop_assert_eq!(out.points.t[p], tr.t[i]);
            match out.advice.space {
                Space::Action => prop_assert_eq!(out.points.z(p), tr.z(i)),
                Space::Observation => prop_assert_eq!(out.points.a(p), tr.a(i)),
            }
            // Clamped to the limits.
            for (v, d) in out.points.z(p).iter().chain(out.points.a(p)).zip(domain.observe.iter().chain(&domain.act)) {
                if let Some(l) = d.limits {
                    prop_assert!(l.contains(*v), "{} = {} outside its limits", d.name, v);
                }
            }
        }
    }

    #[test]
    fn an_empty_chunk_is_the_identity(
        tr in both_domains(),
        at in 0.0..1.0f64,
        which in 0..64usize,
        u in prop::collection::vec(0.0..1.0f64, 1..3),
    ) {
        let set = OperatorSet::standard();
        let s = (at * (tr.len() + 1) as f64) as usize;
        let s = s.min(tr.len());
        let inv = invocation(&set, &tr.domain, which, &u);
        let call = check::bind(&mut SourceMap::new(), &set, &tr.domain, &inv).map_err(|e| TestCaseError::fail(render(&e)))?;
        let out = interp::apply(&call, &tr, Chunk::new(s, s, tr.len()).unwrap())
            .map_err(|e| TestCaseError::fail(render(&e)))?;
        prop_assert!(out.points.is_empty());
        prop_assert!(out.source_index.is_empty());
        prop_assert_eq!(out.advice.chunk, Chunk { start: s, end: s });
    }

    #[test]
    fn no_turning_skips_exactly_the_points_not_turning_and_stops_the_rest(
        tr in trace(Domain::positioning(), 80),
        a in 0.0..1.0f64,
        b in 0.0..1.0f64,
    ) {
        let set = OperatorSet::standard();
        let chunk = chunk_of(tr.len(), a, b);
        let call = check::bind(&mut SourceMap::new(), &set, &tr.domain, &Invocation::bare("no_turning")).unwrap();
        let out = interp::apply(&call, &tr, chunk).unwrap();
        let turning: Vec<usize> = chunk.range().filter(|&i| tr.a(i)[1] != 0.0).collect();
        prop_assert_eq!(&out.source_index, &turning);
        for (p, &i) in out.source_index.iter().enumerate() {
            prop_assert_eq!(out.points.a(p)[1], 0.0);
            prop_assert_eq!(out.points.a(p)[0], tr.a(i)[0]);
        }
    }

    #[test]
    fn recorded_advice_re_synthesizes_the_same_points(
        tr in both_domains(),
        a in 0.0..1.0f64,
        b in 0.0..1.0f64,
        which in 0..64usize,
        u in prop::collection::vec(0.0..1.0f64, 1..3),
    ) {
        let set = OperatorSet::standard();
        let chunk = chunk_of(tr.len(), a, b);
        let inv = invocation(&set, &tr.domain, which, &u);
        let out = interp::apply(&check::bind(&mut SourceMap::new(), &set, &tr.domain, &inv).unwrap(), &tr, chunk).unwrap();
        let json = serde_json::to_string(&out.advice).unwrap();
        let back: interp::AppliedAdvice = serde_json::from_str(&json).unwrap();
        prop_assert_eq!(&back, &out.advice, "{}", json);
        let again = check::bind(&mut SourceMap::new(), &set, &back.domain, &advise::syntax::parse_invocation(&back.invocation()).unwrap()).unwrap();
        prop_assert_eq!(interp::apply(&again, &tr, back.chunk).unwrap(), out);
    }
}

// ---------- random syntax trees for the print-then-parse round trip ----------

const NAMES: [&str; 10] = [
    "trans", "rot", "dist2", "rate", "x_1", "_tmp", "k", "n", "pi", "speed_up",
];

fn ident() -> impl Strategy<Value = Ident> {
    prop::sample::select(&NAMES[..]).prop_map(|n| Ident {
        name: n.to_string(),
        span: Span::default(),
    })
}

fn number() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(1.0),
        Just(0.1),
        Just(1e-7),
        Just(1e21),
        0.0..1000.0f64,
        (0u32..100).prop_map(f64::from),
    ]
}

fn expr() -> impl Strategy<Value = Expr> {
    let leaf = prop_oneof![
        number().prop_map(ExprKind::Num),
        prop::sample::select(&NAMES[..]).prop_map(|n| ExprKind::Var(n.to_string())),
    ]
    .prop_map(|kind| Expr::new(kind, Span::default()));
    leaf.prop_recursive(5, 48, 3, |inner| {
        let bin = prop::sample::select(vec![
            BinOp::Or,
            BinOp::And,
            BinOp::Eq,
            BinOp::Ne,
            BinOp::Lt,
            BinOp::Le,
            BinOp::Gt,
            BinOp::Ge,
            BinOp::Add,
            BinOp::Sub,
            BinOp::Mul,
            BinOp::Div,
        ]);
        prop_oneof![
            (bin, inner.clone(), inner.clone()).prop_map(|(op, a, b)| ExprKind::Binary(
                op,
                Box::new(a),
                Box::new(b)
            )),
            (
                prop::sample::select(vec![UnOp::Neg, UnOp::Not]),
                inner.clone()
            )
                .prop_map(|(op, e)| ExprKind::Unary(op, Box::new(e))),
            (ident(), prop::collection::vec(inner.clone(), 0..4)).prop_map(|(func, args)| {
                ExprKind::Call {
                    func: Box::new(func),
                    args,
                }
            }),
            (ident(), inner).prop_map(|(dim, off)| ExprKind::At {
                dim: Box::new(dim),
                offset: Box::new(off)
            }),
        ]
        .prop_map(|kind| Expr::new(kind, Span::default()))
    })
}

fn doc() -> impl Strategy<Value = Vec<String>> {
    prop::collection::vec("[ -~]{0,20}", 0..3)
}

fn limits() -> impl Strategy<Value = Option<LimitsExpr>> {
    prop::option::of((expr(), expr()).prop_map(|(lo, hi)| LimitsExpr {
        lo,
        hi,
        span: Span::default(),
    }))
}

fn space() -> impl Strategy<Value = advise::domain::Space> {
    prop_oneof![Just(Space::Observation), Just(Space::Action)]
}

fn binding() -> impl Strategy<Value = Binding> {
    (ident(), expr()).prop_map(|(name, value)| Binding {
        name,
        value,
        span: Span::default(),
    })
}

/// A task clause, as the printer must write it back.
/// One shape of a `draw` clause: any name and shape word (the checker, not the parser, knows
/// `pose`, `point` and `circle`), with zero to three arguments.
fn drawing() -> impl Strategy<Value = Drawing> {
    (ident(), ident(), prop::collection::vec(expr(), 0..4)).prop_map(|(name, shape, args)| {
        Drawing {
            name,
            shape,
            args,
            span: Span::default(),
        }
    })
}

fn clause() -> impl Strategy<Value = Clause> {
    let goal_dim =
        (ident(), prop::option::of("[^\"\n\r]{0,6}"), limits()).prop_map(|(name, unit, limits)| {
            DimDecl {
                space: Space::Observation,
                name,
                unit,
                limits,
                meaning: None,
                span: Span::default(),
            }
        });
    let bindings = || prop::collection::vec(binding(), 1..3);
    prop_oneof![
        prop::collection::vec(goal_dim, 1..3).prop_map(Clause::Goal),
        bindings().prop_map(Clause::Let),
        bindings().prop_map(Clause::Score),
        bindings().prop_map(Clause::Recorded),
        prop::collection::vec(drawing(), 1..3).prop_map(Clause::Draw),
        expr().prop_map(|cond| Clause::Success {
            cond,
            span: Span::default()
        }),
        (expr(), prop::option::of(expr())).prop_map(|(cond, hold)| Clause::EndWhen {
            cond,
            hold,
            span: Span::default()
        }),
        expr().prop_map(|limit| Clause::EndAfter {
            limit,
            span: Span::default()
        }),
        (number(), prop::option::of(number())).prop_map(|(count, seed)| Clause::Test {
            count,
            seed,
            span: Span::default()
        }),
        prop::collection::vec((any::<bool>(), binding()), 0..3).prop_map(|stmts| {
            Clause::Teacher {
                stmts: stmts
                    .into_iter()
                    .map(|(is_let, binding)| TeacherStmt { is_let, binding })
                    .collect(),
                span: Span::default(),
            }
        }),
    ]
}

fn item() -> impl Strategy<Value = Item> {
    let dim = (
        space(),
        ident(),
        prop::option::of("[^\"\n\r]{0,6}"),
        limits(),
    )
        .prop_flat_map(|(space, name, unit, limits)| {
            let meaning = match space {
                Space::Observation => prop::option::of(expr().prop_map(DimMeaning::Def)).boxed(),
                Space::Action => prop::option::of(prop_oneof![
                    ident().prop_map(DimMeaning::Drives),
                    (ident(), expr(), expr()).prop_map(|(a, lo, hi)| DimMeaning::Changes(
                        a,
                        LimitsExpr {
                            lo,
                            hi,
                            span: Span::default()
                        }
                    )),
                ])
                .boxed(),
            };
            meaning.prop_map(move |meaning| DimDecl {
                space,
                name: name.clone(),
                unit: unit.clone(),
                limits: limits.clone(),
                meaning,
                span: Span::default(),
            })
        });
    let domain = (
        doc(),
        ident(),
        prop::collection::vec(dim, 0..4),
        prop::collection::vec(clause(), 0..4),
    )
        .prop_map(|(doc, name, dims, clauses)| {
            Item::Domain(DomainDecl {
                doc,
                name,
                dims,
                clauses,
                span: Span::default(),
            })
        });
    let param =
        (ident(), prop::option::of(expr()), limits()).prop_map(|(name, default, limits)| {
            ParamDecl {
                name,
                default,
                limits,
                span: Span::default(),
            }
        });
    let stmt = (
        ident(),
        prop::sample::select(vec![
            AssignOp::Set,
            AssignOp::Add,
            AssignOp::Sub,
            AssignOp::Mul,
            AssignOp::Div,
        ]),
        expr(),
    )
        .prop_map(|(target, op, value)| Stmt {
            target,
            op,
            value,
            span: Span::default(),
        });
    let arg = (prop::option::of(ident()), expr()).prop_map(|(name, value)| Arg {
        name,
        value,
        span: Span::default(),
    });
    let call = (ident(), prop::collection::vec(arg, 0..3)).prop_map(|(name, args)| Call {
        name,
        args,
        span: Span::default(),
    });
    let body = prop_oneof![
        (prop::option::of(expr()), prop::collection::vec(stmt, 0..4))
            .prop_map(|(guard, stmts)| Body::Block { guard, stmts }),
        prop::collection::vec(call, 1..4).prop_map(Body::Pipeline),
    ];
    let operator = (
        doc(),
        ident(),
        prop::collection::vec(param, 0..3),
        ident(),
        space(),
        body,
    )
        .prop_map(|(doc, name, params, domain, space, body)| {
            Item::Operator(OperatorDecl {
                doc,
                name,
                params,
                domain,
                space,
                space_span: Span::default(),
                body,
                span: Span::default(),
            })
        });
    prop_oneof![domain, operator]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn print_then_parse_gives_back_the_same_tree(items in prop::collection::vec(item(), 0..4)) {
        let file = File { items };
        let text = file.to_string();
        let mut back = parse("printed", &text)
            .map_err(|e| TestCaseError::fail(format!("{}\n{text}", render(&e))))?;
        back.erase_spans();
        prop_assert_eq!(back, file, "{}", text);
    }

    #[test]
    fn fmt_keeps_every_comment_and_the_program(
        items in prop::collection::vec(item(), 1..4),
        marks in prop::collection::vec((0usize..200, any::<bool>()), 0..8),
    ) {
        // A printed file with comments put at the ends of some lines and on lines of their own.
        let printed = File { items }.to_string();
        let mut lines: Vec<String> = printed.lines().map(str::to_string).collect();
        for (n, (at, own_line)) in marks.iter().enumerate() {
            let i = at % (lines.len() + 1);
            if *own_line || i == lines.len() {
                lines.insert(i, format!("// c{n}"));
            } else {
                lines[i].push_str(&format!(" // c{n}"));
            }
        }
        let text = lines.join("\n") + "\n";
        let (map, id) = SourceMap::single("commented", text.as_str());
        let once = syntax::fmt::format(map.src(id))
            .map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        let (m2, id2) = SourceMap::single("formatted", once.as_str());
        let twice = syntax::fmt::format(m2.src(id2))
            .map_err(|e| TestCaseError::fail(format!("{e}\n{once}")))?;
        prop_assert_eq!(&twice, &once, "not idempotent; input:\n{}", text);
        // The program, but for trailing blanks in doc comments, which `fmt` removes.
        let tree = |t: &str| {
            parse("t", t)
                .map(|f| f.to_string().lines().map(str::trim_end).collect::<Vec<_>>().join("\n"))
                .ok()
        };
        prop_assert_eq!(tree(&once), tree(&text), "the program changed:\n{}", text);
        for n in 0..marks.len() {
            let c = format!("// c{n}");
            prop_assert_eq!(once.matches(&c).count(), text.matches(&c).count(), "{} lost:\n{}\n---\n{}", c, text, once);
        }
    }

    #[test]
    fn arbitrary_text_never_panics(text in "[ -~\n]{0,300}") {
        exercise(&text);
    }

    #[test]
    fn token_soup_never_panics(tokens in prop::collection::vec(prop::sample::select(vec![
        "operator", "domain", "for", "on", "action", "observation", "observe", "act", "where",
        "then", "and", "or", "not", "in", "positioning", "interception", "trans", "rot", "dist2",
        "bearing", "k", "n", "pi", "rate", "speed_up", "no_turning", "{", "}", "(", ")", "[", "]",
        ",", ";", "=", "==", "!=", "<", "<=", "*=", "+=", "-", "+", "*", "/", "0", "1.5", "1e999",
        "\"m/s\"", "///", "\n", "min", "clamp", "sign", "// note\n", "// two\n",
    ]), 0..60)) {
        exercise(&tokens.join(" "));
    }
}

/// Parse, check and render whatever comes out; apply whatever checks.
fn exercise(text: &str) {
    let (map, id) = SourceMap::single("line", text);
    let _ = syntax::parse_item(map.src(id));
    // `advise fmt`: what it formats, it formats once, to the same program, losing no comment.
    if let Ok(once) = syntax::fmt::format(map.src(id)) {
        let (m2, id2) = SourceMap::single("formatted", once.as_str());
        let twice = syntax::fmt::format(m2.src(id2)).unwrap_or_else(|e| {
            panic!(
                "the formatted text does not parse: {e}\n--- input\n{text}\n--- formatted\n{once}"
            )
        });
        assert_eq!(twice, once, "formatting twice changed it; input:\n{text}");
        let tree = |t: &str| parse("t", t).map(|f| f.to_string()).ok();
        assert_eq!(tree(&once), tree(text), "formatting changed the program");
        for comment in ["// note", "// two"] {
            assert_eq!(
                once.matches(comment).count(),
                text.matches(comment).count(),
                "a comment was lost or copied; input:\n{text}\n--- formatted\n{once}"
            );
        }
    }
    let _ = syntax::parse_invocation(text);
    let std = OperatorSet::standard();
    match std.merge(&[Source::new("fuzz.adv", text)]) {
        Err(e) => {
            let _ = render_all(&e);
        }
        Ok(set) => {
            let tr = {
                let d = Domain::positioning();
                let mut t = Trace::new(&d);
                for i in 0..5 {
                    t.push(
                        i as f64,
                        &[1.0, 0.1, -0.1],
                        &[0.5, if i % 2 == 0 { 0.0 } else { 0.2 }],
                        None,
                    );
                }
                t
            };
            for name in set.operator_names("positioning") {
                if let Ok(call) = check::bind(
                    &mut SourceMap::new(),
                    &set,
                    &tr.domain,
                    &Invocation::bare(name),
                ) {
                    let _ = interp::apply(&call, &tr, Chunk::all(5));
                }
            }
        }
    }
}
