//! Safety and faults over real loopback sockets: the watchdog, stop on drop, the stop handle, a
//! lossy and corrupting link, corrupted feedback.
//!
//! Every socket binds 127.0.0.1 port 0; every loop is bounded in count and time.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use advise::backend::rmp::codec::OpState;
use advise::backend::rmp::config::{FaultInjection, MachineConfig};
use advise::backend::rmp::emulator::{Snapshot, relative_pose};
use advise::backend::rmp::{Emulator, EmulatorConfig, EmulatorHandle, RmpBackend, RmpConfig};
use advise::backend::{Backend, BackendError};
use advise::trace::Pose;

/// Quick to accelerate, slow to decelerate on its own (the platform's 0.5 s command timeout), quick
/// to decelerate on DTZ (what the watchdog asks for): the tests can tell who stopped the base.
fn machine() -> MachineConfig {
    MachineConfig {
        accel_limit_mps2: 2.0,
        decel_limit_mps2: 0.5,
        dtz_decel_mps2: 2.0,
        ..MachineConfig::default()
    }
}

fn emulator(faults: FaultInjection, seed: u64) -> EmulatorHandle {
    Emulator::bind(
        "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
        EmulatorConfig {
            init_s: 0.05,
            machine: machine(),
            faults,
            seed,
            ..EmulatorConfig::default()
        },
    )
    .unwrap()
}

fn config() -> RmpConfig {
    RmpConfig {
        machine: machine(),
        watchdog_timeout_s: 0.25,
        step_timeout_s: 3.0,
        ..RmpConfig::default()
    }
}

/// Get the base going at 0.6 m/s; returns when it is there (bounded).
fn cruise(b: &mut RmpBackend, emu: &EmulatorHandle) {
    for _ in 0..45 {
        b.command(0.6, 0.0).unwrap();
        b.step().unwrap();
        if emu.snapshot().speed_mps > 0.58 {
            return;
        }
    }
    panic!("never reached cruise speed: {:?}", emu.snapshot());
}

/// Sample the emulator every 5 ms for at most `for_s`, until `done`; each sample with its wall
/// time since `since`.
fn watch(
    emu: &EmulatorHandle,
    since: Instant,
    for_s: f64,
    done: impl Fn(&Snapshot) -> bool,
) -> Vec<(f64, Snapshot)> {
    let mut out = Vec::new();
    while since.elapsed().as_secs_f64() < for_s {
        let s = emu.snapshot();
        out.push((since.elapsed().as_secs_f64(), s));
        if done(&s) {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    out
}

fn at_rest(s: &Snapshot) -> bool {
    s.slewed_mps == 0.0 && s.speed_mps.abs() < 0.01 && s.state == OpState::Standby
}

/// Largest deceleration of the platform's slewed command between samples, on its own clock.
fn max_decel(samples: &[(f64, Snapshot)]) -> f64 {
    samples
        .windows(2)
        .filter(|w| w[1].1.t_s > w[0].1.t_s)
        .map(|w| (w[0].1.slewed_mps - w[1].1.slewed_mps) / (w[1].1.t_s - w[0].1.t_s))
        .fold(0.0, f64::max)
}

#[test]
fn when_commands_stop_the_watchdog_brings_the_base_to_rest_at_the_dtz_deceleration() {
    let emu = emulator(FaultInjection::default(), 0);
    let mut b = RmpBackend::connect(emu.addr(), config()).unwrap();
    b.reset(Pose::default()).unwrap();
    cruise(&mut b, &emu);
    b.command(0.6, 0.0).unwrap();
    let silent_from = Instant::now();
    // The session goes quiet (a hung policy, a crashed REPL): no more commands, no more steps.
    let samples = watch(&emu, silent_from, 2.0, at_rest);
    let (rested_at, last) = *samples.last().unwrap();
    assert!(at_rest(&last), "not at rest after 2 s: {last:?}");
    // Within the watchdog timeout and 0.6 m/s at 2 m/s^2, with a margin for a loaded machine; the
    // platform's own timeout would take 0.5 s + 1.2 s.
    assert!(rested_at < 0.25 + 0.3 + 0.6, "{rested_at}");
    // Not before the watchdog timeout: the base held its speed while the session was in time.
    for (t, s) in &samples {
        if *t < 0.2 {
            assert!(s.slewed_mps > 0.59, "slowed at {t}: {s:?}");
        }
    }
    // Never harder than the configured DTZ deceleration.
    let d = max_decel(&samples);
    assert!(d > 1.9 && d <= 2.0 + 1e-6, "{d}");
    assert_eq!(b.counts().watchdog_trips, 1);
    match b.command(0.6, 0.0) {
        Err(BackendError::Stopped { reason }) => assert!(reason.contains("watchdog"), "{reason}"),
        other => panic!("expected Stopped, got {other:?}"),
    }
    // The session can start again.
    b.reset(Pose::default()).unwrap();
    b.command(0.1, 0.0).unwrap();
    b.step().unwrap();
}

#[test]
fn dropping_the_session_stops_the_base_first() {
    let emu = emulator(FaultInjection::default(), 0);
    let mut b = RmpBackend::connect(emu.addr(), config()).unwrap();
    b.reset(Pose::default()).unwrap();
    cruise(&mut b, &emu);
    let dropped_at = Instant::now();
    drop(b);
    let samples = watch(&emu, dropped_at, 2.0, at_rest);
    let (rested_at, last) = *samples.last().unwrap();
    assert!(at_rest(&last), "{last:?}");
    assert!(rested_at < 0.3 + 0.6, "{rested_at}");
    assert!(max_decel(&samples) <= 2.0 + 1e-6);
}

#[test]
fn the_stop_handle_stops_the_base_from_another_thread() {
    let emu = emulator(FaultInjection::default(), 0);
    let mut b = RmpBackend::connect(emu.addr(), config()).unwrap();
    b.reset(Pose::default()).unwrap();
    cruise(&mut b, &emu);
    let handle = b.stop_handle();
    std::thread::spawn(move || handle.stop()).join().unwrap();
    // The session's next command learns it was stopped.
    assert!(matches!(
        b.command(0.6, 0.0),
        Err(BackendError::Stopped { .. })
    ));
    let samples = watch(&emu, Instant::now(), 2.0, at_rest);
    assert!(at_rest(&samples.last().unwrap().1));
}

#[test]
fn a_commanded_motion_completes_with_10_percent_dropped_and_1_percent_corrupted() {
    let faults = FaultInjection {
        drop: 0.10,
        corrupt: 0.01,
        ..FaultInjection::default()
    };
    let emu = emulator(faults, 7);
    let mut b = RmpBackend::connect(emu.addr(), config()).unwrap();
    let start = Pose::new(0.0, 0.0, 0.0);
    b.reset(start).unwrap();
    // Drive to (0.4, 0.15) on odometry with a proportional controller.
    let goal = (0.4, 0.15);
    let mut reached = None;
    for k in 0..240 {
        let s = b.step().unwrap();
        let (dx, dy) = (goal.0 - s.pose.x_m, goal.1 - s.pose.y_m);
        let dist = dx.hypot(dy);
        if dist < 0.05 {
            reached = Some((k, s));
            break;
        }
        let bearing = (dy.atan2(dx) - s.pose.theta_rad)
            .sin()
            .atan2((dy.atan2(dx) - s.pose.theta_rad).cos());
        let v = (1.5 * dist).min(0.5) * bearing.cos().max(0.0);
        b.command(v, 2.0 * bearing).unwrap();
    }
    let (k, s) = reached.expect("the motion never completed");
    b.stop().unwrap();
    assert!(k < 240);
    // The driver's odometry is the platform's, moved to the start frame: at rest they agree.
    let odom = emu.snapshot().odom;
    let here = relative_pose(start, b.step().unwrap().pose);
    assert!(
        (here.x_m - odom.x_m).abs() < 0.01 && (here.y_m - odom.y_m).abs() < 0.01,
        "{s:?} {odom:?}"
    );
    let e = emu.snapshot().counts;
    assert!(e.injected_drops > 10 && e.injected_corruptions > 0, "{e:?}");
    let c = b.counts();
    // Corrupted feedback is counted, never taken.
    assert_eq!(c.implausible, 0);
    assert!(c.feedback > 100, "{c:?}");
}

#[test]
fn corrupted_feedback_never_changes_state() {
    let faults = FaultInjection {
        corrupt: 0.2,
        ..FaultInjection::default()
    };
    let emu = emulator(faults, 11);
    let mut b = RmpBackend::connect(emu.addr(), config()).unwrap();
    let start = Pose::new(1.0, 2.0, 0.3);
    b.reset(start).unwrap();
    for _ in 0..30 {
        b.command(0.0, 0.0).unwrap();
        let s = b.step().unwrap();
        // The base stands still, so any accepted corrupted frame would show as a moved pose.
        assert_eq!(s.pose, start);
        assert_eq!((s.speed_mps, s.rot_radps), (0.0, 0.0));
    }
    let c = b.counts();
    assert!(c.bad_crc > 10, "{c:?}");
    assert_eq!(emu.snapshot().state, OpState::Tractor);
}

#[test]
fn corrupt_odometry_stops_the_base_and_ends_the_run() {
    for bad in [f32::NAN, f32::INFINITY, 3.0e38] {
        let emu = emulator(FaultInjection::default(), 0);
        let mut b = RmpBackend::connect(emu.addr(), config()).unwrap();
        b.reset(Pose::default()).unwrap();
        cruise(&mut b, &emu);
        emu.corrupt_odometry(bad);
        let corrupted_at = Instant::now();
        // The next step sees the corrupt feedback (feedback comes at 100 Hz; a step waits a
        // control period), never hands it to the policy, and stops the base.
        let mut ended = None;
        for _ in 0..10 {
            match b.step() {
                Ok(s) => {
                    assert!(s.pose.x_m.is_finite() && s.pose.x_m.abs() < 10.0, "{s:?}");
                    b.command(0.6, 0.0).unwrap();
                }
                Err(e) => {
                    ended = Some(e);
                    break;
                }
            }
        }
        match ended {
            Some(BackendError::BadOdometry { what, .. }) => {
                assert!(what.contains("its x is"), "{what}")
            }
            other => panic!("expected BadOdometry for {bad}, got {other:?}"),
        }
        // Zero (DTZ) was asked for at once: the platform is slowing within a step or two of the
        // corrupt frame (well before the 0.25 s watchdog would have stopped the silent session,
        // with a margin for a loaded machine), and commands are refused until the next reset.
        let samples = watch(&emu, corrupted_at, 2.0, |s| s.slewed_mps < 0.55);
        let (slowing_at, _) = *samples.last().unwrap();
        assert!(slowing_at < 0.2, "{bad}: slowing only after {slowing_at} s");
        assert!(matches!(
            b.command(0.6, 0.0),
            Err(BackendError::Stopped { .. })
        ));
        let samples = watch(&emu, corrupted_at, 3.0, at_rest);
        assert!(at_rest(&samples.last().unwrap().1), "{bad}");
    }
}
