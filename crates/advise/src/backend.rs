//! Robot bases: the [`Backend`] trait every base implements, and its implementations.
//!
//! A backend is a differential-drive base that accepts translational and rotational speed commands
//! and reports its odometry, in the manner of the base-velocity and localization traits of Rust
//! robotics code (openrr's `MoveBase` and `Localization`). Task logic (goals, balls, observations)
//! lives in the tasks, not here: the same task runs on the in-process simulator and on a real Segway
//! RMP. Backends never panic on link or device trouble; they return [`BackendError`].
//!
//! The session holds a connected base as a [`Base`] (a `Backend` with its description and its
//! stop from another thread), never as a named kind: which kinds exist is [`kinds`]' list, read by
//! the [`registry`]. A new backend is one file (its `BackendKind`, its `Spec`, its `Base`) plus
//! its module line and its line in [`kinds`], both here.

use std::sync::Arc;

use miette::Diagnostic;
use thiserror::Error;

use crate::trace::Pose;

pub mod interrupt;
pub mod registry;
#[cfg(feature = "rmp")]
pub mod rmp;
#[cfg(feature = "ros2")]
pub mod ros2;
/// Built without the `ros2` feature: the message types alone (bags and MCAP files hold them).
#[cfg(not(feature = "ros2"))]
#[path = "backend/ros2/absent.rs"]
pub mod ros2;
pub mod sim;
pub mod spec;
pub mod teleop;

pub use interrupt::{BaseStop, Interruptible, StopSignal};
pub use registry::{BackendKind, Registry};
pub use spec::{BackendSpec, BackendSpecError, Connect, Spec};

/// Every kind of base `backend SPEC` and `--backend` accept, in the order help lists them. A new
/// backend is its file, its `pub mod` line above and its line here (see ARCHITECTURE.md).
pub fn kinds() -> Vec<Arc<dyn BackendKind>> {
    vec![
        Arc::new(sim::SimKind),
        #[cfg(feature = "rmp")]
        Arc::new(rmp::RmpKind),
        #[cfg(not(feature = "rmp"))]
        Arc::new(registry::Absent::RMP),
        #[cfg(feature = "ros2")]
        Arc::new(ros2::Ros2Kind),
        #[cfg(not(feature = "ros2"))]
        Arc::new(registry::Absent::ROS2),
    ]
}

/// What a base reports after a control step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BaseState {
    /// Time since the last reset, seconds.
    pub t_s: f64,
    /// Odometry pose (dead-reckoned: it drifts from the true pose on a real base).
    pub pose: Pose,
    /// Measured translational speed, m/s.
    pub speed_mps: f64,
    /// Measured rotational speed, rad/s.
    pub rot_radps: f64,
}

/// A robot base driven at a fixed control rate.
pub trait Backend {
    /// Human-readable name, e.g. `sim` or `rmp:192.168.0.40:8080`.
    fn name(&self) -> String;

    /// Control period in seconds (1/30 s for the paper's tasks).
    fn period_s(&self) -> f64;

    /// Bring the base to rest at `start` (the sim teleports; a real base re-zeroes its odometry
    /// frame so that `start` is where it stands).
    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError>;

    /// Command speeds for the next control period. Values outside the base's limits are clamped.
    fn command(&mut self, speed_mps: f64, rot_radps: f64) -> Result<(), BackendError>;

    /// Advance one control period and report the new state.
    fn step(&mut self) -> Result<BaseState, BackendError>;

    /// Command zero speed and bring the base to rest (always safe to call).
    fn stop(&mut self) -> Result<(), BackendError>;

    /// The true pose when the backend knows it (the sim), else `None`: evaluation uses it to score
    /// success honestly while the policy only ever sees odometry.
    fn true_pose(&self) -> Option<Pose> {
        None
    }
}

/// A connected base as the session holds it: a [`Backend`] that says what it is and can be
/// stopped from another thread. Connected by its kind's [`Spec::connect`]; dropping it closes the
/// link (a robot's driver stops the base first).
pub trait Base: Backend + Send + std::any::Any {
    /// What the session says on connecting, after `backend NAME: ` (`None` when the name says
    /// it all, as `sim`'s does).
    fn describe(&self) -> Option<String> {
        None
    }

    /// The driver's stop, callable from any thread (Ctrl-C stops the base at once, not at the
    /// next control step); `None` for a base with nothing to stop between steps.
    fn remote_stop(&self) -> Option<BaseStop> {
        None
    }

    /// Stop the base now and say what was done (Ctrl-C at the prompt).
    fn stop_now(&mut self) -> String {
        match self.stop() {
            Ok(()) => format!("{} stopped", self.name()),
            Err(e) => format!("{} was told to stop but: {e}", self.name()),
        }
    }

    /// Whether it is the in-process simulator: its steps return at once (a drive from the keys
    /// paces itself), and `eval` from the prompt runs on it.
    fn is_simulator(&self) -> bool {
        false
    }

    /// Be ready for a new drive seeded with `seed`: the simulator starts afresh from it (a run
    /// is reproducible from the session's seed and run count); a robot keeps its link.
    fn begin(&mut self, _seed: u64) {}

    /// A person's commands that take over a run on this base while they keep coming (a ROS 2
    /// base's `takeover=/TOPIC`), made afresh for each run; none by default.
    fn takeover_commands(&mut self) -> Option<Box<dyn teleop::Commands>> {
        None
    }
}

impl dyn Base {
    /// The base as its own type, if it is a `T` (`record demo` listens to a ROS 2 base's topics).
    pub fn downcast_ref<T: Base>(&self) -> Option<&T> {
        let any: &dyn std::any::Any = self;
        any.downcast_ref()
    }
}

/// Why a backend could not do what was asked.
#[derive(Debug, Error, Diagnostic)]
pub enum BackendError {
    #[error("no feedback from the base for {waited_ms} ms")]
    #[diagnostic(
        code(advise::backend::link_lost),
        help(
            "check the cable or network and that the base is powered; the execution so far is kept"
        )
    )]
    LinkLost { waited_ms: u64 },
    #[error("the base reported a fault: {what}")]
    #[diagnostic(code(advise::backend::fault))]
    Fault { what: String },
    #[error("network error talking to the base: {0}")]
    #[diagnostic(code(advise::backend::io))]
    Io(#[from] std::io::Error),
    #[error("start-up failed at step `{step}`: {detail}")]
    #[diagnostic(
        code(advise::backend::startup_failed),
        help(
            "check the address, that the base is powered, its E-stop released, and that this computer is on the base's network"
        )
    )]
    StartupFailed { step: String, detail: String },
    #[error("the base did not enter {wanted} mode within {waited_ms} ms (it reports {reported})")]
    #[diagnostic(
        code(advise::backend::mode_change),
        help(
            "tractor mode needs the base in standby with its E-stop released; balance mode needs an operator to tip the base back past vertical"
        )
    )]
    ModeChange {
        wanted: String,
        reported: String,
        waited_ms: u64,
    },
    #[error("the base was stopped: {reason}")]
    #[diagnostic(
        code(advise::backend::stopped),
        help("reset the backend to drive again")
    )]
    Stopped { reason: String },
    #[error("command is not a number: speed {speed_mps} m/s, rotation {rot_radps} rad/s")]
    #[diagnostic(
        code(advise::backend::invalid_command),
        help("zero was sent instead; the policy produced a NaN or infinite action")
    )]
    InvalidCommand { speed_mps: f64, rot_radps: f64 },
    #[cfg(feature = "rmp")]
    #[error(transparent)]
    #[diagnostic(transparent)]
    RmpConfig(#[from] rmp::config::RmpConfigError),
    /// A ROS 2 setting read at connect time (`ROS_DOMAIN_ID`, `ROS_AUTOMATIC_DISCOVERY_RANGE`,
    /// `ROS_STATIC_PEERS`).
    #[cfg(feature = "ros2")]
    #[error(transparent)]
    #[diagnostic(transparent)]
    Ros2Spec(#[from] ros2::spec::Ros2SpecError),
    #[error("no odometry on {topic} (domain {domain_id}) within {waited_ms} ms")]
    #[diagnostic(
        code(advise::backend::no_odometry),
        help(
            "discovery saw from other participants: {discovered}; {discovery}. Check that the base's driver runs and publishes nav_msgs/Odometry on that topic, that ROS_DOMAIN_ID matches (or `ros2?domain=N`), the topic names (`ros2:NAMESPACE`, `ros2?odom=TOPIC`), and how far discovery looks (ROS_AUTOMATIC_DISCOVERY_RANGE or `ros2?discovery=localhost|subnet`)"
        )
    )]
    NoOdometry {
        topic: String,
        domain_id: u16,
        waited_ms: u64,
        discovered: String,
        /// How far discovery looked, in words.
        discovery: String,
    },
    #[error("nothing reads commands on {topic} (domain {domain_id}) after {waited_ms} ms")]
    #[diagnostic(
        code(advise::backend::no_command_reader),
        help(
            "{why}. Commands are sent only once the base's command subscription is matched, so none went unread"
        )
    )]
    NoCommandReader {
        topic: String,
        domain_id: u16,
        waited_ms: u64,
        why: String,
    },
    #[error("the base's command reader on {topic} went away mid-run")]
    #[diagnostic(
        code(advise::backend::command_reader_gone),
        help(
            "zero was commanded and the execution so far is kept; check that the base's driver still runs"
        )
    )]
    CommandReaderGone { topic: String },
    #[error("corrupt odometry on {topic}: {what}")]
    #[diagnostic(
        code(advise::backend::bad_odometry),
        help(
            "the base was commanded zero as the sample arrived and the execution so far is kept; check the base's odometry (its driver, encoders or the publisher of that topic) before driving again"
        )
    )]
    BadOdometry { topic: String, what: String },
    #[error("ROS 2: {what}")]
    #[diagnostic(code(advise::backend::ros2))]
    Ros2 { what: String },
    #[error("{0}")]
    #[diagnostic(code(advise::backend::other))]
    Other(String),
}

/// Odometry farther from the origin than this is not a mobile base's (1,000 km): a corrupt value.
pub const ODOM_FAR_M: f64 = 1.0e6;

/// Why odometry (`pose`, measured speeds) cannot be a base's: a non-finite field or a position
/// beyond [`ODOM_FAR_M`]. Every backend that reads odometry from a device refuses such a sample,
/// zeroes the base and ends the run with [`BackendError::BadOdometry`]: a policy never acts on it.
pub fn odometry_fault(pose: Pose, speed_mps: f64, rot_radps: f64) -> Option<String> {
    let fields = [
        ("x", pose.x_m),
        ("y", pose.y_m),
        ("heading", pose.theta_rad),
        ("speed", speed_mps),
        ("rotation", rot_radps),
    ];
    if let Some((name, v)) = fields.iter().find(|(_, v)| !v.is_finite()) {
        return Some(format!("its {name} is {v}"));
    }
    let (name, v) = fields[..2].iter().find(|(_, v)| v.abs() > ODOM_FAR_M)?;
    Some(format!("its {name} is {v} m, beyond any base's reach"))
}

/// A robot backend's fixed-rate schedule: sleep until `next_deadline`, then set the next one a
/// period on. A session that fell more than a period behind starts a new schedule instead of
/// bursting commands to catch up.
pub(crate) fn wait_for_tick(next_deadline: &mut std::time::Instant, period_s: f64) {
    let period = std::time::Duration::from_secs_f64(period_s);
    let now = std::time::Instant::now();
    if *next_deadline > now {
        std::thread::sleep(*next_deadline - now);
    }
    *next_deadline += period;
    if std::time::Instant::now() > *next_deadline {
        *next_deadline = std::time::Instant::now() + period;
    }
}
