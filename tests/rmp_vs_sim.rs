//! The driver against the emulator with the simulator behind it, over real loopback sockets: the
//! same task runner drives a positioning controller to a goal through UDP, and the result is
//! compared with `run_sim` from the same start and seed.
//!
//! Why the two can differ at all, and the tolerance: in process, one control step commands the
//! base and advances it exactly 1/30 s, in lockstep. Over the wire the control loop runs in real
//! time at 30 Hz against a platform that integrates in 10 ms ticks and streams feedback at 100 Hz,
//! so each observation is up to one feedback period (10 ms) old, each command takes effect at the
//! platform's next tick (up to 10 ms late), and on a loaded machine a control step can be late by
//! a few more milliseconds. At the 1 m/s speed limit, 20 ms of skew is 2 cm of path per
//! decision, and the stopping rule may fire one or two control steps earlier or later. Both runs
//! use the noiseless simulator, so there is no noise stream to diverge; what remains is timing.
//! The tolerance for the teacher (a smooth controller): final poses within 0.15 m and 0.15 rad of
//! each other, final errors within 0.1 m, and both runs succeed (measured here: 3 mm, 0.000 rad).
//! For the LWR policy twice that: its regression switches neighbourhoods as the base moves, so a
//! few milliseconds of skew can pick a different set of neighbours and a different action, and the
//! paths part further before the stopping rule ends them (measured here: 0.09 m, 0.11 rad). A
//! protocol or frame error (a wrong sign, a wrong unit, odometry in the wrong frame) moves the end
//! point by metres or radians, far outside either.
//!
//! Every socket binds 127.0.0.1 port 0; every wait is bounded.

use std::net::SocketAddr;

use advise::backend::Backend;
use advise::backend::rmp::config::{FaultInjection, MachineConfig};
use advise::backend::rmp::{Emulator, EmulatorConfig, EmulatorHandle, RmpBackend, RmpConfig};
use advise::backend::sim::SimParams;
use advise::eval::derive_policy;
use advise::policy::learner::LearnerKind;
use advise::task::{Controller, Execution, Start, TaskKind, record_demos, run_episode, run_sim};
use advise::trace::{Episode, Pose};

/// The platform's own limits are set no tighter than the simulator's (1 m/s, 1 rad/s, 1 m/s^2,
/// 2 rad/s^2), so that the base behind the wire is the simulated one and not a slower platform.
fn machine() -> MachineConfig {
    MachineConfig {
        velocity_limit_mps: 1.0,
        accel_limit_mps2: 2.0,
        decel_limit_mps2: 2.0,
        dtz_decel_mps2: 2.0,
        yaw_rate_limit_radps: 1.0,
        yaw_accel_limit_radps2: 4.0,
        ..MachineConfig::default()
    }
}

fn params() -> SimParams {
    SimParams::default().noiseless()
}

fn emulator(faults: FaultInjection) -> EmulatorHandle {
    Emulator::bind_sim(
        "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
        EmulatorConfig {
            init_s: 0.05,
            machine: machine(),
            faults,
            seed: 5,
            ..EmulatorConfig::default()
        },
        params(),
        0,
    )
    .unwrap()
}

fn connect(emu: &EmulatorHandle) -> RmpBackend {
    RmpBackend::connect(
        emu.addr(),
        RmpConfig {
            machine: machine(),
            period_s: params().period_s(),
            // Generous: a loaded CI machine may starve the receiver thread for a while.
            link_timeout_s: 1.0,
            step_timeout_s: 10.0,
            ..RmpConfig::default()
        },
    )
    .unwrap()
}

fn over_the_wire(
    rmp: &mut RmpBackend,
    start: &Start,
    c: &mut dyn Controller,
    seed: u64,
) -> Execution {
    let mut task = start.task();
    match run_episode(rmp, task.as_mut(), c, seed) {
        Ok(e) => e,
        Err(i) => panic!(
            "interrupted: {:?} after {} steps",
            i.error,
            i.execution.trace.len()
        ),
    }
}

/// `tol`: how far apart the final poses may be, in metres and radians (see the module docs).
/// `must_succeed`: the run must reach its goal (the teacher's); a learned policy's run need only
/// end the same way over the wire as in the simulator.
fn assert_close(label: &str, wire: &Execution, sim: &Execution, tol: f64, must_succeed: bool) {
    let (w, s) = (&wire.outcome, &sim.outcome);
    let d = |a: Pose, b: Pose| ((a.x_m - b.x_m).powi(2) + (a.y_m - b.y_m).powi(2)).sqrt();
    let dtheta =
        advise::backend::rmp::emulator::wrap_angle(w.final_pose.theta_rad - s.final_pose.theta_rad);
    eprintln!(
        "{label}: wire {:?} {} steps, error {:.3} m / {:.3} rad, final {:?}; sim {:?} {} steps, error {:.3} m / {:.3} rad, final {:?}; apart {:.3} m, {:.3} rad",
        w.ending,
        w.steps,
        w.position_error_m,
        w.heading_error_rad.unwrap_or(f64::NAN),
        w.final_pose,
        s.ending,
        s.steps,
        s.position_error_m,
        s.heading_error_rad.unwrap_or(f64::NAN),
        s.final_pose,
        d(w.final_pose, s.final_pose),
        dtheta.abs()
    );
    if must_succeed {
        assert!(s.success, "{label}: the simulator run itself failed: {s:?}");
        assert!(w.success, "{label}: the run over the wire failed: {w:?}");
    }
    assert_eq!(w.success, s.success, "{label}");
    assert_eq!(w.ending, s.ending, "{label}");
    assert!(
        d(w.final_pose, s.final_pose) < tol,
        "{label}: final poses apart"
    );
    assert!(dtheta.abs() < tol, "{label}: final headings apart");
    assert!(
        (w.position_error_m - s.position_error_m).abs() < tol * 2.0 / 3.0,
        "{label}"
    );
    let (hw, hs) = (w.heading_error_rad.unwrap(), s.heading_error_rad.unwrap());
    assert!((hw - hs).abs() < tol, "{label}");
}

#[test]
fn the_teacher_and_an_lwr_policy_reach_a_goal_over_the_wire_as_in_the_simulator() {
    let emu = emulator(FaultInjection::default());
    let mut rmp = connect(&emu);
    let kind = TaskKind::Positioning;
    // The goal of the README's session.
    let start = Start::Goal(Pose::new(2.0, -1.0, 0.5));
    let seed = 7;

    // The positioning teacher (the stand-in for the human at the joystick).
    let mut teacher = kind.teacher(params().period_s());
    let wire = over_the_wire(&mut rmp, &start, teacher.as_mut(), seed);
    let mut teacher = kind.teacher(params().period_s());
    let sim = run_sim(&start, teacher.as_mut(), &params(), seed);
    assert_close("teacher", &wire, &sim, 0.15, true);
    // The emulator's base really went there: the driver's odometry in the start frame matches the
    // platform's true pose (noiseless odometry, and the base started at the origin).
    let truth = emu.snapshot().true_pose;
    let fin = wire.outcome.final_pose;
    assert!(
        (truth.x_m - fin.x_m).abs() < 0.05 && (truth.y_m - fin.y_m).abs() < 0.05,
        "{truth:?} vs {fin:?}"
    );

    // An LWR policy derived from teacher demonstrations recorded in the simulator, run on the
    // same base after the first episode: reset re-zeroes the frame where the base stands.
    // 40 demonstrations from seed 0's demonstration stream, to a goal where the run comes to rest
    // (short of it: since issue 48 the kernel is tuned on whole held-out demonstrations and
    // averages widely; whether the policy succeeds is the policy's business, here the wire must
    // do what the simulator does). A run that ends at the 60 s limit would take a minute.
    let demos: Vec<Episode> = record_demos(kind.clone(), 40, 0xD3E0, &params())
        .into_iter()
        .map(|(e, _)| e)
        .collect();
    let policy = derive_policy(LearnerKind::Lwr, &kind.domain(), &demos).unwrap();
    let mut c: &dyn advise::policy::Policy = policy.as_ref();
    let start = Start::Goal(Pose::new(3.0, 1.0, 0.0));
    let wire = over_the_wire(&mut rmp, &start, &mut c, seed);
    let sim = run_sim(&start, &mut c, &params(), seed);
    assert_close("lwr", &wire, &sim, 0.3, false);

    // Between and after episodes the base is brought to rest.
    rmp.stop().unwrap();
    assert!(emu.snapshot().speed_mps.abs() < 0.01);
    assert_eq!(rmp.name(), format!("rmp:{}", emu.addr()));
}

/// The lossy link: 10% of datagrams dropped and 1% corrupted, in both directions. A lost
/// command leaves the previous one in force (the platform's timeout is 0.5 s); a lost or corrupted
/// feedback leaves the driver on the one before, 10 ms older. The teacher still reaches the goal,
/// within the LWR tolerance of the in-process run (the skew is larger, the controller as smooth).
#[test]
fn the_teacher_still_reaches_the_goal_with_10_percent_dropped_and_1_percent_corrupted() {
    let emu = emulator(FaultInjection {
        drop: 0.10,
        corrupt: 0.01,
        ..FaultInjection::default()
    });
    let mut rmp = connect(&emu);
    let kind = TaskKind::Positioning;
    let start = Start::Goal(Pose::new(2.0, -1.0, 0.5));
    let mut teacher = kind.teacher(params().period_s());
    let wire = over_the_wire(&mut rmp, &start, teacher.as_mut(), 7);
    let mut teacher = kind.teacher(params().period_s());
    let sim = run_sim(&start, teacher.as_mut(), &params(), 7);
    assert_close("teacher, lossy link", &wire, &sim, 0.3, true);
    let e = emu.snapshot().counts;
    assert!(e.injected_drops > 50 && e.injected_corruptions > 0, "{e:?}");
    let c = rmp.counts();
    assert!(
        c.bad_crc > 0 || e.bad_crc > 0,
        "no corruption was seen: {c:?} {e:?}"
    );
}
