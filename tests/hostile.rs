//! Hostile input to the operator language: deep nesting, exploding compositions, long texts, lost
//! braces, non-finite values, shadowed standard operators. Each refusal is a coded diagnostic, never
//! a crash; the crash-prone cases run the real binary as a subprocess, so that a stack overflow
//! fails the test instead of killing the harness. Sizes are the ones from the issue reports; speed
//! is measured in `benches/check.rs`, not here.

use std::process::Command;

use advise::check::{self, MAX_STAGES, OperatorSet, Source};
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::interp::{self, ApplyError};
use advise::session::{Session, SessionOptions, script};
use advise::syntax::{MAX_DEPTH, parse_invocation};
use advise::task::TaskKind;
use advise::trace::{Chunk, Trace};

mod common;
use common::parse;

/// Run the binary; the exit code is `None` when a signal (an abort) ended it.
fn advise(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn op(body: &str) -> String {
    format!("operator hostile for positioning on action {{\n  trans = {body}\n}}\n")
}

/// `advise check FILE` refuses `text` with `code`, exiting 1 rather than aborting.
fn check_refuses(dir: &tempfile::TempDir, name: &str, text: &str, code: &str) {
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    let (status, _, err) = advise(&["check", path.to_str().unwrap()]);
    assert_eq!(status, Some(1), "{name}: {}", &err[..err.len().min(2000)]);
    assert!(
        err.contains(code),
        "{name}: {}",
        &err[..err.len().min(2000)]
    );
}

#[test]
fn deep_and_long_expressions_are_refused_by_check_without_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let too_deep = "advise::parse::too_deep";
    // The reported case: a flat chain of 9,500 terms (about 19 KB).
    check_refuses(
        &dir,
        "chain.adv",
        &op(&vec!["1"; 9500].join(" + ")),
        too_deep,
    );
    // A chain of 500,000 terms: 1 MB.
    check_refuses(
        &dir,
        "chain_1mb.adv",
        &op(&vec!["trans"; 170_000].join(" * ")),
        too_deep,
    );
    // Brackets, which pest recurses on: parentheses, calls, offsets.
    let parens = format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000));
    check_refuses(&dir, "parens.adv", &op(&parens), too_deep);
    let calls = format!("{}1{}", "abs(".repeat(20_000), ")".repeat(20_000));
    check_refuses(&dir, "calls.adv", &op(&calls), too_deep);
    let offsets = format!("{}0{}", "dist2[".repeat(20_000), "]".repeat(20_000));
    check_refuses(&dir, "offsets.adv", &op(&offsets), too_deep);
    // Prefixes, which pest repeats but the tree nests.
    check_refuses(
        &dir,
        "negs.adv",
        &op(&format!("{}1", "-".repeat(200_000))),
        too_deep,
    );
    let nots = format!("{}1", "not ".repeat(50_000));
    check_refuses(&dir, "nots.adv", &op(&nots), too_deep);
    // In a guard and in a limit, too.
    let guard = format!(
        "operator g for positioning on action where {} {{ trans = 0 }}\n",
        vec!["rot > 0"; 20_000].join(" and ")
    );
    check_refuses(&dir, "guard.adv", &guard, too_deep);
    let limit = format!(
        "domain d {{ act u in [0, {}] }}\n",
        vec!["1"; 20_000].join(" + ")
    );
    check_refuses(&dir, "limit.adv", &limit, too_deep);
}

#[test]
fn diagnostics_on_a_one_megabyte_line_show_a_window_of_it() {
    // 18,000 operators on one line, each with an unknown name: each diagnostic used to draw the
    // whole line (a megabyte) and took more than a second.
    let dir = tempfile::tempdir().unwrap();
    let text: String = (0..18_000)
        .map(|i| format!("operator o{i} for positioning on action {{ trans = x{i} }} "))
        .collect();
    assert!(text.len() > 1 << 20);
    let path = dir.path().join("oneline.adv");
    std::fs::write(&path, text).unwrap();
    let (status, _, err) = advise(&["check", path.to_str().unwrap()]);
    assert_eq!(status, Some(1));
    assert_eq!(err.matches("advise::check::unknown_name").count(), 100);
    assert!(
        err.contains("advise::check::too_many_errors"),
        "{}",
        &err[err.len() - 500..]
    );
    // A window of about 2 KB of the line per diagnostic, with the right column.
    assert!(err.len() < 100 * 8 * 1024, "{}", err.len());
    assert!(err.contains("oneline.adv:1:49]"), "{}", &err[..3000]);
}

#[test]
fn a_number_of_a_million_digits_is_named_by_its_first_few() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("number.adv");
    std::fs::write(&path, op(&"9".repeat(1_000_000))).unwrap();
    let (status, _, err) = advise(&["check", path.to_str().unwrap()]);
    assert_eq!(status, Some(1));
    assert!(err.contains("advise::parse::number_too_large"), "{err}");
    assert!(err.contains("(1000000 digits)"), "{err}");
    assert!(err.len() < 8 * 1024, "{}", err.len());
}

#[test]
fn a_deep_chain_at_the_prompt_and_through_operators_file_is_a_diagnostic() {
    let dir = tempfile::tempdir().unwrap();
    let chain = op(&vec!["1"; 9500].join(" + "));
    let file = dir.path().join("chain.adv");
    std::fs::write(&file, &chain).unwrap();
    for (name, script) in [
        ("prompt.adv", chain.clone()),
        ("load.adv", format!("operators {}\n", file.display())),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, script).unwrap();
        let (status, out, err) = advise(&[
            "run",
            "--no-journal",
            "--demos",
            "0",
            path.to_str().unwrap(),
        ]);
        assert_eq!(status, Some(1), "{name}: {out}\n{err}");
        assert!(err.contains("advise::parse::too_deep"), "{name}: {err}");
    }
}

/// Expressions exactly at the limit, in every shape that nests.
fn at_the_limit() -> Vec<String> {
    vec![
        vec!["trans"; MAX_DEPTH].join(" + "),
        format!("{}trans", "-".repeat(MAX_DEPTH - 1)),
        format!("{}({})", "-".repeat(MAX_DEPTH - 2), "trans * trans"),
        format!(
            "min({}, {})",
            vec!["trans"; MAX_DEPTH - 1].join(" - "),
            vec!["rot"; MAX_DEPTH - 1].join(" - ")
        ),
        format!("trans[{}]", vec!["k"; MAX_DEPTH - 1].join(" - ")),
    ]
}

#[test]
fn expressions_at_the_limit_check_print_and_apply_and_one_more_level_is_refused() {
    let std = OperatorSet::standard();
    let tr = positioning_trace(8);
    for body in at_the_limit() {
        let text = op(&body);
        let set = std
            .merge(&[Source::new("limit.adv", text.as_str())])
            .unwrap_or_else(|e| panic!("{body}:\n{}", check::render_all(&e)));
        // Printing and parsing back walk the same tree.
        let printed = parse("limit.adv", &text).unwrap().to_string();
        parse("printed", &printed).unwrap();
        let inv = parse_invocation("hostile").unwrap();
        let call = check::bind(&mut SourceMap::new(), &set, &tr.domain, &inv).unwrap();
        interp::apply(&call, &tr, Chunk::all(8)).unwrap();
    }
    for deeper in [
        vec!["trans"; MAX_DEPTH + 1].join(" + "),
        format!("{}trans", "-".repeat(MAX_DEPTH)),
        format!("trans[{}]", vec!["k"; MAX_DEPTH].join(" - ")),
    ] {
        let err = std
            .merge(&[Source::new("deeper.adv", op(&deeper))])
            .unwrap_err();
        let text = check::render_all(&err);
        assert!(text.contains("advise::parse::too_deep"), "{text}");
    }
}

#[test]
fn wide_expressions_are_refused_before_they_cost_memory() {
    // Within both depth limits, 2^16 terms (half a megabyte): compiled, every term would hold a
    // register of a batch of points.
    let mut e = String::from("trans");
    for _ in 0..16 {
        e = format!("({e} + {e})");
    }
    let err = OperatorSet::standard()
        .merge(&[Source::new("wide.adv", op(&e))])
        .unwrap_err();
    let text = check::render_all(&err);
    assert!(text.contains("advise::check::operator_too_large"), "{text}");
    assert!(
        text.contains("computes 131071 terms, more than 4096"),
        "{text}"
    );
}

#[test]
fn the_binary_checks_expressions_at_the_limit() {
    // The unoptimised binary has the largest stack frames; it must still walk the deepest tree.
    let dir = tempfile::tempdir().unwrap();
    let text: String = at_the_limit()
        .iter()
        .enumerate()
        .map(|(i, body)| {
            format!("operator deep{i} for positioning on action {{\n  trans = {body}\n}}\n")
        })
        .collect();
    let path = dir.path().join("deep.adv");
    std::fs::write(&path, text).unwrap();
    let (status, out, err) = advise(&["check", path.to_str().unwrap()]);
    assert_eq!(status, Some(0), "{out}\n{err}");
}

/// A composition that composes the previous one `times` times, `levels` deep, over `c0`.
fn compositions(levels: usize, times: usize) -> String {
    let mut text = String::from("operator c0 for positioning on action { trans += 0.0001 }\n");
    for i in 1..=levels {
        let calls = vec![format!("c{}", i - 1); times].join(" then ");
        text.push_str(&format!(
            "operator c{i} for positioning on action = {calls}\n"
        ));
    }
    text
}

#[test]
fn compositions_past_the_stage_limit_are_refused_at_check_time_naming_the_chain() {
    // The reported file: each of 15 operators composes the one before four times.
    let err = OperatorSet::standard()
        .merge(&[Source::new("comp.adv", compositions(14, 4))])
        .unwrap_err();
    // Only `c6` is reported: it is the first past the limit, the rest inherit its excess.
    assert_eq!(err.error.errors.len(), 1, "{}", check::render_all(&err));
    let text = check::render_all(&err);
    assert!(
        text.contains("advise::check::composition_too_large"),
        "{text}"
    );
    let help = miette::Diagnostic::help(&err.error.errors[0])
        .unwrap()
        .to_string();
    assert!(
        help.contains("`c6` (4096) -> `c5` (1024) -> `c4` (256)"),
        "{help}"
    );
    // Saturating counts: 4^40 stages are counted, not expanded.
    let err = OperatorSet::standard()
        .merge(&[Source::new("comp.adv", compositions(40, 4))])
        .unwrap_err();
    assert_eq!(err.error.errors.len(), 1);
}

#[test]
fn a_composition_at_the_stage_limit_applies_every_stage() {
    assert_eq!(MAX_STAGES, 1024);
    let set = OperatorSet::standard()
        .merge(&[Source::new("comp.adv", compositions(5, 4))])
        .unwrap();
    let tr = positioning_trace(4);
    let call = check::bind(
        &mut SourceMap::new(),
        &set,
        &tr.domain,
        &parse_invocation("c5").unwrap(),
    )
    .unwrap();
    let out = interp::apply(&call, &tr, Chunk::all(4)).unwrap();
    for p in 0..4 {
        let want = (tr.a(p)[0] + 1024.0 * 0.0001).min(1.0);
        assert!((out.points.a(p)[0] - want).abs() < 1e-9, "{p}");
    }
}

#[test]
fn a_long_chain_of_single_stage_compositions_applies_without_recursing() {
    // 20,000 compositions each calling the one before: one stage, nested 20,000 deep.
    let mut text = String::from("operator c0 for positioning on action { trans = 0.25 }\n");
    for i in 1..20_000 {
        text.push_str(&format!(
            "operator c{i} for positioning on action = c{}\n",
            i - 1
        ));
    }
    let set = OperatorSet::standard()
        .merge(&[Source::new("long.adv", text)])
        .unwrap();
    let tr = positioning_trace(3);
    let inv = parse_invocation("c19999").unwrap();
    let call = check::bind(&mut SourceMap::new(), &set, &tr.domain, &inv).unwrap();
    let out = interp::apply(&call, &tr, Chunk::all(3)).unwrap();
    assert_eq!(out.points.a(2)[0], 0.25);
}

#[test]
fn forty_thousand_operators_check() {
    let text: String = (0..40_000)
        .map(|i| {
            format!("/// Op {i}.\noperator op{i} for positioning on action {{ trans *= 1.01 }}\n")
        })
        .collect();
    let std = OperatorSet::standard();
    let set = std.merge(&[Source::new("many.adv", text)]).unwrap();
    assert_eq!(
        set.operator_names("positioning").len(),
        40_000 + std.operator_names("positioning").len()
    );
    assert_eq!(set.operator_count(), 40_000 + std.operator_count());
    assert!(set.operator("positioning", "op39999").is_some());
}

#[test]
fn many_mistakes_stop_at_the_error_limit() {
    // 40,000 unknown names, each of whose hints would list 40,000 candidates.
    let mut text = String::from("domain wide { observe ");
    text.push_str(
        &(0..40_000)
            .map(|i| format!("d{i}"))
            .collect::<Vec<_>>()
            .join(", "),
    );
    text.push_str(" act u }\n");
    for i in 0..40_000 {
        text.push_str(&format!(
            "operator o{i} for wide on action {{ u = x{i} }}\n"
        ));
    }
    let err = check::check(&[Source::new("wide.adv", text)]).unwrap_err();
    assert_eq!(err.error.errors.len(), check::MAX_ERRORS + 1);
    let last = advise::diag::render(&err.sources, err.error.errors.last().unwrap(), false);
    assert!(last.contains("advise::check::too_many_errors"), "{last}");
    // 40,001 dimensions, `k`, `n` and `pi`: the first 20 are named.
    let help = miette::Diagnostic::help(&err.error.errors[0])
        .unwrap()
        .to_string();
    assert!(help.ends_with("`d18`, `d19` and 39984 more"), "{help}");
}

#[test]
fn scripts_are_split_by_brackets_line_by_line() {
    // An unclosed `{` and 8,000 lines after it: one statement, reported where the `{` was opened.
    let text = format!(
        "operator creep for positioning on action {{\n{}show\n",
        "  trans = 0.1 // still inside\n".repeat(8000)
    );
    let st = script::statements(&text);
    assert_eq!(st.len(), 1);
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: 0,
        ..SessionOptions::default()
    })
    .unwrap();
    let err = s.execute(&st[0].text, "script.adv:1").unwrap_err();
    let shown = advise_cli::repl::render(s.sources(), &err, false);
    assert!(
        shown.contains("advise::parse::unclosed_delimiter"),
        "{shown}"
    );
    assert!(shown.contains("close the body opened on line 1"), "{shown}");
    // 8,000 doc comment lines belong to the operator after them.
    let text = format!(
        "{}operator creep for positioning on action {{ trans = 0.1 }}\nshow\n",
        "/// Creep.\n".repeat(8000)
    );
    let st = script::statements(&text);
    assert_eq!(st.len(), 2);
    assert_eq!(st[1].line, 8002);
}

fn positioning_trace(n: usize) -> Trace {
    let mut tr = Trace::new(&Domain::positioning());
    for i in 0..n {
        let x = i as f64;
        tr.push(
            x * 0.1,
            &[4.0 - x * 0.3, 0.2, -0.1],
            &[0.5, 0.1 * x - 0.2],
            None,
        );
    }
    tr
}

#[test]
fn non_finite_values_and_offsets_are_errors_not_clamped() {
    let user = "\
operator divide for positioning on action { trans = trans / 0 }
operator peek(s = 0) for positioning on action { trans = dist2[k / s] }
operator guarded for positioning on action where bearing[0 * k / 0] > 0 { trans = 0 }
operator skipped for positioning on action where k > 0 { trans = dist2[-k / k] }
";
    let set = OperatorSet::standard()
        .merge(&[Source::new("u.adv", user)])
        .unwrap();
    let tr = positioning_trace(4);
    let run = |inv: &str| {
        let call = check::bind(
            &mut SourceMap::new(),
            &set,
            &tr.domain,
            &parse_invocation(inv).unwrap(),
        )
        .unwrap();
        interp::apply(&call, &tr, Chunk::all(4))
    };
    // Before, `trans / 0` was clamped to full speed.
    assert!(
        matches!(run("divide"), Err(ApplyError::NotFinite { point: 0, ref dim, .. }) if dim == "trans"),
        "{:?}",
        run("divide")
    );
    let err = run("peek").unwrap_err();
    assert!(
        matches!(err, ApplyError::OffsetNotFinite { point: 0, value, .. } if value.is_nan()),
        "{err:?}"
    );
    let err = run("peek(s = 1)");
    assert!(err.is_ok(), "{err:?}");
    // A guard that reads at a NaN offset is refused, not silently false.
    assert!(matches!(
        run("guarded"),
        Err(ApplyError::OffsetNotFinite { .. })
    ));
    // A point the guard skips may compute anything.
    let out = run("skipped").unwrap();
    assert_eq!(out.source_index, vec![1, 2, 3]);
    // In a composition, the stage that failed is named.
    let comp = OperatorSet::standard()
        .merge(&[Source::new(
            "c.adv",
            format!("{user}operator both for positioning on action = slow_down then divide\n"),
        )])
        .unwrap();
    let call = check::bind(
        &mut SourceMap::new(),
        &comp,
        &tr.domain,
        &parse_invocation("both").unwrap(),
    )
    .unwrap();
    let err = interp::apply(&call, &tr, Chunk::all(4)).unwrap_err();
    assert!(
        matches!(err, ApplyError::NotFinite { ref operator, .. } if operator == "divide"),
        "{err:?}"
    );
}

/// Issue 47: `advise check` of 250 MB of compositions (under the 256 MiB a file may be) aborted at
/// 3.6 GB. One check now reads at most `MAX_CHECK_BYTES` of operator text (and `MAX_OPERATORS`
/// operators), refused before anything is parsed.
#[test]
fn a_check_past_its_text_bound_is_refused_before_parsing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.adv");
    let line = "operator c for positioning on action = slow_down then no_turning then speed_up\n";
    let text = line.repeat(check::MAX_CHECK_BYTES / line.len() + 1);
    std::fs::write(&path, &text).unwrap();
    let (status, out, err) = advise(&["check", path.to_str().unwrap()]);
    assert_eq!(status, Some(1), "{out}\n{err}");
    common::masked_as(&[(path.to_str().unwrap(), "huge.adv")])
        .bind(|| insta::assert_snapshot!(format!("----- STDOUT\n{out}----- STDERR\n{err}")));
    // Two sources together count as one check.
    let half = line.repeat(check::MAX_CHECK_BYTES / line.len() / 2 + 1);
    let errors = OperatorSet::standard()
        .merge(&[
            Source::new("a.adv", half.clone()),
            Source::new("b.adv", half),
        ])
        .unwrap_err();
    assert!(check::render_all(&errors).contains("advise::check::too_large"));
}

#[test]
fn check_prints_shadowing_warnings_and_succeeds() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shadow.adv");
    std::fs::write(
        &path,
        "/// A gentler speed_up.\noperator speed_up(rate = 0.1 in [0, 0.5]) for positioning on action {\n  trans *= 1 + rate\n}\noperator creep for positioning on action { trans = 0.1 }\n",
    )
    .unwrap();
    let (status, out, err) = advise(&["check", path.to_str().unwrap()]);
    assert_eq!(status, Some(0), "{out}\n{err}");
    common::masked_as(&[(path.to_str().unwrap(), "shadow.adv")])
        .bind(|| insta::assert_snapshot!(format!("----- STDOUT\n{out}----- STDERR\n{err}")));
}

#[test]
fn the_session_says_when_a_definition_shadows_a_standard_operator() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mine.adv");
    std::fs::write(
        &path,
        "operator no_turning for positioning on action { rot = 0 }\n",
    )
    .unwrap();
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: 0,
        ..SessionOptions::default()
    })
    .unwrap();
    let lines = format!(
        "operator slow_down for positioning on action {{\n  trans *= 0.5\n}}\noperator creep for positioning on action {{ trans = 0.1 }}\noperators {}\n",
        path.display()
    );
    let mut out = String::new();
    for st in script::statements(&lines) {
        out.push_str(&format!("advise> {}\n", st.text));
        match s.execute(&st.text, &format!("<line {}>", st.line)) {
            Ok(r) => out.push_str(&format!("{}\n", r.to_string().trim_end())),
            Err(e) => out.push_str(&advise_cli::repl::render(s.sources(), &e, false)),
        }
    }
    common::masked_as(&[(&path.display().to_string(), "mine.adv")])
        .bind(|| insta::assert_snapshot!(out));
}
