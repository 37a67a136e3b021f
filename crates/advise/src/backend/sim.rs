//! The simulated base: a Segway-RMP-like differential drive, and the [`SimBackend`] over it.
//!
//! This module owns the base's physics and sensing model and every number in it, collected in
//! [`SimParams`] (one documented struct with defaults, readable from a JSON file). [`SimBase`] is
//! the model itself, also used behind the RMP emulator; [`SimBackend`] runs it as a
//! [`Backend`] at the control rate. The model, per integration substep:
//!
//! 1. The speed command is clamped to the speed limits (a non-finite command counts as zero).
//! 2. The true speeds follow the command through a first-order lag (the balancing base must pitch
//!    before it accelerates), and each change is then clamped by the acceleration limits, so the
//!    true speeds never leave the speed limits nor change faster than the acceleration limits.
//! 3. The true pose moves along the exact arc of the true speeds.
//! 4. Each wheel's encoder reads its true wheel speed with multiplicative noise (slip); odometry
//!    dead-reckons from those readings with a systematic rotation scale error (the effective wheel
//!    base is not what the odometry assumes) and a heading drift per metre driven (unequal wheel
//!    radii). The odometry pose therefore drifts from the true pose, mostly in heading, as the
//!    paper reports for the real RMP. A base at rest reads exactly zero and does not drift.
//!
//! Everything is deterministic for a seed (ChaCha8). Task logic (goals, balls) is not here. The
//! registry's `sim` entry ([`SimKind`]) is here too: the session's default base, made afresh with
//! each run's seed ([`Base::begin`]).

use std::path::Path;

use miette::Diagnostic;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::backend::{Backend, BackendError, Base, BaseState};
use crate::diag::{Loc, SourceMap, Sourced, Src, locate};
use crate::geometry::{Pose, integrate_arc, lag_fraction, limit_speed, wheel_speeds};

/// Angle wrapping lives in [`crate::geometry`]; kept here under its old path.
pub use crate::geometry::wrap_angle;
pub use kind::{SimKind, SimSpec};

mod kind;

/// Every parameter of the simulated base. The paper gives only the control rate (30 Hz); the rest
/// are ours, chosen to resemble a Segway RMP 200 driven indoors at walking pace.
///
/// Read from JSON with [`SimParams::load`]; omitted fields keep their defaults, unknown fields are
/// an error. Example: `{"lag_s": 0.4, "heading_drift_rad_per_m": 0.05}`.
///
/// Every field has a range (inclusive, in [`SimParams::RANGES`] and quoted on each field): what is
/// physically sensible for a mobile base the size of an RMP, and what keeps a run bounded in time
/// and memory (a 60 s episode is at most 6,000 control steps of at most 1,000 substeps each).
/// [`SimParams::validate`] checks them; every loader does, and so do [`Session`] and the RMP
/// emulator for parameters built in code.
///
/// [`Session`]: crate::session::Session
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimParams {
    /// Control rate, Hz: one command and one observation per period (the paper samples at 30 Hz).
    /// 1 to 100 (the RMP takes commands at up to 100 Hz).
    pub rate_hz: f64,
    /// Translational speed limit, m/s (both directions); matches the positioning domain's `trans`.
    /// 0.05 to 5 (the RMP 200 tops out near 3.6 m/s).
    pub max_speed_mps: f64,
    /// Rotational speed limit, rad/s (both directions); matches the positioning domain's `rot`.
    /// 0.05 to 6.
    pub max_rot_radps: f64,
    /// Translational acceleration limit, m/s^2. 0.05 to 10.
    pub max_accel_mps2: f64,
    /// Rotational acceleration limit, rad/s^2. 0.05 to 20.
    pub max_rot_accel_radps2: f64,
    /// Time constant of the first-order response to a speed command, s (the balancing lag).
    /// 0 (none) to 5.
    pub lag_s: f64,
    /// Distance between the wheels, m. 0.1 to 2.
    pub track_width_m: f64,
    /// Standard deviation of each wheel encoder's reading, as a fraction of the wheel's speed.
    /// 0 to 0.3 (beyond that a wheel often reads backwards).
    pub encoder_noise_frac: f64,
    /// Odometry's systematic rotation error: it believes the base turned `1 + this` times the
    /// true angle. -0.5 to 0.5.
    pub odom_rot_scale_error: f64,
    /// Odometry heading drift per metre driven, rad/m (forward driving drifts one way, reverse the
    /// other), as from slightly unequal wheel radii. -0.5 to 0.5.
    pub heading_drift_rad_per_m: f64,
    /// Longest integration substep, s; a period is split into equal substeps no longer than this.
    /// 0.001 to 0.1.
    pub max_substep_s: f64,
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            rate_hz: 30.0,
            max_speed_mps: 1.0,
            max_rot_radps: 1.0,
            max_accel_mps2: 1.0,
            max_rot_accel_radps2: 2.0,
            lag_s: 0.25,
            track_width_m: 0.53,
            encoder_noise_frac: 0.03,
            odom_rot_scale_error: 0.03,
            heading_drift_rad_per_m: 0.02,
            max_substep_s: 0.01,
        }
    }
}

/// The accepted range of one simulator parameter (inclusive).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamRange {
    pub field: &'static str,
    pub min: f64,
    pub max: f64,
    /// The unit as a teacher reads it (empty for plain fractions).
    pub unit: &'static str,
    /// What the parameter is, in a few words (for the diagnostic's help).
    pub what: &'static str,
}

const fn range(
    field: &'static str,
    min: f64,
    max: f64,
    unit: &'static str,
    what: &'static str,
) -> ParamRange {
    ParamRange {
        field,
        min,
        max,
        unit,
        what,
    }
}

impl SimParams {
    /// The range of every field, in declaration order (the same order as [`SimParams::values`]).
    pub const RANGES: [ParamRange; 11] = [
        range("rate_hz", 1.0, 100.0, "Hz", "the control rate"),
        range("max_speed_mps", 0.05, 5.0, "m/s", "the speed limit"),
        range("max_rot_radps", 0.05, 6.0, "rad/s", "the turn rate limit"),
        range(
            "max_accel_mps2",
            0.05,
            10.0,
            "m/s^2",
            "the acceleration limit",
        ),
        range(
            "max_rot_accel_radps2",
            0.05,
            20.0,
            "rad/s^2",
            "the turn acceleration limit",
        ),
        range("lag_s", 0.0, 5.0, "s", "the time constant of the response"),
        range(
            "track_width_m",
            0.1,
            2.0,
            "m",
            "the distance between the wheels",
        ),
        range(
            "encoder_noise_frac",
            0.0,
            0.3,
            "",
            "the encoders' noise as a fraction of the wheel speed",
        ),
        range(
            "odom_rot_scale_error",
            -0.5,
            0.5,
            "",
            "odometry's rotation scale error",
        ),
        range(
            "heading_drift_rad_per_m",
            -0.5,
            0.5,
            "rad/m",
            "odometry's heading drift per metre",
        ),
        range(
            "max_substep_s",
            0.001,
            0.1,
            "s",
            "the longest integration substep",
        ),
    ];

    /// Every field's value, in declaration order (the order of [`SimParams::RANGES`]).
    pub fn values(&self) -> [f64; 11] {
        [
            self.rate_hz,
            self.max_speed_mps,
            self.max_rot_radps,
            self.max_accel_mps2,
            self.max_rot_accel_radps2,
            self.lag_s,
            self.track_width_m,
            self.encoder_noise_frac,
            self.odom_rot_scale_error,
            self.heading_drift_rad_per_m,
            self.max_substep_s,
        ]
    }

    /// The control period, s.
    pub fn period_s(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// Read parameters from a JSON file into `sources` (see the struct's docs for the format).
    pub fn load(sources: &mut SourceMap, path: &Path) -> Result<SimParams, SimError> {
        crate::files::parse_file(sources, path, SimParams::parse)
    }

    /// [`SimParams::parse`] of a text outside any session (its error brings its own source map).
    pub fn from_json_str(name: &str, text: &str) -> Result<SimParams, Sourced<SimError>> {
        let mut sources = SourceMap::new();
        let id = sources.add(name, text);
        SimParams::parse(sources.src(id)).map_err(|e| sources.attach(e))
    }

    /// Parse and validate JSON text. A value out of range is reported with its place in the text.
    pub fn parse(src: Src<'_>) -> Result<SimParams, SimError> {
        let text = src.text;
        let params: SimParams = serde_json::from_str(text).map_err(|e| {
            let message = e.to_string();
            let help = unknown_field_help(&message);
            SimError::Json {
                message,
                help,
                at: src.at(locate::line_col(text, e.line(), e.column())),
            }
        })?;
        params.validate().map_err(|e| match e {
            SimError::Invalid {
                field,
                value,
                expected,
                help,
                ..
            } => SimError::Invalid {
                field,
                value,
                expected,
                help,
                at: locate::json_member_value(text, field).map(|r| src.at(r)),
            },
            other => other,
        })?;
        Ok(params)
    }

    /// Check every parameter is finite and within its range ([`SimParams::RANGES`]); the first
    /// one that is not is reported.
    pub fn validate(&self) -> Result<(), SimError> {
        let defaults = SimParams::default().values();
        for ((r, value), default) in SimParams::RANGES.iter().zip(self.values()).zip(defaults) {
            if !(value.is_finite() && value >= r.min && value <= r.max) {
                let unit = if r.unit.is_empty() {
                    String::new()
                } else {
                    format!(" {}", r.unit)
                };
                return Err(SimError::Invalid {
                    field: r.field,
                    value: crate::number::fmt_readable(value),
                    expected: format!("from {} to {}{unit}", r.min, r.max),
                    help: format!(
                        "`{}` is {}; remove the field to use the default, {default}{unit}",
                        r.field, r.what
                    ),
                    at: None,
                });
            }
        }
        Ok(())
    }

    /// The same base with perfect sensing: no encoder noise, no odometry error (for tests and for
    /// separating control error from dead-reckoning error).
    pub fn noiseless(&self) -> SimParams {
        SimParams {
            encoder_noise_frac: 0.0,
            odom_rot_scale_error: 0.0,
            heading_drift_rad_per_m: 0.0,
            ..self.clone()
        }
    }
}

/// "did you mean" for serde's `unknown field `x`` message.
fn unknown_field_help(message: &str) -> String {
    let fields = SimParams::RANGES.map(|r| r.field);
    let unknown = message
        .strip_prefix("unknown field `")
        .and_then(|rest| rest.split('`').next());
    if let Some(help) = unknown.and_then(|name| crate::diag::did_you_mean(name, fields)) {
        return help;
    }
    format!(
        "simulator parameters are a JSON object with any of: {}",
        fields.join(", ")
    )
}

/// Why simulator parameters could not be read.
#[derive(Debug, Error, Diagnostic)]
pub enum SimError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("the simulator parameters are malformed: {message}")]
    #[diagnostic(code(advise::sim::params_json), help("{help}"))]
    Json {
        message: String,
        help: String,
        #[label("here")]
        at: Loc,
    },
    #[error("simulator parameter `{field}` is {value}; it must be {expected}")]
    #[diagnostic(code(advise::sim::params_invalid), help("{help}"))]
    Invalid {
        field: &'static str,
        /// The value as written for a person (`1e300`, `NaN`).
        value: String,
        /// The range, with its unit.
        expected: String,
        help: String,
        /// The value in the parameters file, when they came from one.
        #[label("out of range")]
        at: Option<Loc>,
    },
}

/// The most substeps one [`SimBase::advance`] takes, whatever `dt_s` and `max_substep_s` are.
pub const MAX_SUBSTEPS_PER_ADVANCE: usize = 100_000;

/// The simulated differential-drive base: true state, odometry, and the seeded noise.
#[derive(Clone, Debug)]
pub struct SimBase {
    params: SimParams,
    rng: ChaCha8Rng,
    t_s: f64,
    truth: Pose,
    odom: Pose,
    /// True speeds.
    speed_mps: f64,
    rot_radps: f64,
    /// Speeds as the encoders measured them over the last substep.
    measured_speed_mps: f64,
    measured_rot_radps: f64,
    /// The clamped command in force.
    cmd_speed_mps: f64,
    cmd_rot_radps: f64,
}

impl SimBase {
    /// A base at rest at the origin. `params` should be valid ([`SimParams::validate`]): every
    /// loader, the session and the emulator check them; here they are taken as they are (a run
    /// stays bounded in time, see [`MAX_SUBSTEPS_PER_ADVANCE`], but may not be physical).
    pub fn new(params: SimParams, seed: u64) -> SimBase {
        SimBase {
            params,
            rng: ChaCha8Rng::seed_from_u64(seed),
            t_s: 0.0,
            truth: Pose::default(),
            odom: Pose::default(),
            speed_mps: 0.0,
            rot_radps: 0.0,
            measured_speed_mps: 0.0,
            measured_rot_radps: 0.0,
            cmd_speed_mps: 0.0,
            cmd_rot_radps: 0.0,
        }
    }

    pub fn params(&self) -> &SimParams {
        &self.params
    }

    /// Teleport to `pose` at rest; odometry is re-zeroed there and the clock restarts. The noise
    /// stream continues (it is not reseeded), so a run is reproducible from construction.
    pub fn reset(&mut self, pose: Pose) -> BaseState {
        self.t_s = 0.0;
        self.truth = pose;
        self.odom = pose;
        self.speed_mps = 0.0;
        self.rot_radps = 0.0;
        self.measured_speed_mps = 0.0;
        self.measured_rot_radps = 0.0;
        self.cmd_speed_mps = 0.0;
        self.cmd_rot_radps = 0.0;
        self.state()
    }

    /// Command speeds; they are clamped to the speed limits, and a non-finite value counts as 0.
    pub fn set_command(&mut self, speed_mps: f64, rot_radps: f64) {
        self.cmd_speed_mps = limit_speed(speed_mps, self.params.max_speed_mps);
        self.cmd_rot_radps = limit_speed(rot_radps, self.params.max_rot_radps);
    }

    /// The command in force, after clamping.
    pub fn command(&self) -> (f64, f64) {
        (self.cmd_speed_mps, self.cmd_rot_radps)
    }

    /// Advance the simulation by `dt_s` seconds (any length: it is split into substeps of at most
    /// `max_substep_s`). A non-positive or non-finite `dt_s` changes nothing.
    pub fn advance(&mut self, dt_s: f64) -> BaseState {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return self.state();
        }
        // Valid parameters give at most 1,000 substeps a control period; the cap keeps a long
        // `dt_s` (or parameters that skipped validation) bounded in time, with longer substeps.
        let n = (dt_s / self.params.max_substep_s)
            .ceil()
            .clamp(1.0, MAX_SUBSTEPS_PER_ADVANCE as f64) as usize;
        let h = dt_s / n as f64;
        for _ in 0..n {
            self.substep(h);
        }
        self.t_s += dt_s;
        self.state()
    }

    fn substep(&mut self, h: f64) {
        let p = &self.params;
        // Lag, then the acceleration clamp: the result is a convex combination of the old speed and
        // the (clamped) command, so it stays within the speed limits.
        let alpha = lag_fraction(p.lag_s, h);
        let dv = (alpha * (self.cmd_speed_mps - self.speed_mps))
            .clamp(-p.max_accel_mps2 * h, p.max_accel_mps2 * h);
        let dw = (alpha * (self.cmd_rot_radps - self.rot_radps))
            .clamp(-p.max_rot_accel_radps2 * h, p.max_rot_accel_radps2 * h);
        self.speed_mps += dv;
        self.rot_radps += dw;
        self.truth = integrate_arc(self.truth, self.speed_mps, self.rot_radps, h);

        // Encoders: both normals are drawn every substep so the stream stays in step whatever
        // the speeds are.
        let (n_left, n_right) = normal_pair(&mut self.rng);
        let (left, right) = wheel_speeds(self.speed_mps, self.rot_radps, p.track_width_m);
        let left = left * (1.0 + p.encoder_noise_frac * n_left);
        let right = right * (1.0 + p.encoder_noise_frac * n_right);
        let v_m = 0.5 * (left + right);
        let w_m = (right - left) / p.track_width_m * (1.0 + p.odom_rot_scale_error)
            + p.heading_drift_rad_per_m * v_m;
        self.measured_speed_mps = v_m;
        self.measured_rot_radps = w_m;
        self.odom = integrate_arc(self.odom, v_m, w_m, h);
    }

    /// What the base reports: odometry pose and measured speeds.
    pub fn state(&self) -> BaseState {
        BaseState {
            t_s: self.t_s,
            pose: self.odom,
            speed_mps: self.measured_speed_mps,
            rot_radps: self.measured_rot_radps,
        }
    }

    /// Where the base really is.
    pub fn true_pose(&self) -> Pose {
        self.truth
    }

    /// The base's true speeds `(m/s, rad/s)`.
    pub fn true_speeds(&self) -> (f64, f64) {
        (self.speed_mps, self.rot_radps)
    }
}

/// Two independent standard normal draws (Box-Muller): the simulator's noise and the simulated
/// teachers' misjudgements.
pub fn normal_pair<R: Rng + ?Sized>(rng: &mut R) -> (f64, f64) {
    // 1 - u keeps the logarithm's argument in (0, 1].
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    let r = (-2.0 * u1.ln()).sqrt();
    let phi = std::f64::consts::TAU * u2;
    (r * phi.cos(), r * phi.sin())
}

/// [`SimBase`] as a [`Backend`]: one `step` is one control period. It never fails.
#[derive(Clone, Debug)]
pub struct SimBackend {
    base: SimBase,
}

impl SimBackend {
    pub fn new(params: SimParams, seed: u64) -> SimBackend {
        SimBackend {
            base: SimBase::new(params, seed),
        }
    }

    pub fn base(&self) -> &SimBase {
        &self.base
    }
}

impl Backend for SimBackend {
    fn name(&self) -> String {
        "sim".into()
    }

    fn period_s(&self) -> f64 {
        self.base.params.period_s()
    }

    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        Ok(self.base.reset(start))
    }

    fn command(&mut self, speed_mps: f64, rot_radps: f64) -> Result<(), BackendError> {
        self.base.set_command(speed_mps, rot_radps);
        Ok(())
    }

    fn step(&mut self) -> Result<BaseState, BackendError> {
        let dt = self.period_s();
        Ok(self.base.advance(dt))
    }

    fn stop(&mut self) -> Result<(), BackendError> {
        self.base.set_command(0.0, 0.0);
        Ok(())
    }

    fn true_pose(&self) -> Option<Pose> {
        Some(self.base.true_pose())
    }
}

/// The simulator as the session holds it: seeded afresh for each drive.
impl Base for SimBackend {
    fn stop_now(&mut self) -> String {
        // `run` made it for one drive and the drive has ended: nothing moves.
        "the simulated base is at rest".into()
    }

    fn is_simulator(&self) -> bool {
        true
    }

    fn begin(&mut self, seed: u64) {
        *self = SimBackend::new(self.base.params.clone(), seed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noiseless_odometry_equals_truth() {
        let mut b = SimBase::new(SimParams::default().noiseless(), 1);
        b.reset(Pose::new(1.0, 2.0, 0.5));
        b.set_command(0.6, 0.4);
        for _ in 0..90 {
            b.advance(1.0 / 30.0);
        }
        let (o, t) = (b.state().pose, b.true_pose());
        assert!((o.x_m - t.x_m).abs() < 1e-9 && (o.theta_rad - t.theta_rad).abs() < 1e-9);
    }

    #[test]
    fn straight_drive_reaches_commanded_speed() {
        let mut b = SimBase::new(SimParams::default().noiseless(), 1);
        b.reset(Pose::default());
        b.set_command(0.5, 0.0);
        for _ in 0..150 {
            b.advance(1.0 / 30.0);
        }
        let s = b.state();
        assert!((s.speed_mps - 0.5).abs() < 1e-3, "{s:?}");
        // 5 s at up to 0.5 m/s, less the time lost to the lag and the ramp.
        assert!(s.pose.x_m > 2.0 && s.pose.x_m < 2.5, "{s:?}");
        assert!(s.pose.y_m.abs() < 1e-9);
    }
}
