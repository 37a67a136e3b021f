//! A new kind of base is one file and one registration: this file is the file (a recorder that
//! answers every step with a fixed pose and keeps every call made to it), and
//! `Registry::standard().with(RecorderKind::new())` is the registration. The session then reads
//! its spec, suggests it for a typo, completes it, connects it, drives it with `run` like any
//! robot, stops it on Ctrl-C and closes it when another base is chosen, with no other change.

use std::fmt;
use std::sync::{Arc, Mutex};

use advise::backend::{
    Backend, BackendError, BackendKind, BackendSpecError, Base, BaseState, Connect, Registry, Spec,
};
use advise::session::{Reply, Session, SessionOptions};
use advise::task::TaskKind;
use advise::trace::Pose;
use miette::Diagnostic;
use thiserror::Error;

/// Every call the recorder received, shared by the kind, its specs and the bases they connect.
#[derive(Debug, Default)]
struct Log {
    connects: Vec<String>,
    resets: Vec<Pose>,
    commands: Vec<(f64, f64)>,
    steps: usize,
    stops: usize,
    dropped: usize,
}

type Shared = Arc<Mutex<Log>>;

/// `recorder` or `recorder:X,Y`: a base that stands at (X, Y) whatever it is told.
struct RecorderKind {
    log: Shared,
}

impl BackendKind for RecorderKind {
    fn name(&self) -> &'static str {
        "recorder"
    }

    fn syntax(&self) -> &'static str {
        "recorder[:X,Y]"
    }

    fn about(&self) -> &'static str {
        "a base that stays where it is put"
    }

    fn parse(&self, spec: &str) -> Result<Box<dyn Spec>, BackendSpecError> {
        let at = spec.strip_prefix("recorder").unwrap_or(spec);
        let at = at.strip_prefix(':').unwrap_or("0,0");
        let bad = || BackendSpecError::of(RecorderError::Pose { at: at.to_string() });
        let (x, y) = at.split_once(',').ok_or_else(bad)?;
        let (x, y) = (x.parse().map_err(|_| bad())?, y.parse().map_err(|_| bad())?);
        Ok(Box::new(RecorderSpec {
            pose: Pose::new(x, y, 0.0),
            log: self.log.clone(),
        }))
    }
}

#[derive(Debug, Error, Diagnostic)]
enum RecorderError {
    #[error("`{at}` is not a position")]
    #[diagnostic(code(advise::test::recorder_pose), help("write `recorder:X,Y`"))]
    Pose { at: String },
}

#[derive(Debug)]
struct RecorderSpec {
    pose: Pose,
    log: Shared,
}

impl fmt::Display for RecorderSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "recorder:{},{}", self.pose.x_m, self.pose.y_m)
    }
}

impl Spec for RecorderSpec {
    fn connect(&self, _with: &Connect<'_>) -> Result<Box<dyn Base>, BackendError> {
        self.log.lock().unwrap().connects.push(self.to_string());
        Ok(Box::new(Recorder {
            name: self.to_string(),
            pose: self.pose,
            t_s: 0.0,
            log: self.log.clone(),
        }))
    }
}

struct Recorder {
    name: String,
    pose: Pose,
    t_s: f64,
    log: Shared,
}

impl Recorder {
    fn state(&self) -> BaseState {
        BaseState {
            t_s: self.t_s,
            pose: self.pose,
            ..BaseState::default()
        }
    }
}

impl Backend for Recorder {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn period_s(&self) -> f64 {
        1.0 / 30.0
    }

    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        self.log.lock().unwrap().resets.push(start);
        self.t_s = 0.0;
        Ok(self.state())
    }

    fn command(&mut self, speed_mps: f64, rot_radps: f64) -> Result<(), BackendError> {
        self.log
            .lock()
            .unwrap()
            .commands
            .push((speed_mps, rot_radps));
        Ok(())
    }

    fn step(&mut self) -> Result<BaseState, BackendError> {
        self.log.lock().unwrap().steps += 1;
        self.t_s += self.period_s();
        Ok(self.state())
    }

    fn stop(&mut self) -> Result<(), BackendError> {
        self.log.lock().unwrap().stops += 1;
        Ok(())
    }
}

impl Base for Recorder {
    fn describe(&self) -> Option<String> {
        Some(format!(
            "stands at ({}, {}) and records what it is told",
            self.pose.x_m, self.pose.y_m
        ))
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.log.lock().unwrap().dropped += 1;
    }
}

fn session(backends: Registry) -> Session {
    Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: 3,
        backends,
        ..SessionOptions::default()
    })
    .unwrap()
}

fn message(r: Reply) -> String {
    match r {
        Reply::Message(m) => m,
        other => panic!("{other:?}"),
    }
}

fn code(e: &advise::session::SessionError) -> String {
    e.code().map(|c| c.to_string()).unwrap_or_default()
}

#[test]
fn a_registered_kind_is_connected_by_its_spec_and_driven_by_run() {
    let log = Shared::default();
    let mut s = session(Registry::standard().with(RecorderKind { log: log.clone() }));

    let reply = message(s.execute("backend recorder:1.5,-0.5", "<test>").unwrap());
    assert_eq!(
        reply,
        "backend recorder:1.5,-0.5: stands at (1.5, -0.5) and records what it is told"
    );
    assert!(
        s.status().contains("backend recorder:1.5,-0.5"),
        "{}",
        s.status()
    );
    assert_eq!(log.lock().unwrap().connects, ["recorder:1.5,-0.5"]);

    // `run` drives it as it drives any robot: every point of the execution is a command it was
    // given, after a step it answered with its fixed pose.
    let Reply::Ran(ran) = s.execute("run goal 2 -1 0", "<test>").unwrap() else {
        panic!()
    };
    {
        let log = log.lock().unwrap();
        assert_eq!(log.resets.len(), 1);
        assert_eq!(log.commands.len(), ran.points, "{ran:?}");
        assert!(ran.points > 100, "{ran:?}");
        assert_eq!(log.steps, ran.points);
        assert!(
            log.commands
                .iter()
                .all(|(v, w)| v.is_finite() && w.is_finite())
        );
        // The episode ends with the base told to stop.
        assert!(log.stops >= 1);
    }
    // The goal is where the base never goes: 0.71 m from where it stands.
    assert!(ran.outcome.contains("0.71 m"), "{}", ran.outcome);

    // Ctrl-C at the prompt stops it through the trait.
    let stops = log.lock().unwrap().stops;
    assert_eq!(s.stop_robot(), "recorder:1.5,-0.5 stopped");
    assert_eq!(log.lock().unwrap().stops, stops + 1);

    // One base at a time: choosing another closes it before the other connects.
    assert_eq!(
        message(s.execute("backend sim", "<test>").unwrap()),
        "backend sim"
    );
    assert_eq!(log.lock().unwrap().dropped, 1);
    assert!(s.status().contains("backend sim"), "{}", s.status());
}

#[test]
fn a_registered_kind_is_suggested_completed_and_diagnosed() {
    let log = Shared::default();
    let registry = Registry::standard().with(RecorderKind { log: log.clone() });
    assert_eq!(registry.completions("rec"), ["recorder"]);
    assert_eq!(
        registry.completions("r"),
        ["recorder", "rmp:", "ros2", "ros2:"]
    );
    assert!(registry.describe().ends_with(
        "`ros2[:NAMESPACE]` (a ROS 2 base, or `advise ros2-sim`) and `recorder[:X,Y]` (a base that stays where it is put)"
    ));
    let mut s = session(registry);
    assert_eq!(s.backends().completions("rec"), ["recorder"]);

    let e = s.execute("backend recordr:1,2", "<test>").unwrap_err();
    assert_eq!(code(&e), "advise::backend::unknown");
    let shown = advise_cli::repl::render(s.sources(), &e, false);
    assert!(shown.contains("did you mean `recorder[:X,Y]`?"), "{shown}");
    assert!(shown.contains("<test>:1:9"), "{shown}");

    let e = s.execute("backend recorder:here", "<test>").unwrap_err();
    assert_eq!(code(&e), "advise::test::recorder_pose");
    assert!(s.status().contains("backend sim"), "{}", s.status());
    assert!(log.lock().unwrap().connects.is_empty());

    // A session without the registration does not know it.
    let mut plain = session(Registry::standard());
    let e = plain.execute("backend recorder", "<test>").unwrap_err();
    assert_eq!(code(&e), "advise::backend::unknown");
}
