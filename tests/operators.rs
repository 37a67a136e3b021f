//! Operator semantics: the paper's worked example exactly, a before/after table for every standard
//! operator, compositions, guards, offsets, provenance and the apply-time diagnostics.

use advise::check::{self, OperatorSet, Source, render};
use advise::diag::SourceMap;
use advise::domain::{Domain, Space};
use advise::interp::{self, AppliedAdvice};
use advise::number::fmt_num;
use advise::syntax::parse_invocation;
use advise::trace::{Chunk, Pose, Trace};

fn positioning_trace(n: usize) -> Trace {
    let d = Domain::positioning();
    let mut tr = Trace::new(&d);
    for i in 0..n {
        let f = i as f64;
        // Turning in the middle, straight at both ends, one point standing still.
        let rot = if (3..9).contains(&i) {
            0.1 + 0.05 * f
        } else {
            0.0
        };
        let trans = if i == 10 { 0.0 } else { 0.3 + 0.02 * f };
        tr.push(
            f / 30.0,
            &[16.0 - f, 0.5 - 0.05 * f, 1.0 - 0.1 * f],
            &[trans, if i == 5 { -rot } else { rot }],
            Some(Pose::new(0.01 * f, 0.0, 0.0)),
        );
    }
    tr
}

fn interception_trace(n: usize) -> Trace {
    let d = Domain::interception();
    let mut tr = Trace::new(&d);
    for i in 0..n {
        let f = i as f64;
        let rot = if i % 3 == 0 { 0.0 } else { 0.02 * (f - 5.0) };
        tr.push(
            f / 30.0,
            &[5.0 - 0.2 * f, 0.4 - 0.1 * f, -0.2, -0.1, 0.05, 0.01 * f],
            &[if i == 4 { 0.0 } else { 0.01 * (f - 3.0) }, rot],
            None,
        );
    }
    tr
}

fn apply(set: &OperatorSet, inv: &str, tr: &Trace, a: usize, b: usize) -> interp::Synthesized {
    let inv = parse_invocation(inv).unwrap();
    let mut map = SourceMap::new();
    let call = check::bind(&mut map, set, &tr.domain, &inv)
        .unwrap_or_else(|e| panic!("{}", advise::diag::render(&map, &e, false)));
    interp::apply(&call, tr, Chunk::new(a, b, tr.len()).unwrap())
        .unwrap_or_else(|e| panic!("{}", render(&e)))
}

#[test]
fn the_papers_worked_example_exactly() {
    let set = OperatorSet::standard();
    let d = Domain::positioning();
    let mut tr = Trace::new(&d);
    let speeds = [0.30, 0.25, 0.41, 0.33, 0.2, 0.35, 0.45, 0.1, 0.27, 0.5];
    for (i, s) in speeds.iter().enumerate() {
        tr.push(i as f64 / 30.0, &[4.0, 0.1, 0.2], &[*s, 0.3], None);
    }
    let out = apply(&set, "translational_acceleration", &tr, 0, 10);
    let factors = [1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0];
    assert_eq!(out.points.len(), 10);
    for k in 0..10 {
        assert_eq!(out.points.a(k)[0], speeds[k] * factors[k], "point {k}");
        assert_eq!(out.points.a(k)[1], 0.3, "rot untouched at point {k}");
        assert_eq!(
            out.points.z(k),
            tr.z(k),
            "observation untouched at point {k}"
        );
    }
    assert_eq!(out.source_index, (0..10).collect::<Vec<_>>());
}

#[test]
fn required_operator_names_exist() {
    let set = OperatorSet::standard();
    for name in [
        "translational_acceleration",
        "translational_deceleration",
        "rotational_acceleration",
        "rotational_deceleration",
        "no_turning",
        "turn_tighter",
        "turn_looser",
        "speed_up",
        "slow_down",
        "stop",
        "start_turning_earlier",
        "start_turning_later",
    ] {
        let op = set
            .operator("positioning", name)
            .unwrap_or_else(|| panic!("missing {name}"));
        assert!(!op.doc().is_empty(), "{name} has no doc comment");
    }
    let obs: Vec<&str> = set
        .operators("positioning")
        .filter(|o| o.space() == Space::Observation)
        .map(|o| o.name())
        .collect();
    assert_eq!(obs, ["start_turning_earlier", "start_turning_later"]);
}

/// Renders the chunk before and after as a table; skipped points say so.
fn table(domain: &Domain, tr: &Trace, out: &interp::Synthesized) -> String {
    let mut s = String::new();
    let names = domain.names();
    s.push_str(&format!("advice: {}\n", out.advice.invocation()));
    s.push_str(&format!(
        "chunk {}, {} of {} points synthesized, {} modified\n\n",
        out.advice.chunk,
        out.points.len(),
        out.advice.chunk.len(),
        out.advice.space
    ));
    s.push_str(&format!("{:>3} | {:<7}", "i", ""));
    for n in &names {
        s.push_str(&format!(" {n:>16}"));
    }
    s.push('\n');
    for i in out.advice.chunk.range() {
        let row = |z: &[f64], a: &[f64]| {
            z.iter()
                .chain(a)
                .map(|v| format!(" {:>16}", fmt_num((v * 1e9).round() / 1e9)))
                .collect::<String>()
        };
        s.push_str(&format!("{i:>3} | before {}\n", row(tr.z(i), tr.a(i))));
        match out.source_index.iter().position(|&j| j == i) {
            Some(p) => s.push_str(&format!(
                "{:>3} | after  {}\n",
                "",
                row(out.points.z(p), out.points.a(p))
            )),
            None => s.push_str(&format!("{:>3} | skipped\n", "")),
        }
    }
    s
}

#[test]
fn every_standard_operator_before_and_after() {
    let set = OperatorSet::standard();
    for domain in set.domains() {
        let tr = match domain.name.as_str() {
            "positioning" => positioning_trace(12),
            _ => interception_trace(12),
        };
        for op in set.operators(&domain.name) {
            // Short offsets so that the table shows reads from outside the chunk.
            let inv = if op.name().starts_with("start_turning") {
                format!("{}(steps = 2)", op.name())
            } else {
                op.name().to_string()
            };
            let out = apply(&set, &inv, &tr, 2, 11);
            insta::assert_snapshot!(
                format!("{}__{}", domain.name, op.name()),
                table(domain, &tr, &out)
            );
        }
    }
}

#[test]
fn every_standard_operator_has_a_working_example() {
    // Each operator's doc has an example of that operator, and every example holds
    // (`advise test`'s runner; the form is in operators/README.md).
    let set = OperatorSet::standard();
    for domain in set.domains() {
        for op in set.operators(&domain.name) {
            let own = format!("Example: {}", op.name());
            assert!(
                op.doc()
                    .lines()
                    .any(|l| l.trim().starts_with(&own)
                        && l.trim()[own.len()..].starts_with([' ', '('])),
                "{} has no `{own} ...` line",
                op.name()
            );
        }
    }
    let mut map = SourceMap::new();
    let ids: Vec<_> = check::STANDARD_SOURCES
        .iter()
        .map(|(n, t)| map.add(*n, *t))
        .collect();
    let outcome = advise::doctest::run(&mut map, &set, &ids);
    assert!(outcome.failures.is_empty(), "{:?}", outcome.failures);
    assert_eq!(outcome.examples, set.operator_count());
}

#[test]
fn guards_skip_points_and_the_indices_say_which() {
    let set = OperatorSet::standard();
    let tr = positioning_trace(12);
    let out = apply(&set, "no_turning", &tr, 0, 12);
    assert_eq!(out.source_index, vec![3, 4, 5, 6, 7, 8]);
    for p in 0..out.points.len() {
        assert_eq!(out.points.a(p)[1], 0.0);
        let i = out.source_index[p];
        assert_eq!(out.points.a(p)[0], tr.a(i)[0]);
        assert_eq!(out.points.t[p], tr.t[i]);
        assert_eq!(
            out.points.pose.as_ref().unwrap()[p],
            tr.pose.as_ref().unwrap()[i]
        );
    }
}

#[test]
fn compositions_apply_in_sequence_on_the_same_chunk() {
    let set = OperatorSet::standard();
    let tr = positioning_trace(12);
    let composed = apply(&set, "brake_straight", &tr, 1, 10);
    // By hand: the full ramp on the chunk, then no_turning on its result.
    let ramp = apply(&set, "translational_deceleration(gain = 1)", &tr, 1, 10);
    let mut staged = tr.clone();
    for (p, &i) in ramp.source_index.iter().enumerate() {
        staged.a_mut(i).copy_from_slice(ramp.points.a(p));
    }
    let expected = apply(&set, "no_turning", &staged, 1, 10);
    assert_eq!(composed.points, expected.points);
    assert_eq!(composed.source_index, expected.source_index);
    assert_eq!(composed.advice.operator, "brake_straight");
}

#[test]
fn observation_operators_keep_the_executed_action() {
    let set = OperatorSet::standard();
    let tr = positioning_trace(12);
    let out = apply(&set, "start_turning_earlier(steps = 2)", &tr, 3, 9);
    assert_eq!(out.advice.space, Space::Observation);
    for (p, &i) in out.source_index.iter().enumerate() {
        assert_eq!(out.points.a(p), tr.a(i), "executed action kept");
        assert_eq!(
            out.points.z(p),
            tr.z(i - 2),
            "observation from two points earlier"
        );
    }
    let later = apply(&set, "start_turning_later(steps = 50)", &tr, 3, 9);
    for p in 0..later.points.len() {
        assert_eq!(later.points.z(p), tr.z(11), "clamped to the last point");
    }
}

#[test]
fn results_are_clamped_to_the_limits() {
    let set = OperatorSet::standard();
    let tr = positioning_trace(12);
    let out = apply(&set, "speed_up(rate = 4)", &tr, 0, 12);
    for p in 0..out.points.len() {
        assert!(out.points.a(p)[0] <= 1.0 && out.points.a(p)[1].abs() <= 1.0);
    }
    let last = out.source_index.iter().position(|&i| i == 11).unwrap();
    assert_eq!(out.points.a(last)[0], 1.0, "0.52 m/s * 5 clamps to 1 m/s");
}

#[test]
fn advice_re_synthesizes_exactly_and_survives_json() {
    let set = OperatorSet::standard();
    let tr = positioning_trace(12);
    let out = apply(&set, "turn_tighter(0.7)", &tr, 2, 9);
    assert_eq!(out.advice.params[0].name, "rate");
    assert_eq!(out.advice.params[0].value, 0.7);
    let json = serde_json::to_string(&out.advice).unwrap();
    let back: AppliedAdvice = serde_json::from_str(&json).unwrap();
    assert_eq!(back, out.advice);
    let again = interp::apply(
        &check::bind(
            &mut SourceMap::new(),
            &set,
            &back.domain,
            &advise::syntax::parse_invocation(&back.invocation()).unwrap(),
        )
        .unwrap(),
        &tr,
        back.chunk,
    )
    .unwrap();
    assert_eq!(again, out);
    // Defaults are recorded too.
    let d = apply(&set, "speed_up", &tr, 0, 3);
    assert_eq!(d.advice.invocation().to_string(), "speed_up(rate = 0.2)");
}

#[test]
fn a_user_file_composes_standard_operators() {
    let user = "
/// Ease off and straighten out.
operator ease(f = 0.5 in [0, 1]) for positioning on action = slow_down(rate = f / 2) then no_turning
";
    let set = OperatorSet::standard()
        .merge(&[Source::new("user.adv", user)])
        .unwrap_or_else(|e| panic!("{}", advise::check::render_all(&e)));
    assert!(set.operator_names("positioning").contains(&"ease"));
    let tr = positioning_trace(12);
    let out = apply(&set, "ease(0.4)", &tr, 0, 12);
    let slow = apply(&set, "slow_down(0.2)", &tr, 0, 12);
    assert_eq!(out.source_index, vec![3, 4, 5, 6, 7, 8]);
    for (p, &i) in out.source_index.iter().enumerate() {
        let q = slow.source_index.iter().position(|&j| j == i).unwrap();
        assert_eq!(out.points.a(p), &[slow.points.a(q)[0], 0.0]);
    }
}

#[test]
fn apply_errors_are_diagnostics() {
    let set = OperatorSet::standard();
    let tr = positioning_trace(12);
    let cases = [
        ("speed_upp", 0, 5),
        ("speed_up(rat = 0.1)", 0, 5),
        ("speed_up(7)", 0, 5),
        ("speed_up(0.1, 0.2)", 0, 5),
        ("speed_up(0.1, rate = 0.2)", 0, 5),
        ("hold_speed", 0, 5),
        ("speed_up", 3, 40),
    ];
    let mut out = String::new();
    for (inv, a, b) in cases {
        let i = parse_invocation(inv).unwrap();
        let mut map = SourceMap::new();
        let err = match check::bind(&mut map, &set, &tr.domain, &i) {
            Err(e) => advise::diag::render(&map, &e, false),
            Ok(call) => render(&interp::apply(&call, &tr, Chunk { start: a, end: b }).unwrap_err()),
        };
        out.push_str(&format!("----- {inv} on {a}..{b}\n{err}\n"));
    }
    insta::assert_snapshot!(out);
}

#[test]
fn non_finite_results_are_errors_not_garbage() {
    let user = "operator bad for positioning on action { trans = 0 * (1 / (rot - rot)) }";
    let set = OperatorSet::standard()
        .merge(&[Source::new("u.adv", user)])
        .unwrap();
    let tr = positioning_trace(4);
    let call = check::bind(
        &mut SourceMap::new(),
        &set,
        &tr.domain,
        &parse_invocation("bad").unwrap(),
    )
    .unwrap();
    let err = interp::apply(&call, &tr, Chunk::all(4)).unwrap_err();
    assert!(
        matches!(err, interp::ApplyError::NotFinite { point: 0, .. }),
        "{err:?}"
    );
}

#[test]
fn the_operator_readme_lists_every_standard_operator() {
    let readme = include_str!("../operators/README.md");
    let set = OperatorSet::standard();
    for d in set.domains() {
        let section = readme
            .split(&format!("### `{}`", d.name))
            .nth(1)
            .unwrap_or_else(|| panic!("operators/README.md has no section for `{}`", d.name));
        let section = section.split("\n### ").next().unwrap();
        for op in set.operators(&d.name) {
            assert!(
                section.contains(&format!("| `{}` |", op.name())),
                "operators/README.md does not table `{}` for `{}`",
                op.name(),
                d.name
            );
        }
    }
}

#[test]
fn a_compositions_argument_that_leaves_its_limits_for_this_chunk_is_refused_at_run_time() {
    // `gain = n / 10` is within [0, 1] on chunks of up to 10 points only.
    let user =
        "operator ramp for positioning on action = translational_deceleration(gain = n / 10)";
    let set = OperatorSet::standard()
        .merge(&[Source::new("u.adv", user)])
        .unwrap();
    let tr = positioning_trace(12);
    let call = check::bind(
        &mut SourceMap::new(),
        &set,
        &tr.domain,
        &parse_invocation("ramp").unwrap(),
    )
    .unwrap();
    assert!(interp::apply(&call, &tr, Chunk::new(0, 10, 12).unwrap()).is_ok());
    let err = interp::apply(&call, &tr, Chunk::new(0, 12, 12).unwrap()).unwrap_err();
    assert!(
        matches!(&err, interp::ApplyError::BoundOutOfRange { via, operator, value, .. }
            if via == "ramp" && operator == "translational_deceleration" && *value == 1.2),
        "{err:?}"
    );
}
