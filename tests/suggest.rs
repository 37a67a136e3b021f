//! The teacher's copilot (issue 52): `suggest` on fixed seeds, on positioning and on a declared
//! task with `flaw` clauses, as the teacher reads it; `accept` journalled as `select` + `advise`
//! and restored; conflicting advice named; the refusals. Every session here is on the simulator
//! with a fixed seed, so the transcripts are the same on every machine; the re-run budget is set
//! far above what the candidates take (a slow machine must not cut a transcript short), and the
//! number of re-runs is bounded by `suggest::MAX_RERUNS` whatever the budget.

mod common;

use advise::session::{Reply, Session, SessionOptions};
use advise::task::TaskKind;
use common::{masked, positioning, raw_transcript};

/// The budget the tests give `suggest`: generous, still bounded.
const BUDGET_S: f64 = 600.0;

fn on_positioning() -> Session {
    let mut s = positioning(9);
    s.set_suggest_budget(BUDGET_S);
    s
}

fn on_standoff() -> Session {
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Positioning,
        ..SessionOptions::default()
    })
    .unwrap();
    s.set_suggest_budget(BUDGET_S);
    for line in [
        "tasks examples/tasks/standoff.adv",
        "task standoff",
        "load demos teacher:9",
    ] {
        s.execute(line, "<setup>").unwrap();
    }
    s
}

#[test]
fn suggest_on_positioning() {
    let mut s = on_positioning();
    let t = raw_transcript(&mut s, "run start 2\nsuggest\naccept 1\nhistory\nsuggest 0");
    masked(None).bind(|| insta::assert_snapshot!(t));
}

#[test]
fn suggest_on_a_declared_task_with_flaws() {
    let mut s = on_standoff();
    let t = raw_transcript(
        &mut s,
        "run start 0\nsuggest\nrun start 3\nsuggest\naccept 1\nrun start 3",
    );
    masked(None).bind(|| insta::assert_snapshot!(t));
}

/// The best suggestion's re-run is what `accept` then gives: the same start with the same noise
/// on the session's own learner shows the effect the suggestion promised.
#[test]
fn an_accepted_suggestion_does_what_its_rerun_showed() {
    let mut s = on_positioning();
    s.execute("run start 2", "<t>").unwrap();
    let Reply::Suggested(sug) = s.execute("suggest", "<t>").unwrap() else {
        panic!("suggest replies with suggestions")
    };
    let first = sug.suggestions.first().expect("a suggestion").clone();
    let promised = first.after.expect("re-run on the simulator");
    let advise::session::suggest::Trial::Simulated { before, .. } = sug.trial else {
        panic!("the simulator re-runs")
    };
    // The baseline re-run is the recorded run: same learner, start and noise.
    let recorded = s.executions()[0].execution.clone().unwrap().outcome;
    assert_eq!(before.error, recorded.position_error_m);
    assert_eq!(before.length_m, recorded.length_m);
    assert!(matches!(
        s.execute("accept 1", "<t>").unwrap(),
        Reply::Advised(_)
    ));
    let rec = &s.executions()[0];
    assert_eq!(rec.advised, vec![first.chunk]);
    // Re-run the same start with the same noise on the advised learner, as `suggest` did on
    // its copy.
    let mut learner = s.learner().copy();
    learner.prepare();
    let start = TaskKind::Positioning.practice_start(0, 2).unwrap();
    let seed = advise::task::episode_seed(0, 1_000_000);
    let mut policy = learner.policy();
    let again = advise::task::run_sim(&start, &mut policy, &Default::default(), seed);
    assert_eq!(again.outcome.position_error_m, promised.error);
    assert_eq!(again.outcome.length_m, promised.length_m);
    assert_eq!(again.outcome.success, promised.success);
}

#[test]
fn accept_is_journalled_as_select_and_advise_and_restores() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = on_positioning();
    let journal = live.start_journal(dir.path()).unwrap();
    live.execute("run start 2", "<t>").unwrap();
    live.execute("suggest", "<t>").unwrap();
    let Reply::Advised(a) = live.execute("accept 2", "<t>").unwrap() else {
        panic!("accept advises")
    };
    let text = std::fs::read_to_string(&journal).unwrap();
    let statements: Vec<String> = text
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| {
            v.get("statement")
                .and_then(|s| s.as_str())
                .map(String::from)
        })
        .filter(|s| !s.is_empty())
        .collect();
    let select = format!("select {} in 0", a.chunk);
    let advise = format!("advise {}", a.invocation);
    assert_eq!(
        statements[statements.len() - 2..],
        [select.clone(), advise.clone()],
        "{statements:?}"
    );
    assert!(
        !text.contains("suggest"),
        "suggest changes nothing and is not journalled"
    );
    let (len, actions, advised) = (
        live.learner().len(),
        live.learner().dataset().points().a.to_vec(),
        live.executions()[0].advised.clone(),
    );
    drop(live);
    let back = Session::restore(&journal, dir.path()).unwrap().session;
    assert_eq!(back.learner().len(), len);
    assert_eq!(back.learner().dataset().points().a, &actions[..]);
    assert_eq!(back.executions()[0].advised, advised);
}

#[test]
fn contradicting_advice_on_the_same_chunk_names_the_earlier_advice() {
    let mut s = on_positioning();
    let t = raw_transcript(
        &mut s,
        "run start 2\nselect 200..230\nadvise translational_deceleration(gain = 0.9)\n\
         advise translational_acceleration(gain = 2)\nhistory --conflicts\nundo\nhistory --conflicts",
    );
    masked(None).bind(|| insta::assert_snapshot!(t));
}

#[test]
fn advice_that_refines_earlier_advice_is_no_conflict() {
    let mut s = on_positioning();
    s.execute("run start 2", "<t>").unwrap();
    s.execute("select 200..230", "<t>").unwrap();
    s.execute("advise translational_deceleration(gain = 0.25)", "<t>")
        .unwrap();
    let Reply::Advised(a) = s
        .execute("advise translational_deceleration(gain = 0.5)", "<t>")
        .unwrap()
    else {
        panic!("advised")
    };
    assert_eq!(a.conflict, None);
}

#[test]
fn refusals() {
    let mut s = on_positioning();
    let t = raw_transcript(
        &mut s,
        "accept 1\nsuggest\nrun start 2\nsuggest 7\naccept 1\ntask interception\nload demos teacher:3\nrun start 0\nsuggest",
    );
    masked(None).bind(|| insta::assert_snapshot!(t));
}

/// A run opened from a saved dataset is not one this session can re-create: its candidates are
/// listed without a re-run, and the reply says so.
#[test]
fn without_a_rerun_the_candidates_are_listed_and_it_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let saved = dir.path().join("saved.json");
    let mut s = on_positioning();
    s.execute("run start 2", "<t>").unwrap();
    s.execute(&format!("save \"{}\"", saved.display()), "<t>")
        .unwrap();
    let mut other = on_positioning();
    let t = raw_transcript(
        &mut other,
        &format!("open \"{}\"\nsuggest 0", saved.display()),
    );
    masked(Some(dir.path())).bind(|| insta::assert_snapshot!(t));
}

/// The README's Suggestions section quotes these tests' transcripts (abridged with `...`): each
/// line it shows is a line of the snapshot the tests above check against what the session says.
#[test]
fn the_readme_quotes_what_suggest_prints() {
    let readme = include_str!("../README.md");
    let start = readme
        .find("### Suggestions: `suggest`")
        .expect("the README's Suggestions section");
    let section = &readme[start..];
    let section = &section[..section[4..].find("\n### ").map_or(section.len(), |e| e + 4)];
    let snapshots = [
        include_str!("snapshots/suggest__suggest_on_positioning.snap"),
        include_str!(
            "snapshots/suggest__contradicting_advice_on_the_same_chunk_names_the_earlier_advice.snap"
        ),
    ];
    let blocks: Vec<&str> = section.split("```").skip(1).step_by(2).collect();
    assert_eq!(blocks.len(), 2, "two transcripts");
    for (block, snap) in blocks.iter().zip(snapshots) {
        for line in block
            .lines()
            .filter(|l| !l.trim().is_empty() && l.trim() != "...")
        {
            assert!(
                snap.lines().any(|s| s == line),
                "the README quotes a line the session does not print:\n{line}"
            );
        }
    }
}

/// What the web view reads: the last `suggest` beside the run, each suggestion with the points
/// its hover draws (the same as `preview` of it would give).
#[test]
fn the_web_view_state_carries_the_suggestions_and_their_previews() {
    let mut s = on_positioning();
    s.execute("run start 2", "<t>").unwrap();
    s.execute("suggest", "<t>").unwrap();
    let view = s.view_json(None);
    let sug = &view["suggestions"];
    assert_eq!(sug["execution"], 0);
    let first = &sug["suggestions"][0];
    let (a, b) = (
        first["chunk"]["start"].as_u64().unwrap(),
        first["chunk"]["end"].as_u64().unwrap(),
    );
    // The preview of the same advice on the same chunk gives the same points.
    s.execute(&format!("select {a}..{b} in 0"), "<t>").unwrap();
    let inv = first["invocation"].as_str().unwrap();
    let (_, data) = s.execute_previewing(&format!("preview {inv}"), "<t>");
    assert_eq!(first["preview"]["after"], data["after"]);
    assert_eq!(first["preview"]["source_index"], data["source_index"]);
}
