//! Advice invocations as cases: each `invocations/{ok,err}/*.adv` holds one line `OP[(ARGS)] on
//! A..B` (what a teacher types after `advise`, and the points it is for), and optionally
//! `// task: interception`. The `advise` binary runs it as a script on a fixed trace of the task
//! (`invocations/<task>.csv`, 20 points): `load trace`, `select A..B`, `preview OP(ARGS)`. The
//! ok cases snapshot the preview's before/after table and must succeed; the err cases snapshot
//! the diagnostic and must fail. Adding a case means adding a file.

mod common;

use common::{Invocation, assert_no_orphans, cases, masked, name, run_all};
use std::path::Path;

/// The case's task and the script that runs it.
fn script(path: &Path) -> (String, String) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut task = "positioning".to_string();
    let mut line = None;
    for l in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        if let Some(t) = l.strip_prefix("// task:") {
            task = t.trim().to_string();
        } else if !l.starts_with("//") {
            assert!(
                line.is_none(),
                "{}: one invocation per case",
                path.display()
            );
            line = Some(l);
        }
    }
    let line = line.unwrap_or_else(|| panic!("{}: no invocation", path.display()));
    let (inv, range) = line
        .rsplit_once(" on ")
        .unwrap_or_else(|| panic!("{}: write `OP on A..B`", path.display()));
    let script = format!("load trace {task}.csv\nselect {range}\npreview {inv}\n");
    (task, script)
}

fn invocation(path: &Path) -> Invocation {
    let (task, script) = script(path);
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/invocations/{task}.csv"));
    let trace = std::fs::read(&trace).unwrap_or_else(|e| panic!("{}: {e}", trace.display()));
    let args = ["run", "--no-journal", "--demos", "0", "--task", &task]
        .map(str::to_string)
        .into_iter()
        .chain(["invocation.adv".to_string()])
        .collect();
    Invocation {
        args,
        files: vec![
            ("invocation.adv".into(), script.into_bytes()),
            (format!("{task}.csv"), trace),
        ],
    }
}

fn snapshot_all(kind: &str, must_succeed: bool) {
    let dir = format!("tests/invocations/{kind}");
    let paths = cases(&dir, "adv");
    assert_no_orphans("invocations", kind, &paths);
    let runs = paths.iter().map(|p| (name(p), invocation(p))).collect();
    let mut outputs = run_all(runs);
    insta::glob!(format!("invocations/{kind}"), "*.adv", |path| {
        let (inv, out) = outputs.remove(&name(path)).unwrap();
        assert_eq!(
            out.code == Some(0),
            must_succeed,
            "{} in {kind}/ but it {}:\n{}",
            name(path),
            if out.code == Some(0) {
                "succeeds"
            } else {
                "fails"
            },
            out.text
        );
        let case = std::fs::read_to_string(path).unwrap();
        let (_, script) = script(path);
        masked(Some(&out.dir)).bind(|| {
            insta::assert_snapshot!(
                kind,
                format!(
                    "----- CASE\n{case}----- SCRIPT invocation.adv\n{script}----- OUTPUT\n{}\n{}",
                    inv.command_line(),
                    out.text
                )
            )
        });
    });
    // Every case was snapshotted (unless INSTA_GLOB_FILTER picked some).
    if std::env::var_os("INSTA_GLOB_FILTER").is_none() {
        assert!(outputs.is_empty(), "not globbed: {:?}", outputs.keys());
    }
}

#[test]
fn invocations_that_apply() {
    snapshot_all("ok", true);
}

#[test]
fn invocations_that_are_refused() {
    snapshot_all("err", false);
}
