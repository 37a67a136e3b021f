//! The simulator as a ROS 2 robot (`advise ros2-sim`): subscribes `cmd_vel`, publishes `odom` at
//! 50 Hz from a [`SimBase`], with the simulator's lag, limits and noise.
//!
//! This module owns only the loop between DDS and the simulated base; the physics are
//! [`SimBase`]'s. The robot keeps the newest command (a base holds its last command, as ROS 2
//! bases do; the driver's safety rules are the backend's) and publishes odometry in frame `odom`
//! with child `base_link`. It runs until `stop` is raised.

use std::time::{Duration, Instant};

use super::msg::{ODOMETRY_TYPE, Odometry, TWIST_TYPE, Time, Twist};
use super::{Ros2Node, command_qos, odometry_publisher_qos};
use crate::backend::BackendError;
use crate::backend::interrupt::StopSignal;
use crate::backend::sim::{SimBase, SimParams};
use crate::backend::spec::Ros2Spec;
use crate::trace::Pose;

/// The odometry rate, Hz.
pub const ODOM_RATE_HZ: f64 = 50.0;

/// What a finished `ros2-sim` did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RobotCounts {
    pub commands: u64,
    pub odometry: u64,
    pub pose: Pose,
}

/// Run the simulated base as a ROS 2 robot on `spec`'s topics until `stop` is raised.
/// `on_ready` is called once the topics exist (the CLI prints them).
pub fn run_robot(
    spec: &Ros2Spec,
    params: SimParams,
    seed: u64,
    stop: &StopSignal,
    on_ready: impl FnOnce(&str, &str, u16),
) -> Result<RobotCounts, BackendError> {
    let mut node = Ros2Node::open(spec, "advise_sim")?;
    let commands = node.subscription::<Twist>(&spec.cmd(), TWIST_TYPE, command_qos())?;
    let odom = node.publisher::<Odometry>(&spec.odom(), ODOMETRY_TYPE, odometry_publisher_qos())?;
    on_ready(&spec.cmd(), &spec.odom(), node.domain_id);
    let mut base = SimBase::new(params, seed);
    base.reset(Pose::default());
    let period = Duration::from_secs_f64(1.0 / ODOM_RATE_HZ);
    let t0 = Instant::now();
    let mut next = t0;
    let mut counts = RobotCounts::default();
    while !stop.is_raised() {
        // Bounded per round: a flood of commands cannot starve the odometry.
        for _ in 0..1000 {
            match commands.take() {
                Ok(Some((t, _))) => {
                    base.set_command(t.linear.x, t.angular.z);
                    counts.commands += 1;
                }
                Ok(None) | Err(_) => break,
            }
        }
        let state = base.advance(period.as_secs_f64());
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        let msg = Odometry::planar(
            Time::from_secs_f64(wall),
            "odom",
            "base_link",
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
