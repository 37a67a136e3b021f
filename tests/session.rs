//! The advising session driven in process, for what a transcript cannot show: that failed
//! statements leave the dataset alone, that undo restores critique weights exactly, what the
//! plot files hold. The transcripts themselves are cases in `sessions/` (see `sessions.rs`).

use advise::session::{Defined, Reply, Session, SessionOptions, script};
use advise::task::TaskKind;

mod common;
use common::{masked, positioning, raw_transcript};

/// The statements of `sessions/mistakes_get_diagnostics_and_change_nothing.adv` (whose transcript
/// is snapshotted there) change nothing in the dataset.
#[test]
fn mistakes_change_nothing() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/sessions/mistakes_get_diagnostics_and_change_nothing.adv"
    );
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.starts_with("// args: --demos 3\n"));
    let mut s = positioning(3);
    let before = s.learner().len();
    let mut failed = 0;
    for st in script::statements(&text) {
        failed += usize::from(s.execute(&st.text, "<test>").is_err());
    }
    assert!(
        failed > 10,
        "the script is mostly mistakes ({failed} failed)"
    );
    assert_eq!(
        s.learner().len(),
        before,
        "failed statements must not change the dataset"
    );
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
    let t = raw_transcript(&mut s, "run start 0\nselect 0..20\ncritique 0.5\nhistory\n");
    assert!(
        s.learner().dataset().weights() != weights.as_slice(),
        "critique raised weights"
    );
    raw_transcript(&mut s, "undo\n");
    assert_eq!(
        s.learner().dataset().weights(),
        weights.as_slice(),
        "undo restores the weights exactly"
    );
    masked(None).bind(|| insta::assert_snapshot!(t));
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
    let e = Session::new(opts).expect_err("refused");
    insta::assert_snapshot!(advise_cli::repl::render(
        &advise::diag::SourceMap::new(),
        &e,
        false
    ));
}

/// The teacher's pictures: `show` with its action strip, `plot`, `plot actions`, `plot compare`,
/// and what a teacher sees when a plot cannot be drawn. The files are checked for what they hold.
#[test]
fn plots_of_the_selected_execution_and_their_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display().to_string();
    // A trace without poses: its actions can be plotted, its path cannot.
    let mut csv = String::from("t,dist2,bearing,dheading,trans,rot\n");
    for i in 0..30 {
        csv.push_str(&format!(
            "{:.1},4.0,0.1,0.0,{:.2},0.1\n",
            i as f64 * 0.1,
            i as f64 / 60.0
        ));
    }
    std::fs::write(dir.path().join("noposes.csv"), csv).unwrap();
    let mut s = positioning(9);
    let t = raw_transcript(
        &mut s,
        &format!(
            "run goal 2 -1 0.5\nselect 20..40\ncritique\nselect 45..60\nadvise slow_down(0.3)\nrun goal 2 -1 0.5\nselect 10..30 in 0\nshow\nplot {d}/path.svg\nplot actions {d}/actions.svg\nplot compare {d}/compare.svg 0 1\nplot compare {d}/none.svg 0 7\nload trace {d}/noposes.csv\nshow\nplot {d}/none.svg\nplot actions {d}/noposes.svg\nplot compare {d}/none.svg 0 2\n"
        ),
    );
    masked(Some(dir.path())).bind(|| insta::assert_snapshot!(t));
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap();
    assert!(read("path.svg").contains("critiqued 20..40"));
    assert!(read("actions.svg").contains("rot command (rad/s)"));
    assert!(read("compare.svg").contains("after: execution 1"));
    assert!(read("noposes.svg").contains("trans command (m/s)"));
    assert!(!dir.path().join("none.svg").exists());
}

/// Replies are data: what a statement did can be read without parsing its text, and the text is
/// the reply's rendering.
#[test]
fn replies_say_what_happened_as_data() {
    let mut s = positioning(3);
    let ran = s.execute("run goal 2 -1 0.5", "<test>").unwrap();
    let Reply::Ran(r) = &ran else {
        panic!("{ran:?}")
    };
    assert_eq!((r.index, r.label.as_str()), (0, "run goal 2 -1 0.5"));
    assert!(r.points > 0 && !r.outcome.is_empty());
    assert_eq!(
        r.goal.as_deref(),
        Some("x_g = 2 m, y_g = -1 m, theta_g = 0.5 rad")
    );
    assert!(ran.to_string().starts_with(
        "execution 0: run goal 2 -1 0.5 (goal x_g = 2 m, y_g = -1 m, theta_g = 0.5 rad): "
    ));

    let selected = s.execute("select 10..30", "<test>").unwrap();
    assert!(
        matches!(selected, Reply::Selected { execution: 0, chunk } if (chunk.start, chunk.end) == (10, 30))
    );
    let before = s.learner().len();
    let advised = s.execute("advise slow_down(0.3)", "<test>").unwrap();
    let Reply::Advised(a) = &advised else {
        panic!("{advised:?}")
    };
    assert_eq!(a.invocation, "slow_down(rate = 0.3)");
    assert_eq!(a.added + a.skipped, 20);
    assert_eq!(a.dataset, before + a.added);
    assert_eq!(s.learner().len(), a.dataset);

    let defined = s
        .execute(
            "operator creep for positioning on action { trans = 0.1 }",
            "<test>",
        )
        .unwrap();
    assert!(matches!(
        defined,
        Reply::Defined { item: Defined::Operator { ref name, .. }, ref warnings } if name == "creep" && warnings.is_empty()
    ));
    assert!(s.execute("quit", "<test>").unwrap().is_quit());
    assert_eq!(s.execute("// a comment", "<test>").unwrap(), Reply::Nothing);
}

/// `open` of a saved session brings back its executions and history, and so does a resume of a
/// journal that holds the `open`: the same history, the same dataset, and `undo` of an opened
/// edit takes back exactly its points in both. Critiques come back as edits too.
#[test]
fn open_restores_executions_and_history_and_a_resume_restores_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = positioning(3);
    let journal = live.start_journal(dir.path()).unwrap();
    let saved = dir.path().join("s.json");
    let lines = format!(
        "run goal 2 -1 0.5\nselect 20..60\nadvise speed_up(0.3)\ncritique\nrun goal 1 1 0\nselect 5..15\nadvise slow_down\nsave {}\n",
        saved.display()
    );
    let mut slow_down_from = 0;
    for l in lines.lines() {
        if l.starts_with("advise slow_down") {
            slow_down_from = live.learner().len();
        }
        live.execute(l, "<test>").unwrap();
    }
    let history = live.execute("history", "<test>").unwrap().to_string();
    let points = live.learner().len();
    let opened = live
        .execute(&format!("open {}", saved.display()), "<test>")
        .unwrap()
        .to_string();
    assert!(
        opened.contains("restored 2 executions and 3 edits of the history"),
        "{opened}"
    );
    assert!(opened.contains("\nwarning: "), "{opened}");
    let reopened = live.execute("history", "<test>").unwrap().to_string();
    // The same edits, in order; the executions are named by the file now.
    let strip = |h: &str| -> Vec<String> {
        h.lines()
            .map(|l| l.split(" (").next().unwrap_or("").to_string())
            .collect()
    };
    assert_eq!(strip(&reopened), strip(&history));
    assert_eq!(live.learner().len(), points);

    let copy = journal.with_extension("copy.jsonl");
    std::fs::copy(&journal, &copy).unwrap();
    let mut back = Session::restore(&copy, dir.path()).unwrap().session;
    assert_eq!(
        back.execute("history", "<test>").unwrap().to_string(),
        reopened
    );
    for s in [&mut live, &mut back] {
        s.execute("undo", "<test>").unwrap();
        assert_eq!(
            s.learner().len(),
            slow_down_from,
            "undo took back slow_down"
        );
        s.execute("undo", "<test>").unwrap();
        s.execute("redo", "<test>").unwrap();
    }
    assert_eq!(back.status(), live.status());
    assert_eq!(
        back.execute("history", "<test>").unwrap().to_string(),
        live.execute("history", "<test>").unwrap().to_string()
    );
}
