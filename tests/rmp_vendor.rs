//! The emulator as the vendor's own driver sees it: each platform's shipped configuration echoed
//! back unchanged, the fault log in the layout the vendor's fault-log parser reads, and "reset
//! parameters to default" restoring the emulated platform's own defaults. Raw datagrams over
//! loopback UDP; every wait is bounded.

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use advise::backend::rmp::codec::{self, Command, Feedback, Platform, WordOrder, gp};
use advise::backend::rmp::config::EmulatorConfig;
use advise::backend::rmp::emulator::{Emulator, EmulatorHandle};

/// The 11 float words of a machine configuration, in wire order: velocity, accel, decel, DTZ
/// decel, yaw rate, yaw accel, lateral accel limits, tire diameter, wheel base, track width, gear
/// ratio.
type Floats = [f32; 11];

/// What the vendor ships for each platform, written out from the vendor driver's per-platform
/// `launch/config/<PLATFORM>/segway_params.yaml` (RMP_210, RMP_220, RMP_440LE and RMP_440SE, which
/// agree, RMP_OMNI). The RMP 110's is the issue's: the RMP 210/220 values with the RMP 110's
/// track width, 0.481224 m (the vendor's `RMP_110/rmp.urdf.xacro` gives 0.4812244).
#[expect(
    clippy::approx_constant,
    reason = "6.28 rad/s² is the vendor's shipped value, not 2π"
)]
const SHIPPED: [(Platform, Floats); 5] = [
    (
        Platform::Rmp220,
        [
            1.0, 0.5, 0.5, 1.0, 1.0, 1.0, 4.905, 0.46228, 0.5842, 0.542391, 24.2667,
        ],
    ),
    (
        Platform::Rmp210,
        [
            3.0, 0.5, 0.5, 1.0, 1.0, 1.5, 4.905, 0.46228, 0.5842, 0.542391, 24.2667,
        ],
    ),
    (
        Platform::Rmp440,
        [
            2.235, 1.962, 1.962, 3.924, 3.0, 6.28, 9.81, 0.483616, 0.5842, 0.7112, 24.2667,
        ],
    ),
    (
        Platform::RmpOmni,
        [
            1.0, 0.5, 0.5, 1.0, 1.0, 1.0, 4.905, 0.254, 0.693, 0.693, 24.2667,
        ],
    ),
    (
        Platform::Rmp110,
        [
            1.0, 0.5, 0.5, 1.0, 1.0, 1.0, 4.905, 0.46228, 0.5842, 0.481224, 24.2667,
        ],
    ),
];

/// The bitmap the vendor driver computes from every shipped yaml: audio on, motion while charging
/// off (bit 1), balance off, default gains and filters.
const SHIPPED_BITMAP: u32 = 0x2;

fn words(f: &Floats, bitmap: u32) -> [u32; 12] {
    let mut w = [0u32; 12];
    for (slot, v) in w.iter_mut().zip(f) {
        *slot = v.to_bits();
    }
    w[11] = bitmap;
    w
}

fn client() -> UdpSocket {
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    s
}

/// An emulator of `platform` that powers up with the RMP 220's configuration in its F-RAM, so that
/// what it echoes is what it was sent (or reset to), not what it started with.
fn emulator(platform: Platform) -> EmulatorHandle {
    let loopback: SocketAddr = "127.0.0.1:0".parse().unwrap();
    Emulator::bind(
        loopback,
        EmulatorConfig {
            platform,
            ..EmulatorConfig::default()
        },
    )
    .unwrap()
}

/// Send `cmd` and return the first reply of `len` bytes, waiting at most 2 s.
fn ask(c: &UdpSocket, emu: &EmulatorHandle, cmd: &Command, len: usize) -> Vec<u8> {
    c.send_to(&cmd.encode(), emu.addr()).unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    let mut buf = [0u8; 2048];
    while Instant::now() < end {
        if let Ok((n, _)) = c.recv_from(&mut buf)
            && n == len
        {
            return buf[..n].to_vec();
        }
    }
    panic!("no {len}-byte reply to {cmd:?} within 2 s");
}

fn echo_after(c: &UdpSocket, emu: &EmulatorHandle, cmd: &Command) -> [u32; 12] {
    let reply = ask(c, emu, cmd, codec::FEEDBACK_LEN);
    Feedback::decode(&reply, WordOrder::Little)
        .unwrap()
        .config_echo()
}

#[test]
fn every_platforms_shipped_configuration_is_echoed_unchanged() {
    for (platform, floats) in SHIPPED {
        let emu = emulator(platform);
        let c = client();
        let sent = words(&floats, SHIPPED_BITMAP);
        let echo = echo_after(&c, &emu, &Command::MachineConfig(sent));
        assert_eq!(
            echo,
            sent,
            "{} echoes {:?}",
            platform.name(),
            echo[..11]
                .iter()
                .map(|w| f32::from_bits(*w))
                .collect::<Vec<_>>()
        );
        emu.shutdown();
    }
}

#[test]
fn other_platforms_still_clamp_the_rmp_110_track_width() {
    let emu = emulator(Platform::Rmp220);
    let c = client();
    let rmp_110 = SHIPPED[4].1;
    let echo = echo_after(
        &c,
        &emu,
        &Command::MachineConfig(words(&rmp_110, SHIPPED_BITMAP)),
    );
    assert_eq!(f32::from_bits(echo[9]), 0.506476);
    emu.shutdown();
}

#[test]
fn reset_to_defaults_restores_the_emulated_platforms_own_defaults() {
    for (platform, floats) in [SHIPPED[4], SHIPPED[2], SHIPPED[3], SHIPPED[0]] {
        let emu = emulator(platform);
        let c = client();
        // Something else first, so that the reset has to change every word.
        let other = words(
            &[0.3, 0.2, 0.2, 2.0, 0.4, 2.0, 2.0, 0.3, 0.9, 0.9, 30.0],
            0x1,
        );
        assert_eq!(echo_after(&c, &emu, &Command::MachineConfig(other)), other);
        let echo = echo_after(
            &c,
            &emu,
            &Command::General {
                id: gp::RESET_PARAMS,
                param: 0,
            },
        );
        assert_eq!(
            echo,
            words(&floats, SHIPPED_BITMAP),
            "{} after GP 5",
            platform.name()
        );
        emu.shutdown();
    }
}

/// The fault log's layout as the vendor's fault-log parser reads it (the vendor driver's
/// `faultlog_parser.py`): header words 0 log version, 1 log size in bytes, 2 number of entries,
/// 3 latest entry, 4-5 serial number (high, low), 6 SP build id, 7 UIP build id, 8 accumulated
/// time (s), 9 odometer (m), 10 power cycles; then 20 entries of 15 words from word 11, each:
/// 0 time stamp, 1 run time, 2 power cycle, 3-10 the fault groups transient, critical,
/// communication, sensor, BSA, MCU, architecture, internal; 11-12 data.
mod vendor_layout {
    pub const LOG_SIZE_BYTES: usize = 1;
    pub const NUMBER_OF_ENTRIES: usize = 2;
    pub const LATEST_ENTRY: usize = 3;
    pub const POWER_CYCLES: usize = 10;
    pub const FIRST_ENTRY: usize = 11;
    pub const ITEMS_PER_ENTRY: usize = 15;
    pub const ENTRY_POWER_CYCLE: usize = 2;
    pub const ENTRY_CRITICAL: usize = 4;
    pub const ENTRY_COMM: usize = 5;
}

#[test]
fn the_fault_log_puts_its_header_and_entries_where_the_vendor_parser_reads_them() {
    use vendor_layout::*;
    let emu = emulator(Platform::Rmp220);
    let c = client();
    let log = |c: &UdpSocket| {
        let reply = ask(
            c,
            &emu,
            &Command::General {
                id: gp::FAULT_LOG,
                param: 0,
            },
            codec::FAULT_LOG_LEN,
        );
        codec::decode_reply(&reply, WordOrder::Little).unwrap()
    };

    let clean = log(&c);
    assert_eq!(clean.len(), 311);
    assert_eq!(clean[LOG_SIZE_BYTES], 311 * 4);
    assert_eq!(clean[NUMBER_OF_ENTRIES], 0);
    assert_eq!(clean[POWER_CYCLES], 1);
    // No fault yet: every entry is all zero, which the parser shows as empty.
    assert!(clean[FIRST_ENTRY..].iter().all(|w| *w == 0));

    // A datagram with a bad CRC: communication fault 0x40.
    let mut bad = Command::General {
        id: gp::NONE,
        param: 0,
    }
    .encode();
    let last = bad.len() - 1;
    bad[last] ^= 0xFF;
    c.send_to(&bad, emu.addr()).unwrap();
    std::thread::sleep(Duration::from_millis(400));
    // Then a critical fault: pitch angle exceeded (critical group bit 0x800).
    emu.raise_critical_fault(codec::critical_fault::PITCH_ANGLE_EXCEEDED);

    let w = log(&c);
    assert_eq!(w[NUMBER_OF_ENTRIES], 2);
    assert_eq!(w[LATEST_ENTRY], 1);
    let entry = |i: usize| &w[FIRST_ENTRY + i * ITEMS_PER_ENTRY..][..ITEMS_PER_ENTRY];
    assert_eq!(entry(0)[ENTRY_COMM], 0x40);
    assert_eq!(entry(0)[ENTRY_CRITICAL], 0);
    assert_eq!(entry(0)[ENTRY_POWER_CYCLE], 1);
    // Entries record the fault words when written, groups shifted down to bit 0.
    assert_eq!(entry(1)[ENTRY_COMM], 0x40);
    assert_eq!(entry(1)[ENTRY_CRITICAL], 0x800);
    assert!(entry(2).iter().all(|w| *w == 0));
    emu.shutdown();
}
