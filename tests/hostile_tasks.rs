//! Hostile task declarations (issue 31): goal ranges whose width overflows, time limits of a day,
//! observations and scores that are not numbers. The checker refuses what it can prove and warns
//! where it can only suspect; at run time a value that is not a number stops the run before any
//! controller sees it, the base is stopped, and the steps before it are kept; `demo` writes
//! nothing non-finite; an episode never takes more than `MAX_EPISODE_STEPS` steps whatever its
//! definition says. Task files are written by the tests; what a user sees is snapshotted.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;

use advise::backend::sim::{SimBackend, SimParams};
use advise::backend::{Backend, BackendError, BaseState};
use advise::check::{OperatorSet, Source};
use advise::eval::Report;
use advise::program::ir::Ir;
use advise::program::task::{EndRule, TaskDef};
use advise::task::{
    Controller, Declared, Ending, MAX_EPISODE_STEPS, Outcome, TaskKind, ValueKind, declared,
    run_episode,
};
use advise::trace::{Episode, Pose};
use miette::Diagnostic;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;
use common::{Invocation, masked};

/// A small task whose parts the tests replace: `GOAL` (px's range), `END` (extra end rules),
/// `LIMIT` (the time limit) and `OBS` (the observation `o`).
const TEMPLATE: &str = r#"/// A dock a metre in front of a point.
domain dock {
  observe range "m" in [0, 10] = hypot(dx, dy)
  observe bearing "rad" in [-pi, pi] = wrap(atan2(dy, dx) - theta)
  observe o "m" in [-10, 10] = OBS
  act trans "m/s" in [-0.5, 0.5] drives speed, rot "rad/s" in [-1, 1] drives turn
  goal px "m" in GOAL, py "m" in [-1, 1]
  let dx = px - x, dy = py - y
  score error = abs(range - 1)
  success when error < 0.1
  END
  end after LIMIT
  recorded px = x + cos(theta), py = y + sin(theta)
  teacher {
    trans = clamp(0.5 * (range - 1), -0.3, 0.3)
    rot = clamp(bearing, -0.8, 0.8)
  }
}
"#;

fn task_file(goal: &str, end: &str, limit: &str, obs: &str) -> String {
    TEMPLATE
        .replace("GOAL", goal)
        .replace("END", end)
        .replace("LIMIT", limit)
        .replace("OBS", obs)
}

/// The healthy dock.
fn healthy() -> String {
    task_file("[1, 3]", "", "30", "x")
}

/// A dock whose observation `o` stops being a number after half a second: it checks (with a
/// warning), so only the run-time rule can catch it.
fn breaks_at_half_a_second() -> String {
    task_file("[1, 3]", "", "30", "if(t > 0.5, 0 / 0, x)")
}

/// The checked task `name` of `text` (which must check).
fn def_of(text: &str, name: &str) -> Arc<TaskDef> {
    let set = OperatorSet::standard()
        .merge(&[Source::new("t.adv", text)])
        .unwrap_or_else(|e| panic!("{}", advise::check::render_all(&e)));
    set.task(name).unwrap().clone()
}

/// `advise ARGS` in a fresh directory holding `files`, as a user sees it: the command line, the
/// output and the exit code. Files are named relative to that directory, so no path of it shows.
fn advise(args: &[&str], files: &[(&str, String)]) -> (String, Option<i32>) {
    let inv = Invocation {
        args: args.iter().map(|a| a.to_string()).collect(),
        files: files
            .iter()
            .map(|(n, t)| (n.to_string(), t.clone().into_bytes()))
            .collect(),
    };
    let out = inv.run();
    let shown = format!(
        "{}\n{}\n(exit {:?})",
        inv.command_line(),
        out.text,
        out.code
    );
    (shown, out.code)
}

/// Snapshot what a user saw, wall-clock timings masked.
macro_rules! snapshot {
    ($text:expr) => {
        masked(None).bind(|| insta::assert_snapshot!($text))
    };
}

#[test]
fn check_refuses_the_reported_tasks_with_codes_on_their_spans() {
    let cases = [
        // The goal range whose width overflows (eval, demo and the REPL panicked drawing from it).
        ("wide.adv", task_file("[-1e308, 1e308]", "", "30", "x")),
        // A day with no other way to end: 2.59 M steps a run.
        ("day.adv", task_file("[1, 3]", "end when 0 > 1", "86400", "x")),
        // Observations that are never numbers, and one that reads a value that is not.
        (
            "nan.adv",
            TEMPLATE
                .replace("GOAL", "[1, 3]")
                .replace("END", "let q = px / (px - px)")
                .replace("LIMIT", "30")
                .replace(
                    "  observe o \"m\" in [-10, 10] = OBS\n",
                    "  observe a \"m\" in [-10, 10] = 0/0\n  observe b \"m\" in [-10, 10] = sqrt(-1)\n  observe c \"m\" in [-10, 10] = x/(x-x)\n  observe d \"m\" in [-10, 10] = 1e308*1e308\n  observe e \"m\" in [-10, 10] = q + 1\n",
                ),
        ),
        // A score that is never a number at the end of a run.
        (
            "score.adv",
            healthy().replace(
                "score error = abs(range - 1)",
                "score error = abs(range - 1) / (t - t)",
            ),
        ),
    ];
    let mut out = String::new();
    for (name, text) in cases {
        let (text, code) = advise(&["check", name], &[(name, text)]);
        assert_eq!(code, Some(1), "{text}");
        out.push_str(&text);
        out.push_str("\n\n");
    }
    for code in [
        "advise::check::task_goal_range_out_of_bounds",
        "advise::check::task_impossible_limit",
        "advise::check::task_not_finite",
    ] {
        assert!(out.contains(code), "{code}: {out}");
    }
    // Each of the issue's four observations, and the value `e` reads, is refused on its own.
    assert_eq!(out.matches("task_not_finite").count(), 6, "{out}");
    snapshot!(out);
}

#[test]
fn check_warns_where_a_value_may_not_be_a_number_and_the_shipped_tasks_have_no_warning() {
    let text = task_file("[1, 3]", "", "30", "1 / (x - 1)");
    let (shown, code) = advise(&["check", "warn.adv"], &[("warn.adv", text)]);
    assert_eq!(code, Some(0), "{shown}");
    assert!(
        shown.contains("advise::check::task_maybe_not_finite"),
        "{shown}"
    );
    let (shown_late, _) = advise(
        &["check", "late.adv"],
        &[("late.adv", breaks_at_half_a_second())],
    );
    snapshot!(format!("{shown}\n\n{shown_late}"));

    // The shipped declarations are numbers everywhere the checker looks.
    let root = env!("CARGO_MANIFEST_DIR");
    for file in [
        "operators/positioning.adv",
        "examples/tasks/standoff.adv",
        "tests/programs/ok/a_task_declaration.adv",
    ] {
        let text = std::fs::read_to_string(format!("{root}/{file}")).unwrap();
        let (map, id) = advise::diag::SourceMap::single(file, text.as_str());
        let checked = OperatorSet::standard()
            .merge_in(&map, &[id])
            .unwrap_or_else(|_| panic!("{file} does not check"));
        assert!(!checked.set.tasks().is_empty(), "{file}");
        assert!(
            checked.warnings.is_empty(),
            "{file}: {:?}",
            checked.warnings
        );
    }
}

#[test]
fn goal_ranges_that_got_past_the_checker_cannot_panic_the_draw() {
    let good = def_of(&healthy(), "dock");
    for (lo, hi) in [
        (-1e308, 1e308),
        (f64::MIN, f64::MAX),
        (f64::NEG_INFINITY, f64::INFINITY),
        (f64::NAN, 1.0),
        (2.0, 1.0),
        (5.0, 5.0),
    ] {
        let mut def = (*good).clone();
        def.goal[0].lo = lo;
        def.goal[0].hi = hi;
        let drawn = catch_unwind(AssertUnwindSafe(|| {
            let mut all = declared::test_goals(&def);
            all.extend(declared::practice_goals(&def, 7, 5));
            all.push(declared::practice_goal(&def, 7, 123_456));
            all
        }))
        .unwrap_or_else(|_| panic!("drawing from [{lo}, {hi}] panicked"));
        for g in &drawn {
            assert!(g.iter().all(|v| v.is_finite()), "[{lo}, {hi}]: {g:?}");
        }
    }
    // The draw of a good range is the one it always was: the N-th practice goal equals the
    // N-th of the set.
    let set = declared::practice_goals(&good, 3, 10);
    assert_eq!(declared::practice_goal(&good, 3, 9), set[9]);
}

/// A base that records what it was told.
struct Watched {
    inner: SimBackend,
    commands: usize,
    stopped: bool,
}

impl Watched {
    fn new() -> Watched {
        Watched {
            inner: SimBackend::new(SimParams::default(), 1),
            commands: 0,
            stopped: false,
        }
    }
}

impl Backend for Watched {
    fn name(&self) -> String {
        "watched".into()
    }
    fn period_s(&self) -> f64 {
        self.inner.period_s()
    }
    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        self.inner.reset(start)
    }
    fn command(&mut self, v: f64, w: f64) -> Result<(), BackendError> {
        self.commands += 1;
        self.inner.command(v, w)
    }
    fn step(&mut self) -> Result<BaseState, BackendError> {
        self.inner.step()
    }
    fn stop(&mut self) -> Result<(), BackendError> {
        self.stopped = true;
        self.inner.stop()
    }
    fn true_pose(&self) -> Option<Pose> {
        self.inner.true_pose()
    }
}

/// A controller that drives straight on at a fixed speed and notes what it was shown.
struct Probe {
    speed_mps: f64,
    queried: usize,
    seen_bad: bool,
}

impl Probe {
    fn new(speed_mps: f64) -> Probe {
        Probe {
            speed_mps,
            queried: 0,
            seen_bad: false,
        }
    }
}

impl Controller for Probe {
    fn act(&mut self, z: &[f64], a: &mut [f64]) {
        self.queried += 1;
        self.seen_bad |= z.iter().any(|v| !v.is_finite());
        a.fill(0.0);
        a[0] = self.speed_mps;
    }
}

#[test]
fn an_episode_takes_at_most_the_maximum_of_steps_whatever_its_definition_says() {
    // What the checker refuses (a day, no other end), as if it had got through.
    let mut def = (*def_of(&task_file("[1, 3]", "end when 0 > 1", "600", "x"), "dock")).clone();
    for e in &mut def.ends {
        if let EndRule::After { limit_s } = e {
            *limit_s = 86_400.0;
        }
    }
    let def = Arc::new(def);
    let mut task = Declared::new(def, &[2.0, 0.0]);
    let mut base = Watched::new();
    let mut still = Probe::new(0.0);
    let exec = run_episode(&mut base, &mut task, &mut still, 1).unwrap();
    assert_eq!(exec.outcome.steps, MAX_EPISODE_STEPS);
    assert_eq!(exec.trace.len(), MAX_EPISODE_STEPS);
    assert_eq!(exec.outcome.ending, Ending::TimeLimit);
    assert!(base.stopped);
}

#[test]
fn a_non_finite_observation_stops_the_run_before_any_controller_sees_it() {
    let def = def_of(&breaks_at_half_a_second(), "dock");
    let mut task = Declared::new(def, &[2.0, 0.0]);
    let mut base = Watched::new();
    let mut forward = Probe::new(0.2);
    let exec = run_episode(&mut base, &mut task, &mut forward, 1).unwrap();
    let (queried, seen_bad) = (forward.queried, forward.seen_bad);
    assert!(
        !seen_bad,
        "the controller was queried with a non-finite observation"
    );
    // 30 Hz: t = 16/30 > 0.5 at step 16; the 16 steps before it are kept.
    assert_eq!(exec.outcome.ending, Ending::NonFinite);
    assert_eq!(exec.trace.len(), 16);
    assert_eq!(queried, 16);
    assert_eq!(base.commands, 16);
    assert!(base.stopped, "the base was not stopped");
    assert!(!exec.outcome.success);
    assert!(exec.trace.z.iter().all(|v| v.is_finite()));
    let why = exec.outcome.non_finite.clone().unwrap();
    assert_eq!(
        (why.kind, why.name.as_str(), why.step),
        (ValueKind::Observation, "o", 16)
    );
    assert_eq!(
        why.code().map(|c| c.to_string()).as_deref(),
        Some("advise::task::non_finite")
    );
    // The outcome is saved and read back (JSON has no NaN: nothing in it may be one).
    let json = serde_json::to_string(&exec.outcome).unwrap();
    let back: Outcome = serde_json::from_str(&json).unwrap();
    assert_eq!(back, exec.outcome);
    insta::assert_snapshot!(advise::diag::render(
        &advise::diag::SourceMap::new(),
        &why,
        false
    ));
}

#[test]
fn a_non_finite_score_fails_the_run_and_stays_out_of_the_means() {
    // A score that is not a number at the end, as if it had got past the checker.
    let good = def_of(&healthy(), "dock");
    let mut bad = (*good).clone();
    for (slot, ir) in &mut bad.score {
        if *slot == bad.error {
            *ir = Ir::Num(f64::NAN);
        }
    }
    let bad = Arc::new(bad);
    let run = |def: &Arc<TaskDef>| {
        let mut task = Declared::new(def.clone(), &[2.0, 0.0]);
        let mut teacher = TaskKind::Declared(def.clone()).teacher(1.0 / 30.0);
        run_episode(&mut Watched::new(), &mut task, teacher.as_mut(), 1)
            .unwrap()
            .outcome
    };
    let (fine, broken) = (run(&good), run(&bad));
    assert!(fine.success, "{fine:?}");
    assert_eq!(broken.ending, Ending::NonFinite);
    assert!(!broken.success);
    assert_eq!(broken.position_error_m, 0.0);
    let why = broken.non_finite.clone().unwrap();
    assert_eq!((why.kind, why.name.as_str()), (ValueKind::Score, "error"));
    assert_eq!(why.step, broken.steps);
    let json = serde_json::to_string(&broken).unwrap();
    assert!(!json.contains("null"), "{json}");
    // The report's mean error is the scored run's alone; the stopped run is counted and named.
    let report = Report::from_outcomes(
        TaskKind::Declared(good.clone()),
        0,
        vec![fine.clone(), broken],
    );
    assert_eq!(report.mean_position_error_m, fine.position_error_m);
    assert_eq!(report.endings.get("non_finite"), Some(&1));
    assert!(
        report
            .render()
            .contains("episode 1 first: the score `error` was NaN")
    );
}

#[test]
fn demo_refuses_demonstrations_that_stopped_and_writes_nothing() {
    let files = [("late.adv", breaks_at_half_a_second())];
    let inv = Invocation {
        args: [
            "demo", "--tasks", "late.adv", "--task", "dock", "--count", "3", "--out", "d.csv",
        ]
        .map(String::from)
        .to_vec(),
        files: files
            .iter()
            .map(|(n, t)| (n.to_string(), t.clone().into_bytes()))
            .collect(),
    };
    // The run's directory is gone afterwards; look for the file in a run of our own.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("late.adv"), &files[0].1).unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(&inv.args)
        .current_dir(dir.path())
        .env("ADVISE_HOME", dir.path().join(".advise"))
        .output()
        .unwrap();
    assert_eq!(status.status.code(), Some(1));
    assert!(!dir.path().join("d.csv").exists(), "demo wrote its file");
    let (shown, code) = advise(
        &inv.args.iter().map(String::as_str).collect::<Vec<_>>(),
        &files,
    );
    assert_eq!(code, Some(1));
    assert!(shown.contains("advise::task::demos_not_finite"), "{shown}");
    assert!(shown.contains("advise::task::non_finite"), "{shown}");
    snapshot!(shown);
}

#[test]
fn eval_counts_the_runs_that_stopped_and_says_why() {
    let (shown, code) = advise(
        &[
            "eval", "--tasks", "late.adv", "--task", "dock", "--policy", "teacher",
        ],
        &[("late.adv", breaks_at_half_a_second())],
    );
    assert_eq!(code, Some(0), "{shown}");
    assert!(shown.contains("non_finite 25"), "{shown}");
    assert!(shown.contains("[advise::task::non_finite]"), "{shown}");
    snapshot!(shown);
}

#[test]
fn a_session_refuses_the_long_task_and_a_run_that_stops_keeps_its_steps_and_says_why() {
    // Demonstrations of the healthy dock (same domain), for a policy to run the broken one.
    let recorded = advise::task::record_demos(
        TaskKind::Declared(def_of(&healthy(), "dock")),
        3,
        1,
        &SimParams::default(),
    );
    let episodes: Vec<Episode> = recorded.into_iter().map(|(e, _)| e).collect();
    let mut csv = Vec::new();
    Episode::write_csv(&def_of(&healthy(), "dock").domain, &episodes, &mut csv).unwrap();
    let script = "tasks \"day.adv\"\ntasks \"late.adv\"\ntask dock\nload demos teacher:2\nload demos demos.csv\nrun start 0\nrun start 1\n";
    let (shown, code) = advise(
        &["run", "--no-journal", "--keep-going", "script.adv"],
        &[
            ("script.adv", script.to_string()),
            (
                "day.adv",
                task_file("[1, 3]", "end when 0 > 1", "86400", "x"),
            ),
            ("late.adv", breaks_at_half_a_second()),
            ("demos.csv", String::from_utf8(csv).unwrap()),
        ],
    );
    assert_ne!(code, Some(0), "{shown}");
    for c in [
        "advise::check::task_impossible_limit",
        "advise::task::demos_not_finite",
        "advise::session::run_stopped",
        "advise::task::non_finite",
    ] {
        assert!(shown.contains(c), "{c}: {shown}");
    }
    snapshot!(shown);
}

/// Seeded mutations of a task file: byte flips, deletions, repeats, and tokens that broke tasks
/// before.
fn mutate(rng: &mut ChaCha8Rng, input: &str) -> String {
    const TOKENS: &[&str] = &[
        "0/0",
        "sqrt(-1)",
        "/ (x - x)",
        "1e308",
        "-1e308",
        "1e999",
        "1e6",
        "86400",
        "600",
        "prev(",
        "end after",
        "end when",
        "for",
        "goal",
        "let",
        "observe",
        "score",
        "teacher",
        "recorded",
        "test",
        "seed",
        "in [",
        "]",
        "(",
        ")",
        ",",
        "/",
        "*",
        "-",
        "t",
        "x",
        "px",
        "range",
        "\n",
    ];
    let mut b = input.as_bytes().to_vec();
    for _ in 0..rng.random_range(1..=3) {
        let len = b.len();
        let at = rng.random_range(0..=len);
        match rng.random_range(0..4) {
            0 if len > 0 => {
                let i = at.min(len - 1);
                b[i] = b"0123456789.-e(){}[],/* \n"[rng.random_range(0..24)];
            }
            1 if len > 0 => {
                let end = (at + rng.random_range(1..=12)).min(len);
                b.drain(at.min(end)..end);
            }
            2 if len > 0 => {
                let from = rng.random_range(0..len);
                let end = (from + rng.random_range(1..=40)).min(len);
                let slice = b[from..end].to_vec();
                b.splice(at..at, slice);
            }
            _ => {
                let t = TOKENS[rng.random_range(0..TOKENS.len())];
                b.splice(at..at, format!(" {t}").into_bytes());
            }
        }
        b.truncate(2 * input.len());
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn codes(d: &dyn Diagnostic, bad: &mut Vec<String>) {
    match d.code().map(|c| c.to_string()) {
        Some(c) if c.starts_with("advise::") => {}
        other => bad.push(format!("{other:?}: {d}")),
    }
    for r in d.related().into_iter().flatten() {
        codes(r, bad);
    }
}

#[test]
fn mutated_task_files_check_or_are_refused_and_their_runs_stay_numbers() {
    let std = OperatorSet::standard();
    let seeds = [
        std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/tasks/standoff.adv"
        ))
        .unwrap(),
        breaks_at_half_a_second(),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let (mut checked, mut refused, mut failures) = (0, 0, Vec::new());
    for round in 0..400 {
        let input = mutate(&mut rng, &seeds[round % seeds.len()]);
        let result = catch_unwind(AssertUnwindSafe(|| {
            match std.merge(&[Source::new("fuzz.adv", input.clone())]) {
                Err(e) => {
                    let mut bad = Vec::new();
                    codes(&e, &mut bad);
                    (false, bad)
                }
                Ok(set) => {
                    let mut bad = Vec::new();
                    for def in set.tasks() {
                        let goal = declared::practice_goal(def, 1, 0);
                        let tests = declared::test_goals(def);
                        if goal
                            .iter()
                            .chain(tests.iter().flatten())
                            .any(|v| !v.is_finite())
                        {
                            bad.push(format!("{}: a goal that is not a number", def.name()));
                        }
                        let mut task = Declared::new(def.clone(), &goal);
                        let mut teacher = TaskKind::Declared(def.clone()).teacher(1.0 / 30.0);
                        // Its link is lost after a few steps, so that a mutant's run is short.
                        let mut base = common::Flaky::new(20);
                        let exec = match run_episode(&mut base, &mut task, teacher.as_mut(), 1) {
                            Ok(e) => e,
                            Err(i) => *i.execution,
                        };
                        if exec
                            .trace
                            .z
                            .iter()
                            .chain(&exec.trace.a)
                            .any(|v| !v.is_finite())
                        {
                            bad.push(format!("{}: a recorded value is not a number", def.name()));
                        }
                        if serde_json::to_string(&exec.outcome)
                            .ok()
                            .and_then(|j| serde_json::from_str::<Outcome>(&j).ok())
                            .is_none()
                        {
                            bad.push(format!("{}: the outcome does not read back", def.name()));
                        }
                    }
                    (true, bad)
                }
            }
        }));
        match result {
            Err(_) => failures.push(format!("panic for {input:?}")),
            Ok((ok, bad)) => {
                if ok {
                    checked += 1;
                } else {
                    refused += 1;
                }
                failures.extend(bad.into_iter().map(|b| format!("{b} for {input:?}")));
            }
        }
    }
    assert!(
        checked > 40 && refused > 40,
        "{checked} checked, {refused} refused"
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures
            .iter()
            .take(5)
            .map(|f| f.chars().take(800).collect::<String>())
            .collect::<Vec<_>>()
            .join("\n")
    );
}
