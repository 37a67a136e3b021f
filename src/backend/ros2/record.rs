//! Recording a person's teleoperation of a ROS 2 base: the `Twist` commands their usual tool
//! publishes (`teleop_twist_keyboard`, a joystick node) sampled at the task's rate together with
//! the base's odometry. `advise` publishes nothing while it listens: a person drives.
//!
//! Sampling starts at the first command that moves the base (the wait before it is not part of
//! the demonstration) and ends when the person ends it (Enter, or Ctrl-C: [`StopSignal`]), when no moving
//! command has been heard for `idle_s` (teleop nodes keep publishing zero) and the base is at
//! rest, at `max_s`, or when odometry goes stale (kept, with [`Ended::LinkLost`]). Each sample pairs the pose (re-zeroed where the base
//! stood at the first command) with the command the base holds then: the newest heard, as a base
//! holds its last `cmd_vel`.

use std::time::{Duration, Instant};

use ros2_client::Subscription;

use super::driver::OdomSample;
use super::msg::{ODOMETRY_TYPE, Odometry, TWIST_TYPE, Twist};
use super::spec::Ros2Spec;
use super::{Ros2Node, command_qos, odometry_qos};
use crate::backend::{BackendError, StopSignal};
use crate::geometry::{Pose, relative_pose};

/// A base slower than this is at rest (idle ending waits for it).
const REST_MPS: f64 = 0.02;
const REST_RADPS: f64 = 0.05;

/// How to listen.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordOptions {
    /// The teleoperation's command topic as written (`cmd_vel`, `/teleop/cmd_vel`), resolved
    /// under the spec's namespace.
    pub teleop_topic: String,
    /// The task's control period: one sample per period.
    pub period_s: f64,
    /// The longest recording (and the longest wait for the first command).
    pub max_s: f64,
    /// No moving command for this long with the base at rest ends the recording.
    pub idle_s: f64,
}

/// Why a recording ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ended {
    /// The person ended it (Enter or Ctrl-C).
    Stopped,
    /// No moving command for `idle_s` with the base at rest.
    Idle,
    /// `max_s` passed.
    TimeLimit,
    /// Odometry went stale; what came before is kept.
    LinkLost,
}

/// A recorded teleoperation.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Per sample: seconds since the first command, the pose re-zeroed at the first command, and
    /// the command held `(speed m/s, turn rate rad/s)`.
    pub samples: Vec<(f64, Pose, f64, f64)>,
    /// Messages heard on each topic while recording.
    pub commands_heard: u64,
    pub odometry_heard: u64,
    pub ended: Ended,
    /// The full names listened to.
    pub teleop_topic: String,
    pub odom_topic: String,
}

/// Drain `sub`, keeping the newest message and counting them (bounded per call).
fn newest<M: serde::de::DeserializeOwned + 'static>(
    sub: &Subscription<M>,
    count: &mut u64,
) -> Option<M> {
    let mut last = None;
    for _ in 0..1000 {
        match sub.take() {
            Ok(Some((m, _))) => {
                last = Some(m);
                *count += 1;
            }
            Ok(None) | Err(_) => break,
        }
    }
    last
}

/// Listen to `opts.teleop_topic` and the spec's odometry and record a teleoperation.
/// `person_ended` is asked each few milliseconds whether the person ended it (Enter at the
/// session's terminal).
pub fn record_teleop(
    spec: &Ros2Spec,
    opts: &RecordOptions,
    stop: &StopSignal,
    person_ended: &mut dyn FnMut() -> bool,
) -> Result<Recording, BackendError> {
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if !(positive(opts.period_s) && positive(opts.max_s) && positive(opts.idle_s)) {
        return Err(BackendError::Ros2 {
            what: format!(
                "record: the period, the time limit and the idle time must be positive ({opts:?})"
            ),
        });
    }
    let mut node = Ros2Node::open(spec, "advise_record")?;
    let teleop_topic = spec.resolve(&opts.teleop_topic);
    let odom_topic = spec.odom();
    let commands: Subscription<Twist> =
        node.subscription(&teleop_topic, TWIST_TYPE, command_qos())?;
    let odometry: Subscription<Odometry> =
        node.subscription(&odom_topic, ODOMETRY_TYPE, odometry_qos())?;
    let period = Duration::from_secs_f64(opts.period_s);
    let odom_timeout = Duration::from_millis(spec.odom_timeout_ms);
    let began = Instant::now();
    let limit = Duration::from_secs_f64(opts.max_s);
    let idle = Duration::from_secs_f64(opts.idle_s);
    let mut rec = Recording {
        samples: Vec::new(),
        commands_heard: 0,
        odometry_heard: 0,
        ended: Ended::TimeLimit,
        teleop_topic,
        odom_topic,
    };
    let mut odom: Option<OdomSample> = None;
    let mut held: Option<(f64, f64)> = None;
    let mut last_motion_at = began;
    let mut origin: Option<(Pose, Instant)> = None;
    let mut next = began;
    loop {
        let now = Instant::now();
        if let Some(o) = newest(&odometry, &mut rec.odometry_heard) {
            odom = Some(OdomSample::from_msg(&o, now));
        }
        if let Some(t) = newest(&commands, &mut rec.commands_heard) {
            let (v, w) = (t.linear.x, t.angular.z);
            let (v, w) = if v.is_finite() && w.is_finite() {
                (v, w)
            } else {
                (0.0, 0.0)
            };
            // The first command starts the recording only once it moves the base: a teleop
            // node publishing zero while nobody drives is not a demonstration yet.
            if v != 0.0 || w != 0.0 {
                last_motion_at = now;
                held = Some((v, w));
            } else if held.is_some() {
                held = Some((0.0, 0.0));
            }
        }
        if stop.is_raised() || person_ended() {
            rec.ended = Ended::Stopped;
            break;
        }
        if now.duration_since(began) >= limit {
            rec.ended = Ended::TimeLimit;
            break;
        }
        match (&odom, origin) {
            (None, _) if now.duration_since(began) >= Duration::from_millis(spec.wait_ms) => {
                return Err(BackendError::NoOdometry {
                    topic: rec.odom_topic.clone(),
                    domain_id: node.domain_id,
                    waited_ms: spec.wait_ms,
                    discovered: {
                        let d = node.discovered();
                        if d.is_empty() {
                            "nothing".into()
                        } else {
                            d.join(", ")
                        }
                    },
                });
            }
            (Some(o), _) if now.duration_since(o.received) > odom_timeout && origin.is_some() => {
                rec.ended = Ended::LinkLost;
                break;
            }
            (Some(o), None) if held.is_some() => origin = Some((o.pose, now)),
            _ => {}
        }
        if let (Some(o), Some((start, t0)), Some((v, w))) = (&odom, origin, held)
            && now >= next
        {
            let t = now.duration_since(t0).as_secs_f64();
            rec.samples.push((t, relative_pose(start, o.pose), v, w));
            next += period;
            if next < now {
                next = now + period;
            }
            let at_rest = o.speed_mps.abs() < REST_MPS && o.rot_radps.abs() < REST_RADPS;
            if now.duration_since(last_motion_at) >= idle && at_rest {
                rec.ended = Ended::Idle;
                break;
            }
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    Ok(rec)
}
