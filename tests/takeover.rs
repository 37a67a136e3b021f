//! The teacher takes over a run (issue 53): the window's points are a demonstration linked to the
//! run, restored from the journal without driving anything, kept by `save` and `open`; live on
//! the RMP emulator from a person's keys.
//!
//! Sockets bind 127.0.0.1 only; every wait and every loop is bounded.

use std::time::Duration;

use advise::session::{Reply, Session};

mod common;
use common::execute_all as run;
use common::{copy_of, emulator, positioning, restore_hearing_nothing, saved};

fn text(s: &mut Session, line: &str) -> String {
    run(s, line).remove(0).to_string()
}

const WORK: &str = "run goal 2 -1 0.5 takeover 2..4
run start 3 takeover 0.5..1
undo
select 5..15
advise slow_down
undo
undo
redo
redo
run goal 1 -2 0 takeover 1..1.5
";

#[test]
fn a_takeover_is_restored_from_the_journal_as_the_demonstration_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = positioning(9);
    let journal = live.start_journal(dir.path()).unwrap();
    let replies = run(&mut live, WORK);
    let Reply::Ran(first) = &replies[0] else {
        panic!("{:?}", replies[0])
    };
    assert_eq!(first.takeovers.len(), 1);
    assert_eq!(
        (first.takeovers[0].steps.start, first.takeovers[0].steps.end),
        (60, 120)
    );
    // Positioning keeps its demonstrations at 15 Hz: every other step of the window.
    assert_eq!(first.takeovers[0].points, 30);
    run(&mut live, "select 0..5 in 0");
    let why = text(&mut live, "why 64");
    assert!(why.contains("from takeover #1: the teacher took over execution 0 for steps 60..120, from execution point 64"), "{why}");
    let expected = saved(&mut live, &dir.path().join("live.json"));
    let history = text(&mut live, "history");
    assert_eq!(history.lines().count(), 3, "{history}");
    assert!(
        history.contains("takeover of execution 0") && history.contains("takeover of execution 2"),
        "{history}"
    );

    let restored = Session::restore(&copy_of(&journal), dir.path()).unwrap();
    assert!(restored.stopped.is_none(), "{:?}", restored.stopped);
    let mut back = restored.session;
    assert_eq!(saved(&mut back, &dir.path().join("back.json")), expected);
    assert_eq!(text(&mut back, "history"), history);
    run(&mut back, "select 0..5 in 0");
    assert_eq!(text(&mut back, "why 64"), why);
    // The restored takeover is an edit like the live one: undo takes its points back.
    let before = back.learner().len();
    let undone = text(&mut back, "undo");
    assert!(undone.starts_with("undid: #"), "{undone}");
    assert!(undone.contains("takeover of execution 2"), "{undone}");
    assert_eq!(back.learner().len(), before - 8);
}

#[test]
fn a_saved_dataset_keeps_the_link_and_open_gives_the_takeover_back() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = positioning(9);
    run(&mut s, "run goal 2 -1 0.5 takeover 2..4");
    // The plots mark the window the teacher drove.
    for kind in ["", "actions "] {
        let svg = dir.path().join(format!("{}p.svg", kind.trim()));
        run(&mut s, &format!("plot {kind}{}", svg.display()));
        let text = std::fs::read_to_string(&svg).unwrap();
        // The legend wraps its label: the kind on one line, the steps on the next.
        assert!(
            text.contains("the teacher drove") && text.contains("60..120"),
            "{kind}plot"
        );
    }
    let file = dir.path().join("d.json");
    let bytes = saved(&mut s, &file);
    let json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    let linked: Vec<&serde_json::Value> = json["demos"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d.get("takeover").is_some())
        .collect();
    assert_eq!(linked.len(), 1);
    assert_eq!(
        linked[0]["takeover"],
        serde_json::json!({"execution": json["executions"][0]["id"], "steps": {"start": 60, "end": 120}, "every": 2})
    );
    let mut opened = positioning(0);
    run(&mut opened, &format!("open {}", file.display()));
    let history = text(&mut opened, "history");
    assert!(
        history.contains("#1 takeover of execution 0") && history.contains("steps 60..120"),
        "{history}"
    );
    let why = text(&mut opened, "why 70");
    assert!(why.contains("from takeover #1"), "{why}");
    let n = opened.learner().len();
    run(&mut opened, "undo");
    assert_eq!(opened.learner().len(), n - 30);
    // A file whose takeover names steps outside its run is refused whole.
    let bad = String::from_utf8(bytes)
        .unwrap()
        .replace("\"end\":120", "\"end\":99999");
    let bad_file = dir.path().join("bad.json");
    std::fs::write(&bad_file, bad).unwrap();
    let err = positioning(0)
        .execute(&format!("open {}", bad_file.display()), "<test>")
        .unwrap_err();
    let shown = advise_cli::repl::render(s.sources(), &err, false);
    assert!(shown.contains("demos[9].takeover"), "{shown}");
}

#[test]
fn a_takeover_on_the_rmp_is_resumed_without_driving_it_again() {
    let dir = tempfile::tempdir().unwrap();
    let emu = emulator();
    let addr = emu.addr();
    let mut live = positioning(9);
    let journal = live.start_journal(dir.path()).unwrap();
    run(&mut live, &format!("backend rmp:{addr}"));
    // Stopped (as Ctrl-C does) two seconds in, after the window: an interrupted run keeps what
    // the teacher drove and says so.
    let stop = live.stop_signal();
    let err = std::thread::scope(|scope| {
        scope.spawn(|| {
            std::thread::sleep(Duration::from_secs(2));
            stop.raise();
        });
        live.execute("run goal 3 1 0 takeover 0.5..1", "<test>")
    })
    .unwrap_err();
    let said = err.to_string();
    assert!(
        said.contains("was interrupted")
            && said.contains(
                "the teacher drove steps 15..30 (0.50 s to 1.00 s), kept as takeover #1 (8 points)"
            ),
        "{said}"
    );
    let expected = saved(&mut live, &dir.path().join("a.json"));
    drop(live);
    drop(emu);
    // Whatever answers on the robot's address now hears nothing from a resume.
    let restored = restore_hearing_nothing(&journal, dir.path(), addr);
    let mut s = restored.session;
    assert_eq!(saved(&mut s, &dir.path().join("b.json")), expected);
    assert!(text(&mut s, "history").contains("#1 takeover of execution 0"));
}

/// Poll the emulator every 5 ms for at most `for_s` until `done`; whether it happened.
fn wait_for(
    emu: &advise::backend::rmp::EmulatorHandle,
    for_s: f64,
    done: impl Fn(&advise::backend::rmp::EmulatorHandle) -> bool,
) -> bool {
    let t0 = std::time::Instant::now();
    while t0.elapsed().as_secs_f64() < for_s {
        if done(emu) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    done(emu)
}

/// The live takeover in the real REPL on the RMP emulator: while `run` drives the base, Tab takes
/// over holding the learner's command, the person's keys set the base's speed, Tab hands back
/// and the learner drives again; Ctrl-C (a key in the run's raw mode) stops the base and
/// ends the run; the window the person drove is kept as a takeover `history` lists.
#[cfg(unix)]
#[test]
fn a_person_takes_over_a_run_on_the_rmp_from_the_terminal() -> Result<(), rexpect::error::Error> {
    let emu = emulator();
    let home = tempfile::tempdir().unwrap();
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_advise"));
    cmd.args(["repl", "--no-journal", "--backend"])
        .arg(format!("rmp:{}", emu.addr()))
        .env("ADVISE_HOME", home.path())
        .env("NO_COLOR", "1")
        .env("TERM", "xterm");
    let mut p = rexpect::session::spawn_command(cmd, Some(60_000))?;
    p.exp_string("advise> ")?;
    p.send_line("run goal 3 1 0")?;
    p.exp_string("Tab takes over")?;
    let moving = |e: &advise::backend::rmp::EmulatorHandle| e.snapshot().speed_mps > 0.2;
    assert!(wait_for(&emu, 30.0, moving), "{:?}", emu.snapshot());
    p.send("\t")?;
    p.flush()?;
    p.exp_string("you drive")?;
    // Held at the learner's command: still moving a moment after the takeover.
    std::thread::sleep(Duration::from_millis(200));
    assert!(emu.snapshot().speed_mps > 0.1, "{:?}", emu.snapshot());
    // Space zeroes the held command, two steps of speed make it 0.2 m/s: the base settles there,
    // whatever the learner would have done.
    p.send(" ww")?;
    p.flush()?;
    let held =
        |e: &advise::backend::rmp::EmulatorHandle| (e.snapshot().speed_mps - 0.2).abs() < 0.03;
    assert!(
        wait_for(&emu, 10.0, held),
        "the person's command did not drive the base: {:?}",
        emu.snapshot()
    );
    std::thread::sleep(Duration::from_millis(500));
    assert!(held(&emu), "{:?}", emu.snapshot());
    p.send("\t")?;
    p.flush()?;
    p.exp_string("handed back to the learner")?;
    std::thread::sleep(Duration::from_millis(300));
    p.send_control('c')?;
    p.exp_string("^C: stopping the base")?;
    let (_, said) = p.exp_regex(
        r"the teacher drove steps \d+\.\.\d+ \([^)]*\), kept as takeover #1 \(\d+ points\)",
    )?;
    assert!(said.contains("takeover #1"), "{said}");
    p.exp_string("advise> ")?;
    assert!(
        wait_for(&emu, 3.0, |e| e.snapshot().speed_mps.abs() < 0.01),
        "still moving after Ctrl-C: {:?}",
        emu.snapshot()
    );
    p.send_line("history")?;
    p.exp_string("#1 takeover of execution 0 (run goal 3 1 0 (interrupted))")?;
    p.exp_string("advise> ")?;
    p.send_line("quit")?;
    p.exp_eof()?;
    Ok(())
}
