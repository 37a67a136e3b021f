//! Importing a CSV teleoperation log into demonstrations: the result loads as `load demos` reads
//! it, and every messy log is either reported (warnings) or refused (coded diagnostics).

use std::path::Path;

use advise::domain::Domain;
use advise::recording::{ImportOptions, import_csv_log, parse_csv_log, write_demonstrations};
use advise::trace::{Episode, Pose};
use miette::Diagnostic;

const CLEAN: &str = "time,x,y,theta,v,w
0.0,0.0,0.0,0.0,0.2,0.0
0.1,0.02,0.0,0.0,0.2,0.1
0.2,0.04,0.0,0.01,0.0,0.0
";

fn refused(text: &str, options: &ImportOptions) -> String {
    let err = parse_csv_log(Path::new("log.csv"), "log", text, options).unwrap_err();
    let code = err.code().map(|c| c.to_string()).unwrap_or_default();
    let help = err
        .help()
        .map(|h| format!("\nhelp: {h}"))
        .unwrap_or_default();
    format!("{code}: {err}{help}")
}

#[test]
fn a_log_becomes_demonstrations_that_load_back() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("drive.csv");
    std::fs::write(&log, CLEAN).unwrap();
    let (episodes, report) = import_csv_log(&log, &ImportOptions::default()).unwrap();
    assert!(report.warnings().is_empty());
    let domain = Domain::positioning();
    for out in ["demos.json", "demos.csv"] {
        let out = dir.path().join(out);
        write_demonstrations(&out, &advise::domain::Domain::positioning(), &episodes).unwrap();
        let loaded = Episode::load_all(&mut advise::diag::SourceMap::new(), &domain, &out).unwrap();
        assert_eq!(loaded.len(), 1);
        assert_eq!(loaded[0].name, "drive");
        assert_eq!(loaded[0].trace.len(), 3);
        assert_eq!(loaded[0].trace.a(1), &[0.2, 0.1]);
    }
    // Goal = final pose: the last point is at the goal.
    let last = episodes[0].trace.z(2);
    assert_eq!(last, &[0.0, 0.0, 0.0]);
    // A given goal: 1 m straight ahead of the start.
    let options = ImportOptions {
        goal: Some(Pose::new(1.0, 0.0, 0.0)),
        ..ImportOptions::default()
    };
    let (episodes, _) = import_csv_log(&log, &options).unwrap();
    assert_eq!(episodes[0].trace.z(0), &[1.0, 0.0, 0.0]);
}

#[test]
fn split_gap_and_duplicates_are_reported() {
    let text = "time,x,y,theta,v,w
0.0,0,0,0,0.2,0
0.1,0.02,0,0,0.2,0
0.1,0.02,0,0,0.2,0
5.0,0.5,0,0,0.1,0
5.1,0.51,0,0,0,0
";
    let options = ImportOptions {
        split_gap_s: Some(1.0),
        ..ImportOptions::default()
    };
    let (episodes, report) = parse_csv_log(Path::new("log.csv"), "log", text, &options).unwrap();
    let summary: Vec<String> = episodes
        .iter()
        .map(|e| format!("{}: {} points, t = {:?}", e.name, e.trace.len(), e.trace.t))
        .collect();
    insta::assert_snapshot!(format!(
        "{}\nwarnings: {:?}",
        summary.join("\n"),
        report.warnings()
    ));
}

#[test]
fn messy_logs_are_refused_with_codes() {
    let none = ImportOptions::default();
    let cases = [
        refused("time,x,y\n0,0,0\n", &none),
        refused("time,x,y,theta,v,w\n", &none),
        refused("time,x,y,theta,v,w\n1.0,0,0,0,0,0\n0.5,0,0,0,0,0\n", &none),
        refused("time,x,y,theta,v,w\n0,0,0,0,NaN,0\n", &none),
        refused("time,x,y,theta,v,w\n0,0,0,zero,0,0\n", &none),
        refused("time,x,y,theta,v,w\n0,0,0,0,0\n", &none),
        refused(
            CLEAN,
            &ImportOptions {
                split_gap_s: Some(-1.0),
                ..ImportOptions::default()
            },
        ),
    ];
    insta::assert_snapshot!(cases.join("\n\n"));
}

#[test]
fn a_missing_file_is_a_read_error() {
    // Read through `advise::files` like every other loader (regular files only, size-capped).
    let err =
        import_csv_log(Path::new("/nonexistent/log.csv"), &ImportOptions::default()).unwrap_err();
    assert_eq!(err.code().unwrap().to_string(), "advise::file::read");
}

/// `advise import` as a user runs it: a log with a pause and a repeated row becomes two
/// demonstrations that a session loads; what it cannot read yet, and a goal that is not a pose,
/// are refused with codes.
#[test]
fn advise_import_writes_demonstrations_a_session_loads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("log.csv"),
        "time,x,y,theta,v,w\n0,0,0,0,0.2,0\n0.1,0.02,0,0,0.2,0.1\n0.1,0.02,0,0,0.2,0.1\n0.2,0.04,0.001,0.01,0.2,0.1\n5,0.5,0.1,0.2,0.1,0\n5.1,0.51,0.1,0.2,0,0\n",
    )
    .unwrap();
    let advise = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_advise"))
            .args(args)
            .current_dir(d)
            .env("ADVISE_HOME", d)
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        (out.status.success(), text)
    };
    let (ok, text) = advise(&["import", "log.csv", "--split-gap", "1", "--out", "d.json"]);
    assert!(ok, "{text}");
    assert!(text.contains("dropped 1 of 6 rows"), "{text}");
    assert!(text.contains("wrote 2 demonstrations (5 points)"), "{text}");
    std::fs::write(d.join("s.adv"), "load demos d.json\n").unwrap();
    let (ok, text) = advise(&["run", "--demos", "0", "--no-journal", "s.adv"]);
    assert!(ok, "{text}");
    assert!(
        text.contains("loaded 2 demonstrations (5 points)"),
        "{text}"
    );
    for (args, code) in [
        (
            &[
                "import", "log.csv", "--goal", "1", "-2", "nan", "--out", "e.json",
            ][..],
            "advise::import::goal",
        ),
        (
            &["import", "run.mcap", "--out", "e.json"][..],
            "advise::file::read",
        ),
        (
            &[
                "import",
                "log.csv",
                "--task",
                "interception",
                "--out",
                "e.json",
            ][..],
            "advise::import::task",
        ),
        (
            &["import", "missing.csv", "--out", "e.json"][..],
            "advise::file::",
        ),
    ] {
        let (ok, text) = advise(args);
        assert!(!ok && text.contains(code), "{args:?}: {text}");
    }
    assert!(
        !d.join("e.json").exists(),
        "a refused import writes nothing"
    );
}

/// A declared task's demonstrations from a log: its `recorded` clause reads the goal from where
/// the log ends (standoff: the point 1 m ahead), and its observations are computed along the log
/// as a run computes them (`closing` reads the row before). Checked against the formulas
/// written out here.
#[test]
fn a_declared_task_reads_its_goal_and_observations_from_a_log() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/tasks/standoff.adv"
    ))
    .unwrap();
    let set = advise::check::check(&[advise::check::Source::new("standoff.adv", text)]).unwrap();
    let def = set.task("standoff").unwrap().clone();
    let log = "time,x,y,theta,v,w
0.0,0.0,0.0,0.0,0.3,0.2
0.1,0.03,0.0,0.02,0.3,0.2
0.2,0.06,0.001,0.04,0.3,0.0
0.3,0.09,0.002,0.05,0.0,0.0
";
    let options = ImportOptions {
        task: Some(def),
        ..ImportOptions::default()
    };
    let (episodes, _) = parse_csv_log(Path::new("log.csv"), "log", log, &options).unwrap();
    let trace = &episodes[0].trace;
    assert_eq!(trace.domain, "standoff");
    let rows: Vec<[f64; 6]> = log
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3], v[4], v[5]]
        })
        .collect();
    let end = rows[rows.len() - 1];
    let (px, py) = (end[1] + end[3].cos(), end[2] + end[3].sin());
    let mut prev_range = None;
    for (i, r) in rows.iter().enumerate() {
        let (dx, dy) = (px - r[1], py - r[2]);
        let range = dx.hypot(dy);
        let bearing = advise::geometry::wrap_angle(dy.atan2(dx) - r[3]);
        let closing = prev_range.unwrap_or(range) - range;
        prev_range = Some(range);
        assert_eq!(trace.z(i), &[range, bearing, closing], "row {i}");
        assert_eq!(trace.a(i), &[r[4], r[5]], "row {i}");
    }
    // The log ends 1 m from the point, facing it: the standoff's goal state.
    let last = trace.z(rows.len() - 1);
    assert!((last[0] - 1.0).abs() < 1e-12 && last[1].abs() < 1e-12);
}

/// A log's standing still before the first moving command and after the base came to rest is
/// trimmed (the first point at rest kept, where the goal is read) and counted; `keep_idle` keeps
/// it; a decelerating base is not standing still, nor is a log without a moving command trimmed.
#[test]
fn idle_ends_are_trimmed_and_counted() {
    let log = "time,x,y,theta,v,w
0.0,0,0,0,0,0
0.1,0,0,0,0,0
0.2,0,0,0,0.2,0
0.3,0.02,0,0,0.2,0
0.4,0.04,0,0,0,0
0.5,0.045,0,0,0,0
0.6,0.045,0,0,0,0
0.7,0.045,0,0,0,0
0.8,0.0452,0,0,0,0
";
    let path = Path::new("log.csv");
    let (episodes, report) = parse_csv_log(path, "log", log, &ImportOptions::default()).unwrap();
    // 0.8 s moved 0.2 mm: within the standing-still tolerance of its final pose.
    assert_eq!(report.idle_trimmed, (2, 3));
    let t = &episodes[0].trace;
    let want = [0.0, 0.1, 0.2, 0.3];
    assert!(
        t.t.len() == 4 && t.t.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
        "{:?}",
        t.t
    );
    assert_eq!(t.a(3), &[0.0, 0.0]);
    assert!(t.z(3)[0].abs() < 1e-3, "the goal is where it came to rest");
    let keep = ImportOptions {
        keep_idle: true,
        ..ImportOptions::default()
    };
    let (episodes, report) = parse_csv_log(path, "log", log, &keep).unwrap();
    assert_eq!(report.idle_trimmed, (0, 0));
    assert_eq!(episodes[0].trace.len(), 9);
    let still = "time,x,y,theta,v,w\n0,0,0,0,0,0\n0.1,0,0,0,0,0\n";
    let (episodes, report) = parse_csv_log(path, "log", still, &ImportOptions::default()).unwrap();
    assert_eq!((report.idle_trimmed, episodes[0].trace.len()), ((0, 0), 2));
}
