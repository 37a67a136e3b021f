//! Hostile input to the session journal and the command line (issue 31, second round): a journal
//! line edited into something no live statement could have made is refused at resume like a
//! damaged line; an id space that cannot grow is refused; a journal in use by a live session is
//! locked; clap's errors and an ADVISE_HOME where no journal can be created carry codes.
//!
//! Every case shows what the user sees (the binary's output, snapshot). Every wait is bounded.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use advise::diag::SourceMap;
use advise::policy::dataset::Dataset;
use advise::session::{Session, SessionOptions};
use advise::task::TaskKind;
use serde_json::{Value, json};

mod common;
use common::{Invocation, masked, run_all};

/// Run `lines` on `s`, failing the test on any error.
fn run(s: &mut Session, lines: &str) {
    for line in lines.lines() {
        if let Err(e) = s.execute(line, "<test>") {
            panic!(
                "{line}: {}",
                advise_cli::repl::render(s.sources(), &e, false)
            );
        }
    }
}

/// The journal of a scripted session, one JSON value per line: positioning with two teacher
/// demonstrations (the preamble), a run, a selection, advice, a critique, then the dataset saved
/// and opened again (its `open` line names the file `p.json`, as the user typed it).
fn scripted_journal() -> Vec<Value> {
    let dir = tempfile::tempdir().unwrap();
    let mut s = common::positioning(2);
    let journal = s.start_journal(dir.path()).unwrap();
    let saved = dir.path().join("p.json");
    run(
        &mut s,
        &format!(
            "run goal 2 -1 0\nselect 10..30\nadvise speed_up(0.3)\ncritique\nsave {0}\nopen {0}",
            saved.display()
        ),
    );
    drop(s);
    let mut lines: Vec<Value> = std::fs::read_to_string(&journal)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let open = entry(&mut lines, "open");
    open["statement"] = json!("open p.json");
    open["effect"]["path"] = json!("p.json");
    lines
}

/// The (first) journal line whose effect is of `kind`.
fn entry<'a>(lines: &'a mut [Value], kind: &str) -> &'a mut Value {
    lines
        .iter_mut()
        .find(|l| l["effect"]["kind"] == kind)
        .unwrap_or_else(|| panic!("no `{kind}` line in the journal"))
}

/// An interception dataset, as `save` writes it.
fn interception_dataset() -> String {
    let dir = tempfile::tempdir().unwrap();
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Interception,
        default_demos: 1,
        ..SessionOptions::default()
    })
    .unwrap();
    let path = dir.path().join("i.json");
    run(&mut s, &format!("save {}", path.display()));
    std::fs::read_to_string(path).unwrap()
}

fn text(lines: &[Value]) -> String {
    lines.iter().map(|l| l.to_string() + "\n").collect()
}

/// Insta settings for a resumed session's output: the run's directory and the name of the new
/// journal the session continues in (time and process id) masked.
fn resume_settings(dir: &Path) -> insta::Settings {
    let mut settings = masked(Some(dir));
    settings.add_filter(
        r"session-\d+-\d+-[0-9a-f]{8}(-\d+)?\.jsonl",
        "session-<new>.jsonl",
    );
    settings.add_filter(
        r"process \d+, which took it \d+ (s|min|h) ago",
        "process <pid>, which took it <t> ago",
    );
    settings
}

/// The seven journals of the attack, each one hand-edited line of a real journal: the restore
/// stops at that line with `advise::journal::invalid_entry` naming it and what is wrong, restores
/// what came before, drives nothing, and continues in a new journal; what the session then saves
/// is a dataset `open` accepts.
#[test]
fn an_edited_journal_line_is_held_to_the_rules_of_a_live_statement() {
    let base = scripted_journal();
    let other = interception_dataset();
    type Edit = Box<dyn Fn(&mut Vec<Value>)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "an_action_of_1e300",
            Box::new(|l| {
                entry(l, "advice")["effect"]["points"]["points"][0]["a"][0] = json!(1e300)
            }),
        ),
        (
            "a_chunk_past_the_end_of_its_execution",
            Box::new(|l| entry(l, "advice")["effect"]["applied"]["chunk"]["end"] = json!(100_000)),
        ),
        (
            "advice_of_another_domain",
            Box::new(|l| {
                entry(l, "advice")["effect"]["applied"]["domain"] = json!("interception");
            }),
        ),
        (
            "a_reversed_chunk",
            Box::new(|l| entry(l, "critique")["effect"]["chunk"] = json!({"start": 30, "end": 10})),
        ),
        (
            "critique_increments_summing_to_infinity",
            Box::new(|l| {
                let incs = &mut entry(l, "critique")["effect"]["increments"];
                let mut first = incs[0].clone();
                first[1] = json!(1.7e308);
                *incs = json!([first.clone(), first]);
            }),
        ),
        (
            "demonstration_actions_outside_limits",
            Box::new(|l| {
                entry(l, "demos")["effect"]["episodes"][0]["trace"]["points"][3]["a"][0] =
                    json!(9.0);
            }),
        ),
        (
            "another_tasks_dataset_opened",
            Box::new(move |l| entry(l, "open")["effect"]["dataset"] = json!(other.clone())),
        ),
    ];
    let mut runs = Vec::new();
    for (name, edit) in &cases {
        let mut lines = base.clone();
        edit(&mut lines);
        let journal = text(&lines);
        let line = lines
            .iter()
            .zip(base.iter())
            .position(|(a, b)| a != b)
            .unwrap()
            + 1;

        // In process: where it stopped, and what the restored session saves opens again.
        let home = tempfile::tempdir().unwrap();
        let path = home.path().join("j.jsonl");
        std::fs::write(&path, &journal).unwrap();
        let restored = Session::restore(&path, home.path()).unwrap();
        let stopped = restored.stopped.as_ref().unwrap_or_else(|| {
            panic!("{name}: restored with no warning");
        });
        assert_eq!(
            miette::Diagnostic::code(stopped).unwrap().to_string(),
            "advise::journal::invalid_entry",
            "{name}"
        );
        assert!(
            stopped.to_string().starts_with(&format!("line {line} of")),
            "{name}: {stopped}"
        );
        assert_eq!(restored.entries, line - 2, "{name}: every line before it");
        assert_ne!(restored.journal, path, "{name}: continues in a new journal");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), journal, "{name}");
        let mut s = restored.session;
        let out = home.path().join("after.json");
        run(&mut s, &format!("save {}", out.display()));
        Dataset::load(&mut SourceMap::new(), &out)
            .unwrap_or_else(|e| panic!("{name}: the saved dataset does not open: {e}"));
        // And the session goes on: a run (what panicked after another task's dataset) ends in a
        // reply or a diagnostic (an empty policy when the first line was refused).
        let _ = s.execute("run goal 1 -1 0", "<test>");

        runs.push((
            name.to_string(),
            Invocation {
                args: vec!["resume".into(), "j.jsonl".into()],
                files: vec![("j.jsonl".into(), journal.into_bytes())],
            },
        ));
    }
    let outputs = run_all(runs);
    for (name, _) in &cases {
        let (inv, out) = &outputs[*name];
        assert_eq!(out.code, Some(0), "{name}: {}", out.text);
        resume_settings(&out.dir).bind(|| {
            insta::assert_snapshot!(
                format!("resume_{name}"),
                format!("{}\n{}", inv.command_line(), out.text)
            );
        });
    }
}

/// `next_id` at the top of the id range: `open` refuses it (ids would wrap and collide), and so
/// does a journal whose `open` holds it; a dataset one id short of the top gives its last id and
/// then refuses, never wrapping.
#[test]
fn an_id_space_that_cannot_grow_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = common::positioning(1);
    let saved = dir.path().join("p.json");
    run(&mut s, &format!("save {}", saved.display()));
    let mut ds: Value = serde_json::from_str(&std::fs::read_to_string(&saved).unwrap()).unwrap();
    ds["next_id"] = json!(u32::MAX);
    let edited = ds.to_string();

    let out = Invocation {
        args: ["run", "open.adv", "--no-journal", "--demos", "0"]
            .map(String::from)
            .to_vec(),
        files: vec![
            ("open.adv".into(), b"open ds.json\n".to_vec()),
            ("ds.json".into(), edited.clone().into_bytes()),
        ],
    };
    let output = out.run();
    assert_eq!(output.code, Some(1), "{}", output.text);
    masked(Some(&output.dir)).bind(|| {
        insta::assert_snapshot!(format!("{}\n{}", out.command_line(), output.text));
    });

    // One id short of the top: one more record, then a refusal with a code.
    ds["next_id"] = json!(u32::MAX - 1);
    let mut d = Dataset::from_json_str("ds.json", &ds.to_string()).unwrap();
    let trace = d.execution(d.executions().first().map_or(0, |e| e.id));
    let trace = trace.unwrap_or_else(|_| {
        let mut t = advise::trace::Trace::new(d.domain());
        t.push(0.0, &[1.0, 0.0, 0.0], &[0.0, 0.0], None);
        t
    });
    assert_eq!(d.add_execution(&trace).unwrap(), u32::MAX);
    let e = d.add_execution(&trace).unwrap_err();
    assert_eq!(
        miette::Diagnostic::code(&e).unwrap().to_string(),
        "advise::dataset::ids_exhausted"
    );

    // A journal whose `open` holds it stops there too.
    let mut lines = scripted_journal();
    entry(&mut lines, "open")["effect"]["dataset"] = json!(edited);
    // And a run number at the top of its range.
    entry(&mut lines, "execution")["effect"]["run"]["number"] = json!(u64::MAX);
    let path = dir.path().join("j.jsonl");
    std::fs::write(&path, text(&lines)).unwrap();
    let restored = Session::restore(&path, dir.path()).unwrap();
    let stopped = restored.stopped.expect("refused");
    let cause = format!("{:?}", stopped);
    assert!(cause.contains("RunNumber"), "{cause}");
}

/// The `advise` binary with `home` as ADVISE_HOME.
fn advise(home: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_advise"));
    c.env("NO_COLOR", "1").env("ADVISE_HOME", home);
    c
}

/// Run `cmd` with `stdin`, ending it after `limit`; its exit code and its stdout and stderr.
fn output_within(cmd: &mut Command, stdin: &str, limit: Duration) -> (Option<i32>, String) {
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A child that refuses at once (a locked journal) may exit before reading its input: the
    // write then meets a closed pipe, which is the child's answer, not the test's failure.
    let written = child.stdin.take().unwrap().write_all(stdin.as_bytes());
    if let Err(e) = written {
        assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe, "{e}");
    }
    let deadline = Instant::now() + limit;
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "did not end within {limit:?}: {}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr),
    )
}

/// The journal in `home` and whether its holder has named itself (it holds the lock by then).
fn held_journal(home: &Path) -> Option<PathBuf> {
    let journal = std::fs::read_dir(home)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "jsonl"))?;
    let mut owner = journal.clone().into_os_string();
    owner.push(".lock");
    Path::new(&owner).exists().then_some(journal)
}

/// Two processes: a live REPL holds its journal, so `advise resume` of it (the newest) is
/// refused with the owner named and what to do; a copy resumes; once the owner is killed
/// (`kill -9`: no clean-up ran) the journal resumes.
#[test]
fn a_journal_in_use_is_locked_and_a_dead_owners_lock_does_not_block() {
    let home = tempfile::tempdir().unwrap();
    let mut live = advise(home.path())
        .args(["repl", "--demos", "1"])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let journal = loop {
        if let Some(j) = held_journal(home.path()) {
            break j;
        }
        if Instant::now() > deadline || live.try_wait().unwrap().is_some() {
            let _ = live.kill();
            panic!("the REPL never started its journal");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let limit = Duration::from_secs(60);
    let (code, text) = output_within(advise(home.path()).arg("resume"), "quit\n", limit);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains(&format!("process {}, which took it", live.id())),
        "the owner is named: {text}"
    );
    // The owner's process id and the journal's name vary in length, and with them where the
    // diagnostic wraps: its lines are joined before the snapshot.
    let text = text.replace("\n  │ ", " ").replace("\n        ", " ");
    resume_settings(home.path())
        .bind(|| insta::assert_snapshot!(format!("$ advise resume\n{text}")));

    // A copy is a history of its own, and resumes while the original is held.
    let copy = home.path().join("copy.jsonl.bak");
    std::fs::copy(&journal, &copy).unwrap();
    let (code, text) = output_within(
        advise(home.path()).arg("resume").arg(&copy),
        "quit\n",
        limit,
    );
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("resumed"), "{text}");

    // Killed, the owner holds nothing, though its owner file is still there.
    live.kill().unwrap();
    live.wait().unwrap();
    assert!(held_journal(home.path()).is_some(), "no clean-up ran");
    let (code, text) = output_within(
        advise(home.path()).arg("resume").arg(&journal),
        "quit\n",
        limit,
    );
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("resumed"), "{text}");
}

/// clap's refusals keep clap's words and usage under an `advise::cli::` code (exit 2, as clap
/// exits); `--help` and `--version` still print and exit 0; an ADVISE_HOME where no journal can
/// be created is `advise::journal::create` with the path and what to do.
#[test]
fn argument_errors_and_an_unusable_advise_home_carry_codes() {
    let inv = |args: &[&str], files: Vec<(String, Vec<u8>)>| Invocation {
        args: args.iter().map(|a| a.to_string()).collect(),
        files,
    };
    let cases = vec![
        (
            "apply_range_negative",
            inv(&["apply", "--range", "-1..5"], vec![]),
        ),
        (
            "eval_limit_not_a_number",
            inv(&["eval", "--limit", "abc"], vec![]),
        ),
        ("unknown_subcommand", inv(&["resum"], vec![])),
        (
            "advise_home_is_a_file",
            inv(
                &["run", "s.adv", "--demos", "0"],
                vec![
                    (".advise".into(), b"in the way".to_vec()),
                    ("s.adv".into(), b"history\n".to_vec()),
                ],
            ),
        ),
    ];
    let names: Vec<&str> = cases.iter().map(|(n, _)| *n).collect();
    let outputs = run_all(cases.into_iter().map(|(n, i)| (n.to_string(), i)).collect());
    for name in names {
        let (inv, out) = &outputs[name];
        let want = if name.starts_with("advise_home") {
            1
        } else {
            2
        };
        assert_eq!(out.code, Some(want), "{name}: {}", out.text);
        assert!(out.text.contains("advise::"), "{name}: {}", out.text);
        masked(Some(&out.dir)).bind(|| {
            insta::assert_snapshot!(
                format!("cli_{name}"),
                format!("{}\n{}", inv.command_line(), out.text)
            );
        });
    }
    for (args, shows) in [(["--help"], "Usage:"), (["--version"], "advise ")] {
        let out = inv(&args, vec![]).run();
        assert_eq!(out.code, Some(0), "{args:?}: {}", out.text);
        assert!(out.text.contains(shows), "{args:?}: {}", out.text);
        assert!(!out.text.contains("advise::"), "{args:?}: {}", out.text);
    }
}
