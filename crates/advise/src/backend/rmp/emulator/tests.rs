//! Unit tests of the platform, stepped by hand (no socket).

use super::*;
use crate::backend::rmp::codec::{
    self, Command, FAULT_LOG_WORDS, ModeRequest, OpState, WordOrder, comm_fault,
    fault_log::{self, entry},
    gp, word,
};
use crate::backend::rmp::config::{BITMAP_BALANCE_ENABLED, EmulatorConfig, MachineConfig};

fn platform() -> Platform {
    let mut p = Platform::new(
        EmulatorConfig {
            init_s: 0.03,
            ..EmulatorConfig::default()
        },
        Box::new(LagBase::new(0.05)),
    );
    for _ in 0..5 {
        p.tick(0.01);
    }
    p
}

fn send(p: &mut Platform, c: Command) -> Reply {
    p.receive(&c.encode())
}

fn mode(p: &mut Platform, m: ModeRequest) {
    send(
        p,
        Command::General {
            id: gp::SET_MODE,
            param: m as u32,
        },
    );
}

fn motion(vx: f32, yaw: f32) -> Command {
    Command::Motion {
        vx_mps: vx,
        vy_mps: 0.0,
        yaw_radps: yaw,
    }
}

#[test]
fn powers_up_through_init_to_standby() {
    let mut p = Platform::new(EmulatorConfig::default(), Box::new(LagBase::new(0.1)));
    assert_eq!(p.state(), OpState::CcuInit);
    let mut seen = vec![p.state()];
    for _ in 0..40 {
        p.tick(0.01);
        if seen.last() != Some(&p.state()) {
            seen.push(p.state());
        }
    }
    assert_eq!(
        seen,
        [
            OpState::CcuInit,
            OpState::PropulsionInit,
            OpState::CheckingStartup,
            OpState::Standby
        ]
    );
}

#[test]
fn motion_only_in_tractor_and_clamped_and_slewed() {
    let mut p = platform();
    send(&mut p, motion(5.0, 0.0));
    p.tick(0.01);
    assert_eq!(p.snapshot().slewed_mps, 0.0, "standby ignores motion");
    mode(&mut p, ModeRequest::Tractor);
    assert_eq!(p.state(), OpState::Tractor);
    let mut max_step: f64 = 0.0;
    let mut prev = 0.0;
    for _ in 0..300 {
        send(&mut p, motion(5.0, 0.0));
        p.tick(0.01);
        let s = p.snapshot().slewed_mps;
        max_step = max_step.max(s - prev);
        prev = s;
    }
    // Clamped to the 1.0 m/s velocity limit, reached at 0.5 m/s^2.
    assert!((prev - 1.0).abs() < 1e-9, "{prev}");
    assert!(max_step <= 0.5 * 0.01 + 1e-12, "{max_step}");
    assert!((p.snapshot().speed_mps - 1.0).abs() < 0.01);
}

#[test]
fn command_timeout_decelerates_at_the_decel_limit() {
    let mut p = platform();
    mode(&mut p, ModeRequest::Tractor);
    for _ in 0..250 {
        send(&mut p, motion(1.0, 0.0));
        p.tick(0.01);
    }
    // 0.5 s of silence keeps the speed; then 1.0 m/s at 0.5 m/s^2 takes 2 s.
    for _ in 0..45 {
        p.tick(0.01);
    }
    assert!((p.snapshot().slewed_mps - 1.0).abs() < 1e-9);
    for _ in 0..100 {
        p.tick(0.01);
    }
    // 0.95 s of deceleration at 0.5 m/s^2 leaves 0.525 m/s.
    let s = p.snapshot().slewed_mps;
    assert!((s - 0.525).abs() < 0.011, "{s}");
    for _ in 0..120 {
        p.tick(0.01);
    }
    assert_eq!(p.snapshot().slewed_mps, 0.0);
    assert_eq!(p.state(), OpState::Tractor);
}

#[test]
fn dtz_decelerates_at_the_dtz_limit_then_stands_by() {
    let mut p = platform();
    mode(&mut p, ModeRequest::Tractor);
    for _ in 0..250 {
        send(&mut p, motion(1.0, 0.0));
        p.tick(0.01);
    }
    mode(&mut p, ModeRequest::Dtz);
    let mut n = 0;
    while p.snapshot().dtz && n < 1000 {
        send(&mut p, motion(1.0, 0.0)); // ignored while decelerating
        p.tick(0.01);
        n += 1;
    }
    // 1.0 m/s at the 1.0 m/s^2 DTZ limit: 100 ticks, then the lag of the base settles.
    assert!((100..=140).contains(&n), "{n}");
    assert!(p.snapshot().speed_mps.abs() < 1e-3);
    assert_eq!(p.state(), OpState::Standby);
}

#[test]
fn bad_packets_set_fault_bits_and_change_nothing_else() {
    let mut p = platform();
    mode(&mut p, ModeRequest::Tractor);
    let before = p.snapshot();
    let mut b = motion(1.0, 0.0).encode();
    b[3] ^= 0x10;
    assert_eq!(p.receive(&b), Reply::None);
    let mut unknown = vec![0x12, 0x34, 0, 0, 0, 0];
    unknown.extend_from_slice(&codec::crc16(&unknown).to_be_bytes());
    p.receive(&unknown);
    let mut short_motion = vec![0x18, 0x00, 0, 0, 0, 0];
    short_motion.extend_from_slice(&codec::crc16(&short_motion).to_be_bytes());
    p.receive(&short_motion);
    p.tick(0.01);
    let s = p.snapshot();
    assert_eq!(s.slewed_mps, 0.0);
    assert_eq!(s.state, before.state);
    assert_eq!(
        s.faults[1],
        comm_fault::BAD_PACKET_CHECKSUM
            | comm_fault::UNKNOWN_COMMAND
            | comm_fault::BAD_MOTION_COMMAND
    );
    assert_eq!(
        (s.counts.bad_crc, s.counts.unknown_id, s.counts.bad_length),
        (1, 1, 1)
    );
}

#[test]
fn the_fault_log_is_a_ring_of_20_entries_with_the_groups_split() {
    let mut p = platform();
    // A fault in every status word, each group at a distinct bit.
    p.faults = [0x0000_1003, 0x0002_0020, 0x0004_0008, 0x10];
    p.log_new_faults();
    let w = p.fault_log();
    let e = &w[fault_log::ENTRIES..][..fault_log::ENTRY_WORDS];
    assert_eq!(
        e[entry::GROUPS..entry::GROUPS + 8],
        [0, 0x1, 0x20, 0x8, 0x4, 0x10, 0x3, 0x2]
    );
    // The same faults again write no entry; each new one does, and after 20 the ring wraps.
    p.log_new_faults();
    assert_eq!(p.fault_log()[fault_log::ENTRY_COUNT], 1);
    let mut p = platform();
    for bit in 0..23 {
        p.faults[2] |= 1 << bit;
        p.log_new_faults();
    }
    let w = p.fault_log();
    assert_eq!(w.len(), FAULT_LOG_WORDS);
    assert_eq!(w[fault_log::ENTRY_COUNT], 20);
    // 23 entries written: the 21st to 23rd overwrote entries 0 to 2.
    let latest = &w[fault_log::ENTRIES + 2 * fault_log::ENTRY_WORDS..][..fault_log::ENTRY_WORDS];
    assert_eq!((latest[entry::SENSOR], latest[entry::BSA]), (0xFFFF, 0x7F));
    assert_eq!(w[fault_log::LATEST_ENTRY], 2);
}

#[test]
fn config_is_clamped_and_echoed() {
    let mut p = platform();
    let m = MachineConfig {
        velocity_limit_mps: 0.7,
        accel_limit_mps2: 50.0,
        ..MachineConfig::default()
    };
    send(&mut p, Command::MachineConfig(m.to_words()));
    let echo = MachineConfig::from_words(&p.feedback().config_echo());
    assert_eq!(echo.velocity_limit_mps, 0.7);
    assert_eq!(echo.accel_limit_mps2, 7.848);
}

#[test]
fn balance_needs_the_bitmap_and_a_tip_back() {
    let mut p = platform();
    mode(&mut p, ModeRequest::Balance);
    p.tick(0.01);
    assert_eq!(p.state(), OpState::Standby, "bitmap bit 6 is off");
    let m = MachineConfig {
        bitmap: BITMAP_BALANCE_ENABLED,
        ..MachineConfig::default()
    };
    send(&mut p, Command::MachineConfig(m.to_words()));
    mode(&mut p, ModeRequest::Balance);
    for _ in 0..10 {
        p.tick(0.01);
    }
    assert_eq!(p.state(), OpState::Standby);
    assert!(p.snapshot().awaiting_tip_back);
    p.tip_back();
    p.tick(0.01);
    assert_eq!(p.state(), OpState::Balance);
    // Leaning into an acceleration shows as pitch.
    for _ in 0..20 {
        send(&mut p, motion(1.0, 0.0));
        p.tick(0.01);
    }
    assert!(p.feedback().f(word::PITCH_DEG) > 0.5);
}

#[test]
fn replies_once_per_command_unless_streaming() {
    let mut p = platform();
    assert_eq!(
        send(
            &mut p,
            Command::General {
                id: gp::NONE,
                param: 0
            }
        ),
        Reply::Feedback
    );
    assert_eq!(
        send(
            &mut p,
            Command::General {
                id: gp::FAULT_LOG,
                param: 0
            }
        ),
        Reply::FaultLog
    );
    send(
        &mut p,
        Command::General {
            id: gp::STREAMING,
            param: 1,
        },
    );
    assert_eq!(
        send(
            &mut p,
            Command::General {
                id: gp::NONE,
                param: 0
            }
        ),
        Reply::None
    );
    let log = codec::encode_reply(&p.fault_log(), WordOrder::Little);
    assert_eq!(log.len(), codec::FAULT_LOG_LEN);
}

#[test]
fn feedback_is_plausible_in_both_orders() {
    let p = platform();
    let fb = p.feedback();
    assert!(fb.plausible());
    for order in [WordOrder::Little, WordOrder::Big] {
        assert_eq!(WordOrder::detect(&fb.encode(order)), Some(order));
    }
}
