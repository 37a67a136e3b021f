//! The tools for operator authors, run as a user would: `advise fmt` (canonical layout, comments
//! kept, idempotent, the meaning unchanged) and `advise test` (the doc examples, run).

use std::path::{Path, PathBuf};

use advise::diag::SourceMap;
use advise::syntax::fmt::{format, format_script, is_script};

mod common;

fn advise(dir: &Path, args: &[&str]) -> (i32, String) {
    let (status, text) = common::advise_status(dir, args);
    (status.code().unwrap_or(-1), text)
}

fn files_under(dir: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join(dir)];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "adv") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The `//` comment texts of a file, in order (doc comments are the AST's).
fn comment_texts(text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| {
            let i = l.find("//")?;
            let c = &l[i..];
            (!c.starts_with("///") && !l[..i].contains('"')).then(|| c.trim_end().to_string())
        })
        .collect()
}

fn fmt(name: &str, text: &str) -> String {
    let (map, id) = SourceMap::single(name, text);
    match format(map.src(id)) {
        Ok(f) => f,
        Err(e) if is_script(text) => {
            let _ = e;
            format_script(text)
        }
        Err(e) => panic!("{name}: {e}"),
    }
}

#[test]
fn fmt_round_trips_every_shipped_file_keeping_meaning_and_comments() {
    let mut files = files_under("operators");
    files.extend(files_under("examples"));
    files.extend(files_under("tests/programs/ok"));
    assert!(files.len() >= 14, "{files:?}");
    for dir in ["operators", "tests/programs/ok", "examples/tasks"] {
        for f in files_under(dir) {
            let text = std::fs::read_to_string(&f).unwrap();
            assert!(!is_script(&text), "{} is an operator file", f.display());
        }
    }
    // Scripts, one of them starting with an operator definition.
    let first_an_operator = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/sessions/an_operator_defined_at_the_repl_is_used_at_once.adv");
    for f in files_under("examples/sessions")
        .into_iter()
        .chain([first_an_operator])
    {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(is_script(&text), "{} is a session script", f.display());
    }
    for path in files {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let once = fmt(&name, &text);
        assert_eq!(fmt(&name, &once), once, "{name}: formatting is idempotent");
        assert_eq!(
            comment_texts(&once),
            comment_texts(&text),
            "{name}: comments kept"
        );
        if !is_script(&text) {
            let before = common::parse(&name, &text).unwrap().to_string();
            let after = common::parse(&name, &once).unwrap().to_string();
            assert_eq!(after, before, "{name}: the same program");
        }
        // The shipped operators and examples are already formatted; test inputs may be compact.
        if !name.contains("tests/programs") {
            assert_eq!(
                once, text,
                "{name} is not formatted: run `advise fmt {name}`"
            );
        }
    }
}

#[test]
fn the_shipped_operators_and_examples_pass_advise_fmt_check() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = files_under("operators");
    files.extend(files_under("examples"));
    let mut args = vec!["fmt".to_string(), "--check".to_string()];
    args.extend(files.iter().map(|f| f.display().to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, out) = advise(root, &args);
    assert_eq!(code, 0, "{out}");
    assert!(
        out.ends_with(&format!("{} files already formatted\n", files.len())),
        "{out}"
    );
}

#[test]
fn fmt_rewrites_checks_and_reports_what_it_cannot_parse() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let messy = "// the lab's operators\noperator creep(f = 0.5 in [0, 1])   for positioning on action where trans!=0 {trans=trans*f // halve\n\n\n rot = rot*f}\n";
    std::fs::write(d.join("messy.adv"), messy).unwrap();
    std::fs::write(
        d.join("tidy.adv"),
        "operator halt for positioning on action {\n  trans = 0\n}\n",
    )
    .unwrap();
    std::fs::write(
        d.join("broken.adv"),
        "operator oops for positioning on action { trans = }\n",
    )
    .unwrap();
    let (code, check) = advise(d, &["fmt", "--check", "messy.adv", "tidy.adv"]);
    assert_eq!(code, 1, "{check}");
    assert_eq!(
        std::fs::read_to_string(d.join("messy.adv")).unwrap(),
        messy,
        "--check writes nothing"
    );
    let (code, write) = advise(d, &["fmt", "messy.adv", "tidy.adv", "broken.adv"]);
    assert_eq!(code, 1, "{write}");
    let formatted = std::fs::read_to_string(d.join("messy.adv")).unwrap();
    let (code, again) = advise(d, &["fmt", "--check", "messy.adv", "tidy.adv"]);
    assert_eq!(code, 0, "{again}");
    insta::assert_snapshot!(format!(
        "$ advise fmt --check messy.adv tidy.adv\n{check}\n$ advise fmt messy.adv tidy.adv broken.adv\n{write}\n$ cat messy.adv\n{formatted}\n$ advise fmt --check messy.adv tidy.adv\n{again}"
    ));
}

/// Issue 47: a file `fmt` could not write was counted as reformatted ("2 of 2 files
/// reformatted"). A name so long that no temporary file fits beside it is refused as root too
/// (where a read-only file is not: root may write it).
#[test]
fn fmt_counts_only_the_files_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let messy = "operator halt   for positioning on action {trans=0}\n";
    let long = format!("{}.adv", "l".repeat(240));
    std::fs::write(d.join("messy.adv"), messy).unwrap();
    std::fs::write(d.join(&long), messy).unwrap();
    let (code, out) = advise(d, &["fmt", "messy.adv", &long]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("advise::file::write"), "{out}");
    assert!(out.contains("1 of 2 files reformatted; 1 failed"), "{out}");
    assert_eq!(std::fs::read_to_string(d.join(&long)).unwrap(), messy);
    assert_ne!(std::fs::read_to_string(d.join("messy.adv")).unwrap(), messy);
}

#[test]
fn advise_test_runs_the_standard_librarys_examples() {
    let dir = tempfile::tempdir().unwrap();
    let (code, out) = advise(dir.path(), &["test"]);
    assert_eq!(code, 0, "{out}");
    assert_eq!(out.trim(), "25 examples, 0 failed");
}

#[test]
fn a_wrong_example_is_a_diagnostic_at_its_line_with_expected_and_got() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("lab.adv"),
        "/// Creep: scale both speeds by `f`.\n\
         /// Example: creep(0.5) on {trans: 0.4, rot: 0.2} gives {trans: 0.2, rot: 0.1}\n\
         /// Example: creep on 4 of {trans: 0.4} gives 4 of {trans: 0.1 .. 0.4}\n\
         /// Example: creep on {trans: 0} gives {trans: 0}\n\
         /// Example: creep(0.5) on {trans: 0.4} gives {speed: 0.2}\n\
         operator creep(f = 0.5 in [0, 1]) for positioning on action where trans != 0 {\n  trans *= f\n  rot *= f\n}\n\n\
         operator halt for positioning on action {\n  trans = 0\n}\n",
    )
    .unwrap();
    let (code, out) = advise(d, &["test", "lab.adv"]);
    assert_eq!(code, 1, "{out}");
    insta::assert_snapshot!(out);
}

/// `advise test --tasks FILE OPS` checks the task file first (with the standard operators by
/// role), then runs the examples of its operators and of the operator file's, which are written
/// for its task; without `--tasks` the task is unknown.
#[test]
fn test_takes_task_files_and_runs_their_operators_examples() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/examples/tasks/standoff.adv"),
        d.join("standoff.adv"),
    )
    .unwrap();
    std::fs::write(
        d.join("ops.adv"),
        "/// Edge in: a little more forward speed.\n\
         /// Example: edge_in(0.1) on {trans: 0.2, rot: 0.1} gives {trans: 0.3, rot: 0.1}\n\
         operator edge_in(gain = 0.05 in [0, 0.3]) for standoff on action where trans > 0 {\n  trans += gain\n}\n",
    )
    .unwrap();
    let (code, out) = advise(d, &["test", "ops.adv"]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("advise::check::unknown_domain"), "{out}");
    let (code, out) = advise(d, &["test", "--tasks", "standoff.adv", "ops.adv"]);
    assert_eq!(code, 0, "{out}");
    assert!(out.ends_with("3 examples, 0 failed\n"), "{out}");
    let (code, out) = advise(d, &["test", "--tasks", "standoff.adv"]);
    assert_eq!(code, 0, "{out}");
    assert!(out.ends_with("2 examples, 0 failed\n"), "{out}");
}
