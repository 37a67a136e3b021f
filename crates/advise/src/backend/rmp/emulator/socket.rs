//! The emulator on a UDP socket: [`Emulator`] binds and starts a background thread that runs the
//! [`Platform`] at the stream rate, answers the source of the last valid datagram, and injects
//! datagram faults (drop, corrupt, delay) in both directions; [`EmulatorHandle`] stops it cleanly.

use std::collections::VecDeque;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::base::{EmulatedBase, LagBase};
use super::platform::{EmulatorCounts, Platform, Reply, Snapshot};
use crate::backend::rmp::codec;
use crate::backend::rmp::config::{EmulatorConfig, FaultInjection, RmpConfigError};
use crate::backend::sim::{SimBase, SimError, SimParams};

/// Why the emulator could not start.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum EmulatorError {
    #[error("cannot bind the emulator to {addr}: {source}")]
    #[diagnostic(
        code(advise::rmp::emulator_bind),
        help("pick a free port, or port 0 for any free one")
    )]
    Bind {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error(transparent)]
    #[diagnostic(transparent)]
    Config(#[from] RmpConfigError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Sim(#[from] SimError),
}

/// Start an emulator.
pub struct Emulator;

impl Emulator {
    /// Bind `addr` (port 0 for an ephemeral port) and run the emulated platform on a background
    /// thread with the stand-in [`LagBase`].
    pub fn bind(addr: SocketAddr, cfg: EmulatorConfig) -> Result<EmulatorHandle, EmulatorError> {
        let base = Box::new(LagBase::new(cfg.base_lag_s));
        Emulator::bind_with(addr, cfg, base)
    }

    /// As [`Emulator::bind`], with the team's simulator ([`SimBase`]) as the base physics: what
    /// `advise rmp-emulator` runs. `sim_seed` seeds the simulator's noise. The parameters are
    /// validated first ([`SimParams::validate`]).
    pub fn bind_sim(
        addr: SocketAddr,
        cfg: EmulatorConfig,
        params: SimParams,
        sim_seed: u64,
    ) -> Result<EmulatorHandle, EmulatorError> {
        params.validate()?;
        Emulator::bind_with(addr, cfg, Box::new(SimBase::new(params, sim_seed)))
    }

    /// As [`Emulator::bind`], with the given base physics.
    pub fn bind_with(
        addr: SocketAddr,
        cfg: EmulatorConfig,
        base: Box<dyn EmulatedBase>,
    ) -> Result<EmulatorHandle, EmulatorError> {
        cfg.faults.validate()?;
        let socket =
            UdpSocket::bind(addr).map_err(|source| EmulatorError::Bind { addr, source })?;
        let local = socket
            .local_addr()
            .map_err(|source| EmulatorError::Bind { addr, source })?;
        let shared = Arc::new(Mutex::new(Platform::new(cfg.clone(), base)));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let shared = Arc::clone(&shared);
            let stop = Arc::clone(&stop);
            std::thread::Builder::new()
                .name("rmp-emulator".into())
                .spawn(move || run(socket, cfg, shared, stop))
                .map_err(|source| EmulatorError::Bind { addr, source })?
        };
        Ok(EmulatorHandle {
            addr: local,
            shared,
            stop,
            thread: Some(thread),
        })
    }
}

/// A running emulator. Dropping it stops the thread and closes the socket.
pub struct EmulatorHandle {
    addr: SocketAddr,
    shared: Arc<Mutex<Platform>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl EmulatorHandle {
    /// The address the emulator listens on (with the real port when bound to port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    pub fn snapshot(&self) -> Snapshot {
        lock(&self.shared).snapshot()
    }

    /// The operator tips the base back: a pending balance request is granted.
    pub fn tip_back(&self) {
        lock(&self.shared).tip_back();
    }

    /// Raise critical fault bits (word 0) as if the platform had detected them.
    pub fn raise_critical_fault(&self, bits: u32) {
        lock(&self.shared).raise_critical_fault(bits);
    }

    /// From now on report `x` as the odometry's x (NaN, say), as a failing sensor would (a test
    /// hook: the driver must stop the base rather than act on it).
    pub fn corrupt_odometry(&self, x: f32) {
        lock(&self.shared).odom_x_override = Some(x);
    }

    /// Stop the thread and close the socket; waits for the thread (at most one loop turn).
    pub fn shutdown(mut self) {
        self.stop_thread();
    }

    fn stop_thread(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            // The loop only ends by this flag; a panic in it is a bug we want to see in tests.
            if t.join().is_err() {
                let _ = std::io::Write::write_all(
                    &mut std::io::stderr(),
                    b"rmp emulator thread panicked\n",
                );
            }
        }
    }
}

impl Drop for EmulatorHandle {
    fn drop(&mut self) {
        self.stop_thread();
    }
}

/// The platform lock; a poisoned lock still holds a consistent platform (every update is a plain
/// field write), so we keep going rather than panic.
fn lock(m: &Mutex<Platform>) -> MutexGuard<'_, Platform> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A datagram held back by the delay injection.
struct Held {
    due: Instant,
    bytes: Vec<u8>,
    /// `Some(to)` for outgoing, `None` for incoming.
    to: Option<SocketAddr>,
    from: SocketAddr,
}

/// What the fault injector decided for one datagram.
enum Fate {
    Pass(Vec<u8>),
    Hold(Vec<u8>),
    Drop,
}

struct Injector {
    faults: FaultInjection,
    rng: ChaCha8Rng,
}

impl Injector {
    fn fate(&mut self, mut bytes: Vec<u8>, counts: &mut EmulatorCounts) -> Fate {
        let f = self.faults;
        if f.drop > 0.0 && self.rng.random_bool(f.drop) {
            counts.injected_drops += 1;
            return Fate::Drop;
        }
        if f.corrupt > 0.0 && !bytes.is_empty() && self.rng.random_bool(f.corrupt) {
            let at = self.rng.random_range(0..bytes.len());
            bytes[at] ^= self.rng.random_range(1..=255u8);
            counts.injected_corruptions += 1;
        }
        if f.delay > 0.0 && f.delay_ms > 0 && self.rng.random_bool(f.delay) {
            counts.injected_delays += 1;
            return Fate::Hold(bytes);
        }
        Fate::Pass(bytes)
    }
}

fn run(
    socket: UdpSocket,
    cfg: EmulatorConfig,
    shared: Arc<Mutex<Platform>>,
    stop: Arc<AtomicBool>,
) {
    let mut inj = Injector {
        faults: cfg.faults,
        rng: ChaCha8Rng::seed_from_u64(cfg.seed),
    };
    let delay = Duration::from_millis(cfg.faults.delay_ms);
    let tick = Duration::from_secs_f64(cfg.stream_period_s.max(0.001));
    let mut next_tick = Instant::now() + tick;
    let mut held: VecDeque<Held> = VecDeque::new();
    let mut peer: Option<SocketAddr> = None;
    let mut buf = [0u8; 2048];

    // Send through the injector; outgoing faults are counted like incoming ones.
    let send = |bytes: Vec<u8>,
                to: SocketAddr,
                inj: &mut Injector,
                held: &mut VecDeque<Held>,
                p: &mut Platform| {
        match inj.fate(bytes, &mut p.counts) {
            Fate::Pass(b) => {
                if socket.send_to(&b, to).is_ok() {
                    p.counts.sent += 1;
                }
            }
            Fate::Hold(b) => held.push_back(Held {
                due: Instant::now() + delay,
                bytes: b,
                to: Some(to),
                from: to,
            }),
            Fate::Drop => {}
        }
    };

    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        let wait = next_tick
            .saturating_duration_since(now)
            .max(Duration::from_micros(200));
        let _ = socket.set_read_timeout(Some(wait));
        // Anything but a datagram (timeout, ICMP port unreachable echoed as an error) is ignored.
        let incoming = match socket.recv_from(&mut buf) {
            Ok((n, from)) => Some((buf[..n].to_vec(), from)),
            Err(_) => None,
        };

        let mut p = lock(&shared);
        let mut ready: Vec<(Vec<u8>, SocketAddr)> = Vec::new();
        if let Some((bytes, from)) = incoming {
            match inj.fate(bytes, &mut p.counts) {
                Fate::Pass(b) => ready.push((b, from)),
                Fate::Hold(b) => held.push_back(Held {
                    due: Instant::now() + delay,
                    bytes: b,
                    to: None,
                    from,
                }),
                Fate::Drop => {}
            }
        }
        // Release held datagrams that are due (both directions).
        let now = Instant::now();
        let mut i = 0;
        while i < held.len() {
            if held[i].due <= now {
                if let Some(h) = held.remove(i) {
                    match h.to {
                        Some(to) => {
                            if socket.send_to(&h.bytes, to).is_ok() {
                                p.counts.sent += 1;
                            }
                        }
                        None => ready.push((h.bytes, h.from)),
                    }
                }
            } else {
                i += 1;
            }
        }
        for (bytes, from) in ready {
            let accepted_before = p.counts.accepted;
            let reply = p.receive(&bytes);
            if p.counts.accepted > accepted_before {
                peer = Some(from);
            }
            let out = match reply {
                Reply::None => None,
                Reply::Feedback => Some(p.feedback().encode(cfg.order)),
                Reply::FaultLog => Some(codec::encode_reply(&p.fault_log(), cfg.order)),
            };
            if let (Some(b), Some(to)) = (out, peer) {
                send(b, to, &mut inj, &mut held, &mut p);
            }
        }
        // Physics at the stream rate; catch up at most 5 ticks, then skip (a stalled machine).
        let mut caught = 0;
        while Instant::now() >= next_tick && caught < 5 {
            p.tick(cfg.stream_period_s);
            next_tick += tick;
            caught += 1;
            if p.streaming
                && let Some(to) = peer
            {
                let b = p.feedback().encode(cfg.order);
                send(b, to, &mut inj, &mut held, &mut p);
            }
        }
        if Instant::now() >= next_tick {
            next_tick = Instant::now() + tick;
        }
    }
}
