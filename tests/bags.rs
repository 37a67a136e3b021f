//! Recordings in and out. ROS 2 bags in, written by libraries this project did not write: `rosbags` (a rosbag2
//! directory with MCAP storage, and its `.mcap` file alone) and `mcap-ros2-support` (one MCAP file,
//! zstd and lz4 chunks). `tests/python/bags.py` writes each scenario and, on its own, the log the
//! import should make (each kept command with the latest odometry before it); the import of every
//! bag must equal it. The messy scenario's warnings and the refusals are checked as a user sees
//! them. The MCAP export is read back by mcap-ros2-support and rosbags, the LeRobot export's
//! tables by pyarrow. Without Python or the packages, each test prints why and passes without running.

#[path = "python/mod.rs"]
mod python;

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use advise::recording::{ImportOptions, import};
use advise::trace::Episode;

const PACKAGES: [&str; 5] = [
    "rosbags==0.11.9",
    "mcap==1.6.0",
    "mcap-ros2-support==0.6.0",
    "pyarrow==26.0.1",
    "pandas==2.3.3",
];

fn peer() -> Option<PathBuf> {
    match python::venv(
        "bags",
        &PACKAGES,
        "import rosbags.rosbag2, mcap_ros2.writer, mcap_ros2.decoder, numpy, pyarrow.parquet, pandas",
    ) {
        Ok(p) => Some(p),
        Err(why) => {
            eprintln!("skipping: no Python with rosbags and mcap-ros2-support ({why})");
            None
        }
    }
}

/// Write `scenario` with `writer` into `dir`; the bag's path.
fn write(python: &Path, dir: &Path, writer: &str, scenario: &str) -> PathBuf {
    let name = match writer {
        "rosbags" => format!("{writer}-{scenario}"),
        _ => format!("{writer}-{scenario}.mcap"),
    };
    let out = dir.join(name);
    python::run(
        Command::new(python)
            .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/bags.py"))
            .args([writer, scenario])
            .arg(&out),
        Duration::from_secs(120),
    )
    .unwrap();
    out
}

fn expected(bag: &Path) -> Vec<Episode> {
    let log = PathBuf::from(format!("{}.expected.csv", bag.display()));
    import(&log, &ImportOptions::default()).unwrap().0
}

/// The two imports hold the same points, to rounding (the bag's yaw comes from a quaternion).
fn assert_same(got: &[Episode], want: &[Episode], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: episodes");
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g.trace.len(), w.trace.len(), "{what}: points");
        let close = |x: &[f64], y: &[f64]| x.iter().zip(y).all(|(p, q)| (p - q).abs() < 1e-9);
        for i in 0..g.trace.len() {
            let (gt, wt) = (g.trace.t[i], w.trace.t[i]);
            assert!(
                (gt - wt).abs() < 1e-9
                    && close(g.trace.z(i), w.trace.z(i))
                    && close(g.trace.a(i), w.trace.a(i)),
                "{what}: point {i}: t {gt} z {:?} a {:?}, expected t {wt} z {:?} a {:?}",
                g.trace.z(i),
                g.trace.a(i),
                w.trace.z(i),
                w.trace.a(i)
            );
        }
    }
}

#[test]
fn bags_from_three_writers_import_to_the_independent_pairing() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    for scenario in ["clean", "messy", "stamped"] {
        for writer in ["rosbags", "mcap-zstd", "mcap-lz4"] {
            let bag = write(&py, dir.path(), writer, scenario);
            let want = expected(&bag);
            let (got, warnings) = import(&bag, &ImportOptions::default()).unwrap();
            assert_same(&got, &want, &format!("{writer} {scenario}"));
            assert_eq!(
                warnings.is_empty(),
                scenario != "messy",
                "{writer} {scenario}: {warnings:?}"
            );
            if writer == "rosbags" {
                // The rosbag2 directory's MCAP file on its own: the same demonstration.
                let file = bag.join(format!("{writer}-{scenario}.mcap"));
                let (alone, _) = import(&file, &ImportOptions::default()).unwrap();
                assert_same(&alone, &want, &format!("{writer} {scenario} (.mcap alone)"));
            }
        }
    }
}

fn advise(args: &[&str], dir: &Path) -> (bool, String) {
    common::advise_in(dir, args)
}

#[test]
fn a_messy_bag_is_imported_with_every_repair_counted() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    write(&py, dir.path(), "mcap-zstd", "messy");
    let (ok, text) = advise(
        &["import", "mcap-zstd-messy.mcap", "--out", "d.json"],
        dir.path(),
    );
    assert!(ok, "{text}");
    insta::assert_snapshot!(text);
    // The session's `load demos` takes the bag itself, with the same warnings.
    std::fs::write(
        dir.path().join("s.adv"),
        "load demos mcap-zstd-messy.mcap\n",
    )
    .unwrap();
    let (ok, text) = advise(
        &["run", "--demos", "0", "--no-journal", "s.adv"],
        dir.path(),
    );
    assert!(ok, "{text}");
    assert!(
        text.contains("loaded 1 demonstration (68 points) from mcap-zstd-messy.mcap"),
        "{text}"
    );
    assert!(text.contains("warning: dropped 3 of 82 commands sent before the first odometry"));
}

#[test]
fn a_robots_namespace_and_a_pause_in_the_driving() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bag = write(&py, d, "rosbags", "namespaced");
    // The library, with the robot's topics: the independent pairing.
    let options = ImportOptions {
        cmd_topic: Some("/robot1/cmd_vel".into()),
        odom_topic: Some("robot1/odom".into()),
        ..Default::default()
    };
    let (got, warnings) = import(&bag, &options).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_same(&got, &expected(&bag), "namespaced");
    // The command line splits the drive at the pause.
    let (ok, text) = advise(
        &[
            "import",
            "rosbags-namespaced",
            "--cmd-topic",
            "/robot1/cmd_vel",
            "--odom-topic",
            "/robot1/odom",
            "--split-gap",
            "1",
            "--out",
            "d.json",
        ],
        d,
    );
    assert!(ok, "{text}");
    assert!(text.contains("2 demonstrations"), "{text}");
    // The session names the topics after the bag; topics for a file that is not a bag, or the
    // default topics for this bag, are refused.
    std::fs::write(
        d.join("s.adv"),
        "load demos rosbags-namespaced odom /robot1/odom cmd /robot1/cmd_vel
         load demos d.json cmd /robot1/cmd_vel
         load demos rosbags-namespaced
",
    )
    .unwrap();
    let (ok, text) = advise(
        &[
            "run",
            "--demos",
            "0",
            "--no-journal",
            "--keep-going",
            "s.adv",
        ],
        d,
    );
    assert!(!ok, "{text}");
    let points: usize = got.iter().map(|e| e.trace.len()).sum();
    assert!(
        text.contains(&format!(
            "loaded 1 demonstration ({points} points) from rosbags-namespaced"
        )),
        "{text}"
    );
    assert!(
        text.contains("advise::session::topics_need_a_bag"),
        "{text}"
    );
    assert!(text.contains("advise::import::topic_missing"), "{text}");
}

/// A TwistStamped teleop's bag (rosbags and mcap-ros2-support) that stands still for a second
/// before the driving and two after it: the standing still is trimmed by default and counted,
/// `--keep-idle` keeps it, and the reply names the type the commands were read as (issue 35).
#[test]
fn idle_ends_of_a_twist_stamped_bag_are_trimmed_and_counted() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for writer in ["rosbags", "mcap-zstd"] {
        let bag = write(&py, d, writer, "idle");
        let keep = ImportOptions {
            keep_idle: true,
            ..Default::default()
        };
        // Kept, the import is the independent pairing: 121 commands from 0 to 6 s.
        let log = PathBuf::from(format!("{}.expected.csv", bag.display()));
        let (want, _) = import(&log, &keep).unwrap();
        let (got, _) = import(&bag, &keep).unwrap();
        assert_same(&got, &want, &format!("{writer} idle kept"));
        assert_eq!(got[0].trace.len(), 121);
        // Trimmed: the 20 zero commands before 1 s and the 40 after 4 s go; the zero command at
        // 4 s, where the base stands at its final pose, ends the demonstration at rest.
        let imported =
            advise::recording::import_recording(&bag, &ImportOptions::default()).unwrap();
        assert_eq!(imported.idle_trimmed, (20, 40), "{writer}");
        let trace = &imported.episodes[0].trace;
        assert_eq!(trace.len(), 61, "{writer}");
        assert_eq!(trace.a(0), [0.5, 0.1]);
        assert_eq!(trace.a(59), [0.5, 0.1]);
        assert_eq!(trace.a(60), [0.0, 0.0]);
        assert!((trace.t[60] - 3.0).abs() < 1e-9, "{}", trace.t[60]);
        // The goal is where the base came to rest: the last point is at it.
        assert!(trace.z(60)[0].abs() < 1e-9, "{:?}", trace.z(60));
    }
    let (ok, text) = advise(&["import", "mcap-zstd-idle.mcap", "--out", "d.json"], d);
    assert!(ok, "{text}");
    assert_eq!(
        text.trim(),
        "mcap-zstd-idle.mcap: commands read as geometry_msgs/msg/TwistStamped on /cmd_vel
mcap-zstd-idle.mcap: trimmed 60 standing-still points (20 before the first moving command, 40 after the base came to rest; --keep-idle keeps them)
wrote 1 demonstration (61 points) to d.json; `load demos d.json` adds them to a session"
    );
    let (ok, text) = advise(
        &[
            "import",
            "mcap-zstd-idle.mcap",
            "--keep-idle",
            "--out",
            "k.json",
        ],
        d,
    );
    assert!(ok, "{text}");
    assert!(
        text.contains("wrote 1 demonstration (121 points)"),
        "{text}"
    );
    assert!(!text.contains("trimmed"), "{text}");
    // A session's `load demos BAG` trims as the import does.
    std::fs::write(d.join("s.adv"), "load demos mcap-zstd-idle.mcap\n").unwrap();
    let (ok, text) = advise(&["run", "--demos", "0", "--no-journal", "s.adv"], d);
    assert!(ok, "{text}");
    assert!(
        text.contains("loaded 1 demonstration (61 points) from mcap-zstd-idle.mcap"),
        "{text}"
    );
    assert!(
        text.contains("trimmed 60 standing-still points (20 before the first moving command, 40 after the base came to rest; `advise import --keep-idle` keeps them)"),
        "{text}"
    );
}

#[test]
fn bags_that_cannot_be_imported_say_which_topic_file_and_time() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&py, d, "rosbags", "clean");
    let bag = write(&py, d, "mcap-zstd", "clean");
    // A recording cut short: the messages before the damage are kept, with a warning.
    let bytes = std::fs::read(&bag).unwrap();
    std::fs::write(d.join("cut.mcap"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    std::fs::write(d.join("garbage.mcap"), b"not an mcap file at all").unwrap();
    std::fs::create_dir(d.join("old_bag")).unwrap();
    std::fs::write(
        d.join("old_bag/metadata.yaml"),
        "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n",
    )
    .unwrap();
    std::fs::write(d.join("old_bag/old_bag_0.db3"), b"SQLite format 3\0").unwrap();
    let mut out = String::new();
    for args in [
        &["import", "cut.mcap", "--out", "d.json"][..],
        &["import", "garbage.mcap", "--out", "d.json"],
        &["import", "old_bag", "--out", "d.json"],
        &[
            "import",
            "rosbags-clean",
            "--cmd-topic",
            "/teleop/cmd_vel",
            "--out",
            "d.json",
        ],
        &[
            "import",
            "rosbags-clean",
            "--cmd-topic",
            "/odom",
            "--out",
            "d.json",
        ],
        &["import", "missing_bag", "--out", "d.json"],
    ] {
        let (ok, text) = advise(args, d);
        out.push_str(&format!(
            "----- advise {} ({})\n{text}\n",
            args.join(" "),
            if ok { "ok" } else { "refused" }
        ));
    }
    insta::with_settings!({filters => vec![(r"\d+ points", "[N] points"), (r"at byte \d+", "at byte [N]")]}, {
        insta::assert_snapshot!(out);
    });
}

/// A session's dataset exported as MCAP: read back by mcap-ros2-support's decoder and by
/// rosbags, every command the dataset's demonstrations hold and every command and pose of its
/// executions (also as `/tf` odom -> base_link, with `/tf_static` map -> odom), on a timeline in
/// the session's wall-clock time; `/advise/episode` marks each episode, advice and critique carry
/// their chunk's times, the session is in a metadata record, and the summary is what a person
/// opening the file would expect (issue 35: executions only, no /tf, times at the 1970 epoch).
#[test]
fn the_mcap_export_reads_back_in_both_readers_as_the_datasets_executions() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.adv"),
        "run start 0\nselect 5..20\nadvise speed_up(0.2)\nselect 20..30\ncritique\nrun start 1\nsave s.json\nexport mcap session.mcap\n",
    )
    .unwrap();
    let before = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    let (ok, text) = advise(&["run", "--demos", "3", "--no-journal", "s.adv"], d);
    assert!(ok, "{text}");
    assert!(
        text.contains("wrote session.mcap: 3 demonstrations (commands only) and 2 executions"),
        "{text}"
    );
    let (ok, text) = advise(&["export", "s.json", "--mcap", "cli.mcap"], d);
    assert!(ok, "{text}");
    let read_mcap = |file: &str| python::peer_json(&py, "read_mcap.py", &d.join(file));
    let read = read_mcap("cli.mcap");
    assert_eq!(read["profile"], "ros2");
    // The session's export and the command line's hold the same messages; only their timelines'
    // starts differ (the session's start, the saved file's time).
    let session = read_mcap("session.mcap");
    let shifted = |r: &serde_json::Value| -> serde_json::Value {
        let start = r["summary"]["start"].as_u64().unwrap();
        let mut topics = r["topics"].clone();
        for rows in topics.as_object_mut().unwrap().values_mut() {
            for row in rows.as_array_mut().unwrap() {
                let t = row[0].as_u64().unwrap();
                row[0] = (t - start).into();
                if let Some(s) = row.get(6).and_then(|s| s.as_u64()) {
                    row[6] = (s - start).into();
                }
            }
        }
        topics
    };
    assert_eq!(shifted(&session), shifted(&read));

    let mut files = advise::diag::SourceMap::new();
    let ds = advise::policy::dataset::Dataset::load(&mut files, &d.join("s.json")).unwrap();
    // The timeline is the session's: it starts at its wall clock, not at the epoch.
    let summary = &read["summary"];
    let t0 = summary["start"].as_u64().unwrap();
    let after = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    assert!((before - 1_000_000_000..=after).contains(&t0), "{t0}");
    // The session began between `before` and now (a loaded machine may cross a second there).
    let began = session["summary"]["start"].as_u64().unwrap();
    assert!(
        (before - 1_000_000_000..=after).contains(&began),
        "the session's timeline starts when it began: {began} not in {before}..={after}"
    );
    let episodes = read["topics"]["/advise/episode"].as_array().unwrap();
    let marks: Vec<&str> = episodes.iter().map(|e| e[1].as_str().unwrap()).collect();
    assert_eq!(marks.len(), 5, "{marks:?}");
    assert!(
        marks[0].starts_with("demonstration `demo-0`: "),
        "{marks:?}"
    );
    assert!(marks[3].starts_with("execution 0: "), "{marks:?}");
    let tf_static = &read["topics"]["/tf_static"][0];
    assert_eq!(tf_static[0].as_u64(), Some(t0));
    assert_eq!(
        (tf_static[4].as_str(), tf_static[5].as_str()),
        (Some("map"), Some("odom"))
    );

    let cmd = read["topics"]["/cmd_vel"].as_array().unwrap();
    let odom = read["topics"]["/odom"].as_array().unwrap();
    let tf = read["topics"]["/tf"].as_array().unwrap();
    // The demonstrations' commands first: every demonstration point's action, in order.
    let demo_points: usize = ds.demos().iter().map(|d| d.points as usize).sum();
    let mut j = 0;
    for i in 0..ds.len() {
        if let advise::policy::dataset::Provenance::Demonstration { .. } = ds.provenance(i) {
            assert_eq!(
                cmd[j][1].as_f64(),
                Some(ds.a(i)[0]),
                "demonstration command {j}"
            );
            assert_eq!(
                cmd[j][2].as_f64(),
                Some(ds.a(i)[1]),
                "demonstration command {j}"
            );
            j += 1;
        }
    }
    assert_eq!(j, demo_points);
    // Each demonstration's commands at its recorded times (issue 49: the positioning teacher's
    // 15 Hz, not the simulator's 30 Hz), from its `/advise/episode` mark.
    let mut j = 0;
    for (n, demo) in ds.demos().iter().enumerate() {
        let start = episodes[n][0].as_u64().unwrap();
        let period = demo
            .period_s
            .expect("a teacher's demonstration keeps its period");
        assert!((period - 1.0 / 15.0).abs() < 1e-9, "{period}");
        assert!(
            marks[n].ends_with(&format!("(commands only, {period:.3} s apart)")),
            "{}",
            marks[n]
        );
        for k in 0..demo.points as usize {
            let want = start + (k as f64 * period * 1e9).round() as u64;
            assert_eq!(
                cmd[j][0].as_u64(),
                Some(want),
                "demonstration {n} point {k}"
            );
            j += 1;
        }
    }
    let mut k = 0;
    for (n, rec) in ds.executions().iter().enumerate() {
        let start = episodes[3 + n][0].as_u64().unwrap();
        let tr = ds.execution(rec.id).unwrap();
        let poses = tr.pose.as_ref().expect("simulated executions have poses");
        for (i, pose) in poses.iter().enumerate() {
            let t = start + ((tr.t[i] - tr.t[0]) * 1e9).round() as u64;
            let (c, o, f) = (&cmd[demo_points + k], &odom[k], &tf[k]);
            assert_eq!(c[0].as_u64(), Some(t), "command {k}");
            assert_eq!(c[1].as_f64(), Some(tr.a(i)[0]), "command {k}");
            assert_eq!(c[2].as_f64(), Some(tr.a(i)[1]), "command {k}");
            assert_eq!(o[0].as_u64(), Some(t));
            assert_eq!(o[1].as_f64(), Some(pose.x_m));
            assert_eq!(o[2].as_f64(), Some(pose.y_m));
            let dyaw = o[3].as_f64().unwrap() - pose.theta_rad;
            assert!(dyaw.sin().abs() < 1e-9 && dyaw.cos() > 0.0, "pose {k}: {o}");
            assert_eq!(
                (o[4].as_str(), o[5].as_str()),
                (Some("odom"), Some("base_link"))
            );
            // The same pose on /tf, stamped at its log time (to the stamp's rounding).
            assert_eq!(f[0].as_u64(), Some(t));
            assert_eq!(
                (f[1].as_f64(), f[2].as_f64()),
                (Some(pose.x_m), Some(pose.y_m))
            );
            assert_eq!(
                (f[4].as_str(), f[5].as_str()),
                (Some("odom"), Some("base_link"))
            );
            assert_eq!(f[6].as_u64(), Some(t), "{f}");
            k += 1;
        }
    }
    assert_eq!((cmd.len(), odom.len(), tf.len()), (demo_points + k, k, k));
    let advice = read["topics"]["/advise/advice"][0][1].as_str().unwrap();
    assert!(
        advice.starts_with("speed_up(rate = 0.2) on execution 0, points 5..20 ("),
        "{advice}"
    );
    assert!(
        advice.ends_with("): 15 points synthesized (action space)"),
        "{advice}"
    );
    // At its chunk's first point, naming the chunk's times from the start of the recording.
    let (from, to) = (
        cmd[demo_points + 5][0].as_u64().unwrap(),
        cmd[demo_points + 19][0].as_u64().unwrap(),
    );
    assert_eq!(read["topics"]["/advise/advice"][0][0].as_u64(), Some(from));
    let span = format!(
        "({:.3} s to {:.3} s into the recording)",
        (from - t0) as f64 * 1e-9,
        (to - t0) as f64 * 1e-9
    );
    assert!(advice.contains(&span), "{advice}: {span}");
    let critique = read["topics"]["/advise/critique"][0][1].as_str().unwrap();
    assert!(
        critique.starts_with("critique with kappa 1 on execution 0, points 20..30 ("),
        "{critique}"
    );
    assert_eq!(read["metadata"]["advise"]["executions"], "2");
    assert_eq!(read["metadata"]["advise"]["domain"], "positioning");
    // The summary as `mcap info` shows it: every channel with its type and count.
    assert_eq!(
        summary["channels"],
        serde_json::json!([
            ["/advise/advice", "std_msgs/msg/String", 1],
            ["/advise/critique", "std_msgs/msg/String", 1],
            ["/advise/episode", "std_msgs/msg/String", 5],
            ["/cmd_vel", "geometry_msgs/msg/Twist", demo_points + k],
            ["/odom", "nav_msgs/msg/Odometry", k],
            ["/tf", "tf2_msgs/msg/TFMessage", k],
            ["/tf_static", "tf2_msgs/msg/TFMessage", 1],
        ])
    );
    assert!(summary["end"].as_u64().unwrap() > t0);
    let rosbags = &read["rosbags"];
    assert_eq!(
        rosbags["/cmd_vel"],
        serde_json::json!(["geometry_msgs/msg/Twist", demo_points + k])
    );
    assert_eq!(
        rosbags["/odom"],
        serde_json::json!(["nav_msgs/msg/Odometry", k])
    );
    assert_eq!(
        rosbags["/tf"],
        serde_json::json!(["tf2_msgs/msg/TFMessage", k])
    );
    assert_eq!(
        rosbags["/tf_static"],
        serde_json::json!(["tf2_msgs/msg/TFMessage", 1])
    );
    assert_eq!(
        rosbags["/advise/advice"],
        serde_json::json!(["std_msgs/msg/String", 1])
    );

    // And advise reads its own export back as a bag: each execution's commands with its poses
    // (the demonstrations' commands come before any odometry, and are dropped, counted).
    let keep = ImportOptions {
        keep_idle: true,
        ..Default::default()
    };
    let (demos, warnings) = import(&d.join("cli.mcap"), &keep).unwrap();
    assert_eq!(demos[0].trace.len(), k);
    assert_eq!(
        warnings,
        [format!(
            "dropped {demo_points} of {} commands sent before the first odometry",
            demo_points + k
        )]
    );

    // A dataset saved before datasets kept times opens as before: its demonstrations at the
    // task's period (the simulator's 1/30 s).
    let mut old: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    for demo in old["demos"].as_array_mut().unwrap() {
        demo.as_object_mut().unwrap().remove("period_s");
    }
    std::fs::write(d.join("old.json"), old.to_string()).unwrap();
    let (ok, text) = advise(&["export", "old.json", "--mcap", "old.mcap"], d);
    assert!(ok, "{text}");
    let read = read_mcap("old.mcap");
    let cmd = read["topics"]["/cmd_vel"].as_array().unwrap();
    let gap = cmd[1][0].as_u64().unwrap() - cmd[0][0].as_u64().unwrap();
    assert_eq!(gap, (1e9_f64 / 30.0).round() as u64);
}

/// A LeRobot export as `tests/python/read_lerobot.py` reads it, the way LeRobot's loader does.
fn read_lerobot(py: &Path, dir: &Path) -> serde_json::Value {
    python::peer_json(py, "read_lerobot.py", dir)
}

/// A session's dataset exported as LeRobot v3.0: pyarrow reads every table; each frame is a
/// dataset point (state, action, BC weight and source), each demonstration and each advice an
/// episode whose index range holds its frames.
#[test]
fn the_lerobot_export_reads_back_in_pyarrow_as_the_datasets_points() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.adv"),
        "run start 0\nselect 5..20\nadvise speed_up(0.2)\nselect 20..30\ncritique\nsave s.json\nexport lerobot session_lr\n",
    )
    .unwrap();
    let (ok, text) = advise(&["run", "--demos", "3", "--no-journal", "s.adv"], d);
    assert!(ok, "{text}");
    let (ok, text) = advise(&["export", "s.json", "--lerobot", "lr", "--fps", "10"], d);
    assert!(ok, "{text}");
    // One dataset per rate (issue 49): the teacher's demonstrations were recorded at 15 Hz, the
    // advice on a 30 Hz execution; `--fps` is only for sources without times.
    assert!(
        text.contains("recorded at 15 fps and 30 fps: one dataset per rate under lr"),
        "{text}"
    );
    assert!(
        text.contains("wrote lr/15fps: a LeRobot v3.0 dataset of")
            && text.contains("in 3 episodes (3 demonstrations, 0 advice)"),
        "{text}"
    );
    assert!(
        text.contains("wrote lr/30fps: a LeRobot v3.0 dataset of 15 frames at 30 fps"),
        "{text}"
    );
    // An export never writes into a directory that holds something.
    let (ok, text) = advise(&["export", "s.json", "--lerobot", "lr"], d);
    assert!(
        !ok && text.contains("advise::export::lerobot_exists"),
        "{text}"
    );

    let mut files = advise::diag::SourceMap::new();
    let ds = advise::policy::dataset::Dataset::load(&mut files, &d.join("s.json")).unwrap();
    let f32s = |v: &serde_json::Value| -> Vec<f32> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect()
    };
    // Every dataset point is one frame, once: match them by provenance order within episodes.
    let mut seen = vec![false; ds.len()];
    let mut reweighted = 0;
    for (part, fps, source, count) in [
        ("lr/15fps", 15, "demonstration", 3),
        ("lr/30fps", 30, "advice", 1),
    ] {
        let info: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(part).join("meta/info.json")).unwrap())
                .unwrap();
        assert_eq!(info["codebase_version"], "v3.0");
        assert_eq!(info["fps"], fps);
        assert_eq!(
            info["features"]["action"]["names"],
            serde_json::json!(["trans", "rot"])
        );
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(part).join("meta/stats.json")).unwrap())
                .unwrap();
        let read = read_lerobot(&py, &d.join(part));
        let data = &read["data"];
        assert_eq!(
            data["schema"]["observation.state"],
            "fixed_size_list<item: float>[3]"
        );
        assert_eq!(data["schema"]["action"], "fixed_size_list<item: float>[2]");
        assert_eq!(data["schema"]["index"], "int64");
        assert_eq!(data["schema"]["advise.weight"], "float");
        let rows = data["rows"].as_array().unwrap();
        assert_eq!(stats["action"]["count"], serde_json::json!([rows.len()]));
        let episodes = read["episodes"]["rows"].as_array().unwrap();
        assert_eq!(episodes.len(), count);
        for (e, ep) in episodes.iter().enumerate() {
            let (from, to) = (
                ep["dataset_from_index"].as_u64().unwrap() as usize,
                ep["dataset_to_index"].as_u64().unwrap() as usize,
            );
            assert_eq!(ep["length"].as_u64(), Some((to - from) as u64));
            assert_eq!(ep["advise.source"], source);
            for (f, row) in rows[from..to].iter().enumerate() {
                assert_eq!(row["episode_index"].as_u64(), Some(e as u64));
                assert_eq!(row["frame_index"].as_u64(), Some(f as u64));
                assert_eq!(row["advise.source"], source);
                let i = (0..ds.len())
                    .find(|&i| {
                        !seen[i]
                            && ds.z(i).iter().map(|&x| x as f32).collect::<Vec<_>>()
                                == f32s(&row["observation.state"])
                            && ds.a(i).iter().map(|&x| x as f32).collect::<Vec<_>>()
                                == f32s(&row["action"])
                    })
                    .unwrap_or_else(|| panic!("frame {from}+{f} is no dataset point: {row}"));
                seen[i] = true;
                assert_eq!(
                    row["advise.weight"].as_f64().map(|w| w as f32),
                    Some(ds.m(i) as f32)
                );
                reweighted += (ds.m(i) > 1.0) as usize;
                // At the source's own rate: a 15 Hz demonstration plays in real time.
                assert!(
                    (row["timestamp"].as_f64().unwrap() - f as f64 / f64::from(fps)).abs() < 1e-6
                );
            }
        }
        if source == "advice" {
            assert_eq!(episodes[0]["advise.name"], "speed_up(rate = 0.2)");
        }
        assert_eq!(
            read["tasks"]["rows"][0]["task"],
            "drive the base to the goal pose"
        );
        // LeRobot's loader reads each frame's task text through tasks.parquet's index (issue
        // 35: it read `0`).
        let loader = read["loader_task"].as_array().unwrap();
        assert_eq!(loader.len(), rows.len());
        assert!(
            loader
                .iter()
                .all(|t| t == "drive the base to the goal pose"),
            "{:?}",
            &loader[..3]
        );
    }
    assert!(seen.iter().all(|&s| s));
    assert!(reweighted > 0, "the critique's weights are carried");
    // A dataset saved before datasets kept times: its demonstrations at `--fps`.
    let mut old: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    for demo in old["demos"].as_array_mut().unwrap() {
        demo.as_object_mut().unwrap().remove("period_s");
    }
    std::fs::write(d.join("old.json"), old.to_string()).unwrap();
    let (ok, text) = advise(&["export", "old.json", "--lerobot", "lo", "--fps", "10"], d);
    assert!(ok, "{text}");
    assert!(text.contains("recorded at 10 fps and 30 fps"), "{text}");
    assert!(d.join("session_lr/15fps/meta/info.json").exists());

    // `--with-executions`: the session's execution is a fifth episode, marked `execution`, its
    // frames the execution's points with weight 0.
    let (ok, text) = advise(
        &[
            "export",
            "s.json",
            "--lerobot",
            "lx",
            "--fps",
            "10",
            "--with-executions",
        ],
        d,
    );
    assert!(ok, "{text}");
    // The execution is at the simulator's 30 Hz, with the advice on it.
    assert!(
        text.contains("in 2 episodes (0 demonstrations, 1 advice, 1 executions)"),
        "{text}"
    );
    let read = read_lerobot(&py, &d.join("lx/30fps"));
    let rows = read["data"]["rows"].as_array().unwrap();
    let episodes = read["episodes"]["rows"].as_array().unwrap();
    assert_eq!(episodes.len(), 2);
    assert_eq!(episodes[1]["advise.source"], "execution");
    assert_eq!(episodes[1]["advise.name"], "execution 0");
    let exec = ds.execution(ds.executions()[0].id).unwrap();
    let from = episodes[1]["dataset_from_index"].as_u64().unwrap() as usize;
    assert_eq!(rows.len(), from + exec.len());
    for (f, row) in rows[from..].iter().enumerate() {
        assert_eq!(row["advise.source"], "execution");
        assert_eq!(row["advise.weight"].as_f64(), Some(0.0));
        assert_eq!(
            f32s(&row["observation.state"]),
            exec.z(f).iter().map(|&x| x as f32).collect::<Vec<_>>()
        );
        assert_eq!(
            f32s(&row["action"]),
            exec.a(f).iter().map(|&x| x as f32).collect::<Vec<_>>()
        );
    }
    assert_eq!(read["loader_task"].as_array().unwrap().len(), rows.len());
}

/// A bag of a person's driving is a demonstration of a task declared in a file: the standoff's
/// goal read from where the drive ends (`recorded`), its observations computed along the bag,
/// equal to the same task over the independent pairing of the bag's messages.
#[test]
fn a_bag_imports_as_demonstrations_of_a_declared_task() {
    let Some(py) = peer() else { return };
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/tasks/standoff.adv"
    ))
    .unwrap();
    let set = advise::check::check(&[advise::check::Source::new("standoff.adv", text)]).unwrap();
    let options = ImportOptions {
        task: Some(set.task("standoff").unwrap().clone()),
        ..ImportOptions::default()
    };
    let dir = tempfile::tempdir().unwrap();
    for writer in ["rosbags", "mcap-zstd"] {
        let bag = write(&py, dir.path(), writer, "clean");
        let log = PathBuf::from(format!("{}.expected.csv", bag.display()));
        let (want, _) = import(&log, &options).unwrap();
        let (got, _) = import(&bag, &options).unwrap();
        assert_eq!(got[0].trace.domain, "standoff");
        assert_same(&got, &want, &format!("{writer} standoff"));
        // The drive ends at the standoff: 1 m from the point it faces.
        let last = got[0].trace.z(got[0].trace.len() - 1);
        assert!(
            (last[0] - 1.0).abs() < 1e-9 && last[1].abs() < 1e-9,
            "{last:?}"
        );
    }
}

/// Parquet demonstrations (issue 36), written by pandas and pyarrow from `advise demo`'s CSV: they
/// load to the very points the CSV loads to (float64 to the bit; float32 to the nearest float32),
/// in a session as in the library, and every way a file can be wrong is refused with its row and
/// column, as a user sees it.
#[test]
fn parquet_demonstrations_from_pandas_and_pyarrow_load_as_their_csv_does() {
    let Some(py) = peer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let (ok, text) = advise(
        &[
            "demo",
            "--task",
            "positioning",
            "--count",
            "4",
            "--out",
            "demos.csv",
        ],
        dir.path(),
    );
    assert!(ok, "{text}");
    python::run(
        Command::new(&py)
            .arg(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/tests/python/parquet_demos.py"
            ))
            .arg(dir.path().join("demos.csv"))
            .arg(dir.path()),
        Duration::from_secs(120),
    )
    .unwrap();
    let domain = advise::domain::Domain::positioning();
    let mut sources = advise::diag::SourceMap::new();
    let csv = advise::policy::dataset::load_demonstrations(
        &mut sources,
        &domain,
        &dir.path().join("demos.csv"),
    )
    .unwrap()
    .episodes;
    let read_at_most = |name: &str, max: usize| {
        advise::recording::parquet_demos::read_demos(
            &domain,
            &dir.path().join(name),
            max,
            &mut |_, _| {},
        )
    };
    let read = |name: &str| read_at_most(name, 1_000_000);
    // More rows than may be held: refused by the file's row count, before any is read.
    assert!(matches!(
        read_at_most("good.parquet", 100),
        Err(advise::recording::parquet_demos::ParquetDemosError::TooManyPoints { rows, max: 100, .. }) if rows > 100
    ));
    assert_eq!(read("good.parquet").unwrap(), csv, "float64 from pandas");
    let f32 = read("good-f32.parquet").unwrap();
    assert_eq!(f32.len(), csv.len());
    for (g, w) in f32.iter().zip(&csv) {
        assert_eq!(g.name, w.name);
        let rounded = |v: &[f64]| v.iter().map(|x| f64::from(*x as f32)).collect::<Vec<_>>();
        for i in 0..w.trace.len() {
            assert_eq!(g.trace.z(i), rounded(w.trace.z(i)).as_slice());
            assert_eq!(g.trace.a(i), rounded(w.trace.a(i)).as_slice());
        }
    }
    // A session loads it as the CSV: the same reply, but for the file's name.
    let load = |name: &str| {
        let script = format!("load-{name}.adv");
        std::fs::write(dir.path().join(&script), format!("load demos {name}\n")).unwrap();
        advise(
            &["run", "--demos", "0", "--no-journal", &script],
            dir.path(),
        )
    };
    let (ok, parquet) = load("good.parquet");
    assert!(ok, "{parquet}");
    let (_, from_csv) = load("demos.csv");
    let strip = |t: &str| {
        t.replace("good.parquet", "FILE")
            .replace("demos.csv", "FILE")
            .split(" points (")
            .next()
            .unwrap_or_default()
            .to_string()
    };
    assert_eq!(strip(&parquet), strip(&from_csv));
    let mut refused = String::new();
    for bad in [
        "null",
        "int-t",
        "nan",
        "limits",
        "misspelled",
        "missing",
        "split",
    ] {
        let (ok, text) = load(&format!("{bad}.parquet"));
        assert!(!ok, "{bad}: {text}");
        refused.push_str(&format!("--- {bad}.parquet\n{text}\n"));
    }
    insta::assert_snapshot!(refused);
}
