//! The `check` and `apply` subcommands, and the no-argument REPL fed from a pipe, run as a user
//! would.

use std::process::Command;

fn advise(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn check_without_files_checks_the_standard_operators() {
    let (code, out, _) = advise(&["check"]);
    assert_eq!(code, 0);
    assert_eq!(
        out.trim(),
        "checked 2 domains (task: positioning) and 25 operators in operators/: all good"
    );
}

#[test]
fn no_arguments_opens_a_session_with_the_default_demonstrations() {
    use std::io::Write;
    let home = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_advise"))
        .env("NO_COLOR", "1")
        .env("ADVISE_HOME", home.path())
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"run goal 2 -1 0\nselect 0..10\nadvise slow_down\nquit\n")
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("task positioning, backend sim"), "{stdout}");
    assert!(stdout.contains("execution 0: run goal 2 -1 0"), "{stdout}");
    assert!(
        stdout.contains("advised 0..10 of execution 0 with slow_down"),
        "{stdout}"
    );
    // The session was journalled where ADVISE_HOME points.
    let journal = std::fs::read_dir(home.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .find(|e| e.file_name().to_string_lossy().starts_with("session-"))
        .expect("a journal was written");
    let text = std::fs::read_to_string(journal.path()).unwrap();
    let statements: Vec<String> = text
        .lines()
        .skip(1)
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).expect("one JSON entry per line");
            v["statement"].as_str().unwrap().to_string()
        })
        .collect();
    assert_eq!(
        statements,
        [
            "load demos teacher:9",
            "run goal 2 -1 0",
            "select 0..10",
            "advise slow_down"
        ],
        "{text}"
    );
}

#[test]
fn check_exits_zero_on_good_files_and_reports_every_error_otherwise() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.adv");
    std::fs::write(
        &good,
        "operator halt for positioning on action { trans = 0 }\n",
    )
    .unwrap();
    let (code, out, _) = advise(&["check", good.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}");

    let bad1 = dir.path().join("bad1.adv");
    std::fs::write(&bad1, "operator a for positioning on action { rott = 0 }\n").unwrap();
    let bad2 = dir.path().join("bad2.adv");
    std::fs::write(&bad2, "operator b for positionin on action { trans = 0 }\n").unwrap();
    let (code, _, err) = advise(&[
        "check",
        good.to_str().unwrap(),
        bad1.to_str().unwrap(),
        bad2.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("advise::check::unknown_dimension"), "{err}");
    assert!(err.contains("did you mean `rot`?"), "{err}");
    assert!(err.contains("advise::check::unknown_domain"), "{err}");
    assert!(err.contains("2 errors in 3 files"), "{err}");
}

#[test]
fn apply_prints_the_synthesized_points_as_csv() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("run.csv");
    std::fs::write(
        &trace,
        "t,dist2,bearing,dheading,trans,rot\n0,4,0.1,0.2,0.5,0\n1,3,0.1,0.2,0.5,0.2\n2,2,0.1,0.2,0.5,-0.4\n3,1,0.1,0.2,0.5,0\n",
    )
    .unwrap();
    let (code, out, err) = advise(&[
        "apply",
        "--op",
        "turn_tighter(rate = 0.5)",
        "--trace",
        trace.to_str().unwrap(),
        "--range",
        "0..3",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        out,
        "t,dist2,bearing,dheading,trans,rot\n1,3,0.1,0.2,0.5,0.30000000000000004\n2,2,0.1,0.2,0.5,-0.6000000000000001\n"
    );
    assert!(
        err.contains("synthesized 2 of 3 points (1 skipped by its guard)"),
        "{err}"
    );

    let ops = dir.path().join("mine.adv");
    std::fs::write(
        &ops,
        "operator creep for positioning on action { trans = 0.1 }\n",
    )
    .unwrap();
    let (code, out, err) = advise(&[
        "apply",
        "--operators",
        ops.to_str().unwrap(),
        "--op",
        "creep",
        "--trace",
        trace.to_str().unwrap(),
        "--range",
        "3..4",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().nth(1), Some("3,1,0.1,0.2,0.1,0"));

    let (code, _, err) = advise(&[
        "apply",
        "--op",
        "speed_up",
        "--trace",
        trace.to_str().unwrap(),
        "--range",
        "2..9",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("advise::chunk::out_of_range"), "{err}");
}

#[test]
fn apply_takes_one_episode_of_a_demonstrations_file_and_run_counts_failures() {
    let dir = tempfile::tempdir().unwrap();
    let demos = dir.path().join("d.csv");
    let (code, _, err) = advise(&[
        "demo",
        "--task",
        "positioning",
        "--count",
        "2",
        "--out",
        demos.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let d = demos.to_str().unwrap();
    let (code, _, err) = advise(&["apply", "--op", "stop", "--trace", d, "--range", "0..3"]);
    assert_ne!(code, 0);
    assert!(err.contains("--episode K"), "{err}");
    let episode = |k: &str| {
        advise(&[
            "apply",
            "--op",
            "stop",
            "--trace",
            d,
            "--range",
            "0..3",
            "--episode",
            k,
        ])
    };
    let (code, out, err) = episode("1");
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 4, "{out}");
    let (code, _, err) = episode("2");
    assert_ne!(code, 0);
    assert!(err.contains("advise::cli::no_such_episode"), "{err}");

    let script = dir.path().join("s.adv");
    std::fs::write(&script, "select 0..1\nrun goal 2 -1 0\nwhy 100000\n").unwrap();
    let (code, _, err) = advise(&[
        "run",
        script.to_str().unwrap(),
        "--demos",
        "1",
        "--no-journal",
        "--keep-going",
    ]);
    assert_ne!(code, 0);
    assert!(
        err.trim_end()
            .ends_with(&format!("2 statements of {} failed", script.display())),
        "{err}"
    );
}

/// Issue 47: `advise ... 2>&1 | head -1` made advise panic ("failed printing to stderr: Broken
/// pipe") and exit 101 when the reader left first. Here the reader is gone before advise starts,
/// so every write fails: each command ends with the code it ends with when read to the end.
#[test]
fn a_closed_pipe_on_stdout_and_stderr_keeps_advises_own_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut bad = String::new();
    for i in 0..50 {
        bad.push_str(&format!(
            "operator o{i} for positioning on action {{ trans = nope{i} }}\n"
        ));
    }
    std::fs::write(d.join("bad.adv"), bad).unwrap();
    std::fs::write(
        d.join("messy.adv"),
        "operator halt   for positioning on action {trans=0}\n",
    )
    .unwrap();
    std::fs::write(
        d.join("script.adv"),
        "help\nrun goal 1 0 0\nnot_a_command\n",
    )
    .unwrap();
    let cases: [&[&str]; 7] = [
        &["check"],
        &["check", "bad.adv"],
        &["fmt", "--check", "messy.adv"],
        &["--help"],
        &["--no-such-option"],
        &["run", "--no-journal", "--demos", "1", "script.adv"],
        &["test"],
    ];
    for args in cases {
        let run = |closed: bool| {
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_advise"));
            cmd.args(args)
                .current_dir(d)
                .env("NO_COLOR", "1")
                .env("ADVISE_HOME", d);
            if closed {
                let (reader, writer) = std::io::pipe().unwrap();
                drop(reader);
                cmd.stdout(writer.try_clone().unwrap()).stderr(writer);
            } else {
                cmd.stdout(std::process::Stdio::piped())
                    .stderr(std::process::Stdio::piped());
            }
            cmd.output().unwrap().status
        };
        let (open, closed) = (run(false), run(true));
        assert_ne!(closed.code(), Some(101), "advise {args:?} panicked");
        assert_eq!(closed.code(), open.code(), "advise {args:?}");
    }
}
