//! The RMP v3 wire format (Stanley Innovation command set, ids 0x1800-0x1803): command frames,
//! the 132-word feedback frame, the 311-word fault log, and CRC-16/ARC.
//!
//! This module owns bytes and nothing else: it turns commands into datagrams and datagrams into
//! checked words, and detects the byte order of feedback words. It opens no socket, keeps no
//! state and knows no timing; the driver and the emulator share it so that they can only disagree
//! about behaviour, never about framing. Facts and their sources are in the team's research notes
//! (`research/rmp-protocol.md`, sections 3.1, 3.2).
//!
//! Framing, as the vendor's driver does it:
//! - a command is `[id hi][id lo][k words, each big-endian][crc hi][crc lo]`;
//! - a reply (feedback or fault log) is `n` words, then a CRC word whose last two bytes hold the CRC
//!   high byte first; the CRC covers every byte before those two (so also the two padding bytes).
//!
//! The CRC is CRC-16/ARC (reflected, so "CRC over the whole frame is zero" does not hold when it is
//! appended high byte first; we always recompute and compare).

use crc::{CRC_16_ARC, Crc};
use thiserror::Error;

/// CRC-16/ARC as the RMP computes it.
const ARC: Crc<u16> = Crc::<u16>::new(&CRC_16_ARC);

/// CRC-16/ARC of `bytes`.
pub fn crc16(bytes: &[u8]) -> u16 {
    ARC.checksum(bytes)
}

/// Motion command: vx m/s, vy m/s (Omni only, else 0), yaw rate rad/s (counter-clockwise positive).
pub const MOTION_ID: u16 = 0x1800;
/// Load the 12-word machine configuration (stored in the platform's F-RAM).
pub const MACHINE_CONFIG_ID: u16 = 0x1801;
/// Load the 4-word Ethernet configuration (IP, port, subnet mask, gateway).
pub const ETHERNET_CONFIG_ID: u16 = 0x1802;
/// General-purpose command: command id and parameter (see [`gp`]).
pub const GENERAL_ID: u16 = 0x1803;

/// Words in one feedback frame (before the CRC word).
pub const FEEDBACK_WORDS: usize = 132;
/// Bytes in one feedback datagram: 132 words and the CRC word.
pub const FEEDBACK_LEN: usize = (FEEDBACK_WORDS + 1) * 4;
/// Words in the fault log reply (before the CRC word).
pub const FAULT_LOG_WORDS: usize = 311;
/// Bytes in one fault-log datagram.
pub const FAULT_LOG_LEN: usize = (FAULT_LOG_WORDS + 1) * 4;
/// Words in the machine configuration (0x1801) and its echo in the feedback.
pub const MACHINE_CONFIG_WORDS: usize = 12;

/// Layout of the 311-word fault-log reply, as the vendor's fault-log parser reads it (the vendor
/// driver's `faultlog_parser.py`): an 11-word header, then [`fault_log::MAX_ENTRIES`] entries of
/// [`fault_log::ENTRY_WORDS`] words each (11 + 20 × 15 = 311). An entry whose words are all zero
/// is empty.
pub mod fault_log {
    /// Log format version (the parser prints it in hex).
    pub const LOG_VERSION: usize = 0;
    /// Size of the log in bytes.
    pub const LOG_SIZE_BYTES: usize = 1;
    /// How many entries hold a fault.
    pub const ENTRY_COUNT: usize = 2;
    /// Index (0-19) of the latest entry; meaningful when the entry count is not zero.
    pub const LATEST_ENTRY: usize = 3;
    /// The serial number, 64 bits: high word, then low word.
    pub const SERIAL_HIGH: usize = 4;
    pub const SERIAL_LOW: usize = 5;
    /// Software build ids of the SP and UIP processors.
    pub const SP_BUILD_ID: usize = 6;
    pub const UIP_BUILD_ID: usize = 7;
    /// Accumulated run time, whole seconds.
    pub const ACCUMULATED_TIME_S: usize = 8;
    /// Odometer, whole metres.
    pub const ODOMETER_M: usize = 9;
    /// Power cycles.
    pub const POWER_CYCLES: usize = 10;
    /// First word of entry 0.
    pub const ENTRIES: usize = 11;
    pub const MAX_ENTRIES: usize = 20;
    pub const ENTRY_WORDS: usize = 15;

    /// Word offsets inside an entry.
    pub mod entry {
        /// Calendar time stamp, seconds since 2011-01-01.
        pub const TIME_STAMP_S: usize = 0;
        /// Run time at the fault, whole seconds.
        pub const RUN_TIME_S: usize = 1;
        /// Power cycle the fault happened in.
        pub const POWER_CYCLE: usize = 2;
        /// The eight fault groups, each right-aligned (shifted down to bit 0): transient,
        /// critical, communication, sensor, BSA, motor drive (MCU), architecture, internal.
        pub const GROUPS: usize = 3;
        pub const TRANSIENT: usize = 3;
        pub const CRITICAL: usize = 4;
        pub const COMM: usize = 5;
        pub const SENSOR: usize = 6;
        pub const BSA: usize = 7;
        pub const MCU: usize = 8;
        pub const ARCHITECTURE: usize = 9;
        pub const INTERNAL: usize = 10;
        /// Two words of fault-specific data (the parser also shows them as floats).
        pub const DATA_0: usize = 11;
        pub const DATA_1: usize = 12;
    }

    const _: () = assert!(ENTRIES + MAX_ENTRIES * ENTRY_WORDS == super::FAULT_LOG_WORDS);
}

/// General-purpose (0x1803) command ids.
pub mod gp {
    /// No operation; elicits a reply.
    pub const NONE: u32 = 0;
    /// Play an audio song (parameter 0-16).
    pub const AUDIO_SONG: u32 = 1;
    /// Request an operational mode (parameter: [`super::ModeRequest`]).
    pub const SET_MODE: u32 = 2;
    /// Send the fault log (a 311-word reply).
    pub const FAULT_LOG: u32 = 3;
    /// Reset integrators (bitmask; 0x1F all).
    pub const RESET_INTEGRATORS: u32 = 4;
    /// Reset the machine parameters to their defaults.
    pub const RESET_PARAMS: u32 = 5;
    /// Continuous feedback at 100 Hz on (1) or off (0).
    pub const STREAMING: u32 = 6;
    /// Torque limit, parameter is the bits of an f32 in 0.0..=1.0.
    pub const TORQUE_LIMIT: u32 = 7;
}

/// Operational mode requests (the parameter of [`gp::SET_MODE`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModeRequest {
    /// Cut motor power at once: the platform rolls freely.
    Disable = 1,
    PowerDown = 2,
    /// Decelerate to zero at the DTZ limit, then hold.
    Dtz = 3,
    Standby = 4,
    Tractor = 5,
    /// Balance (RMP 220 with balance enabled in the config bitmap).
    Balance = 6,
}

impl ModeRequest {
    pub fn from_u32(v: u32) -> Option<ModeRequest> {
        Some(match v {
            1 => ModeRequest::Disable,
            2 => ModeRequest::PowerDown,
            3 => ModeRequest::Dtz,
            4 => ModeRequest::Standby,
            5 => ModeRequest::Tractor,
            6 => ModeRequest::Balance,
            _ => return None,
        })
    }
}

/// Operational state reported in feedback word 9 (vendor `RMP_MODES_DICT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OpState {
    CcuInit = 0,
    PropulsionInit = 1,
    CheckingStartup = 2,
    Standby = 3,
    Tractor = 4,
    Balance = 5,
    /// After a power-down or disable request: motors unpowered.
    Disabled = 6,
}

impl OpState {
    pub fn from_u32(v: u32) -> Option<OpState> {
        Some(match v {
            0 => OpState::CcuInit,
            1 => OpState::PropulsionInit,
            2 => OpState::CheckingStartup,
            3 => OpState::Standby,
            4 => OpState::Tractor,
            5 => OpState::Balance,
            6 => OpState::Disabled,
            _ => return None,
        })
    }

    /// Lower-case name, as shown to users.
    pub fn name(self) -> &'static str {
        match self {
            OpState::CcuInit => "ccu-init",
            OpState::PropulsionInit => "propulsion-init",
            OpState::CheckingStartup => "checking-startup",
            OpState::Standby => "standby",
            OpState::Tractor => "tractor",
            OpState::Balance => "balance",
            OpState::Disabled => "disabled",
        }
    }

    /// Whether the platform accepts motion commands in this state.
    pub fn drives(self) -> bool {
        matches!(self, OpState::Tractor | OpState::Balance)
    }
}

/// Platform identifiers (low 5 bits of feedback word 12).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Platform {
    Rmp440 = 1,
    Rmp220 = 2,
    Rmp210 = 5,
    RmpOmni = 6,
    Rmp110 = 8,
}

impl Platform {
    /// Every platform the vendor driver knows, in id order.
    pub const ALL: [Platform; 5] = [
        Platform::Rmp440,
        Platform::Rmp220,
        Platform::Rmp210,
        Platform::RmpOmni,
        Platform::Rmp110,
    ];

    pub fn from_word(word: u32) -> Option<Platform> {
        Some(match word & 0x1F {
            1 => Platform::Rmp440,
            2 => Platform::Rmp220,
            5 => Platform::Rmp210,
            6 => Platform::RmpOmni,
            8 => Platform::Rmp110,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Platform::Rmp440 => "RMP 440",
            Platform::Rmp220 => "RMP 220",
            Platform::Rmp210 => "RMP 210",
            Platform::RmpOmni => "RMP Omni",
            Platform::Rmp110 => "RMP 110",
        }
    }
}

/// A host-to-RMP command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// 0x1800. The vendor driver sends 3 words for every platform; we do too.
    Motion {
        vx_mps: f32,
        vy_mps: f32,
        yaw_radps: f32,
    },
    /// 0x1801: the machine configuration words (floats by bit pattern, the bitmap as a u32).
    MachineConfig([u32; MACHINE_CONFIG_WORDS]),
    /// 0x1802: IP, port, subnet mask, gateway.
    EthernetConfig([u32; 4]),
    /// 0x1803: a general-purpose command id (see [`gp`]) and its parameter.
    General { id: u32, param: u32 },
}

/// Why a datagram is not a valid frame. Every variant is "drop and count", never "trust".
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum FrameError {
    #[error("{len} bytes is too short for a frame")]
    TooShort { len: usize },
    #[error("bad CRC: frame says {found:#06x}, bytes give {computed:#06x}")]
    BadCrc { found: u16, computed: u16 },
    #[error("unknown message id {id:#06x}")]
    UnknownId { id: u16 },
    #[error("message {id:#06x} carries {bytes} payload bytes, which is not a valid word count")]
    BadLength { id: u16, bytes: usize },
    #[error(
        "a reply of {len} bytes is neither feedback ({FEEDBACK_LEN}) nor a fault log ({FAULT_LOG_LEN})"
    )]
    BadReplyLength { len: usize },
    #[error("feedback words are implausible under either byte order")]
    Implausible,
}

impl Command {
    /// The datagram for this command (words big-endian, CRC high byte first).
    pub fn encode(&self) -> Vec<u8> {
        let (id, words): (u16, Vec<u32>) = match *self {
            Command::Motion {
                vx_mps,
                vy_mps,
                yaw_radps,
            } => (
                MOTION_ID,
                vec![vx_mps.to_bits(), vy_mps.to_bits(), yaw_radps.to_bits()],
            ),
            Command::MachineConfig(w) => (MACHINE_CONFIG_ID, w.to_vec()),
            Command::EthernetConfig(w) => (ETHERNET_CONFIG_ID, w.to_vec()),
            Command::General { id, param } => (GENERAL_ID, vec![id, param]),
        };
        let mut out = Vec::with_capacity(2 + 4 * words.len() + 2);
        out.extend_from_slice(&id.to_be_bytes());
        for w in words {
            out.extend_from_slice(&w.to_be_bytes());
        }
        let crc = crc16(&out);
        out.extend_from_slice(&crc.to_be_bytes());
        out
    }

    /// Parse a command datagram (the emulator's side). A motion command with 2 words is read as
    /// `vx, yaw` (the non-holonomic form in the vendor's source comment).
    pub fn decode(bytes: &[u8]) -> Result<Command, FrameError> {
        if bytes.len() < 4 {
            return Err(FrameError::TooShort { len: bytes.len() });
        }
        check_crc(bytes)?;
        let id = u16::from_be_bytes([bytes[0], bytes[1]]);
        let payload = &bytes[2..bytes.len() - 2];
        if !matches!(
            id,
            MOTION_ID | MACHINE_CONFIG_ID | ETHERNET_CONFIG_ID | GENERAL_ID
        ) {
            return Err(FrameError::UnknownId { id });
        }
        let bad = FrameError::BadLength {
            id,
            bytes: payload.len(),
        };
        if !payload.len().is_multiple_of(4) {
            return Err(bad);
        }
        let words: Vec<u32> = payload
            .chunks_exact(4)
            .map(|c| u32::from_be_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let f = |w: u32| f32::from_bits(w);
        Ok(match (id, words.len()) {
            (MOTION_ID, 3) => Command::Motion {
                vx_mps: f(words[0]),
                vy_mps: f(words[1]),
                yaw_radps: f(words[2]),
            },
            (MOTION_ID, 2) => Command::Motion {
                vx_mps: f(words[0]),
                vy_mps: 0.0,
                yaw_radps: f(words[1]),
            },
            (MACHINE_CONFIG_ID, MACHINE_CONFIG_WORDS) => {
                let mut w = [0u32; MACHINE_CONFIG_WORDS];
                w.copy_from_slice(&words);
                Command::MachineConfig(w)
            }
            (ETHERNET_CONFIG_ID, 4) => {
                Command::EthernetConfig([words[0], words[1], words[2], words[3]])
            }
            (GENERAL_ID, 2) => Command::General {
                id: words[0],
                param: words[1],
            },
            _ => return Err(bad),
        })
    }
}

/// Check the trailing CRC (high byte first) against the bytes before it.
fn check_crc(bytes: &[u8]) -> Result<(), FrameError> {
    let n = bytes.len();
    if n < 2 {
        return Err(FrameError::TooShort { len: n });
    }
    let found = u16::from_be_bytes([bytes[n - 2], bytes[n - 1]]);
    let computed = crc16(&bytes[..n - 2]);
    if found == computed {
        Ok(())
    } else {
        Err(FrameError::BadCrc { found, computed })
    }
}

/// Byte order of the 32-bit words in a reply. Commands are always big-endian; the feedback of the
/// 0x1800 firmware is little-endian as far as anyone can tell (inferred, not documented), so the
/// driver detects it instead of assuming.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WordOrder {
    Little,
    Big,
}

impl WordOrder {
    /// `little-endian` or `big-endian`.
    pub fn name(self) -> &'static str {
        match self {
            WordOrder::Little => "little-endian",
            WordOrder::Big => "big-endian",
        }
    }

    fn read(self, c: &[u8]) -> u32 {
        let b = [c[0], c[1], c[2], c[3]];
        match self {
            WordOrder::Little => u32::from_le_bytes(b),
            WordOrder::Big => u32::from_be_bytes(b),
        }
    }

    fn write(self, w: u32) -> [u8; 4] {
        match self {
            WordOrder::Little => w.to_le_bytes(),
            WordOrder::Big => w.to_be_bytes(),
        }
    }

    /// Detect the word order of a CRC-checked feedback frame: the order under which its words are
    /// plausible (see [`Feedback::plausible`]). `None` when neither order is, or when both are and
    /// the frame cannot tell them apart.
    pub fn detect(frame: &[u8]) -> Option<WordOrder> {
        let le = Feedback::decode(frame, WordOrder::Little).ok()?;
        let be = Feedback::decode(frame, WordOrder::Big).ok()?;
        match (le.plausible(), be.plausible()) {
            (true, false) => Some(WordOrder::Little),
            (false, true) => Some(WordOrder::Big),
            _ => None,
        }
    }
}

/// Frame `words` as a reply: the words in `order`, two zero bytes, the CRC high byte first.
pub fn encode_reply(words: &[u32], order: WordOrder) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 * words.len() + 4);
    for &w in words {
        out.extend_from_slice(&order.write(w));
    }
    out.extend_from_slice(&[0, 0]);
    let crc = crc16(&out);
    out.extend_from_slice(&crc.to_be_bytes());
    out
}

/// Check a reply's CRC and return its words (without the CRC word) read in `order`.
pub fn decode_reply(bytes: &[u8], order: WordOrder) -> Result<Vec<u32>, FrameError> {
    if bytes.len() < 8 || !bytes.len().is_multiple_of(4) {
        return Err(FrameError::BadReplyLength { len: bytes.len() });
    }
    check_crc(bytes)?;
    Ok(bytes[..bytes.len() - 4]
        .chunks_exact(4)
        .map(|c| order.read(c))
        .collect())
}

/// Feedback word indices (research notes, section 3.2).
pub mod word {
    pub const FAULT_ARCH_CRITICAL: usize = 0;
    pub const FAULT_COMM_INTERNAL: usize = 1;
    pub const FAULT_SENSOR_BSA: usize = 2;
    pub const FAULT_MCU: usize = 3;
    pub const OPERATIONAL_TIME_S: usize = 8;
    pub const OPERATIONAL_STATE: usize = 9;
    pub const BUILD_ID: usize = 11;
    pub const PLATFORM_ID: usize = 12;
    pub const MIN_PROPULSION_SOC: usize = 13;
    pub const AUX_7V2_BATTERY_V: usize = 54;
    pub const PITCH_DEG: usize = 60;
    pub const PITCH_RATE_DEGPS: usize = 61;
    pub const ROLL_DEG: usize = 62;
    pub const ROLL_RATE_DEGPS: usize = 63;
    /// Clockwise positive (the vendor driver negates it for ROS).
    pub const PSE_YAW_RATE_DEGPS: usize = 64;
    pub const PSE_DATA_VALID: usize = 65;
    pub const VX_TARGET: usize = 94;
    pub const VY_TARGET: usize = 95;
    pub const YAW_RATE_TARGET: usize = 96;
    pub const YAW_RATE_LIMIT: usize = 97;
    pub const VELOCITY_LIMIT: usize = 98;
    /// RF, LF, RR, LR wheel velocity (m/s).
    pub const WHEEL_VELOCITY: usize = 99;
    /// RF, LF, RR, LR integrated wheel position (m).
    pub const WHEEL_POSITION: usize = 103;
    pub const ODOM_ACCEL_X: usize = 107;
    pub const ODOM_VX: usize = 110;
    pub const ODOM_VY: usize = 111;
    pub const ODOM_YAW_RATE: usize = 112;
    pub const ODOM_X: usize = 113;
    pub const ODOM_Y: usize = 114;
    pub const ODOM_YAW: usize = 115;
    /// The 12 machine-config words as the platform holds them.
    pub const CONFIG_ECHO: usize = 116;
    /// IP, port, subnet mask, gateway.
    pub const ETHERNET_ECHO: usize = 128;
}

/// Critical fault bits live in word 0 from bit 12 up (research notes: group-relative values).
pub const CRITICAL_FAULT_MASK: u32 = 0xFFFF_F000;
/// Communication fault bits (word 1, group-relative = absolute since the group starts at bit 0).
pub mod comm_fault {
    pub const BAD_UIP_CHECKSUM: u32 = 0x04;
    pub const BAD_MOTION_COMMAND: u32 = 0x10;
    pub const UNKNOWN_COMMAND: u32 = 0x20;
    pub const BAD_PACKET_CHECKSUM: u32 = 0x40;
}
/// Critical faults (word 0), shifted to their absolute bit positions.
pub mod critical_fault {
    pub const PITCH_ANGLE_EXCEEDED: u32 = 0x800 << 12;
    pub const ROLL_ANGLE_EXCEEDED: u32 = 0x1000 << 12;
}

/// One decoded feedback frame: the raw words, with typed accessors for what the driver uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Feedback {
    pub words: [u32; FEEDBACK_WORDS],
}

impl Default for Feedback {
    fn default() -> Self {
        Feedback {
            words: [0; FEEDBACK_WORDS],
        }
    }
}

impl Feedback {
    /// Check length and CRC and read the words in `order`.
    pub fn decode(bytes: &[u8], order: WordOrder) -> Result<Feedback, FrameError> {
        if bytes.len() != FEEDBACK_LEN {
            return Err(FrameError::BadReplyLength { len: bytes.len() });
        }
        let w = decode_reply(bytes, order)?;
        let mut words = [0u32; FEEDBACK_WORDS];
        words.copy_from_slice(&w);
        Ok(Feedback { words })
    }

    /// The 532-byte datagram for this feedback in `order`.
    pub fn encode(&self, order: WordOrder) -> Vec<u8> {
        encode_reply(&self.words, order)
    }

    /// Word `i` read as an f32.
    pub fn f(&self, i: usize) -> f32 {
        f32::from_bits(self.words[i])
    }

    /// Set word `i` to the bits of `v`.
    pub fn set_f(&mut self, i: usize, v: f32) {
        self.words[i] = v.to_bits();
    }

    /// Whether the words make sense as a feedback frame: a known platform id, an operational state
    /// in 0..=6, and a finite non-negative operational time. The byte-order check of the research
    /// notes plus one float, so that a byte-swapped frame is not mistaken for a real one.
    pub fn plausible(&self) -> bool {
        let t = self.f(word::OPERATIONAL_TIME_S);
        Platform::from_word(self.words[word::PLATFORM_ID]).is_some()
            && self.words[word::OPERATIONAL_STATE] <= 6
            && t.is_finite()
            && t >= 0.0
    }

    pub fn op_state(&self) -> Option<OpState> {
        OpState::from_u32(self.words[word::OPERATIONAL_STATE])
    }

    pub fn platform(&self) -> Option<Platform> {
        Platform::from_word(self.words[word::PLATFORM_ID])
    }

    /// Seconds since the platform powered up; increases with every frame, so it orders frames.
    pub fn operational_time_s(&self) -> f32 {
        self.f(word::OPERATIONAL_TIME_S)
    }

    /// The four fault status words.
    pub fn faults(&self) -> [u32; 4] {
        [self.words[0], self.words[1], self.words[2], self.words[3]]
    }

    /// The platform's own odometry: x m, y m, yaw rad.
    pub fn odom(&self) -> (f32, f32, f32) {
        (
            self.f(word::ODOM_X),
            self.f(word::ODOM_Y),
            self.f(word::ODOM_YAW),
        )
    }

    /// The machine-config echo (words 116-127).
    pub fn config_echo(&self) -> [u32; MACHINE_CONFIG_WORDS] {
        let mut w = [0u32; MACHINE_CONFIG_WORDS];
        w.copy_from_slice(&self.words[word::CONFIG_ECHO..word::CONFIG_ECHO + MACHINE_CONFIG_WORDS]);
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(bytes: &[u8]) -> String {
        bytes
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<Vec<_>>()
            .join(" ")
    }

    #[test]
    fn crc_check_value() {
        assert_eq!(crc16(b"123456789"), 0xBB3D);
    }

    #[test]
    fn research_frames_byte_for_byte() {
        let cases = [
            (
                Command::Motion {
                    vx_mps: 0.5,
                    vy_mps: 0.0,
                    yaw_radps: 0.0,
                },
                "18 00 3f 00 00 00 00 00 00 00 00 00 00 00 4c 4c",
            ),
            (
                Command::General {
                    id: gp::SET_MODE,
                    param: ModeRequest::Tractor as u32,
                },
                "18 03 00 00 00 02 00 00 00 05 4c 2d",
            ),
            (
                Command::General {
                    id: gp::SET_MODE,
                    param: ModeRequest::Standby as u32,
                },
                "18 03 00 00 00 02 00 00 00 04 8c ec",
            ),
            (
                Command::General {
                    id: gp::STREAMING,
                    param: 1,
                },
                "18 03 00 00 00 06 00 00 00 01 4f dd",
            ),
            (
                Command::General {
                    id: gp::NONE,
                    param: 0,
                },
                "18 03 00 00 00 00 00 00 00 00 8f 94",
            ),
        ];
        for (cmd, want) in cases {
            let bytes = cmd.encode();
            assert_eq!(hex(&bytes), want, "{cmd:?}");
            assert_eq!(Command::decode(&bytes), Ok(cmd));
        }
    }

    #[test]
    fn the_2013_command_set_uses_the_same_crc() {
        // 0x0500 motion, 0.5 normalized, yaw 0: the same framing under another id. We do not speak
        // this profile, but the vector checks our CRC placement against a second source.
        let mut b = vec![0x05, 0x00];
        b.extend_from_slice(&0.5f32.to_bits().to_be_bytes());
        b.extend_from_slice(&0u32.to_be_bytes());
        b.extend_from_slice(&crc16(&b).to_be_bytes());
        assert_eq!(hex(&b), "05 00 3f 00 00 00 00 00 00 00 44 53");
        assert_eq!(
            Command::decode(&b),
            Err(FrameError::UnknownId { id: 0x0500 })
        );
    }

    #[test]
    fn two_word_motion_is_vx_and_yaw() {
        let mut b = vec![0x18, 0x00];
        b.extend_from_slice(&0.25f32.to_bits().to_be_bytes());
        b.extend_from_slice(&(-0.5f32).to_bits().to_be_bytes());
        b.extend_from_slice(&crc16(&b).to_be_bytes());
        assert_eq!(
            Command::decode(&b),
            Ok(Command::Motion {
                vx_mps: 0.25,
                vy_mps: 0.0,
                yaw_radps: -0.5
            })
        );
    }

    #[test]
    fn bad_frames_are_named() {
        let mut b = Command::General { id: 0, param: 0 }.encode();
        b[5] ^= 1;
        assert!(matches!(
            Command::decode(&b),
            Err(FrameError::BadCrc { .. })
        ));
        // A general command with one word: right CRC, wrong length.
        let mut short = vec![0x18, 0x03, 0, 0, 0, 0];
        short.extend_from_slice(&crc16(&short).to_be_bytes());
        assert_eq!(
            Command::decode(&short),
            Err(FrameError::BadLength {
                id: GENERAL_ID,
                bytes: 4
            })
        );
        assert_eq!(
            Command::decode(&[0x18]),
            Err(FrameError::TooShort { len: 1 })
        );
    }

    fn sample_feedback() -> Feedback {
        let mut fb = Feedback::default();
        fb.words[word::PLATFORM_ID] = Platform::Rmp220 as u32;
        fb.words[word::OPERATIONAL_STATE] = OpState::Tractor as u32;
        fb.set_f(word::OPERATIONAL_TIME_S, 12.5);
        fb.set_f(word::ODOM_X, 1.25);
        fb.set_f(word::ODOM_YAW, -0.5);
        fb
    }

    #[test]
    fn feedback_is_532_bytes_with_the_crc_in_the_last_two() {
        let fb = sample_feedback();
        let le = fb.encode(WordOrder::Little);
        assert_eq!(le.len(), FEEDBACK_LEN);
        assert_eq!(le.len(), 532);
        assert_eq!(&le[528..530], &[0, 0]);
        assert_eq!(u16::from_be_bytes([le[530], le[531]]), crc16(&le[..530]));
        // Platform id 2 little-endian: first byte of word 12 is 0x02.
        assert_eq!(&le[48..52], &[2, 0, 0, 0]);
        let be = fb.encode(WordOrder::Big);
        assert_eq!(&be[48..52], &[0, 0, 0, 2]);
        assert_eq!(FAULT_LOG_LEN, 1248);
    }

    #[test]
    fn word_order_is_detected_both_ways() {
        let fb = sample_feedback();
        for order in [WordOrder::Little, WordOrder::Big] {
            let bytes = fb.encode(order);
            assert_eq!(WordOrder::detect(&bytes), Some(order));
            assert_eq!(Feedback::decode(&bytes, order).unwrap(), fb);
        }
        // All zeros: no platform id, so no order can be chosen.
        assert_eq!(
            WordOrder::detect(&Feedback::default().encode(WordOrder::Little)),
            None
        );
    }
}

#[cfg(test)]
mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Replacing any one byte of a frame by another value (a burst of at most 8 bits, which
        /// CRC-16 always detects) never yields a frame that decodes.
        #[test]
        fn damaged_commands_never_decode(vx in -8.0f32..8.0, yaw in -4.5f32..4.5, at in 0usize..16, x in 1u8..=255) {
            let mut b = Command::Motion { vx_mps: vx, vy_mps: 0.0, yaw_radps: yaw }.encode();
            b[at] ^= x;
            prop_assert!(Command::decode(&b).is_err());
        }

        #[test]
        fn damaged_feedback_never_decodes(odom_x in -100.0f32..100.0, at in 0usize..FEEDBACK_LEN, x in 1u8..=255, big in any::<bool>()) {
            let order = if big { WordOrder::Big } else { WordOrder::Little };
            let mut fb = Feedback::default();
            fb.words[word::PLATFORM_ID] = Platform::Rmp220 as u32;
            fb.set_f(word::ODOM_X, odom_x);
            let mut b = fb.encode(order);
            b[at] ^= x;
            prop_assert!(Feedback::decode(&b, order).is_err());
        }

        #[test]
        fn commands_round_trip(id in any::<u32>(), param in any::<u32>()) {
            let c = Command::General { id, param };
            prop_assert_eq!(Command::decode(&c.encode()), Ok(c));
        }
    }
}
