//! Reading and writing files, as a teacher meets it in a session: special files refused at once,
//! reads capped, a byte-order mark accepted and bad UTF-8 located; saves atomic, through links,
//! with the umask's permissions and a named format; a saved dataset validated whole when opened
//! and usable as demonstrations; and no diagnostic printing a whole file. Transcripts are
//! snapshotted (insta). Demonstration files whose episodes are split, repeated or empty are a
//! session case (`sessions/demonstration_files_*.adv`, its files in the folder of that name).

use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::Command;

use advise::session::{Session, SessionOptions};
use advise::task::TaskKind;
use serde_json::Value;

mod common;

/// Run `lines` and return the transcript (masked when snapshotted: see [`common::masked`]).
fn transcript(session: &mut Session, lines: &str) -> String {
    common::raw_transcript(session, lines)
}

fn session(task: TaskKind, demos: usize) -> Session {
    Session::new(SessionOptions {
        task,
        default_demos: demos,
        ..SessionOptions::default()
    })
    .unwrap()
}

fn mkfifo(p: &Path) {
    let ok = Command::new("mkfifo").arg(p).status().unwrap().success();
    assert!(ok, "mkfifo {} failed", p.display());
}

#[test]
fn special_files_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    mkfifo(&d.join("pipe.csv"));
    mkfifo(&d.join("pipe.json"));
    mkfifo(&d.join("pipe.svg"));
    mkfifo(&d.join("pipe.mcap"));
    std::fs::create_dir(d.join("bag")).unwrap();
    mkfifo(&d.join("bag/bag_0.mcap"));
    let mut s = session(TaskKind::Positioning, 1);
    // Before, each of these blocked on the FIFO or read /dev/zero until memory ran out.
    let t = transcript(
        &mut s,
        &format!(
            "load demos {0}/pipe.csv\nload demos {0}/pipe.mcap\nload demos {0}/bag\nload trace {0}/pipe.csv\nopen {0}/pipe.json\noperators {0}/pipe.csv\n\
             load demos /dev/zero\nrun goal 2 -1 0\nsave {0}/pipe.json\nexport advice {0}/pipe.csv\n\
             plot {0}/pipe.svg\nplot {0}\n",
            d.display()
        ),
    );
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));
}

#[test]
fn text_files_may_start_with_a_byte_order_mark_and_bad_utf8_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ops = "operator crawl for positioning on action { trans = trans * 0.5 }\n";
    std::fs::write(
        d.join("bom.adv"),
        [b"\xEF\xBB\xBF".as_slice(), ops.as_bytes()].concat(),
    )
    .unwrap();
    std::fs::write(
        d.join("latin1.adv"),
        b"// caf\xE9 au lait\noperator crawl for positioning on action { trans = 0 }\n",
    )
    .unwrap();
    let csv = "t,dist2,bearing,dheading,trans,rot\n0,4,0.1,0.2,0.5,0\n0.1,3.9,0.1,0.2,0.5,0\n";
    std::fs::write(
        d.join("bom.csv"),
        [b"\xEF\xBB\xBF".as_slice(), csv.as_bytes()].concat(),
    )
    .unwrap();
    let mut s = session(TaskKind::Positioning, 0);
    let t = transcript(
        &mut s,
        &format!(
            "operators {0}/bom.adv\noperators {0}/latin1.adv\nload demos {0}/bom.csv\n",
            d.display()
        ),
    );
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));
}

#[test]
fn saves_name_their_format_keep_links_and_use_the_umask() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("real")).unwrap();
    std::fs::write(d.join("real/data.json"), "old").unwrap();
    std::os::unix::fs::symlink("real/data.json", d.join("link.json")).unwrap();
    let mut s = session(TaskKind::Positioning, 1);
    let t = transcript(
        &mut s,
        &format!(
            "save {0}/x.txt\nsave {0}/x\nsave {0}/x.csv\nsave {0}/link.json\nopen {0}/link.json\n",
            d.display()
        ),
    );
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));
    assert!(!d.join("x.txt").exists() && !d.join("x").exists());
    let link = std::fs::symlink_metadata(d.join("link.json")).unwrap();
    assert!(link.file_type().is_symlink(), "the link was replaced");
    let saved = std::fs::read_to_string(d.join("real/data.json")).unwrap();
    assert!(saved.starts_with("{\"format\":\"advise-dataset-1\""));
    // The old code wrote through `tempfile`, which makes files 0600.
    let mode = std::fs::metadata(d.join("x.csv"))
        .unwrap()
        .permissions()
        .mode()
        & 0o777;
    assert_ne!(mode, 0o600);
    assert_eq!(mode & 0o600, 0o600);
    let leftovers: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// A saved positioning dataset with one demonstration and one piece of advice, as JSON.
fn saved_dataset(d: &Path) -> Value {
    let mut s = session(TaskKind::Positioning, 1);
    transcript(
        &mut s,
        &format!(
            "run goal 2 -1 0\nselect 5..25\nadvise speed_up\nsave {}/base.json\n",
            d.display()
        ),
    );
    serde_json::from_str(&std::fs::read_to_string(d.join("base.json")).unwrap()).unwrap()
}

#[test]
fn a_corrupted_long_one_line_dataset_renders_a_short_diagnostic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut v = saved_dataset(d);
    // Grow it past 200 KB with copies of its execution (one JSON line, as `save` writes).
    let exec = v["executions"][0].clone();
    let mut id = v["next_id"].as_u64().unwrap();
    let mut text = String::new();
    while text.len() < 200_000 {
        id += 1;
        let mut e = exec.clone();
        e["id"] = id.into();
        v["executions"].as_array_mut().unwrap().push(e);
        v["next_id"] = id.into();
        text = serde_json::to_string(&v).unwrap();
    }
    assert!(!text.contains('\n'));
    // A stray character far past column 65,535 (miette alone panicked on such a span).
    let at = text.len() - 5_000;
    let at = (at..).find(|&i| text.as_bytes()[i] == b',').unwrap();
    text.insert(at, '#');
    std::fs::write(d.join("long.json"), &text).unwrap();

    let mut s = session(TaskKind::Positioning, 1);
    let before = s.status();
    let t = transcript(&mut s, &format!("open {}/long.json\n", d.display()));
    assert!(t.len() < 2_500, "{} bytes:\n{t}", t.len());
    assert_eq!(s.status(), before);
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));

    // The command line prints the same short diagnostic.
    let out = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args([
            "eval",
            "--task",
            "positioning",
            "--policy",
            "bc",
            "--dataset",
        ])
        .arg(d.join("long.json"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("advise::dataset::json"), "{stderr}");
    assert!(stderr.len() < 2_500, "{} bytes", stderr.len());
}

#[test]
fn open_validates_the_whole_file_and_a_failed_open_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = saved_dataset(d);
    let write = |name: &str, edit: &dyn Fn(&mut Value)| {
        let mut v = base.clone();
        edit(&mut v);
        std::fs::write(d.join(name), serde_json::to_string(&v).unwrap()).unwrap();
        name.to_string()
    };
    let advice_id = base["advice"][0]["id"].clone();
    let cases = [
        write("duplicate_id.json", &|v| {
            v["demos"][0]["id"] = advice_id.clone()
        }),
        write("dangling.json", &|v| {
            v["points"][0]["provenance"]["demonstration"]["demo"] = 99.into()
        }),
        write("next_id.json", &|v| v["next_id"] = 1.into()),
        write("dimension.json", &|v| {
            v["points"][3]["z"].as_array_mut().unwrap().pop();
        }),
        write("null.json", &|v| v["points"][2]["a"][0] = Value::Null),
        write("limits.json", &|v| v["points"][4]["a"][0] = 5.0.into()),
        write("count.json", &|v| v["demos"][0]["points"] = 1.into()),
        write("chunk.json", &|v| {
            v["advice"][0]["applied"]["chunk"]["end"] = 100_000.into()
        }),
        write("domain.json", &|v| {
            v["domain"]["act"][0]["limits"]["hi"] = 9.0.into()
        }),
    ];
    let mut inter = session(TaskKind::Interception, 1);
    transcript(
        &mut inter,
        &format!("save {}/interception.json\n", d.display()),
    );

    let mut s = session(TaskKind::Positioning, 2);
    transcript(&mut s, "run goal 1 1 0\n");
    let before = (s.status(), s.learner().len());
    let mut lines = format!("open {}/interception.json\n", d.display());
    for c in &cases {
        lines.push_str(&format!("open {}/{c}\n", d.display()));
    }
    lines.push_str("show\n");
    let t = transcript(&mut s, &lines);
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));
    assert_eq!((s.status(), s.learner().len()), before);
    // Every case was refused, the untouched file opens.
    assert_eq!(t.matches("advise::").count(), cases.len() + 1, "{t}");
    let t = transcript(&mut s, &format!("open {}/base.json\n", d.display()));
    assert!(
        t.contains(&format!("opened {}/base.json", d.display())),
        "{t}"
    );
}

/// Issue 47: an execution's goal that is short or out of reach was refused only after the
/// session had taken the opened dataset, so its demonstrations were gone, `save` wrote the bad
/// goal and the journal (without the failed open) resumed to a state the session never had.
#[test]
fn an_open_refused_for_an_executions_goal_changes_nothing_saved_or_journalled() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = saved_dataset(d);
    let bad = |name: &str, goal: Value| {
        let mut v = base.clone();
        v["executions"][0]["goal"] = goal;
        std::fs::write(d.join(name), serde_json::to_string(&v).unwrap()).unwrap();
    };
    bad("short.json", serde_json::json!([1.0, 2.0]));
    bad("far.json", serde_json::json!([1.0e9, 0.0, 0.0]));
    let mut s = session(TaskKind::Positioning, 3);
    let journal = s.start_journal(d).unwrap();
    transcript(
        &mut s,
        "run goal 1 1 0
select 2..12
advise slow_down
",
    );
    let before = (s.status(), s.learner().dataset().to_json_string());
    for name in ["short.json", "far.json"] {
        let t = transcript(&mut s, &format!("open {}/{name}\n", d.display()));
        assert!(t.contains("advise::session::bad_goal"), "{t}");
        assert_eq!(
            (s.status(), s.learner().dataset().to_json_string()),
            before,
            "{name}"
        );
    }
    // What `save` writes and what the journal resumes are the session as it was.
    transcript(&mut s, &format!("save {}/after.json\n", d.display()));
    let after: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("after.json")).unwrap()).unwrap();
    assert_eq!(
        after["executions"][0]["goal"],
        serde_json::json!([1.0, 1.0, 0.0])
    );
    drop(s);
    let back = Session::restore(&journal, d).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(back.stopped.is_none(), "{:?}", back.stopped);
    assert_eq!(
        (
            back.session.status(),
            back.session.learner().dataset().to_json_string()
        ),
        before
    );
}

#[test]
fn a_saved_dataset_is_demonstrations_for_load_demos_and_eval() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    saved_dataset(d);
    let mut s = session(TaskKind::Positioning, 0);
    let t = transcript(
        &mut s,
        &format!("load demos {0}/base.json\nhistory\n", d.display()),
    );
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));
    // Another task refuses it.
    let mut i = session(TaskKind::Interception, 0);
    let t = transcript(&mut i, &format!("load demos {}/base.json\n", d.display()));
    assert!(t.contains("advise::trace::domain_mismatch"), "{t}");

    // `eval` used to refuse it: "unknown field `format`".
    let out = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args([
            "eval",
            "--task",
            "positioning",
            "--policy",
            "bc",
            "--json",
            "--dataset",
        ])
        .arg(d.join("base.json"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["episodes"], 25);
}

#[test]
fn the_command_line_refuses_special_files_and_reads_a_script_with_a_byte_order_mark() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("pipe.adv");
    mkfifo(&fifo);
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_advise"))
            .args(args)
            .current_dir(d)
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    // Each of these used to wait forever for a writer on the FIFO.
    for args in [
        &["run", "pipe.adv"][..],
        &["check", "pipe.adv"],
        &[
            "eval",
            "--task",
            "positioning",
            "--policy",
            "teacher",
            "--sim-params",
            "pipe.adv",
        ],
        &[
            "demo",
            "--task",
            "positioning",
            "--count",
            "1",
            "--out",
            "pipe.adv",
        ],
    ] {
        let (ok, stderr) = run(args);
        assert!(
            !ok && stderr.contains("advise::file::not_regular"),
            "{args:?}: {stderr}"
        );
    }
    std::fs::write(d.join("bom.adv"), b"\xEF\xBB\xBFtask interception\n").unwrap();
    let (ok, stderr) = run(&["run", "bom.adv"]);
    assert!(ok, "{stderr}");
}

#[test]
fn data_files_stay_in_the_sessions_source_map_only_when_they_fail() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut s = session(TaskKind::Positioning, 0);
    let mut lines = String::new();
    for k in 0..20 {
        // Twenty different traces, each loaded: none is needed by a diagnostic afterwards.
        let csv = format!(
            "t,dist2,bearing,dheading,trans,rot\n0,{k},0.1,0.2,0.5,0\n0.1,3.9,0.1,0.2,0.5,0\n"
        );
        std::fs::write(d.join(format!("t{k}.csv")), csv).unwrap();
        lines.push_str(&format!("load trace {}/t{k}.csv\n", d.display()));
    }
    transcript(&mut s, &lines);
    assert_eq!(s.sources().len(), 0, "{:?}", s.sources());
    // A failing one is kept for its diagnostic, once however often it fails.
    std::fs::write(
        d.join("bad.csv"),
        "t,dist2,bearing,dheading,trans,rot\n0,x,0,0,0,0\n",
    )
    .unwrap();
    let bad = format!("load trace {}/bad.csv\n", d.display()).repeat(3);
    let t = transcript(&mut s, &bad);
    assert_eq!(t.matches("advise::trace::not_a_number").count(), 3, "{t}");
    assert!(t.contains(&format!("[{}/bad.csv:2:3]", d.display())), "{t}");
    // The file once, and each failed statement (three lines of the script, three sources).
    assert_eq!(s.sources().len(), 4, "{:?}", s.sources());
    // A statement that succeeds gives back what it added.
    transcript(&mut s, &format!("load trace {}/t1.csv\n", d.display()));
    assert_eq!(s.sources().len(), 4, "{:?}", s.sources());
}

/// `advise check --tasks TASKS OPS`: the task file's task gets the standard operators by role (the
/// reply counts them), so an operator file, or the task file itself, that defines its own
/// `slow_down` for the task is told, with a coded warning, that it shadows the standard one, and
/// where each is.
#[test]
fn check_with_tasks_counts_the_role_operators_and_warns_of_a_shadowing_one() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join(
        "tests/sessions/a_task_written_from_scratch_is_checked_run_drawn_advised_explained_evaluated_saved_and_opened",
    );
    let read = |name: &str| std::fs::read(fixtures.join(name)).unwrap();
    let shadow = b"/// Slow down, the lab's way: only the forward speed.\n\
operator slow_down(rate = 0.2 in [0, 1]) for waypoint on action where fwd > 0 {\n  fwd *= 1 - rate\n}\n";
    let files = vec![
        ("waypoint.adv".to_string(), read("waypoint.adv")),
        ("waypointops.adv".to_string(), read("waypointops.adv")),
        ("shadow.adv".to_string(), shadow.to_vec()),
        // The task and its own `slow_down` in one file.
        (
            "withown.adv".to_string(),
            [read("waypoint.adv"), shadow.to_vec()].concat(),
        ),
    ];
    let check = |tasks: &str, ops: &str| {
        let inv = common::Invocation {
            args: ["check", "--tasks", tasks, ops].map(String::from).to_vec(),
            files: files.clone(),
        };
        let out = inv.run();
        assert_eq!(out.code, Some(0), "{}", out.text);
        format!("{}\n{}", inv.command_line(), out.text)
    };
    let plain = check("waypoint.adv", "waypointops.adv");
    assert!(
        plain.contains("standard ones by role: 11 for waypoint"),
        "{plain}"
    );
    let shadowed = check("waypoint.adv", "shadow.adv");
    assert!(
        shadowed.contains("advise::check::shadows_standard"),
        "{shadowed}"
    );
    let own = check("withown.adv", "waypointops.adv");
    assert!(own.contains("advise::check::shadows_standard"), "{own}");
    insta::assert_snapshot!(format!("{plain}\n{shadowed}\n{own}"));
}

/// A session's `tasks FILE` warns as `advise check --tasks` does when the task file defines its
/// own operator of a standard name: the task's `slow_down` shadows the one by role, the reply
/// says so with the coded warning, and it is the task's own that advice then binds (its guard
/// and its one-dimensional body).
#[test]
fn tasks_in_a_session_warns_when_the_task_file_shadows_a_standard_operator() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join(
        "tests/sessions/a_task_written_from_scratch_is_checked_run_drawn_advised_explained_evaluated_saved_and_opened",
    );
    let dir = tempfile::tempdir().unwrap();
    let shadow = "/// Slow down, the lab's way: only the forward speed.\n\
operator slow_down(rate = 0.2 in [0, 1]) for waypoint on action where fwd > 0 {\n  fwd *= 1 - rate\n}\n";
    let task = std::fs::read_to_string(fixtures.join("waypoint.adv")).unwrap();
    std::fs::write(dir.path().join("withown.adv"), format!("{task}{shadow}")).unwrap();
    std::fs::write(dir.path().join("plain.adv"), &task).unwrap();
    let mut s = session(TaskKind::Positioning, 0);
    let own = transcript(
        &mut s,
        &format!("tasks {}", dir.path().join("withown.adv").display()),
    );
    assert!(own.contains("advise::check::shadows_standard"), "{own}");
    assert!(own.contains("slow_down"), "{own}");
    insta::assert_snapshot!(own.replace(&dir.path().display().to_string(), "DIR"));
    let docs = transcript(&mut s, "task waypoint\nhelp slow_down");
    assert!(
        docs.contains("the lab's way"),
        "the task's own slow_down is bound: {docs}"
    );
    // A task file without its own operator of a standard name warns of nothing.
    let mut s = session(TaskKind::Positioning, 0);
    let plain = transcript(
        &mut s,
        &format!("tasks {}", dir.path().join("plain.adv").display()),
    );
    assert!(!plain.contains("shadows_standard"), "{plain}");
}

/// A dataset saved as CSV loads back as demonstrations (it used to be refused for its `source`
/// column): the same points as the same dataset saved as JSON gives, each source one episode;
/// an edited file with an action beyond its limits is refused with its line and column.
#[test]
fn a_dataset_saved_as_csv_loads_back_as_its_json_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    saved_dataset(d);
    let mut s = session(TaskKind::Positioning, 0);
    transcript(
        &mut s,
        &format!("load demos {0}/base.json\nsave {0}/base.csv\n", d.display()),
    );
    let reload = |name: &str| {
        let mut s = session(TaskKind::Positioning, 0);
        let t = transcript(
            &mut s,
            &format!(
                "load demos {0}/{name}\nsave {0}/{name}.out.csv\n",
                d.display()
            ),
        );
        assert!(t.contains("a saved dataset's"), "{t}");
        // The points (observations and actions), without their provenance's wording.
        std::fs::read_to_string(d.join(format!("{name}.out.csv")))
            .unwrap()
            .lines()
            .map(|l| l.split(',').skip(2).collect::<Vec<_>>().join(","))
            .collect::<Vec<_>>()
    };
    let (csv, json) = (reload("base.csv"), reload("base.json"));
    assert!(csv.len() > 50, "{} rows", csv.len());
    assert_eq!(csv, json);
    // An edited file: the first row's first action set beyond its limits.
    let text = std::fs::read_to_string(d.join("base.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[1].split(',').map(String::from).collect();
    fields[5] = "40".into();
    lines[1] = fields.join(",");
    std::fs::write(d.join("edited.csv"), lines.join("\n") + "\n").unwrap();
    let mut s = session(TaskKind::Positioning, 0);
    let t = transcript(&mut s, &format!("load demos {}/edited.csv\n", d.display()));
    common::masked(Some(d)).bind(|| insta::assert_snapshot!(t));
    // A source's rows split apart (the first row moved to the end), and a header of another
    // domain's columns: each refused, saying where.
    let mut split = text.lines().map(String::from).collect::<Vec<_>>();
    let first = split.remove(1);
    split.push(first);
    std::fs::write(d.join("split.csv"), split.join("\n") + "\n").unwrap();
    let other = text.replacen("dist2", "distance", 1);
    std::fs::write(d.join("other.csv"), other).unwrap();
    for (name, says) in [
        ("split.csv", "starts again here"),
        ("other.csv", "a `positioning` dataset saved as CSV has"),
    ] {
        let mut s = session(TaskKind::Positioning, 0);
        let t = transcript(&mut s, &format!("load demos {}/{name}\n", d.display()));
        assert!(t.contains(says), "{name}: {t}");
        assert!(t.contains(name), "{name} is named: {t}");
    }
}
