//! The simulator as a ROS 2 robot (`advise ros2-sim`): subscribes `cmd_vel`, publishes `odom` at
//! 50 Hz from a [`SimBase`], with the simulator's lag, limits and noise.
//!
//! This module owns only the loop between DDS and the simulated base; the physics are
//! [`SimBase`]'s. Like a real base's controller (ros2_control's diff_drive_controller, a Segway's
//! own 0.5 s timeout), it holds the newest command only for a command timeout and then commands
//! zero itself, so a driver that dies mid-run does not leave it driving. It reads commands
//! best-effort, which matches reliable and best-effort publishers alike, and publishes odometry in
//! frames under its namespace (`odom` and `base_link`, or `robot1/odom` and `robot1/base_link`
//! under `/robot1`, as namespaced robots prefix their tf frames). It runs until `stop` is raised.

use std::time::{Duration, Instant};

use super::msg::{ODOMETRY_TYPE, Odometry, TWIST_TYPE, Time, Twist};
use super::spec::Ros2Spec;
use super::{Ros2Node, odometry_publisher_qos, odometry_qos};
use crate::backend::BackendError;
use crate::backend::interrupt::StopSignal;
use crate::backend::sim::{SimBase, SimParams};
use crate::trace::Pose;

/// The odometry rate, Hz.
pub const ODOM_RATE_HZ: f64 = 50.0;

/// How long the robot holds a command with no newer one before it commands zero itself, s (the
/// RMP's own timeout, and the usual `cmd_vel_timeout` of ROS 2 base controllers).
pub const COMMAND_TIMEOUT_S: f64 = 0.5;

/// The tf frames of a robot in `namespace`: `(odom, base_link)` at the root, prefixed with the
/// namespace's path (without its leading slash) elsewhere.
pub fn frames(namespace: &str) -> (String, String) {
    let prefix = namespace.trim_matches('/');
    if prefix.is_empty() {
        ("odom".into(), "base_link".into())
    } else {
        (format!("{prefix}/odom"), format!("{prefix}/base_link"))
    }
}

/// What a finished `ros2-sim` did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RobotCounts {
    pub commands: u64,
    pub odometry: u64,
    /// How often a command timed out and the robot stopped itself.
    pub timeouts: u64,
    pub pose: Pose,
}

/// Run the simulated base as a ROS 2 robot on `spec`'s topics until `stop` is raised, holding
/// each command for at most `command_timeout_s`. `on_ready` is called once the topics exist (the
/// CLI prints them).
pub fn run_robot(
    spec: &Ros2Spec,
    params: SimParams,
    seed: u64,
    command_timeout_s: f64,
    stop: &StopSignal,
    on_ready: impl FnOnce(&str, &str, u16),
) -> Result<RobotCounts, BackendError> {
    // The simulator plays a base: the backend must discover it as another participant.
    let mut node = Ros2Node::open_with(spec, "advise_sim", false)?;
    // Best-effort: a reliable reader would not match a best-effort publisher (and get nothing).
    let commands = node.subscription::<Twist>(&spec.cmd(), TWIST_TYPE, odometry_qos())?;
    let odom = node.publisher::<Odometry>(&spec.odom(), ODOMETRY_TYPE, odometry_publisher_qos())?;
    on_ready(&spec.cmd(), &spec.odom(), node.domain_id);
    let mut base = SimBase::new(params, seed);
    base.reset(Pose::default());
    let period = Duration::from_secs_f64(1.0 / ODOM_RATE_HZ);
    let t0 = Instant::now();
    let mut next = t0;
    let mut counts = RobotCounts::default();
    let (frame, child) = frames(&spec.namespace);
    let timeout = Duration::from_secs_f64(command_timeout_s);
    // When the command being held arrived; `None` once it timed out (or before the first).
    let mut held_since: Option<Instant> = None;
    while !stop.is_raised() {
        // Bounded per round: a flood of commands cannot starve the odometry.
        for _ in 0..1000 {
            match commands.take() {
                Ok(Some((t, _))) => {
                    base.set_command(t.linear.x, t.angular.z);
                    counts.commands += 1;
                    held_since = Some(Instant::now());
                }
                Ok(None) | Err(_) => break,
            }
        }
        if held_since.is_some_and(|at| at.elapsed() > timeout) {
            base.set_command(0.0, 0.0);
            counts.timeouts += 1;
            held_since = None;
        }
        let state = base.advance(period.as_secs_f64());
        let msg = Odometry::planar(
            Time::now(),
            &frame,
            &child,
            state.pose,
            state.speed_mps,
            state.rot_radps,
        );
        if odom.publish(msg).is_ok() {
            counts.odometry += 1;
        }
        counts.pose = state.pose;
        crate::backend::wait_for_tick(&mut next, period.as_secs_f64());
    }
    Ok(counts)
}
