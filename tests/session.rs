//! The advising session driven by scripted lines, as a teacher would type them: transcripts are
//! snapshotted (insta), and every example session runs end to end.

use advise::session::{Session, SessionOptions, script};
use advise::task::TaskKind;

mod common;
use common::{positioning, raw_transcript};

/// Run `lines` and return the transcript, timings written as `<t>`.
fn transcript(session: &mut Session, lines: &str) -> String {
    // Timings vary from run to run; everything else is deterministic.
    regex_lite_ms()(&raw_transcript(session, lines))
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
        // As `advise run` starts it: the REPL's starting demonstrations.
        let mut s = positioning(9);
        for st in script::statements(&text) {
            if let Err(e) = s.execute(&st.text, &format!("{}:{}", path.display(), st.line)) {
                panic!("{}", advise::repl::render(s.sources(), &e, false));
            }
        }
    }
    assert!(count >= 2, "examples/sessions holds the example scripts");
}

#[test]
fn each_task_keeps_its_work_and_switching_to_the_current_one_changes_nothing() {
    let mut s = positioning(9);
    let t = transcript(
        &mut s,
        "task positioning\nrun goal 2 -1 0\ntask interception\nload demos teacher:3\nrun start 0\ntask positioning\nshow\nhistory\ntask interception\nselect 0..10\n",
    );
    insta::assert_snapshot!(t);
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

#[test]
fn an_empty_policy_and_unbounded_numbers_are_refused() {
    let mut s = positioning(0);
    let t = transcript(
        &mut s,
        "run goal 2 -1 0\nrun start 0\nload demos teacher:1\nrun goal 1e200 0 0\nrun goal 2 -1 7\nrun goal 2 -1 0\nselect 0..10\ncritique 1e308\ncritique 0\n",
    );
    assert_eq!(s.learner().dataset().critiques().len(), 0);
    insta::assert_snapshot!(t);
}

#[test]
fn any_execution_can_be_shown_selected_and_advised_and_numbers_agree() {
    let mut s = positioning(9);
    let t = transcript(
        &mut s,
        "run goal 2 -1 0.5\nrun goal 1 -2 0\nselect 20..40 in 0\nadvise slow_down(0.3)\nwhy 30\nselect 10..20\ncritique\nhistory\nshow 5\nselect 0..10 in 7\nlearner bc\nrun goal 2 -1 0.5\nlearner lwr\nlearner knn\n",
    );
    insta::assert_snapshot!(t);
}

#[test]
fn eval_says_what_changed_since_the_last_one() {
    let mut s = positioning(9);
    let t = transcript(
        &mut s,
        "eval\nrun goal 2 -1 0.5\nselect 20..60\nadvise slow_down(0.5)\neval --detail\nundo\neval\n",
    );
    insta::assert_snapshot!(t);
}

#[test]
fn help_groups_the_commands_by_the_workflow() {
    let mut s = positioning(0);
    insta::assert_snapshot!(transcript(&mut s, "help\n"));
}

#[test]
fn a_misspelt_command_gets_the_one_that_was_meant() {
    let mut s = positioning(0);
    insta::assert_snapshot!(transcript(
        &mut s,
        "selec 0..1\nadvize slow_down\nfoo\nadvise slow_down(\n"
    ));
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
    insta::assert_snapshot!(advise::repl::render(
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
    let t = transcript(
        &mut s,
        &format!(
            "run goal 2 -1 0.5\nselect 20..40\ncritique\nselect 45..60\nadvise slow_down(0.3)\nrun goal 2 -1 0.5\nselect 10..30 in 0\nshow\nplot {d}/path.svg\nplot actions {d}/actions.svg\nplot compare {d}/compare.svg 0 1\nplot compare {d}/none.svg 0 7\nload trace {d}/noposes.csv\nshow\nplot {d}/none.svg\nplot actions {d}/noposes.svg\nplot compare {d}/none.svg 0 2\n"
        ),
    );
    let t = t.replace(&d, "<dir>");
    insta::assert_snapshot!(t);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap();
    assert!(read("path.svg").contains("critiqued 20..40"));
    assert!(read("actions.svg").contains("rot command (rad/s)"));
    assert!(read("compare.svg").contains("after: execution 1"));
    assert!(read("noposes.svg").contains("trans command (m/s)"));
    assert!(!dir.path().join("none.svg").exists());
}
