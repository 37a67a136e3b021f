//! What the RMP driver and emulator are configured with: the platform's machine configuration (the
//! 12 words of message 0x1801), the driver's own limits and timeouts, and the emulator's options.
//!
//! This module owns defaults and validation. Every default is written here once, with its source:
//! the machine configuration defaults are the vendor's RMP 220 parameters (`segway_params.yaml`),
//! the timeouts are ours and are explained where they are set. It does no IO.

use miette::Diagnostic;
use thiserror::Error;

use super::codec::{MACHINE_CONFIG_WORDS, Platform, WordOrder};

/// The machine configuration the driver loads into the platform at start-up (message 0x1801) and
/// verifies in the feedback echo. Floats are f32 because that is what travels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MachineConfig {
    pub velocity_limit_mps: f32,
    pub accel_limit_mps2: f32,
    pub decel_limit_mps2: f32,
    /// Deceleration used by decelerate-to-zero (DTZ), which the watchdog requests.
    pub dtz_decel_mps2: f32,
    pub yaw_rate_limit_radps: f32,
    pub yaw_accel_limit_radps2: f32,
    pub lateral_accel_limit_mps2: f32,
    pub tire_diameter_m: f32,
    pub wheel_base_m: f32,
    pub track_width_m: f32,
    pub gear_ratio: f32,
    /// Bit 0 silence audio, bit 1 AC-present CSI, bits 2-5 balance gains, bit 6 balance enabled,
    /// bits 7-10 and 11-14 velocity and yaw input filters.
    pub bitmap: u32,
}

/// Config bitmap bit 6: balance mode allowed (RMP 220 only).
pub const BITMAP_BALANCE_ENABLED: u32 = 1 << 6;

/// Names and NVM ranges of the 11 float words, in wire order: the limits the vendor driver's
/// `system_defines.py` gives for the platform's F-RAM (research notes, section 3.2). These are the
/// ranges of the RMP 210, 220, 440 and Omni; the RMP 110 differs, see [`nvm_ranges`].
pub const MACHINE_CONFIG_FIELDS: [(&str, f32, f32); 11] = [
    ("velocity_limit_mps", 0.0, 8.047),
    ("accel_limit_mps2", 0.0, 7.848),
    ("decel_limit_mps2", 0.0, 7.848),
    ("dtz_decel_mps2", 0.0, 7.848),
    ("yaw_rate_limit_radps", 0.0, 4.5),
    ("yaw_accel_limit_radps2", 0.0, 28.274),
    ("lateral_accel_limit_mps2", 0.981, 9.81),
    ("tire_diameter_m", 0.1524, 1.0),
    ("wheel_base_m", 0.4142, 1.0),
    ("track_width_m", 0.506476, 1.0),
    ("gear_ratio", 1.0, 200.0),
];

/// Index of the track width among the machine-config words.
const TRACK_WIDTH: usize = 9;

/// The lowest track width an RMP 110 stores. The RMP 110 is narrower than the minimum that the
/// vendor driver's `system_defines.py` gives for the two-wheel bases (0.506476 m): its track is
/// 0.4812244 m (the vendor's `RMP_110/rmp.urdf.xacro`, `track`; 0.481224 m in the configuration
/// the vendor ships for it). The bound is the lower bound of the vendor driver's own
/// dynamic-reconfigure range for the track width (`segway.cfg`: 0.3556..1.0), the widest range
/// the vendor lets a user send. The RMP 110's firmware range itself is not public.
pub const RMP_110_TRACK_WIDTH_MIN_M: f32 = 0.3556;

/// The NVM range `(min, max)` of each of the 11 float words on `platform`: what it stores without
/// clamping. Every value the vendor ships for a platform (see [`MachineConfig::vendor_defaults`])
/// lies within that platform's ranges.
pub fn nvm_ranges(platform: Platform) -> [(f32, f32); 11] {
    let mut r = MACHINE_CONFIG_FIELDS.map(|(_, lo, hi)| (lo, hi));
    if platform == Platform::Rmp110 {
        r[TRACK_WIDTH].0 = RMP_110_TRACK_WIDTH_MIN_M;
    }
    r
}

/// The ranges a value must lie in on at least one platform: what the driver accepts when it does
/// not know the platform in advance (the echo check then catches a platform that clamps).
fn widest_nvm_ranges() -> [(f32, f32); 11] {
    let mut r = nvm_ranges(Platform::Rmp220);
    for p in Platform::ALL {
        for (w, (lo, hi)) in r.iter_mut().zip(nvm_ranges(p)) {
            *w = (w.0.min(lo), w.1.max(hi));
        }
    }
    r
}

impl Default for MachineConfig {
    /// The vendor's RMP 220 parameters.
    fn default() -> Self {
        MachineConfig::vendor_defaults(Platform::Rmp220)
    }
}

impl MachineConfig {
    /// The machine configuration the vendor ships for `platform`: its driver's per-platform
    /// `segway_params.yaml` (RMP_210, RMP_220, RMP_440LE/SE, RMP_OMNI). What a platform restores
    /// on "reset parameters to default" (GP 5); the firmware's own factory values are not public,
    /// so the emulator uses these.
    ///
    /// The yaml flags become the bitmap as the vendor driver computes it: audio on (bit 0 clear),
    /// `motion_while_charging: 0` (bit 1 set), balance off, default gains, 10 Hz filters: 0x2 on
    /// every platform. The vendor's public releases ship no RMP_110 yaml: the RMP 110 here is
    /// the RMP 210/220 family's values (same i2 wheels, gearbox and wheel base) with the RMP 110's
    /// own track width, 0.481224 m (the vendor's `RMP_110/rmp.urdf.xacro`: 0.4812244).
    #[expect(
        clippy::approx_constant,
        reason = "6.28 rad/s² is the vendor's shipped value, not 2π"
    )]
    pub fn vendor_defaults(platform: Platform) -> MachineConfig {
        let rmp_220 = MachineConfig {
            velocity_limit_mps: 1.0,
            accel_limit_mps2: 0.5,
            decel_limit_mps2: 0.5,
            dtz_decel_mps2: 1.0,
            yaw_rate_limit_radps: 1.0,
            yaw_accel_limit_radps2: 1.0,
            lateral_accel_limit_mps2: 4.905,
            tire_diameter_m: 0.46228,
            wheel_base_m: 0.5842,
            track_width_m: 0.542391,
            gear_ratio: 24.2667,
            bitmap: 0x0000_0002,
        };
        match platform {
            Platform::Rmp220 => rmp_220,
            Platform::Rmp210 => MachineConfig {
                velocity_limit_mps: 3.0,
                yaw_accel_limit_radps2: 1.5,
                ..rmp_220
            },
            Platform::Rmp440 => MachineConfig {
                velocity_limit_mps: 2.235,
                accel_limit_mps2: 1.962,
                decel_limit_mps2: 1.962,
                dtz_decel_mps2: 3.924,
                yaw_rate_limit_radps: 3.0,
                yaw_accel_limit_radps2: 6.28,
                lateral_accel_limit_mps2: 9.81,
                tire_diameter_m: 0.483616,
                track_width_m: 0.7112,
                ..rmp_220
            },
            Platform::RmpOmni => MachineConfig {
                tire_diameter_m: 0.254,
                wheel_base_m: 0.693,
                track_width_m: 0.693,
                ..rmp_220
            },
            Platform::Rmp110 => MachineConfig {
                track_width_m: 0.481224,
                ..rmp_220
            },
        }
    }

    fn floats(&self) -> [f32; 11] {
        [
            self.velocity_limit_mps,
            self.accel_limit_mps2,
            self.decel_limit_mps2,
            self.dtz_decel_mps2,
            self.yaw_rate_limit_radps,
            self.yaw_accel_limit_radps2,
            self.lateral_accel_limit_mps2,
            self.tire_diameter_m,
            self.wheel_base_m,
            self.track_width_m,
            self.gear_ratio,
        ]
    }

    /// The 12 words of message 0x1801 (and of the feedback echo).
    pub fn to_words(&self) -> [u32; MACHINE_CONFIG_WORDS] {
        let mut w = [0u32; MACHINE_CONFIG_WORDS];
        for (slot, v) in w.iter_mut().zip(self.floats()) {
            *slot = v.to_bits();
        }
        w[11] = self.bitmap;
        w
    }

    pub fn from_words(w: &[u32; MACHINE_CONFIG_WORDS]) -> MachineConfig {
        let f = |i: usize| f32::from_bits(w[i]);
        MachineConfig {
            velocity_limit_mps: f(0),
            accel_limit_mps2: f(1),
            decel_limit_mps2: f(2),
            dtz_decel_mps2: f(3),
            yaw_rate_limit_radps: f(4),
            yaw_accel_limit_radps2: f(5),
            lateral_accel_limit_mps2: f(6),
            tire_diameter_m: f(7),
            wheel_base_m: f(8),
            track_width_m: f(9),
            gear_ratio: f(10),
            bitmap: w[11],
        }
    }

    /// What `platform` stores when sent these words: each float clamped into that platform's NVM
    /// range (a non-finite value becomes the lower bound). The driver sees the difference in the
    /// echo.
    pub fn clamped_to_nvm(&self, platform: Platform) -> MachineConfig {
        let mut w = self.to_words();
        for (i, (lo, hi)) in nvm_ranges(platform).into_iter().enumerate() {
            let v = f32::from_bits(w[i]);
            let c = if v.is_finite() { v.clamp(lo, hi) } else { lo };
            w[i] = c.to_bits();
        }
        MachineConfig::from_words(&w)
    }

    /// Every float within its NVM range on `platform` (on some platform when `None`), so that
    /// the platform's echo can match.
    pub fn validate(&self, platform: Option<Platform>) -> Result<(), RmpConfigError> {
        let ranges = platform.map_or_else(widest_nvm_ranges, nvm_ranges);
        for (((name, _, _), (lo, hi)), v) in
            MACHINE_CONFIG_FIELDS.iter().zip(ranges).zip(self.floats())
        {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(RmpConfigError::OutOfRange {
                    field: format!("machine.{name}"),
                    value: f64::from(v),
                    min: f64::from(lo),
                    max: f64::from(hi),
                });
            }
        }
        Ok(())
    }
}

/// The operational mode the driver drives in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DriveMode {
    /// All wheels on the ground (the RMP 220 rests on its casters): the safe default.
    #[default]
    Tractor,
    /// Dynamically balancing (RMP 220 with [`BITMAP_BALANCE_ENABLED`]); entering it needs an operator
    /// to tip the base back past vertical.
    Balance,
}

/// The driver's configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct RmpConfig {
    /// Loaded into the platform at start-up and verified in its echo.
    pub machine: MachineConfig,
    pub drive_mode: DriveMode,
    /// Host-side clamp applied before a speed is sent (also never above the machine limit).
    pub max_speed_mps: f64,
    /// Host-side clamp applied before a rotation rate is sent (also never above the machine limit).
    pub max_rot_radps: f64,
    /// Control period of the tasks: 1/30 s (the paper samples at 30 Hz).
    pub period_s: f64,
    /// When the session has not commanded for this long, the driver commands zero and DTZ. Ours:
    /// 0.25 s, about 7 control periods, and half the platform's own 0.5 s comm timeout so that the
    /// host acts first and decelerates at the DTZ limit the user configured.
    pub watchdog_timeout_s: f64,
    /// No valid feedback for this long is a lost link. Ours: 0.3 s, 30 feedback periods at 100 Hz.
    pub link_timeout_s: f64,
    /// Each start-up step and mode change gives up after this long (the vendor driver: 3 s).
    pub step_timeout_s: f64,
    /// The platform the driver insists on, if any (e.g. an RMP 220 for balance mode).
    pub expect_platform: Option<Platform>,
}

impl Default for RmpConfig {
    fn default() -> Self {
        RmpConfig {
            machine: MachineConfig::default(),
            drive_mode: DriveMode::Tractor,
            max_speed_mps: 1.0,
            max_rot_radps: 1.0,
            period_s: 1.0 / 30.0,
            watchdog_timeout_s: 0.25,
            link_timeout_s: 0.3,
            step_timeout_s: 3.0,
            expect_platform: None,
        }
    }
}

impl RmpConfig {
    /// The configuration the session and `advise eval` drive with: the platform's velocity,
    /// acceleration and yaw limits loaded from the simulator's (clamped into the NVM ranges), and
    /// its control rate, so that a policy learned from demonstrations in the simulator meets the
    /// same limits on the base. DTZ decelerates at twice the acceleration limit (a stop is quicker
    /// than a start). Everything else keeps the vendor's RMP 220 defaults.
    pub fn for_sim(sim: &crate::backend::sim::SimParams) -> RmpConfig {
        let f = |v: f64| v as f32;
        let machine = MachineConfig {
            velocity_limit_mps: f(sim.max_speed_mps),
            accel_limit_mps2: f(sim.max_accel_mps2),
            decel_limit_mps2: f(sim.max_accel_mps2),
            dtz_decel_mps2: f(2.0 * sim.max_accel_mps2),
            yaw_rate_limit_radps: f(sim.max_rot_radps),
            yaw_accel_limit_radps2: f(sim.max_rot_accel_radps2),
            ..MachineConfig::default()
        }
        .clamped_to_nvm(Platform::Rmp220);
        RmpConfig {
            machine,
            max_speed_mps: sim.max_speed_mps.min(f64::from(machine.velocity_limit_mps)),
            max_rot_radps: sim
                .max_rot_radps
                .min(f64::from(machine.yaw_rate_limit_radps)),
            period_s: sim.period_s(),
            ..RmpConfig::default()
        }
    }

    /// Check every field; the first problem becomes a diagnostic naming the field and its range.
    pub fn validate(&self) -> Result<(), RmpConfigError> {
        self.machine.validate(self.expect_platform)?;
        let range = |field: &str, value: f64, min: f64, max: f64| {
            if value.is_finite() && value >= min && value <= max {
                Ok(())
            } else {
                Err(RmpConfigError::OutOfRange {
                    field: field.to_string(),
                    value,
                    min,
                    max,
                })
            }
        };
        range("max_speed_mps", self.max_speed_mps, 0.0, 8.047)?;
        range("max_rot_radps", self.max_rot_radps, 0.0, 4.5)?;
        range("period_s", self.period_s, 0.005, 1.0)?;
        // The watchdog must outlast two control periods (one late step is not a stop) and act
        // before the platform's own 0.5 s timeout.
        range(
            "watchdog_timeout_s",
            self.watchdog_timeout_s,
            2.0 * self.period_s,
            0.5,
        )?;
        range("link_timeout_s", self.link_timeout_s, 0.05, 5.0)?;
        range("step_timeout_s", self.step_timeout_s, 0.1, 60.0)?;
        if self.drive_mode == DriveMode::Balance
            && self.machine.bitmap & BITMAP_BALANCE_ENABLED == 0
        {
            return Err(RmpConfigError::BalanceNotEnabled);
        }
        Ok(())
    }

    /// The speed limits actually applied before sending: the host clamp and the machine limit.
    pub fn speed_limits(&self) -> (f64, f64) {
        (
            self.max_speed_mps
                .min(f64::from(self.machine.velocity_limit_mps)),
            self.max_rot_radps
                .min(f64::from(self.machine.yaw_rate_limit_radps)),
        )
    }
}

/// Datagram faults the emulator injects, each a fraction of datagrams in either direction.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct FaultInjection {
    /// Fraction of datagrams silently dropped.
    pub drop: f64,
    /// Fraction of datagrams with one byte replaced by another value (CRC-16 detects all of these).
    pub corrupt: f64,
    /// Fraction of datagrams held back by `delay_ms` (so they also arrive out of order).
    pub delay: f64,
    pub delay_ms: u64,
}

impl FaultInjection {
    pub fn validate(&self) -> Result<(), RmpConfigError> {
        for (field, v) in [
            ("drop", self.drop),
            ("corrupt", self.corrupt),
            ("delay", self.delay),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(RmpConfigError::OutOfRange {
                    field: field.to_string(),
                    value: v,
                    min: 0.0,
                    max: 1.0,
                });
            }
        }
        if self.delay_ms > 10_000 {
            return Err(RmpConfigError::OutOfRange {
                field: "delay_ms".into(),
                value: self.delay_ms as f64,
                min: 0.0,
                max: 10_000.0,
            });
        }
        Ok(())
    }
}

/// The emulator's options.
#[derive(Clone, Debug, PartialEq)]
pub struct EmulatorConfig {
    /// Byte order of feedback words (the driver must detect it). Commands are big-endian always.
    pub order: WordOrder,
    pub platform: Platform,
    /// The machine configuration in F-RAM at power-up (until the driver loads its own).
    pub machine: MachineConfig,
    pub faults: FaultInjection,
    /// Seed of the fault-injection random stream, so a failing run can be replayed.
    pub seed: u64,
    /// Time from power-up through the init states to standby.
    pub init_s: f64,
    /// Without a motion command for this long the platform slews to zero (vendor forum: 0.5 s).
    pub command_timeout_s: f64,
    /// Feedback period when streaming (100 Hz).
    pub stream_period_s: f64,
    /// Balance mode waits for [`EmulatorHandle::tip_back`](super::emulator::EmulatorHandle::tip_back),
    /// as the real base waits for its operator; off, balance is entered at once.
    pub balance_needs_tip_back: bool,
    /// Time constant of the stand-in base's first-order lag.
    pub base_lag_s: f64,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        EmulatorConfig {
            order: WordOrder::Little,
            platform: Platform::Rmp220,
            machine: MachineConfig::default(),
            faults: FaultInjection::default(),
            seed: 0,
            init_s: 0.3,
            command_timeout_s: 0.5,
            stream_period_s: 0.01,
            balance_needs_tip_back: true,
            base_lag_s: 0.1,
        }
    }
}

impl EmulatorConfig {
    /// An emulator of `platform` that powers up with that platform's own shipped configuration
    /// (its [`MachineConfig::vendor_defaults`]), everything else default.
    pub fn for_platform(platform: Platform) -> EmulatorConfig {
        EmulatorConfig {
            platform,
            machine: MachineConfig::vendor_defaults(platform),
            ..EmulatorConfig::default()
        }
    }
}

/// A configuration value the driver or emulator cannot use.
#[derive(Debug, Error, Diagnostic, PartialEq)]
pub enum RmpConfigError {
    #[error("`{field}` is {value}, outside {min}..={max}")]
    #[diagnostic(
        code(advise::rmp::config_out_of_range),
        help("set `{field}` within {min}..={max}")
    )]
    OutOfRange {
        field: String,
        value: f64,
        min: f64,
        max: f64,
    },
    #[error("balance mode is asked for but the machine config bitmap does not enable it")]
    #[diagnostic(
        code(advise::rmp::balance_not_enabled),
        help("set bit 6 of `machine.bitmap` (RMP 220 only), or drive in tractor mode")
    )]
    BalanceNotEnabled,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_round_trip() {
        RmpConfig::default().validate().unwrap();
        let m = MachineConfig::default();
        assert_eq!(MachineConfig::from_words(&m.to_words()), m);
        assert_eq!(m.clamped_to_nvm(Platform::Rmp220), m);
    }

    #[test]
    fn out_of_range_names_the_field() {
        let mut c = RmpConfig::default();
        c.machine.velocity_limit_mps = 9.0;
        assert_eq!(
            c.validate(),
            Err(RmpConfigError::OutOfRange {
                field: "machine.velocity_limit_mps".into(),
                value: 9.0,
                min: 0.0,
                max: f64::from(8.047f32),
            })
        );
        for watchdog_timeout_s in [2.0, 0.01, f64::NAN] {
            let c = RmpConfig {
                watchdog_timeout_s,
                ..RmpConfig::default()
            };
            assert!(c.validate().is_err());
        }
        let c = RmpConfig {
            drive_mode: DriveMode::Balance,
            ..RmpConfig::default()
        };
        assert_eq!(c.validate(), Err(RmpConfigError::BalanceNotEnabled));
    }

    #[test]
    fn the_platform_clamps_what_it_stores() {
        let m = MachineConfig {
            velocity_limit_mps: 20.0,
            track_width_m: f32::NAN,
            ..MachineConfig::default()
        };
        let c = m.clamped_to_nvm(Platform::Rmp220);
        assert_eq!(c.velocity_limit_mps, 8.047);
        assert_eq!(c.track_width_m, 0.506476);
        let narrow = MachineConfig {
            track_width_m: 0.2,
            ..MachineConfig::default()
        };
        assert_eq!(
            narrow.clamped_to_nvm(Platform::Rmp110).track_width_m,
            RMP_110_TRACK_WIDTH_MIN_M
        );
    }

    #[test]
    fn every_platform_stores_its_own_shipped_configuration_unchanged() {
        for p in Platform::ALL {
            let m = MachineConfig::vendor_defaults(p);
            assert_eq!(m.clamped_to_nvm(p), m, "{}", p.name());
            m.validate(Some(p)).unwrap();
            m.validate(None).unwrap();
        }
        // The RMP 110's shipped track width is below the other platforms' minimum.
        let rmp_110 = MachineConfig::vendor_defaults(Platform::Rmp110);
        assert_eq!(rmp_110.track_width_m, 0.481224);
        assert_ne!(rmp_110.clamped_to_nvm(Platform::Rmp220), rmp_110);
        assert!(rmp_110.validate(Some(Platform::Rmp220)).is_err());
    }

    #[test]
    fn the_sessions_configuration_follows_the_simulator() {
        let sim = crate::backend::sim::SimParams::default();
        let c = RmpConfig::for_sim(&sim);
        c.validate().unwrap();
        assert_eq!(c.machine.accel_limit_mps2, 1.0);
        assert_eq!(c.machine.yaw_accel_limit_radps2, 2.0);
        assert_eq!(c.speed_limits(), (1.0, 1.0));
        assert_eq!(c.period_s, 1.0 / 30.0);
        let fast = crate::backend::sim::SimParams {
            max_speed_mps: 20.0,
            ..sim
        };
        assert_eq!(
            RmpConfig::for_sim(&fast).speed_limits().0,
            f64::from(8.047f32)
        );
    }

    #[test]
    fn speed_limits_take_the_tighter_bound() {
        let c = RmpConfig {
            max_speed_mps: 2.0,
            max_rot_radps: 0.5,
            ..RmpConfig::default()
        };
        assert_eq!(c.speed_limits(), (1.0, 0.5));
    }
}
