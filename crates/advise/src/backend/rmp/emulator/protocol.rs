//! The platform's side of the wire: a datagram in (decoded, checked, applied to the state) and
//! the feedback frame out. A bad datagram sets a comm fault bit and changes nothing else.

use super::platform::{Platform, Reply};
use crate::backend::rmp::codec::{
    self, Command, Feedback, FrameError, ModeRequest, comm_fault, gp, word,
};
use crate::backend::rmp::config::MachineConfig;
use crate::geometry::wheel_speeds;

impl Platform {
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
        w[word::ODOM_X] = match self.odom_x_override {
            Some(x) => x.to_bits(),
            None => f(odom.x_m),
        };
        w[word::ODOM_Y] = f(odom.y_m);
        w[word::ODOM_YAW] = f(odom.theta_rad);
        w[word::CONFIG_ECHO..word::CONFIG_ECHO + 12].copy_from_slice(&self.machine.to_words());
        w[word::ETHERNET_ECHO..word::ETHERNET_ECHO + 4].copy_from_slice(&self.ethernet);
        fb
    }
}
