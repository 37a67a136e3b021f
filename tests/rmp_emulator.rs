//! The emulator over real loopback sockets, spoken to with raw datagrams (no driver).

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use advise::backend::rmp::codec::{self, Command, Feedback, ModeRequest, OpState, WordOrder, gp};
use advise::backend::rmp::config::EmulatorConfig;
use advise::backend::rmp::emulator::Emulator;

fn loopback() -> SocketAddr {
    "127.0.0.1:0".parse().unwrap()
}

fn client() -> UdpSocket {
    let s = UdpSocket::bind(loopback()).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    s
}

/// Receive datagrams for `for_ms`, returning them (bounded in count and time).
fn collect(s: &UdpSocket, for_ms: u64) -> Vec<Vec<u8>> {
    let end = Instant::now() + Duration::from_millis(for_ms);
    let mut out = Vec::new();
    let mut buf = [0u8; 2048];
    while Instant::now() < end && out.len() < 10_000 {
        if let Ok((n, _)) = s.recv_from(&mut buf) {
            out.push(buf[..n].to_vec());
        }
    }
    out
}

#[test]
fn streams_feedback_at_100_hz_in_the_chosen_order_and_shuts_down() {
    for order in [WordOrder::Little, WordOrder::Big] {
        let emu = Emulator::bind(
            loopback(),
            EmulatorConfig {
                order,
                ..EmulatorConfig::default()
            },
        )
        .unwrap();
        let c = client();
        c.send_to(
            &Command::General {
                id: gp::STREAMING,
                param: 1,
            }
            .encode(),
            emu.addr(),
        )
        .unwrap();
        let frames = collect(&c, 500);
        // 100 Hz for 0.5 s; a loaded CI machine may lose some ticks, never gain them.
        assert!((25..=55).contains(&frames.len()), "{}", frames.len());
        for f in &frames {
            assert_eq!(f.len(), codec::FEEDBACK_LEN);
            assert_eq!(WordOrder::detect(f), Some(order));
        }
        let last = Feedback::decode(frames.last().unwrap(), order).unwrap();
        assert!(last.operational_time_s() > 0.3);
        emu.shutdown();
        // The thread has stopped: after draining what was in flight, nothing more arrives.
        collect(&c, 30);
        assert!(collect(&c, 100).is_empty());
    }
}

#[test]
fn replies_once_per_command_when_not_streaming_and_sends_the_fault_log() {
    let emu = Emulator::bind(loopback(), EmulatorConfig::default()).unwrap();
    let c = client();
    c.send_to(
        &Command::General {
            id: gp::NONE,
            param: 0,
        }
        .encode(),
        emu.addr(),
    )
    .unwrap();
    let got = collect(&c, 150);
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].len(), codec::FEEDBACK_LEN);
    c.send_to(
        &Command::General {
            id: gp::FAULT_LOG,
            param: 0,
        }
        .encode(),
        emu.addr(),
    )
    .unwrap();
    let got = collect(&c, 150);
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].len(), codec::FAULT_LOG_LEN);
    assert_eq!(
        codec::decode_reply(&got[0], WordOrder::Little)
            .unwrap()
            .len(),
        codec::FAULT_LOG_WORDS
    );
}

#[test]
fn a_corrupted_motion_command_never_moves_the_base() {
    let emu = Emulator::bind(
        loopback(),
        EmulatorConfig {
            init_s: 0.02,
            ..EmulatorConfig::default()
        },
    )
    .unwrap();
    let c = client();
    std::thread::sleep(Duration::from_millis(60));
    c.send_to(
        &Command::General {
            id: gp::SET_MODE,
            param: ModeRequest::Tractor as u32,
        }
        .encode(),
        emu.addr(),
    )
    .unwrap();
    collect(&c, 60);
    assert_eq!(emu.snapshot().state, OpState::Tractor);
    for i in 0..20u8 {
        let mut b = Command::Motion {
            vx_mps: 1.0,
            vy_mps: 0.0,
            yaw_radps: 0.5,
        }
        .encode();
        b[2 + usize::from(i % 12)] ^= 1 + i;
        c.send_to(&b, emu.addr()).unwrap();
    }
    collect(&c, 100);
    let s = emu.snapshot();
    assert_eq!((s.slewed_mps, s.speed_mps), (0.0, 0.0));
    assert_eq!(s.counts.bad_crc, 20);
    assert_ne!(s.faults[1] & codec::comm_fault::BAD_PACKET_CHECKSUM, 0);
}
