//! The emulated platform's state: what it holds, how it powers up and changes mode, and the
//! [`Snapshot`] tests and the CLI read. Datagrams ([`super::protocol`]), motion
//! ([`super::motion`]) and faults ([`super::faults`]) are further `impl Platform` blocks beside
//! this one; the fields are shared with them and nothing else.

use super::base::EmulatedBase;
use crate::backend::BaseState;
use crate::backend::rmp::codec::{self, ModeRequest, OpState, fault_log};
use crate::backend::rmp::config::{BITMAP_BALANCE_ENABLED, EmulatorConfig, MachineConfig};
use crate::geometry::{Pose, relative_pose};

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
    pub(super) cfg: EmulatorConfig,
    pub(super) machine: MachineConfig,
    pub(super) ethernet: [u32; 4],
    pub(super) base: Box<dyn EmulatedBase>,
    pub(super) t_s: f64,
    pub(super) state: OpState,
    pub(super) streaming: bool,
    pub(super) faults: [u32; 4],
    /// Commanded (vx, yaw) and when (platform time).
    pub(super) cmd: (f64, f64),
    pub(super) last_motion_s: Option<f64>,
    /// After limits and slew.
    pub(super) slewed: (f64, f64),
    pub(super) dtz: bool,
    pub(super) awaiting_tip_back: bool,
    pub(super) tipped_back: bool,
    pub(super) last: BaseState,
    /// The base's odometry pose at the last integrator reset; reported odometry is relative to it.
    pub(super) odom_origin: Pose,
    /// Integrated wheel positions RF, LF, RR, LR.
    pub(super) wheel_pos_m: [f64; 4],
    pub(super) accel_mps2: f64,
    pub(super) pitch_deg: f64,
    pub(super) soc_pct: f64,
    pub(super) torque_limit: f32,
    pub(super) counts: EmulatorCounts,
    /// Distance the base has travelled since power-up (the fault log's odometer).
    pub(super) odometer_m: f64,
    /// The fault log's entries, a ring; how many are written and which was written last.
    pub(super) log: [[u32; fault_log::ENTRY_WORDS]; fault_log::MAX_ENTRIES],
    pub(super) log_count: usize,
    pub(super) log_latest: usize,
    /// The fault words when the last entry was written.
    pub(super) logged: [u32; 4],
    /// A test hook: when set, feedback reports this as the odometry's x (a corrupt sensor).
    pub(super) odom_x_override: Option<f32>,
}

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
            odom_x_override: None,
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

    pub(super) fn moving(&self) -> bool {
        self.slewed.0.abs() > 1e-3 || self.slewed.1.abs() > 1e-3
    }

    pub(super) fn request_mode(&mut self, m: ModeRequest) {
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

    /// The mode changes time alone makes: power-up through the init states to standby, and a
    /// pending balance request granted once the base is tipped back (or needs no tip-back).
    pub(super) fn advance_modes(&mut self) {
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
    }

    /// The odometry pose in the frame of the last integrator reset.
    pub(super) fn odom(&self) -> Pose {
        relative_pose(self.odom_origin, self.last.pose)
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
