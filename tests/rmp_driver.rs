//! The RMP driver against the emulator over real loopback sockets: start-up, motion and odometry,
//! limits, foreign and corrupted datagrams, lost link, faults and balance mode.
//!
//! Every socket binds 127.0.0.1 port 0; every loop is bounded in count and time.

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use advise::backend::rmp::codec::{self, Feedback, OpState, Platform, WordOrder, word};
use advise::backend::rmp::config::{BITMAP_BALANCE_ENABLED, DriveMode, MachineConfig};
use advise::backend::rmp::emulator::{compose_pose, relative_pose};
use advise::backend::rmp::{Emulator, EmulatorConfig, EmulatorHandle, RmpBackend, RmpConfig};
use advise::backend::{Backend, BackendError, BaseState};
use advise::trace::Pose;

fn loopback() -> SocketAddr {
    "127.0.0.1:0".parse().unwrap()
}

fn emulator(cfg: EmulatorConfig) -> EmulatorHandle {
    Emulator::bind(
        loopback(),
        EmulatorConfig {
            init_s: 0.05,
            ..cfg
        },
    )
    .unwrap()
}

fn quick() -> RmpConfig {
    RmpConfig {
        step_timeout_s: 2.0,
        ..RmpConfig::default()
    }
}

/// Run `n` control steps at constant command, returning the states.
fn drive(b: &mut RmpBackend, n: usize, v: f64, w: f64) -> Vec<BaseState> {
    (0..n)
        .map(|_| {
            b.command(v, w).unwrap();
            b.step().unwrap()
        })
        .collect()
}

/// As the REPL draws it.
fn render(e: &dyn miette::Diagnostic) -> String {
    advise::diag::render(&advise::diag::SourceMap::new(), e, false)
}

#[test]
fn starts_up_in_either_word_order() {
    for order in [WordOrder::Little, WordOrder::Big] {
        let emu = emulator(EmulatorConfig {
            order,
            ..EmulatorConfig::default()
        });
        let b = RmpBackend::connect(emu.addr(), quick()).unwrap();
        assert_eq!(b.platform(), Platform::Rmp220);
        let st = b.status().unwrap();
        assert_eq!(st.order, order);
        assert_eq!(st.state, Some(OpState::Standby));
        assert_eq!(b.fault_log().unwrap().len(), codec::FAULT_LOG_WORDS);
        assert_eq!(b.name(), format!("rmp:{}", emu.addr()));
        assert!((b.period_s() - 1.0 / 30.0).abs() < 1e-12);
        // The platform holds the configuration we loaded, and streams.
        assert_eq!(emu.snapshot().machine, MachineConfig::default());
        assert!(emu.snapshot().streaming);
        let c = b.counts();
        assert_eq!((c.bad_crc, c.foreign, c.implausible), (0, 0, 0));
    }
}

#[test]
fn loads_a_custom_machine_configuration_and_verifies_the_echo() {
    let emu = emulator(EmulatorConfig::default());
    let machine = MachineConfig {
        velocity_limit_mps: 0.8,
        dtz_decel_mps2: 1.5,
        bitmap: 0x3,
        ..MachineConfig::default()
    };
    let _b = RmpBackend::connect(emu.addr(), RmpConfig { machine, ..quick() }).unwrap();
    assert_eq!(emu.snapshot().machine, machine);
}

#[test]
fn motion_commands_move_the_base_and_odometry_follows_in_the_start_frame() {
    let emu = emulator(EmulatorConfig::default());
    let mut b = RmpBackend::connect(emu.addr(), quick()).unwrap();
    let odom0 = emu.snapshot().odom;
    let start = Pose::new(1.0, -2.0, 0.5);
    let s0 = b.reset(start).unwrap();
    assert_eq!((s0.t_s, s0.pose), (0.0, start));
    assert_eq!(emu.snapshot().state, OpState::Tractor);

    let states = drive(&mut b, 30, 0.5, 0.4);
    let last = states.last().unwrap();
    assert!(last.speed_mps > 0.2, "{last:?}");
    assert!(
        last.rot_radps > 0.2,
        "counter-clockwise is positive: {last:?}"
    );
    assert!(states.windows(2).all(|w| w[1].t_s > w[0].t_s));
    // About 30 steps at 30 Hz.
    assert!(last.t_s > 0.9 && last.t_s < 2.0, "{}", last.t_s);
    // Heading grew from the start heading; the base moved forward along it.
    assert!(last.pose.theta_rad > start.theta_rad + 0.1);
    let moved = relative_pose(start, last.pose);
    assert!(moved.x_m > 0.05, "{moved:?}");

    b.stop().unwrap();
    let rest = b.step().unwrap();
    assert!(rest.speed_mps.abs() < 0.02, "{rest:?}");
    // At rest the driver's pose is the platform's odometry, moved into the start frame.
    let want = compose_pose(start, relative_pose(odom0, emu.snapshot().odom));
    assert!((rest.pose.x_m - want.x_m).abs() < 1e-3, "{rest:?} {want:?}");
    assert!((rest.pose.y_m - want.y_m).abs() < 1e-3);
    assert!((rest.pose.theta_rad - want.theta_rad).abs() < 1e-3);
    // Stopping is DTZ, after which the platform stands by; commands now are refused.
    assert!(matches!(
        b.command(0.1, 0.0),
        Err(BackendError::Stopped { .. })
    ));

    // A second execution from a new start re-enters tractor mode.
    b.reset(Pose::default()).unwrap();
    let s = drive(&mut b, 10, -0.3, 0.0);
    assert!(s.last().unwrap().pose.x_m < 0.0);
}

#[test]
fn speeds_are_clamped_before_they_are_sent() {
    let emu = emulator(EmulatorConfig {
        machine: MachineConfig {
            accel_limit_mps2: 4.0,
            yaw_accel_limit_radps2: 8.0,
            ..MachineConfig::default()
        },
        ..EmulatorConfig::default()
    });
    let cfg = RmpConfig {
        max_speed_mps: 0.3,
        max_rot_radps: 0.2,
        machine: MachineConfig {
            accel_limit_mps2: 4.0,
            yaw_accel_limit_radps2: 8.0,
            ..MachineConfig::default()
        },
        ..quick()
    };
    let mut b = RmpBackend::connect(emu.addr(), cfg).unwrap();
    b.reset(Pose::default()).unwrap();
    let mut max_target: (f64, f64) = (0.0, 0.0);
    for _ in 0..20 {
        b.command(5.0, -3.0).unwrap();
        b.step().unwrap();
        let s = emu.snapshot();
        max_target = (
            max_target.0.max(s.slewed_mps.abs()),
            max_target.1.max(s.slewed_radps.abs()),
        );
    }
    // The platform would allow 1.0 m/s and 1.0 rad/s; the driver sent no more than its own limits.
    assert!((max_target.0 - 0.3).abs() < 1e-6, "{max_target:?}");
    assert!((max_target.1 - 0.2).abs() < 1e-6, "{max_target:?}");
    // A NaN action is refused, and zero is sent in its place.
    assert!(matches!(
        b.command(f64::NAN, 0.0),
        Err(BackendError::InvalidCommand { .. })
    ));
}

#[test]
fn foreign_datagrams_never_change_state() {
    let emu = emulator(EmulatorConfig::default());
    let mut b = RmpBackend::connect(emu.addr(), quick()).unwrap();
    let start = Pose::new(0.0, 0.0, 0.0);
    b.reset(start).unwrap();
    // A well-formed feedback frame, from another socket, saying the base is far away.
    let mut fake = Feedback::default();
    fake.words[word::PLATFORM_ID] = Platform::Rmp220 as u32;
    fake.words[word::OPERATIONAL_STATE] = OpState::Tractor as u32;
    fake.set_f(word::OPERATIONAL_TIME_S, 1.0e6);
    fake.set_f(word::ODOM_X, 42.0);
    let intruder = UdpSocket::bind(loopback()).unwrap();
    let to = b.local_addr().unwrap();
    for _ in 0..20 {
        intruder
            .send_to(&fake.encode(WordOrder::Little), to)
            .unwrap();
        b.command(0.0, 0.0).unwrap();
        let s = b.step().unwrap();
        assert_eq!(s.pose, start);
    }
    let c = b.counts();
    assert_eq!(c.foreign, 20);
    assert!(b.status().unwrap().operational_time_s < 1000.0);
}

#[test]
fn a_lost_link_is_an_error_and_what_was_recorded_is_kept() {
    let emu = emulator(EmulatorConfig::default());
    let cfg = RmpConfig {
        link_timeout_s: 0.2,
        ..quick()
    };
    let mut b = RmpBackend::connect(emu.addr(), cfg).unwrap();
    b.reset(Pose::default()).unwrap();
    let mut recorded = drive(&mut b, 10, 0.3, 0.0);
    emu.shutdown();
    let lost_at = Instant::now();
    let mut err = None;
    for _ in 0..60 {
        // Commands still go out (into nothing); the step reports the silence.
        let _ = b.command(0.3, 0.0);
        match b.step() {
            Ok(s) => recorded.push(s),
            Err(e) => {
                err = Some(e);
                break;
            }
        }
    }
    let err = err.expect("the lost link was never reported");
    let BackendError::LinkLost { waited_ms } = err else {
        panic!("expected LinkLost, got {err:?}")
    };
    assert!(waited_ms >= 200, "{waited_ms}");
    assert!(lost_at.elapsed() < Duration::from_secs(2));
    // Nothing recorded before the loss is lost; the last feedback is still there to inspect.
    assert!(recorded.len() >= 10);
    assert!(recorded.windows(2).all(|w| w[1].t_s > w[0].t_s));
    assert!(b.status().is_some());
    assert!(matches!(
        b.command(0.3, 0.0),
        Err(BackendError::Stopped { .. })
    ));
    insta::assert_snapshot!(render(&BackendError::LinkLost { waited_ms: 250 }));
}

#[test]
fn start_up_against_silence_fails_at_the_fault_log_step() {
    // A socket that never answers.
    let silent = UdpSocket::bind(loopback()).unwrap();
    let addr = silent.local_addr().unwrap();
    let began = Instant::now();
    let err = RmpBackend::connect(
        addr,
        RmpConfig {
            step_timeout_s: 0.3,
            ..RmpConfig::default()
        },
    )
    .unwrap_err();
    assert!(began.elapsed() < Duration::from_secs(2));
    let text = render(&err).replace(&addr.to_string(), "127.0.0.1:PORT");
    insta::assert_snapshot!(text);
}

#[test]
fn a_critical_fault_stops_the_execution() {
    let emu = emulator(EmulatorConfig::default());
    let mut b = RmpBackend::connect(emu.addr(), quick()).unwrap();
    b.reset(Pose::default()).unwrap();
    drive(&mut b, 5, 0.2, 0.0);
    emu.raise_critical_fault(codec::critical_fault::PITCH_ANGLE_EXCEEDED);
    let mut got = None;
    for _ in 0..30 {
        let _ = b.command(0.2, 0.0);
        if let Err(e) = b.step() {
            got = Some(e);
            break;
        }
    }
    match got {
        Some(BackendError::Fault { what }) => assert!(what.contains("0x00800000"), "{what}"),
        other => panic!("expected a fault, got {other:?}"),
    }
}

#[test]
fn balance_mode_waits_for_the_operator_to_tip_the_base_back() {
    let machine = MachineConfig {
        bitmap: BITMAP_BALANCE_ENABLED,
        ..MachineConfig::default()
    };
    let emu = emulator(EmulatorConfig::default());
    let cfg = RmpConfig {
        machine,
        drive_mode: DriveMode::Balance,
        step_timeout_s: 0.3,
        ..RmpConfig::default()
    };
    let mut b = RmpBackend::connect(emu.addr(), cfg).unwrap();
    let err = b.reset(Pose::default()).unwrap_err();
    assert!(
        matches!(&err, BackendError::ModeChange { wanted, reported, .. } if wanted == "balance" && reported == "standby"),
        "{err:?}"
    );
    std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(Duration::from_millis(100));
            emu.tip_back();
        });
        b.reset(Pose::default()).unwrap();
    });
    assert_eq!(emu.snapshot().state, OpState::Balance);
    // Accelerating, a balancing base leans forward.
    let mut max_pitch: f64 = 0.0;
    for _ in 0..10 {
        b.command(1.0, 0.0).unwrap();
        b.step().unwrap();
        max_pitch = max_pitch.max(b.status().unwrap().pitch_deg);
    }
    assert!(max_pitch > 1.0, "{max_pitch}");
}

#[test]
fn balance_mode_needs_an_rmp_220() {
    let emu = emulator(EmulatorConfig {
        platform: Platform::Rmp440,
        ..EmulatorConfig::default()
    });
    let cfg = RmpConfig {
        machine: MachineConfig {
            bitmap: BITMAP_BALANCE_ENABLED,
            ..MachineConfig::default()
        },
        drive_mode: DriveMode::Balance,
        ..quick()
    };
    let err = RmpBackend::connect(emu.addr(), cfg).unwrap_err();
    assert!(
        matches!(&err, BackendError::StartupFailed { step, .. } if step == "check platform"),
        "{err:?}"
    );
}
