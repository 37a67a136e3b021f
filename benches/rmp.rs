//! One command-to-feedback round trip to the RMP emulator on loopback: encode a 0x1800 motion
//! command (with its CRC), send it, receive the platform's 532-byte feedback reply and decode it
//! (CRC check, words in the detected order). The emulator runs the simulator behind it in tractor
//! mode, with streaming off, so every command is answered by exactly one feedback (as the vendor's
//! 2013 drivers expect); with streaming on, the driver instead reads the latest of a 100 Hz stream.
//!
//! Criterion reports the median-like estimate; a second, plain loop of `SAMPLES` round trips prints
//! the median and the 99th percentile, which criterion does not give. The control period is 33 ms,
//! so anything under a millisecond leaves the link out of the control loop's budget.

use std::hint::black_box;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use advise::backend::rmp::codec::{
    Command, FEEDBACK_LEN, Feedback, ModeRequest, OpState, WordOrder, gp,
};
use advise::backend::rmp::{Emulator, EmulatorConfig, EmulatorHandle};
use advise::backend::sim::SimParams;
use criterion::{Criterion, criterion_group};

const SAMPLES: usize = 5_000;

struct Link {
    socket: UdpSocket,
    emu: EmulatorHandle,
    order: WordOrder,
    buf: Vec<u8>,
}

impl Link {
    fn new() -> Link {
        let emu = Emulator::bind_sim(
            "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
            EmulatorConfig {
                init_s: 0.05,
                ..EmulatorConfig::default()
            },
            SimParams::default(),
            0,
        )
        .unwrap();
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket
            .set_read_timeout(Some(Duration::from_secs(1)))
            .unwrap();
        let mut link = Link {
            socket,
            emu,
            order: WordOrder::Little,
            buf: vec![0; 2048],
        };
        std::thread::sleep(Duration::from_millis(100));
        link.round_trip(Command::General {
            id: gp::SET_MODE,
            param: ModeRequest::Tractor as u32,
        });
        let fb = link.round_trip(Command::General {
            id: gp::NONE,
            param: 0,
        });
        assert_eq!(
            fb.op_state(),
            Some(OpState::Tractor),
            "{:?}",
            link.emu.snapshot()
        );
        link
    }

    /// Send `cmd` and wait for its feedback.
    fn round_trip(&mut self, cmd: Command) -> Feedback {
        self.socket.send_to(&cmd.encode(), self.emu.addr()).unwrap();
        loop {
            let (n, _) = self
                .socket
                .recv_from(&mut self.buf)
                .expect("the emulator answers");
            if n == FEEDBACK_LEN {
                if self.order == WordOrder::Little
                    && let Some(o) = WordOrder::detect(&self.buf[..n])
                {
                    self.order = o;
                }
                return Feedback::decode(&self.buf[..n], self.order).expect("a good frame");
            }
        }
    }
}

fn motion(i: usize) -> Command {
    Command::Motion {
        vx_mps: if i.is_multiple_of(2) { 0.2 } else { 0.3 },
        vy_mps: 0.0,
        yaw_radps: 0.1,
    }
}

fn bench(c: &mut Criterion) {
    let mut link = Link::new();
    let mut i = 0;
    c.bench_function("rmp_command_to_feedback_loopback", |b| {
        b.iter(|| {
            i += 1;
            black_box(link.round_trip(motion(i)))
        })
    });
}

criterion_group!(benches, bench);

/// Median and 99th percentile over a plain loop of round trips.
fn percentiles() {
    let mut link = Link::new();
    for i in 0..200 {
        link.round_trip(motion(i));
    }
    let mut us: Vec<f64> = (0..SAMPLES)
        .map(|i| {
            let t = Instant::now();
            black_box(link.round_trip(motion(i)));
            t.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    us.sort_by(f64::total_cmp);
    let q = |p: f64| us[((us.len() - 1) as f64 * p).round() as usize];
    println!(
        "rmp command-to-feedback round trip on loopback, {SAMPLES} samples: median {:.0} us, p99 {:.0} us, max {:.0} us",
        q(0.5),
        q(0.99),
        us[us.len() - 1]
    );
}

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    percentiles();
}
