//! An RMP v3 platform on a UDP socket: the protocol, the state machine, limits and slew, the 0.5 s
//! command timeout, 100 Hz streaming, the config echo, fault bits for bad packets, either feedback
//! byte order, and injected datagram faults (drop, corrupt, delay).
//!
//! This module owns the emulated platform ([`Platform`], no sockets, stepped by the caller) and the
//! socket loop around it ([`Emulator::bind`], a background thread with a clean shutdown). The
//! physics of the base sits behind [`EmulatedBase`]: the team's simulator ([`SimBase`], what the
//! CLI runs, [`Emulator::bind_sim`]) or a simple noiseless stand-in ([`LagBase`]). It must not
//! send anywhere but to the source of the last valid datagram it received, and it never panics on
//! what arrives.

use std::collections::VecDeque;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::codec::{
    self, Command, FAULT_LOG_WORDS, Feedback, FrameError, ModeRequest, OpState, comm_fault,
    critical_fault,
    fault_log::{self, entry},
    gp, word,
};
use super::config::{BITMAP_BALANCE_ENABLED, EmulatorConfig, MachineConfig, RmpConfigError};
use crate::backend::BaseState;
use crate::backend::sim::{SimBase, SimError, SimParams};
use crate::geometry::{Pose, integrate_arc, limit_speed, wheel_speeds};

/// The pose arithmetic lives in [`crate::geometry`]; kept here under its old paths.
pub use crate::geometry::{compose_pose, relative_pose, wrap_angle};

const G_MPS2: f64 = 9.80665;

/// The physics under the emulated platform: a differential-drive base that takes the platform's
/// slewed speed commands ([`SimBase`] and [`LagBase`] implement it).
pub trait EmulatedBase: Send {
    /// Put the base at rest at `pose`.
    fn reset(&mut self, pose: Pose);
    /// The speeds the platform's motor controllers aim for from now on.
    fn set_command(&mut self, speed_mps: f64, rot_radps: f64);
    /// Advance `dt_s` seconds; the state's pose is the base's odometry.
    fn advance(&mut self, dt_s: f64) -> BaseState;
    /// The true pose (equal to odometry for a base without drift).
    fn true_pose(&self) -> Pose;
}

/// Stand-in base: each speed follows its command through a first-order lag (the motor and, on a
/// balancing base, the lean it must take before it can accelerate), and odometry is exact.
#[derive(Clone, Debug)]
pub struct LagBase {
    pub lag_s: f64,
    state: BaseState,
    cmd: (f64, f64),
}

impl LagBase {
    pub fn new(lag_s: f64) -> LagBase {
        LagBase {
            lag_s: lag_s.max(0.0),
            state: BaseState::default(),
            cmd: (0.0, 0.0),
        }
    }
}

impl EmulatedBase for LagBase {
    fn reset(&mut self, pose: Pose) {
        self.state = BaseState {
            pose,
            ..BaseState::default()
        };
        self.cmd = (0.0, 0.0);
    }

    fn set_command(&mut self, speed_mps: f64, rot_radps: f64) {
        self.cmd = (speed_mps, rot_radps);
    }

    fn advance(&mut self, dt_s: f64) -> BaseState {
        let s = &mut self.state;
        let alpha = if self.lag_s > 0.0 {
            1.0 - (-dt_s / self.lag_s).exp()
        } else {
            1.0
        };
        s.speed_mps += alpha * (self.cmd.0 - s.speed_mps);
        s.rot_radps += alpha * (self.cmd.1 - s.rot_radps);
        s.pose = integrate_arc(s.pose, s.speed_mps, s.rot_radps, dt_s);
        s.t_s += dt_s;
        *s
    }

    fn true_pose(&self) -> Pose {
        self.state.pose
    }
}

/// The team's simulator behind the emulator: the same lag, acceleration limits, encoder noise and
/// odometry drift as `advise eval` on `sim`, so a policy sees the same base over the wire. The
/// platform's own limits and slew act first, as on the real RMP.
impl EmulatedBase for SimBase {
    fn reset(&mut self, pose: Pose) {
        SimBase::reset(self, pose);
    }

    fn set_command(&mut self, speed_mps: f64, rot_radps: f64) {
        SimBase::set_command(self, speed_mps, rot_radps);
    }

    fn advance(&mut self, dt_s: f64) -> BaseState {
        SimBase::advance(self, dt_s)
    }

    fn true_pose(&self) -> Pose {
        SimBase::true_pose(self)
    }
}

/// Counts of what arrived and what was done to it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmulatorCounts {
    pub received: u64,
    pub accepted: u64,
    pub bad_crc: u64,
    pub bad_length: u64,
    pub unknown_id: u64,
    pub sent: u64,
    pub injected_drops: u64,
    pub injected_corruptions: u64,
    pub injected_delays: u64,
}

/// A view of the emulated platform for tests and the CLI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Snapshot {
    pub t_s: f64,
    pub state: OpState,
    pub streaming: bool,
    /// The base's measured speeds.
    pub speed_mps: f64,
    pub rot_radps: f64,
    /// The speeds after limits and slew, as sent to the base.
    pub slewed_mps: f64,
    pub slewed_radps: f64,
    pub odom: Pose,
    pub true_pose: Pose,
    pub faults: [u32; 4],
    pub machine: MachineConfig,
    pub counts: EmulatorCounts,
    /// Decelerating to zero after a DTZ request.
    pub dtz: bool,
    /// Waiting for the operator to tip the base back before balancing.
    pub awaiting_tip_back: bool,
}

/// The emulated platform: state machine, limits, slew and feedback, stepped by its caller.
pub struct Platform {
    cfg: EmulatorConfig,
    machine: MachineConfig,
    ethernet: [u32; 4],
    base: Box<dyn EmulatedBase>,
    t_s: f64,
    state: OpState,
    streaming: bool,
    faults: [u32; 4],
    /// Commanded (vx, yaw) and when (platform time).
    cmd: (f64, f64),
    last_motion_s: Option<f64>,
    /// After limits and slew.
    slewed: (f64, f64),
    dtz: bool,
    awaiting_tip_back: bool,
    tipped_back: bool,
    last: BaseState,
    /// The base's odometry pose at the last integrator reset; reported odometry is relative to it.
    odom_origin: Pose,
    /// Integrated wheel positions RF, LF, RR, LR.
    wheel_pos_m: [f64; 4],
    accel_mps2: f64,
    pitch_deg: f64,
    soc_pct: f64,
    torque_limit: f32,
    counts: EmulatorCounts,
    /// Distance the base has travelled since power-up (the fault log's odometer).
    odometer_m: f64,
    /// The fault log's entries, a ring; how many are written and which was written last.
    log: [[u32; fault_log::ENTRY_WORDS]; fault_log::MAX_ENTRIES],
    log_count: usize,
    log_latest: usize,
    /// The fault words when the last entry was written.
    logged: [u32; 4],
}

/// The fault-log format version the emulator reports (the real platform's value is not public).
const FAULT_LOG_VERSION: u32 = 1;
/// The emulated platform has powered up once.
const POWER_CYCLES: u32 = 1;

/// What a datagram asks the socket loop to send back.
#[derive(Debug, PartialEq)]
pub enum Reply {
    None,
    Feedback,
    FaultLog,
}

impl Platform {
    /// A platform that has just powered up at the origin, on `base`.
    pub fn new(cfg: EmulatorConfig, mut base: Box<dyn EmulatedBase>) -> Platform {
        base.reset(Pose::default());
        Platform {
            machine: cfg.machine.clamped_to_nvm(cfg.platform),
            ethernet: [0x0100_007F, 8080, 0x00FF_FFFF, 0],
            cfg,
            base,
            t_s: 0.0,
            state: OpState::CcuInit,
            streaming: false,
            faults: [0; 4],
            cmd: (0.0, 0.0),
            last_motion_s: None,
            slewed: (0.0, 0.0),
            dtz: false,
            awaiting_tip_back: false,
            tipped_back: false,
            last: BaseState::default(),
            odom_origin: Pose::default(),
            wheel_pos_m: [0.0; 4],
            accel_mps2: 0.0,
            pitch_deg: 0.0,
            soc_pct: 100.0,
            torque_limit: 1.0,
            counts: EmulatorCounts::default(),
            odometer_m: 0.0,
            log: [[0; fault_log::ENTRY_WORDS]; fault_log::MAX_ENTRIES],
            log_count: 0,
            log_latest: 0,
            logged: [0; 4],
        }
    }

    pub fn state(&self) -> OpState {
        self.state
    }

    pub fn streaming(&self) -> bool {
        self.streaming
    }

    /// The operator tips the base back past vertical: a pending balance request is granted.
    pub fn tip_back(&mut self) {
        self.tipped_back = true;
    }

    /// Raise critical fault bits in word 0 (a test hook); the platform disables its motors.
    pub fn raise_critical_fault(&mut self, bits: u32) {
        self.faults[0] |= bits & codec::CRITICAL_FAULT_MASK;
        self.state = OpState::Disabled;
        self.log_new_faults();
    }

    /// Write a fault-log entry when the fault words hold a bit the last entry did not. The log is
    /// a ring of [`fault_log::MAX_ENTRIES`] entries, as on the platform.
    fn log_new_faults(&mut self) {
        if self
            .faults
            .iter()
            .zip(&self.logged)
            .all(|(f, l)| f & !l == 0)
        {
            return;
        }
        self.logged = self.faults;
        let i = if self.log_count == 0 {
            0
        } else {
            (self.log_latest + 1) % fault_log::MAX_ENTRIES
        };
        let [fsw0, fsw1, fsw2, fsw3] = self.faults;
        let run_time_s = self.t_s as u32;
        let e = &mut self.log[i];
        *e = [0; fault_log::ENTRY_WORDS];
        // No calendar on the emulated platform: its clock starts at 2011-01-01 at power-up.
        e[entry::TIME_STAMP_S] = run_time_s;
        e[entry::RUN_TIME_S] = run_time_s;
        e[entry::POWER_CYCLE] = POWER_CYCLES;
        // The fault status words split into their groups, each shifted down to bit 0 (research
        // notes, section 3.2: word 0 architecture 0-11 and critical 12-31, word 1 comm 0-15 and
        // internal 16-19, word 2 sensor 0-15 and BSA 16-31, word 3 MCU).
        e[entry::CRITICAL] = (fsw0 & codec::CRITICAL_FAULT_MASK) >> 12;
        e[entry::COMM] = fsw1 & 0xFFFF;
        e[entry::SENSOR] = fsw2 & 0xFFFF;
        e[entry::BSA] = fsw2 >> 16;
        e[entry::MCU] = fsw3;
        e[entry::ARCHITECTURE] = fsw0 & 0xFFF;
        e[entry::INTERNAL] = (fsw1 >> 16) & 0xF;
        self.log_latest = i;
        self.log_count = (self.log_count + 1).min(fault_log::MAX_ENTRIES);
    }

    /// Handle one datagram. Invalid datagrams set a comm fault bit and change nothing else.
    pub fn receive(&mut self, bytes: &[u8]) -> Reply {
        let reply = self.receive_datagram(bytes);
        self.log_new_faults();
        reply
    }

    fn receive_datagram(&mut self, bytes: &[u8]) -> Reply {
        self.counts.received += 1;
        let cmd = match Command::decode(bytes) {
            Ok(c) => c,
            Err(e) => {
                let bit = match e {
                    FrameError::BadCrc { .. } | FrameError::TooShort { .. } => {
                        self.counts.bad_crc += 1;
                        comm_fault::BAD_PACKET_CHECKSUM
                    }
                    FrameError::UnknownId { .. } => {
                        self.counts.unknown_id += 1;
                        comm_fault::UNKNOWN_COMMAND
                    }
                    FrameError::BadLength { id, .. } => {
                        self.counts.bad_length += 1;
                        if id == codec::MOTION_ID {
                            comm_fault::BAD_MOTION_COMMAND
                        } else {
                            comm_fault::UNKNOWN_COMMAND
                        }
                    }
                    _ => comm_fault::UNKNOWN_COMMAND,
                };
                self.faults[1] |= bit;
                return Reply::None;
            }
        };
        self.counts.accepted += 1;
        let reply = self.apply(cmd);
        if reply == Reply::Feedback && self.streaming {
            Reply::None
        } else {
            reply
        }
    }

    fn apply(&mut self, cmd: Command) -> Reply {
        match cmd {
            Command::Motion {
                vx_mps, yaw_radps, ..
            } => {
                if !(vx_mps.is_finite() && yaw_radps.is_finite()) {
                    self.faults[1] |= comm_fault::BAD_MOTION_COMMAND;
                } else if self.state.drives() && !self.dtz {
                    self.cmd = (f64::from(vx_mps), f64::from(yaw_radps));
                    self.last_motion_s = Some(self.t_s);
                }
                Reply::Feedback
            }
            Command::MachineConfig(w) => {
                self.machine = MachineConfig::from_words(&w).clamped_to_nvm(self.cfg.platform);
                Reply::Feedback
            }
            Command::EthernetConfig(w) => {
                self.ethernet = w;
                Reply::Feedback
            }
            Command::General { id, param } => match id {
                gp::NONE | gp::AUDIO_SONG => Reply::Feedback,
                gp::SET_MODE => {
                    match ModeRequest::from_u32(param) {
                        Some(m) => self.request_mode(m),
                        None => self.faults[1] |= comm_fault::UNKNOWN_COMMAND,
                    }
                    Reply::Feedback
                }
                gp::FAULT_LOG => Reply::FaultLog,
                gp::RESET_INTEGRATORS => {
                    if param & 0x01 != 0 {
                        // Odometry restarts at the origin of a new frame where the base stands.
                        self.odom_origin = self.last.pose;
                    }
                    for (bit, i) in [(0x02, 0), (0x04, 1), (0x08, 2), (0x10, 3)] {
                        if param & bit != 0 {
                            self.wheel_pos_m[i] = 0.0;
                        }
                    }
                    Reply::Feedback
                }
                gp::RESET_PARAMS => {
                    // The emulated platform's own defaults, not the RMP 220's.
                    self.machine = MachineConfig::vendor_defaults(self.cfg.platform);
                    Reply::Feedback
                }
                gp::STREAMING => {
                    self.streaming = param != 0;
                    Reply::Feedback
                }
                gp::TORQUE_LIMIT => {
                    let v = f32::from_bits(param);
                    if v.is_finite() {
                        self.torque_limit = v.clamp(0.0, 1.0);
                    }
                    Reply::Feedback
                }
                _ => {
                    self.faults[1] |= comm_fault::UNKNOWN_COMMAND;
                    Reply::Feedback
                }
            },
        }
    }

    fn moving(&self) -> bool {
        self.slewed.0.abs() > 1e-3 || self.slewed.1.abs() > 1e-3
    }

    fn request_mode(&mut self, m: ModeRequest) {
        let ready = matches!(
            self.state,
            OpState::Standby | OpState::Tractor | OpState::Balance
        );
        match m {
            ModeRequest::Disable | ModeRequest::PowerDown => {
                // Motor power is cut at once: the base rolls freely (the lag base coasts down).
                self.state = OpState::Disabled;
                self.dtz = false;
            }
            _ if !ready => {}
            ModeRequest::Dtz => {
                if self.state.drives() {
                    self.dtz = true;
                }
            }
            ModeRequest::Standby => {
                // Standby while moving first decelerates to zero, as DTZ does.
                if self.state.drives() && self.moving() {
                    self.dtz = true;
                } else {
                    self.state = OpState::Standby;
                }
                self.awaiting_tip_back = false;
            }
            ModeRequest::Tractor => {
                if !self.dtz {
                    self.state = OpState::Tractor;
                    self.awaiting_tip_back = false;
                }
            }
            ModeRequest::Balance => {
                let allowed = self.cfg.platform == codec::Platform::Rmp220
                    && self.machine.bitmap & BITMAP_BALANCE_ENABLED != 0;
                if allowed && self.state == OpState::Standby {
                    self.awaiting_tip_back = true;
                    self.tipped_back = false;
                }
            }
        }
    }

    /// Advance the platform by `dt_s` seconds.
    pub fn tick(&mut self, dt_s: f64) {
        self.t_s += dt_s;
        if self.state as u32 <= OpState::CheckingStartup as u32 {
            let phase = self.t_s / self.cfg.init_s.max(1e-6);
            self.state = if phase < 1.0 / 3.0 {
                OpState::CcuInit
            } else if phase < 2.0 / 3.0 {
                OpState::PropulsionInit
            } else if phase < 1.0 {
                OpState::CheckingStartup
            } else {
                OpState::Standby
            };
        }
        if self.awaiting_tip_back
            && (self.tipped_back || !self.cfg.balance_needs_tip_back)
            && self.state == OpState::Standby
        {
            self.awaiting_tip_back = false;
            self.state = OpState::Balance;
        }

        let m = &self.machine;
        let fresh = self
            .last_motion_s
            .is_some_and(|t| self.t_s - t <= self.cfg.command_timeout_s);
        let (target, decel) = if self.state.drives() && !self.dtz && fresh {
            let v = f64::from(m.velocity_limit_mps);
            let w = f64::from(m.yaw_rate_limit_radps);
            (
                (limit_speed(self.cmd.0, v), limit_speed(self.cmd.1, w)),
                f64::from(m.decel_limit_mps2),
            )
        } else if self.dtz {
            ((0.0, 0.0), f64::from(m.dtz_decel_mps2))
        } else {
            // Timed out, standby or disabled: slew to zero at the deceleration limit.
            ((0.0, 0.0), f64::from(m.decel_limit_mps2))
        };
        let accel = f64::from(m.accel_limit_mps2);
        let yaw_accel = f64::from(m.yaw_accel_limit_radps2);
        let (v0, w0) = self.slewed;
        let dv = target.0 - v0;
        // Moving toward zero is decelerating; away from zero is accelerating.
        let lim = if v0 * dv < 0.0 { decel } else { accel } * dt_s;
        let v = v0 + dv.clamp(-lim, lim);
        let lim_w = yaw_accel * dt_s;
        let w = w0 + (target.1 - w0).clamp(-lim_w, lim_w);
        self.slewed = (v, w);
        if self.state == OpState::Disabled {
            self.slewed = (0.0, 0.0);
        }
        self.base.set_command(self.slewed.0, self.slewed.1);
        let prev = self.last;
        self.last = self.base.advance(dt_s);
        // DTZ ends once the base itself is at rest, not just its command: then it holds (standby).
        if self.dtz
            && !self.moving()
            && self.last.speed_mps.abs() < 1e-3
            && self.last.rot_radps.abs() < 1e-3
        {
            self.dtz = false;
            self.state = OpState::Standby;
        }
        self.accel_mps2 = (self.last.speed_mps - prev.speed_mps) / dt_s;
        self.odometer_m += self.last.speed_mps.abs() * dt_s;
        let (left, right) = wheel_speeds(
            self.last.speed_mps,
            self.last.rot_radps,
            f64::from(m.track_width_m),
        );
        for (i, v) in [right, left, right, left].into_iter().enumerate() {
            self.wheel_pos_m[i] += v * dt_s;
        }
        // A balancing base leans into its acceleration: tan(pitch) = a / g.
        self.pitch_deg = if self.state == OpState::Balance {
            (self.accel_mps2 / G_MPS2).atan().to_degrees()
        } else {
            0.0
        };
        if self.pitch_deg.abs() > 30.0 {
            self.raise_critical_fault(critical_fault::PITCH_ANGLE_EXCEEDED);
        }
        // About 8 hours from full to empty.
        self.soc_pct = (self.soc_pct - dt_s * 100.0 / (8.0 * 3600.0)).max(0.0);
    }

    /// The odometry pose in the frame of the last integrator reset.
    fn odom(&self) -> Pose {
        relative_pose(self.odom_origin, self.last.pose)
    }

    /// The feedback frame describing the platform now.
    pub fn feedback(&self) -> Feedback {
        let mut fb = Feedback::default();
        let w = &mut fb.words;
        w[..4].copy_from_slice(&self.faults);
        w[word::OPERATIONAL_STATE] = self.state as u32;
        w[word::BUILD_ID] = 0x0001_0000;
        w[word::PLATFORM_ID] = self.cfg.platform as u32;
        let f = |v: f64| (v as f32).to_bits();
        w[word::OPERATIONAL_TIME_S] = f(self.t_s);
        for i in 0..5 {
            w[word::MIN_PROPULSION_SOC + i] = f(self.soc_pct);
        }
        w[word::AUX_7V2_BATTERY_V] = f(7.2);
        w[word::PITCH_DEG] = f(self.pitch_deg);
        w[word::PSE_YAW_RATE_DEGPS] = f(-self.last.rot_radps.to_degrees());
        w[word::PSE_DATA_VALID] = 1;
        w[word::VX_TARGET] = f(self.slewed.0);
        w[word::YAW_RATE_TARGET] = f(self.slewed.1);
        w[word::YAW_RATE_LIMIT] = f(f64::from(self.machine.yaw_rate_limit_radps));
        w[word::VELOCITY_LIMIT] = f(f64::from(self.machine.velocity_limit_mps));
        let (left, right) = wheel_speeds(
            self.last.speed_mps,
            self.last.rot_radps,
            f64::from(self.machine.track_width_m),
        );
        for (i, v) in [right, left, right, left].into_iter().enumerate() {
            w[word::WHEEL_VELOCITY + i] = f(v);
            w[word::WHEEL_POSITION + i] = f(self.wheel_pos_m[i]);
        }
        w[word::ODOM_ACCEL_X] = f(self.accel_mps2);
        w[word::ODOM_VX] = f(self.last.speed_mps);
        w[word::ODOM_YAW_RATE] = f(self.last.rot_radps);
        let odom = self.odom();
        w[word::ODOM_X] = f(odom.x_m);
        w[word::ODOM_Y] = f(odom.y_m);
        w[word::ODOM_YAW] = f(odom.theta_rad);
        w[word::CONFIG_ECHO..word::CONFIG_ECHO + 12].copy_from_slice(&self.machine.to_words());
        w[word::ETHERNET_ECHO..word::ETHERNET_ECHO + 4].copy_from_slice(&self.ethernet);
        fb
    }

    /// The 311-word fault log in the layout the vendor's fault-log parser reads
    /// ([`codec::fault_log`]): the header, then one entry for each time the fault words gained a
    /// bit since power-up (the emulator keeps no log across power cycles).
    pub fn fault_log(&self) -> Vec<u32> {
        let mut w = vec![0u32; FAULT_LOG_WORDS];
        w[fault_log::LOG_VERSION] = FAULT_LOG_VERSION;
        w[fault_log::LOG_SIZE_BYTES] = (FAULT_LOG_WORDS * 4) as u32;
        w[fault_log::ENTRY_COUNT] = self.log_count as u32;
        w[fault_log::LATEST_ENTRY] = self.log_latest as u32;
        // An emulator's serial number: "EMU" and the platform id.
        w[fault_log::SERIAL_HIGH] = u32::from_be_bytes(*b"\0EMU");
        w[fault_log::SERIAL_LOW] = self.cfg.platform as u32;
        w[fault_log::ACCUMULATED_TIME_S] = self.t_s as u32;
        w[fault_log::ODOMETER_M] = self.odometer_m as u32;
        w[fault_log::POWER_CYCLES] = POWER_CYCLES;
        for (i, e) in self.log.iter().enumerate() {
            let at = fault_log::ENTRIES + i * fault_log::ENTRY_WORDS;
            w[at..at + fault_log::ENTRY_WORDS].copy_from_slice(e);
        }
        w
    }

    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            t_s: self.t_s,
            state: self.state,
            streaming: self.streaming,
            speed_mps: self.last.speed_mps,
            rot_radps: self.last.rot_radps,
            slewed_mps: self.slewed.0,
            slewed_radps: self.slewed.1,
            odom: self.odom(),
            true_pose: self.base.true_pose(),
            faults: self.faults,
            machine: self.machine,
            counts: self.counts,
            dtz: self.dtz,
            awaiting_tip_back: self.awaiting_tip_back,
        }
    }
}

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

    /// Stop the thread and close the socket; waits for the thread (at most one loop turn).
    pub fn shutdown(mut self) {
        self.stop_thread();
    }

    fn stop_thread(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            // The loop only ends by this flag; a panic in it is a bug we want to see in tests.
            if t.join().is_err() {
                eprintln!("rmp emulator thread panicked");
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
    faults: super::config::FaultInjection,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::rmp::codec::WordOrder;

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
        let latest =
            &w[fault_log::ENTRIES + 2 * fault_log::ENTRY_WORDS..][..fault_log::ENTRY_WORDS];
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
}
