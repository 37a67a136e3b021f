//! Session transcripts as cases: each `sessions/*.adv` script is run by the `advise` binary
//! (`advise run --keep-going`, no journal, in a fresh directory) and its output snapshotted, as a
//! teacher sees it: each statement, its reply, and each failing statement's diagnostic. The
//! example scripts under `examples/sessions/` are snapshotted the same way and must succeed.
//! Adding a case means adding a file; a first line `// args: --demos 3 --task interception`
//! gives it its own command-line options, and a folder of the script's name (`sessions/NAME/`)
//! holds the files it reads, copied beside it. `INSTA_GLOB_FILTER='*NAME*'` checks one case.

mod common;

use common::{Invocation, assert_no_orphans, cases, masked, name, run_all};
use std::path::Path;

/// The options a script asks for in its first line (`// args: ...`), if any.
fn header_args(text: &str) -> Vec<String> {
    text.lines()
        .next()
        .and_then(|l| l.strip_prefix("// args:"))
        .map(|a| a.split_whitespace().map(str::to_string).collect())
        .unwrap_or_default()
}

fn invocation(path: &Path, keep_going: bool) -> Invocation {
    let text = std::fs::read(path).unwrap();
    let file = name(path);
    let mut args = vec!["run".to_string(), "--no-journal".to_string()];
    if keep_going {
        args.push("--keep-going".into());
    }
    args.extend(header_args(&String::from_utf8_lossy(&text)));
    args.push(file.clone());
    let mut files = vec![(file, text)];
    // The files a case reads: the folder of its name, copied beside the script.
    let fixtures = path.with_extension("");
    if fixtures.is_dir() {
        for entry in std::fs::read_dir(&fixtures).unwrap() {
            let p = entry.unwrap().path();
            files.push((name(&p), std::fs::read(&p).unwrap()));
        }
    }
    Invocation { args, files }
}

/// Run every script of `dir` and snapshot each transcript under the script's name.
/// `dir` is relative to the package, `base` the same folder relative to this file (for insta).
fn snapshot_all(snapshot: &str, dir: &str, base: &str, keep_going: bool, must_succeed: bool) {
    let paths = cases(dir, "adv");
    assert_no_orphans("sessions", snapshot, &paths);
    let runs = paths
        .iter()
        .map(|p| (name(p), invocation(p, keep_going)))
        .collect();
    let mut outputs = run_all(runs);
    insta::glob!(base, "*.adv", |path| {
        let (inv, out) = outputs.remove(&name(path)).unwrap();
        assert!(
            out.code == Some(0) || !must_succeed,
            "{} failed:\n{}",
            path.display(),
            out.text
        );
        let script = std::fs::read_to_string(path).unwrap();
        let numbered: String = script
            .lines()
            .enumerate()
            .map(|(i, l)| format!("{:>3} | {l}\n", i + 1))
            .collect();
        let status = match out.code {
            Some(0) => String::new(),
            Some(code) => format!("(exit status {code})\n"),
            None => "(killed by a signal)\n".to_string(),
        };
        masked(Some(&out.dir)).bind(|| {
            insta::assert_snapshot!(
                snapshot,
                format!(
                    "----- {}\n{numbered}----- {}\n{}{status}",
                    name(path),
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
fn session_transcripts() {
    snapshot_all("session", "tests/sessions", "sessions", true, false);
}

#[test]
fn example_sessions() {
    snapshot_all(
        "example",
        "examples/sessions",
        "../examples/sessions",
        false,
        true,
    );
}
