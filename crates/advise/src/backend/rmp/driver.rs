//! The RMP driver: a [`Backend`] that drives a Segway RMP (or the emulator) over UDP.
//!
//! This module owns the link to one platform: the vendor's start-up sequence, mode changes, motion
//! commands clamped to the configured limits, odometry from the platform's own feedback, and the
//! safety that runs beside the session (a watchdog thread that commands zero and decelerate-to-zero
//! when the session stops commanding, and a stop on drop). Feedback is taken only when it comes from
//! the platform's address, has a good CRC, the right length and plausible words; everything else is
//! dropped and counted. It never sends to any address but the one it was given.
//!
//! Threads: a receiver keeps the latest feedback (the platform streams at 100 Hz, the session steps
//! at 30 Hz), and a watchdog ticks every 10 ms. Both end when the backend is dropped.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::codec::{
    self, CRITICAL_FAULT_MASK, Command, FAULT_LOG_LEN, FEEDBACK_LEN, Feedback, FrameError,
    ModeRequest, OpState, Platform, WordOrder, gp, word,
};
use super::config::{DriveMode, MachineConfig, RmpConfig};
use crate::backend::{Backend, BackendError, Base, BaseState, BaseStop};
use crate::geometry::{Pose, rezero};

/// How often the watchdog looks, and how often it repeats zero + DTZ while stopping (UDP may lose
/// any one datagram, so a stop is repeated until the platform reports it has left drive mode).
const WATCHDOG_TICK: Duration = Duration::from_millis(10);
const STOP_REPEAT: Duration = Duration::from_millis(50);
/// Receiver wake-up, so that the thread notices shutdown promptly.
const RECV_TIMEOUT: Duration = Duration::from_millis(20);
/// Below this the base counts as at rest.
const REST_MPS: f64 = 0.01;
const REST_RADPS: f64 = 0.01;

/// What the driver dropped, and why, plus what it sent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriverCounts {
    /// Feedback frames accepted.
    pub feedback: u64,
    pub fault_logs: u64,
    pub bad_crc: u64,
    /// Neither a feedback frame nor a fault log.
    pub bad_length: u64,
    /// From an address other than the platform's.
    pub foreign: u64,
    /// Good CRC, but words that make no sense under the detected byte order.
    pub implausible: u64,
    /// Older than the feedback already held (reordered on the way).
    pub stale: u64,
    pub sent: u64,
    pub watchdog_trips: u64,
}

/// The platform as last reported.
#[derive(Clone, Debug, PartialEq)]
pub struct RmpStatus {
    pub state: Option<OpState>,
    pub platform: Option<Platform>,
    pub order: WordOrder,
    pub pitch_deg: f64,
    pub pitch_rate_degps: f64,
    pub roll_deg: f64,
    pub min_battery_soc_pct: f64,
    pub faults: [u32; 4],
    /// Time since this feedback arrived.
    pub age: Duration,
    pub operational_time_s: f64,
    pub feedback: Feedback,
}

/// Why the base is being (or was) stopped.
#[derive(Clone, Debug, PartialEq)]
enum StopReason {
    Requested,
    Watchdog { idle_ms: u64 },
    LinkLost,
    Fault(String),
    Dropped,
}

impl StopReason {
    fn describe(&self) -> String {
        match self {
            StopReason::Requested => "stop was requested".into(),
            StopReason::Watchdog { idle_ms } => format!(
                "the watchdog stopped it after {idle_ms} ms without a command from the session"
            ),
            StopReason::LinkLost => "the link was lost".into(),
            StopReason::Fault(f) => format!("it reported a fault ({f})"),
            StopReason::Dropped => "the session ended".into(),
        }
    }
}

/// State shared by the session, the receiver and the watchdog.
#[derive(Debug)]
struct LinkState {
    order: Option<WordOrder>,
    latest: Option<(Feedback, Instant)>,
    /// The last datagram of any kind from the platform's address (start-up waits for quiet).
    last_datagram: Option<Instant>,
    fault_log_raw: Option<Vec<u8>>,
    counts: DriverCounts,
    /// Set by `reset`: the session is driving and must keep commanding.
    armed: bool,
    last_command_at: Instant,
    /// Set when a stop begins; the watchdog repeats zero + DTZ until the platform leaves drive mode.
    stopping: Option<(StopReason, Instant)>,
    last_stop_sent: Option<Instant>,
}

impl LinkState {
    fn new() -> LinkState {
        LinkState {
            order: None,
            latest: None,
            last_datagram: None,
            fault_log_raw: None,
            counts: DriverCounts::default(),
            armed: false,
            last_command_at: Instant::now(),
            stopping: None,
            last_stop_sent: None,
        }
    }

    /// Take in one datagram: keep it only if it is from `rmp`, well framed, plausible and newer
    /// than what we hold.
    fn ingest(&mut self, bytes: &[u8], from: SocketAddr, rmp: SocketAddr, now: Instant) {
        if from != rmp {
            self.counts.foreign += 1;
            return;
        }
        self.last_datagram = Some(now);
        match bytes.len() {
            FEEDBACK_LEN => self.ingest_feedback(bytes, now),
            FAULT_LOG_LEN => match codec::decode_reply(bytes, WordOrder::Little) {
                // CRC does not depend on the word order; the words are read once it is known.
                Ok(_) => {
                    self.counts.fault_logs += 1;
                    self.fault_log_raw = Some(bytes.to_vec());
                }
                Err(_) => self.counts.bad_crc += 1,
            },
            _ => self.counts.bad_length += 1,
        }
    }

    fn ingest_feedback(&mut self, bytes: &[u8], now: Instant) {
        let order = match self.order {
            Some(o) => o,
            None => {
                if let Err(FrameError::BadCrc { .. }) = Feedback::decode(bytes, WordOrder::Little) {
                    self.counts.bad_crc += 1;
                    return;
                }
                match WordOrder::detect(bytes) {
                    Some(o) => {
                        self.order = Some(o);
                        o
                    }
                    None => {
                        self.counts.implausible += 1;
                        return;
                    }
                }
            }
        };
        let fb = match Feedback::decode(bytes, order) {
            Ok(fb) => fb,
            Err(FrameError::BadCrc { .. }) => {
                self.counts.bad_crc += 1;
                return;
            }
            Err(_) => {
                self.counts.bad_length += 1;
                return;
            }
        };
        if !fb.plausible() {
            self.counts.implausible += 1;
            return;
        }
        if let Some((held, _)) = &self.latest {
            let (t_new, t_held) = (fb.operational_time_s(), held.operational_time_s());
            // Older by less than a second is a reordered datagram; older by more is a platform
            // that restarted, whose clock began again.
            if t_new <= t_held && t_held - t_new < 1.0 {
                self.counts.stale += 1;
                return;
            }
        }
        self.counts.feedback += 1;
        self.latest = Some((fb, now));
    }
}

/// The socket and the shared state; the threads hold it by `Arc`.
#[derive(Debug)]
struct Link {
    socket: UdpSocket,
    rmp: SocketAddr,
    state: Mutex<LinkState>,
}

impl Link {
    fn lock(&self) -> MutexGuard<'_, LinkState> {
        // Every update under this lock is a plain field write, so a poisoned lock is still whole.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn send(&self, c: Command) -> std::io::Result<()> {
        self.socket.send_to(&c.encode(), self.rmp)?;
        self.lock().counts.sent += 1;
        Ok(())
    }

    fn send_zero_and_dtz(&self) -> std::io::Result<()> {
        self.send(Command::Motion {
            vx_mps: 0.0,
            vy_mps: 0.0,
            yaw_radps: 0.0,
        })?;
        self.send(Command::General {
            id: gp::SET_MODE,
            param: ModeRequest::Dtz as u32,
        })
    }

    /// Begin a stop (unless one is under way): zero, DTZ, and the watchdog repeats them.
    fn begin_stop(&self, reason: StopReason) {
        {
            let mut st = self.lock();
            st.armed = false;
            if st.stopping.is_none() {
                st.stopping = Some((reason, Instant::now()));
            }
            st.last_stop_sent = Some(Instant::now());
        }
        // A send error here means the network is gone; the platform's own timeout takes over.
        let _ = self.send_zero_and_dtz();
    }
}

/// Stops the base from another thread (a Ctrl-C handler): zero and decelerate-to-zero, repeated by
/// the watchdog until the platform leaves drive mode.
#[derive(Clone, Debug)]
pub struct RmpStopHandle {
    link: Arc<Link>,
}

impl RmpStopHandle {
    pub fn stop(&self) {
        self.link.begin_stop(StopReason::Requested);
    }
}

/// A Segway RMP v3 (Stanley Innovation firmware) driven over UDP.
#[derive(Debug)]
pub struct RmpBackend {
    link: Arc<Link>,
    config: RmpConfig,
    platform: Platform,
    shutdown: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    /// Odometry at reset (platform frame) and the start pose it stands for.
    frame: Option<(Pose, Pose)>,
    t0: Instant,
    next_deadline: Instant,
}

impl RmpBackend {
    /// Open a link to the platform at `addr` and run the vendor's start-up sequence: stop streaming
    /// until quiet, fetch the fault log, start streaming (and detect the feedback byte order),
    /// check the platform, load the machine configuration and verify its echo, wait for standby.
    /// Each step gives up after `config.step_timeout_s`. The base is left in standby; `reset`
    /// enters the drive mode.
    pub fn connect(addr: SocketAddr, config: RmpConfig) -> Result<RmpBackend, BackendError> {
        config.validate()?;
        // Bind on the interface family of the platform; loopback stays on loopback.
        let local: SocketAddr = match addr.ip() {
            IpAddr::V4(ip) if ip.is_loopback() => (Ipv4Addr::LOCALHOST, 0).into(),
            IpAddr::V4(_) => (Ipv4Addr::UNSPECIFIED, 0).into(),
            IpAddr::V6(ip) if ip.is_loopback() => (Ipv6Addr::LOCALHOST, 0).into(),
            IpAddr::V6(_) => (Ipv6Addr::UNSPECIFIED, 0).into(),
        };
        let socket = UdpSocket::bind(local)?;
        socket.set_read_timeout(Some(RECV_TIMEOUT))?;
        let link = Arc::new(Link {
            socket,
            rmp: addr,
            state: Mutex::new(LinkState::new()),
        });
        let shutdown = Arc::new(AtomicBool::new(false));
        let threads = vec![
            spawn("rmp-receiver", {
                let (link, shutdown) = (Arc::clone(&link), Arc::clone(&shutdown));
                move || receiver(&link, &shutdown)
            })?,
            spawn("rmp-watchdog", {
                let (link, shutdown) = (Arc::clone(&link), Arc::clone(&shutdown));
                let (timeout, step_timeout) = (
                    Duration::from_secs_f64(config.watchdog_timeout_s),
                    Duration::from_secs_f64(config.step_timeout_s),
                );
                move || watchdog(&link, &shutdown, timeout, step_timeout)
            })?,
        ];
        let now = Instant::now();
        let mut backend = RmpBackend {
            link,
            config,
            platform: Platform::Rmp220,
            shutdown,
            threads,
            frame: None,
            t0: now,
            next_deadline: now,
        };
        backend.start_up()?;
        Ok(backend)
    }

    /// How long one start-up or reset step may wait for the platform.
    fn step_timeout(&self) -> Duration {
        Duration::from_secs_f64(self.config.step_timeout_s)
    }

    /// The vendor's start-up sequence, one step after the other; each step fails with its name.
    fn start_up(&mut self) -> Result<(), BackendError> {
        self.stop_streaming()?;
        self.read_fault_log()?;
        self.start_streaming()?;
        self.check_platform()?;
        self.load_machine_config()?;
        self.wait_for_standby()
    }

    /// Start-up: stop streaming until the platform has been quiet for 0.1 s.
    fn stop_streaming(&mut self) -> Result<(), BackendError> {
        let timeout = self.step_timeout();
        let link = Arc::clone(&self.link);
        let quiet = Duration::from_millis(100);
        let began = Instant::now();
        let mut sent_at: Option<Instant> = None;
        loop {
            let now = Instant::now();
            if sent_at.is_none_or(|t| now - t >= Duration::from_millis(500)) {
                link.send(Command::General {
                    id: gp::STREAMING,
                    param: 0,
                })?;
                sent_at = Some(now);
            }
            let last = link.lock().last_datagram;
            let since = last.map_or(now - began, |t| now - t);
            if since >= quiet && sent_at.is_some_and(|t| now - t >= quiet) {
                break;
            }
            if now - began > timeout {
                return Err(startup_failed(
                    "stop streaming",
                    format!(
                        "the platform kept sending for {} ms after being asked to stop",
                        timeout.as_millis()
                    ),
                ));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Ok(())
    }

    /// Start-up: the fault log, requested at 2 Hz.
    fn read_fault_log(&mut self) -> Result<(), BackendError> {
        let timeout = self.step_timeout();
        let link = Arc::clone(&self.link);
        retry(
            &link,
            timeout,
            Duration::from_millis(500),
            Command::General {
                id: gp::FAULT_LOG,
                param: 0,
            },
            |st| st.fault_log_raw.is_some(),
        )
        .map_err(|e| match e {
            RetryError::Io(e) => e.into(),
            RetryError::Timeout => startup_failed(
                "fault log",
                format!(
                    "no fault log from {} within {} ms: nothing answers at that address",
                    link.rmp,
                    timeout.as_millis()
                ),
            ),
        })?;
        Ok(())
    }

    /// Start-up: start streaming at 10 Hz until the first plausible feedback (which fixes byte order).
    fn start_streaming(&mut self) -> Result<(), BackendError> {
        let timeout = self.step_timeout();
        let link = Arc::clone(&self.link);
        // Replies to the earlier commands do not count: forget them.
        link.lock().latest = None;
        retry(
            &link,
            timeout,
            Duration::from_millis(100),
            Command::General {
                id: gp::STREAMING,
                param: 1,
            },
            |st| st.latest.is_some(),
        )
        .map_err(|e| match e {
            RetryError::Io(e) => e.into(),
            RetryError::Timeout => {
                let c = link.lock().counts;
                startup_failed(
                    "start streaming",
                    format!(
                        "no plausible feedback within {} ms ({} bad CRC, {} implausible, {} of another length)",
                        timeout.as_millis(),
                        c.bad_crc,
                        c.implausible,
                        c.bad_length
                    ),
                )
            }
        })?;
        Ok(())
    }

    /// Start-up: the platform, as the feedback names it, checked against what the configuration expects.
    fn check_platform(&mut self) -> Result<(), BackendError> {
        let fb = self.latest_feedback().0;
        let platform = fb.platform().ok_or_else(|| {
            startup_failed(
                "check platform",
                format!("unknown platform id {:#x}", fb.words[word::PLATFORM_ID]),
            )
        })?;
        if let Some(want) = self.config.expect_platform
            && want != platform
        {
            return Err(startup_failed(
                "check platform",
                format!("expected an {}, found an {}", want.name(), platform.name()),
            ));
        }
        if self.config.drive_mode == DriveMode::Balance && platform != Platform::Rmp220 {
            return Err(startup_failed(
                "check platform",
                format!(
                    "balance mode needs an RMP 220, found an {}",
                    platform.name()
                ),
            ));
        }
        self.platform = platform;
        Ok(())
    }

    /// Start-up: load the machine configuration at 2 Hz until the echo matches bit for bit.
    fn load_machine_config(&mut self) -> Result<(), BackendError> {
        let timeout = self.step_timeout();
        let link = Arc::clone(&self.link);
        let words = self.config.machine.to_words();
        let echo_ok = retry(
            &link,
            timeout,
            Duration::from_millis(500),
            Command::MachineConfig(words),
            |st| {
                st.latest
                    .as_ref()
                    .is_some_and(|(fb, _)| fb.config_echo() == words)
            },
        );
        match echo_ok {
            Ok(()) => {}
            Err(RetryError::Io(e)) => return Err(e.into()),
            Err(RetryError::Timeout) => {
                let echo = self.latest_feedback().0.config_echo();
                return Err(startup_failed(
                    "load machine configuration",
                    describe_echo_mismatch(&self.config.machine, &echo),
                ));
            }
        }
        Ok(())
    }

    /// Start-up: standby, without critical faults.
    fn wait_for_standby(&mut self) -> Result<(), BackendError> {
        let timeout = self.step_timeout();
        let began = Instant::now();
        loop {
            let fb = self.latest_feedback().0;
            if fb.words[0] & CRITICAL_FAULT_MASK != 0 {
                return Err(startup_failed(
                    "wait for standby",
                    format!("critical fault word {:#010x}", fb.words[0]),
                ));
            }
            match fb.op_state() {
                Some(OpState::Standby | OpState::Tractor | OpState::Balance) => break,
                Some(OpState::Disabled) => {
                    return Err(startup_failed(
                        "wait for standby",
                        "the platform is disabled (powered down or E-stopped); power-cycle it"
                            .into(),
                    ));
                }
                _ => {}
            }
            if began.elapsed() > timeout {
                return Err(startup_failed(
                    "wait for standby",
                    format!("still {}", state_name(fb.op_state())),
                ));
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        Ok(())
    }

    /// The latest feedback; start-up guarantees there is one.
    fn latest_feedback(&self) -> (Feedback, Instant) {
        self.link
            .lock()
            .latest
            .clone()
            .unwrap_or_else(|| (Feedback::default(), self.t0))
    }

    /// The local address the driver receives on (tests send foreign datagrams to it).
    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.link.socket.local_addr()
    }

    pub fn platform(&self) -> Platform {
        self.platform
    }

    pub fn counts(&self) -> DriverCounts {
        self.link.lock().counts
    }

    /// The fault log fetched at start-up, in the detected word order.
    pub fn fault_log(&self) -> Option<Vec<u32>> {
        let st = self.link.lock();
        let raw = st.fault_log_raw.as_ref()?;
        codec::decode_reply(raw, st.order?).ok()
    }

    /// The latest feedback, decoded (pitch, faults, battery and the raw words).
    pub fn status(&self) -> Option<RmpStatus> {
        let st = self.link.lock();
        let (fb, at) = st.latest.clone()?;
        Some(RmpStatus {
            state: fb.op_state(),
            platform: fb.platform(),
            order: st.order.unwrap_or(WordOrder::Little),
            pitch_deg: f64::from(fb.f(word::PITCH_DEG)),
            pitch_rate_degps: f64::from(fb.f(word::PITCH_RATE_DEGPS)),
            roll_deg: f64::from(fb.f(word::ROLL_DEG)),
            min_battery_soc_pct: f64::from(fb.f(word::MIN_PROPULSION_SOC)),
            faults: fb.faults(),
            age: at.elapsed(),
            operational_time_s: f64::from(fb.operational_time_s()),
            feedback: fb,
        })
    }

    /// A handle that stops the base from another thread.
    pub fn stop_handle(&self) -> RmpStopHandle {
        RmpStopHandle {
            link: Arc::clone(&self.link),
        }
    }

    fn drive_state(&self) -> OpState {
        match self.config.drive_mode {
            DriveMode::Tractor => OpState::Tractor,
            DriveMode::Balance => OpState::Balance,
        }
    }

    /// Feedback newer than `link_timeout_s`, or a lost link (which also begins a stop).
    fn fresh_feedback(&self) -> Result<(Feedback, Instant), BackendError> {
        let (fb, at) = self.latest_feedback();
        let age = at.elapsed();
        if age > Duration::from_secs_f64(self.config.link_timeout_s) {
            self.link.begin_stop(StopReason::LinkLost);
            return Err(BackendError::LinkLost {
                waited_ms: age.as_millis() as u64,
            });
        }
        Ok((fb, at))
    }

    /// The platform's odometry pose and measured `(speed, rotation)` in `fb`. Corrupt odometry
    /// ([`crate::backend::odometry_fault`]) is never acted on: the base is stopped now (DTZ, as on
    /// a fault) and the run ends with [`BackendError::BadOdometry`].
    fn odometry(&self, fb: &Feedback) -> Result<(Pose, (f64, f64)), BackendError> {
        let (x, y, yaw) = fb.odom();
        let odom = Pose::new(f64::from(x), f64::from(y), f64::from(yaw));
        let speeds = (
            f64::from(fb.f(word::ODOM_VX)),
            f64::from(fb.f(word::ODOM_YAW_RATE)),
        );
        if let Some(what) = crate::backend::odometry_fault(odom, speeds.0, speeds.1) {
            self.link
                .begin_stop(StopReason::Fault(format!("corrupt odometry: {what}")));
            return Err(BackendError::BadOdometry {
                topic: "the RMP's feedback".into(),
                what,
            });
        }
        Ok((odom, speeds))
    }

    /// Wait (bounded) until the base is measured at rest.
    fn wait_for_rest(&self) -> Result<(), BackendError> {
        let (fb, _) = self.fresh_feedback()?;
        let v = f64::from(fb.f(word::ODOM_VX)).abs();
        let budget = v / f64::from(self.config.machine.dtz_decel_mps2).max(0.05)
            + self.config.step_timeout_s;
        let began = Instant::now();
        loop {
            let (fb, _) = self.fresh_feedback()?;
            let at_rest = f64::from(fb.f(word::ODOM_VX)).abs() < REST_MPS
                && f64::from(fb.f(word::ODOM_YAW_RATE)).abs() < REST_RADPS;
            if at_rest {
                return Ok(());
            }
            if began.elapsed().as_secs_f64() > budget {
                return Err(BackendError::Fault {
                    what: format!(
                        "the base is still moving at {:.2} m/s {budget:.1} s after being told to stop",
                        fb.f(word::ODOM_VX)
                    ),
                });
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

fn spawn(name: &str, f: impl FnOnce() + Send + 'static) -> Result<JoinHandle<()>, BackendError> {
    Ok(std::thread::Builder::new().name(name.into()).spawn(f)?)
}

fn state_name(s: Option<OpState>) -> String {
    s.map_or_else(|| "in an unknown state".into(), |s| s.name().to_string())
}

enum RetryError {
    Io(std::io::Error),
    Timeout,
}

/// A start-up step that failed, named as the vendor's sequence names it.
fn startup_failed(step: &str, detail: String) -> BackendError {
    BackendError::StartupFailed {
        step: step.into(),
        detail,
    }
}

/// Send `cmd` every `every` until `done` holds or `timeout` passes.
fn retry(
    link: &Link,
    timeout: Duration,
    every: Duration,
    cmd: Command,
    done: impl Fn(&LinkState) -> bool,
) -> Result<(), RetryError> {
    let began = Instant::now();
    let mut sent_at: Option<Instant> = None;
    loop {
        if done(&link.lock()) {
            return Ok(());
        }
        let now = Instant::now();
        if now - began > timeout {
            return Err(RetryError::Timeout);
        }
        if sent_at.is_none_or(|t| now - t >= every) {
            link.send(cmd).map_err(RetryError::Io)?;
            sent_at = Some(now);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn describe_echo_mismatch(sent: &MachineConfig, echo: &[u32; 12]) -> String {
    let words = sent.to_words();
    for (i, (s, e)) in words.iter().zip(echo).enumerate() {
        if s != e {
            let name = super::config::MACHINE_CONFIG_FIELDS
                .get(i)
                .map_or("bitmap", |f| f.0);
            return if i < 11 {
                format!(
                    "the platform echoes `{name}` as {} where {} was sent",
                    f32::from_bits(*e),
                    f32::from_bits(*s)
                )
            } else {
                format!("the platform echoes the config bitmap as {e:#x} where {s:#x} was sent")
            };
        }
    }
    "no echo of the machine configuration arrived".into()
}

fn receiver(link: &Link, shutdown: &AtomicBool) {
    let mut buf = [0u8; 2048];
    while !shutdown.load(Ordering::Relaxed) {
        // Timeouts, and ICMP "port unreachable" surfacing as errors, are not data: the link
        // timeout decides when silence is a lost link.
        if let Ok((n, from)) = link.socket.recv_from(&mut buf) {
            link.lock()
                .ingest(&buf[..n], from, link.rmp, Instant::now());
        }
    }
}

fn watchdog(link: &Link, shutdown: &AtomicBool, timeout: Duration, give_up: Duration) {
    while !shutdown.load(Ordering::Relaxed) {
        std::thread::sleep(WATCHDOG_TICK);
        let now = Instant::now();
        let send = {
            let mut st = link.lock();
            if st.armed && st.stopping.is_none() && now - st.last_command_at > timeout {
                let idle_ms = (now - st.last_command_at).as_millis() as u64;
                st.counts.watchdog_trips += 1;
                st.armed = false;
                st.stopping = Some((StopReason::Watchdog { idle_ms }, now));
                st.last_stop_sent = None;
            }
            match &st.stopping {
                Some((_, since)) => {
                    let driving = st
                        .latest
                        .as_ref()
                        .is_some_and(|(fb, _)| fb.op_state().is_some_and(OpState::drives));
                    let due = st.last_stop_sent.is_none_or(|t| now - t >= STOP_REPEAT);
                    // Repeat until the platform reports it left drive mode; past `give_up` the
                    // platform's own command timeout is what remains.
                    let send = driving && due && now - *since < give_up;
                    if send {
                        st.last_stop_sent = Some(now);
                    }
                    send
                }
                None => false,
            }
        };
        if send {
            let _ = link.send_zero_and_dtz();
        }
    }
}

impl Backend for RmpBackend {
    fn name(&self) -> String {
        format!("rmp:{}", self.link.rmp)
    }

    fn period_s(&self) -> f64 {
        self.config.period_s
    }

    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        let timeout = self.step_timeout();
        let (fb, _) = self.fresh_feedback()?;
        if fb.op_state().is_some_and(OpState::drives)
            && f64::from(fb.f(word::ODOM_VX)).abs() >= REST_MPS
        {
            self.link.begin_stop(StopReason::Requested);
            self.wait_for_rest()?;
        }
        // Let a stop under way finish (the platform goes to standby after DTZ) before re-arming.
        let began = Instant::now();
        while self.link.lock().stopping.is_some() {
            let (fb, _) = self.fresh_feedback()?;
            if !fb.op_state().is_some_and(OpState::drives) || began.elapsed() > timeout {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        self.link.lock().stopping = None;

        let want = self.drive_state();
        let request = match self.config.drive_mode {
            DriveMode::Tractor => ModeRequest::Tractor,
            DriveMode::Balance => ModeRequest::Balance,
        };
        let r = retry(
            &self.link,
            timeout,
            Duration::from_millis(200),
            Command::General {
                id: gp::SET_MODE,
                param: request as u32,
            },
            |st| {
                st.latest
                    .as_ref()
                    .is_some_and(|(fb, _)| fb.op_state() == Some(want))
            },
        );
        match r {
            Ok(()) => {}
            Err(RetryError::Io(e)) => return Err(e.into()),
            Err(RetryError::Timeout) => {
                let (fb, _) = self.fresh_feedback()?;
                return Err(BackendError::ModeChange {
                    wanted: want.name().into(),
                    reported: state_name(fb.op_state()),
                    waited_ms: timeout.as_millis() as u64,
                });
            }
        }
        self.link.send(Command::Motion {
            vx_mps: 0.0,
            vy_mps: 0.0,
            yaw_radps: 0.0,
        })?;
        let (fb, _) = self.fresh_feedback()?;
        // A frame origin taken from corrupt odometry would make every pose of the run corrupt.
        let (odom, speeds) = self.odometry(&fb)?;
        self.frame = Some((odom, start));
        let now = Instant::now();
        self.t0 = now;
        self.next_deadline = now + Duration::from_secs_f64(self.config.period_s);
        {
            let mut st = self.link.lock();
            st.armed = true;
            st.stopping = None;
            st.last_command_at = now;
        }
        Ok(BaseState {
            t_s: 0.0,
            pose: start,
            speed_mps: speeds.0,
            rot_radps: speeds.1,
        })
    }

    fn command(&mut self, speed_mps: f64, rot_radps: f64) -> Result<(), BackendError> {
        {
            let st = self.link.lock();
            if let Some((reason, _)) = &st.stopping {
                return Err(BackendError::Stopped {
                    reason: reason.describe(),
                });
            }
            if !st.armed {
                return Err(BackendError::Stopped {
                    reason: "the backend has not been reset into drive mode".into(),
                });
            }
        }
        let finite = speed_mps.is_finite() && rot_radps.is_finite();
        let (max_v, max_w) = self.config.speed_limits();
        let (v, w) = if finite {
            (
                speed_mps.clamp(-max_v, max_v),
                rot_radps.clamp(-max_w, max_w),
            )
        } else {
            (0.0, 0.0)
        };
        self.link.send(Command::Motion {
            vx_mps: v as f32,
            vy_mps: 0.0,
            yaw_radps: w as f32,
        })?;
        self.link.lock().last_command_at = Instant::now();
        if finite {
            Ok(())
        } else {
            Err(BackendError::InvalidCommand {
                speed_mps,
                rot_radps,
            })
        }
    }

    fn step(&mut self) -> Result<BaseState, BackendError> {
        crate::backend::wait_for_tick(&mut self.next_deadline, self.config.period_s);
        let (fb, _) = self.fresh_feedback()?;
        let critical = fb.words[0] & CRITICAL_FAULT_MASK;
        if critical != 0 {
            let what = format!("critical fault word {critical:#010x}");
            self.link.begin_stop(StopReason::Fault(what.clone()));
            return Err(BackendError::Fault { what });
        }
        let armed = self.link.lock().armed;
        if armed && !fb.op_state().is_some_and(OpState::drives) {
            // The platform left drive mode on its own: an E-stop, a DTZ line, a power-down.
            let what = format!(
                "the platform left {} mode and is now {}",
                self.drive_state().name(),
                state_name(fb.op_state())
            );
            self.link.begin_stop(StopReason::Fault(what.clone()));
            return Err(BackendError::Fault { what });
        }
        let (odom, (speed_mps, rot_radps)) = self.odometry(&fb)?;
        let pose = match self.frame {
            Some((origin, start)) => rezero(origin, start, odom),
            None => odom,
        };
        Ok(BaseState {
            t_s: self.t0.elapsed().as_secs_f64(),
            pose,
            speed_mps,
            rot_radps,
        })
    }

    fn stop(&mut self) -> Result<(), BackendError> {
        self.link.begin_stop(StopReason::Requested);
        self.wait_for_rest()
    }
}

/// What the session holds: the platform and feedback said on connecting, the Ctrl-C stop from
/// any thread.
impl Base for RmpBackend {
    fn describe(&self) -> Option<String> {
        let platform = self.platform().name();
        let order = self.status().map_or("unknown", |s| s.order.name());
        Some(format!(
            "an {platform} in standby ({order} feedback); `run` drives it in tractor mode, Ctrl-C stops it"
        ))
    }

    fn remote_stop(&self) -> Option<BaseStop> {
        let handle = self.stop_handle();
        Some(BaseStop::new(move || handle.stop()))
    }

    fn stop_now(&mut self) -> String {
        match self.stop() {
            Ok(()) => format!("{} stopped (decelerate-to-zero)", self.name()),
            Err(e) => format!(
                "{} was told to stop (zero and decelerate-to-zero) but did not confirm it: {e}",
                self.name()
            ),
        }
    }
}

impl Drop for RmpBackend {
    /// A dropped session stops the base first: zero and DTZ, repeated a few times (UDP may lose
    /// one) while the watchdog is still running, then the threads end.
    fn drop(&mut self) {
        let driving = self
            .link
            .lock()
            .latest
            .as_ref()
            .is_some_and(|(fb, _)| fb.op_state().is_some_and(OpState::drives));
        if driving {
            self.link.begin_stop(StopReason::Dropped);
            std::thread::sleep(STOP_REPEAT * 3);
        }
        self.shutdown.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feedback(op_time_s: f32, odom_x: f32) -> Feedback {
        let mut fb = Feedback::default();
        fb.words[word::PLATFORM_ID] = Platform::Rmp220 as u32;
        fb.words[word::OPERATIONAL_STATE] = OpState::Tractor as u32;
        fb.set_f(word::OPERATIONAL_TIME_S, op_time_s);
        fb.set_f(word::ODOM_X, odom_x);
        fb
    }

    fn addr(port: u16) -> SocketAddr {
        (Ipv4Addr::LOCALHOST, port).into()
    }

    #[test]
    fn only_good_feedback_from_the_platform_is_kept() {
        let (rmp, other) = (addr(8080), addr(9999));
        let mut st = LinkState::new();
        let now = Instant::now();
        let good = feedback(1.0, 0.5).encode(WordOrder::Big);
        st.ingest(&good, rmp, rmp, now);
        assert_eq!(st.order, Some(WordOrder::Big));
        let kept = st.latest.clone().unwrap().0;

        // Foreign, corrupted, truncated, implausible and stale frames change nothing.
        st.ingest(&feedback(2.0, 9.0).encode(WordOrder::Big), other, rmp, now);
        let mut bad = feedback(2.0, 9.0).encode(WordOrder::Big);
        bad[100] ^= 0x40;
        st.ingest(&bad, rmp, rmp, now);
        st.ingest(&good[..500], rmp, rmp, now);
        st.ingest(&feedback(2.0, 9.0).encode(WordOrder::Little), rmp, rmp, now);
        st.ingest(&feedback(0.99, 9.0).encode(WordOrder::Big), rmp, rmp, now);
        assert_eq!(st.latest.clone().unwrap().0, kept);
        let c = st.counts;
        assert_eq!(
            (
                c.feedback,
                c.foreign,
                c.bad_crc,
                c.bad_length,
                c.implausible,
                c.stale
            ),
            (1, 1, 1, 1, 1, 1)
        );

        st.ingest(&feedback(1.01, 0.6).encode(WordOrder::Big), rmp, rmp, now);
        assert_eq!(st.latest.clone().unwrap().0.f(word::ODOM_X), 0.6);
        // A platform that restarted: its clock begins again, and it is believed.
        st.ingest(&feedback(0.01, 0.0).encode(WordOrder::Big), rmp, rmp, now);
        assert_eq!(st.latest.clone().unwrap().0.f(word::ODOM_X), 0.0);
    }

    #[test]
    fn echo_mismatch_names_the_word() {
        let sent = MachineConfig::default();
        let mut echo = sent.to_words();
        echo[0] = 0.5f32.to_bits();
        assert_eq!(
            describe_echo_mismatch(&sent, &echo),
            "the platform echoes `velocity_limit_mps` as 0.5 where 1 was sent"
        );
    }
}
