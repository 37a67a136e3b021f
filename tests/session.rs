//! The advising session driven by scripted lines, as a teacher would type them: transcripts are
//! snapshotted (insta), and every example session runs end to end.

use advise::session::{Session, SessionOptions, script};
use advise::task::TaskKind;

/// Run `lines` and return the transcript: each statement, then its reply or its diagnostic.
fn transcript(session: &mut Session, lines: &str) -> String {
    let mut out = String::new();
    for st in script::statements(lines) {
        out.push_str(&format!("advise> {}\n", st.text));
        match session.execute(&st.text, &format!("<line {}>", st.line)) {
            Ok(r) => {
                if !r.text.is_empty() {
                    out.push_str(r.text.trim_end());
                    out.push('\n');
                }
            }
            Err(e) => out.push_str(&advise::repl::render(&e, false)),
        }
    }
    // Timings vary from run to run; everything else is deterministic.
    let re = regex_lite_ms();
    re(&out)
}

fn regex_lite_ms() -> impl Fn(&str) -> String {
    |s: &str| {
        s.lines()
            .map(|l| match (l.find(" in "), l.find(" ms")) {
                (Some(a), Some(b)) if b > a => format!("{} in <t>{}", &l[..a], &l[b + 3..]),
                _ => match (l.find("ready in "), l.rfind(" ms")) {
                    (Some(a), Some(_)) => format!("{}ready in <t>", &l[..a]),
                    _ => match (l.find('('), l.find(" ms)")) {
                        (Some(a), Some(b)) if b > a => format!("{}(<t>){}", &l[..a], &l[b + 4..]),
                        _ => l.to_string(),
                    },
                },
            })
            .collect::<Vec<_>>()
            .join("\n")
            + "\n"
    }
}

fn positioning(demos: usize) -> Session {
    Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: demos,
        ..SessionOptions::default()
    })
    .unwrap()
}

#[test]
fn advising_a_positioning_run() {
    let mut s = positioning(9);
    let t = transcript(
        &mut s,
        "run goal 2 -1 0.5\nselect 20..40\npreview slow_down(0.3)\nadvise slow_down(0.3)\nhistory\nundo\nredo\nundo\nhistory\n",
    );
    insta::assert_snapshot!(t);
}

#[test]
fn mistakes_get_diagnostics_and_change_nothing() {
    let mut s = positioning(3);
    let before = s.learner().len();
    let t = transcript(
        &mut s,
        "select 0..10\nadvise slow_down\nrun goal 2 -1\nrun goal 2 -1 0\nselect 10..5\nselect 0..100000\nselect 0..10\nadvise slow_dwn\nadvise slow_down(rate = 7)\nadvise slow_down(speed = 1)\nwhy 99999\ncritique -1\nundo\nredo\ntask kitchen\nhelp advize\nbackend tcp:1\nload demos /no/such/file.csv\nrun start 0\n",
    );
    assert_eq!(
        s.learner().len(),
        before,
        "failed statements must not change the dataset"
    );
    insta::assert_snapshot!(t);
}

#[test]
fn an_operator_defined_at_the_repl_is_used_at_once() {
    let mut s = positioning(9);
    let t = transcript(
        &mut s,
        "/// Creep forward.\noperator creep for positioning on action where trans > 0.1 {\n  trans = 0.1\n}\nrun goal 2 -1 0.5\nselect 20..26\npreview creep\nadvise creep\nhelp creep\n",
    );
    insta::assert_snapshot!(t);
}

#[test]
fn critique_and_exact_undo_in_interception() {
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Interception,
        default_demos: 10,
        ..SessionOptions::default()
    })
    .unwrap();
    let weights = s.learner().dataset().weights().to_vec();
    let t = transcript(&mut s, "run start 0\nselect 0..20\ncritique 0.5\nhistory\n");
    assert!(
        s.learner().dataset().weights() != weights.as_slice(),
        "critique raised weights"
    );
    transcript(&mut s, "undo\n");
    assert_eq!(
        s.learner().dataset().weights(),
        weights.as_slice(),
        "undo restores the weights exactly"
    );
    insta::assert_snapshot!(t);
}

#[test]
fn advice_survives_save_and_open() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.json");
    let mut s = positioning(3);
    transcript(&mut s, "run goal 2 -1 0\nselect 5..25\nadvise speed_up\n");
    let n = s.learner().len();
    let t = transcript(
        &mut s,
        &format!("save {}\nopen {}\n", path.display(), path.display()),
    );
    assert!(
        t.contains(&format!("opened {}: {n} points", path.display())),
        "{t}"
    );
    assert_eq!(s.learner().dataset().advice().len(), 1);
}

#[test]
fn every_example_session_runs() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sessions");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "adv") {
            continue;
        }
        count += 1;
        let text = std::fs::read_to_string(&path).unwrap();
        let mut s = Session::new(SessionOptions::default()).unwrap();
        for st in script::statements(&text) {
            if let Err(e) = s.execute(&st.text, &format!("{}:{}", path.display(), st.line)) {
                panic!("{}", advise::repl::render(&e, false));
            }
        }
    }
    assert!(count >= 2, "examples/sessions holds the example scripts");
}

/// Practice starts are drawn directly, so a far start costs what start 0 does; past the documented
/// maximum the session refuses with a diagnostic (it used to overflow, or allocate gigabytes).
#[test]
fn far_practice_starts_run_and_impossible_ones_are_refused() {
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Interception,
        default_demos: 2,
        ..SessionOptions::default()
    })
    .unwrap();
    let t = transcript(
        &mut s,
        "run start 100000000\nrun start 999999999\nrun start 1000000000\nrun start 18446744073709551615\n",
    );
    insta::assert_snapshot!(t);
}

/// Simulator parameters given in code are checked like a file's.
#[test]
fn a_session_refuses_simulator_parameters_out_of_range() {
    let opts = SessionOptions {
        sim: advise::backend::sim::SimParams {
            rate_hz: 1e6,
            ..Default::default()
        },
        ..SessionOptions::default()
    };
    let e = Session::new(opts).err().expect("refused");
    insta::assert_snapshot!(advise::repl::render(&e, false));
}
