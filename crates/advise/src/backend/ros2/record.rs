//! Recording a person's teleoperation of a ROS 2 base: the `Twist` or `TwistStamped` commands
//! their usual tool publishes (`teleop_twist_keyboard`, with `stamped:=true` on Jazzy, a joystick
//! node) sampled at the task's rate together with the base's odometry. `advise` publishes nothing
//! while it listens: a person drives.
//!
//! The command type is the one discovery sees another participant publish on the topic: DDS
//! matches a reader only with writers of its own type, so a `Twist` reader never hears a
//! `TwistStamped` teleop. Until a writer of either type is seen, nothing is subscribed; a recording
//! that heard nothing says what discovery saw on the topic ([`Recording::seen`]).
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
use super::msg::{
    ODOMETRY_TYPE, Odometry, TWIST_STAMPED_TYPE, TWIST_TYPE, Twist, TwistStamped, dds_type_name,
};
use super::spec::Ros2Spec;
use super::{Ros2Node, odometry_qos};
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
    /// The command type heard (`geometry_msgs/Twist` or `geometry_msgs/TwistStamped`): the type
    /// of the first writer of it discovery saw; `None` when none was seen.
    pub command_type: Option<&'static str>,
    /// What discovery saw on the command topic from other participants at the end, in words
    /// (for a recording that heard nothing).
    pub seen: String,
}

/// The command subscription, of the type the teleoperation publishes.
enum Commands {
    /// No writer of Twist or TwistStamped seen on the topic yet.
    Unknown,
    Twist(Subscription<Twist>),
    Stamped(Subscription<TwistStamped>),
}

impl Commands {
    /// The newest command heard since the last call, `(v, w)`, counting every one.
    fn newest(&self, count: &mut u64) -> Option<(f64, f64)> {
        match self {
            Commands::Unknown => None,
            Commands::Twist(s) => newest(s, count).map(|t| (t.linear.x, t.angular.z)),
            Commands::Stamped(s) => newest(s, count).map(|t| (t.twist.linear.x, t.twist.angular.z)),
        }
    }
}

/// A message type as people write it: `geometry_msgs/Twist`.
fn ros_type(ty: (&'static str, &'static str)) -> &'static str {
    match ty {
        TWIST_STAMPED_TYPE => "geometry_msgs/TwistStamped",
        _ => "geometry_msgs/Twist",
    }
}

/// Subscribe to `topic` with the type another participant publishes there, once one is seen
/// (best-effort, so reliable and best-effort teleop publishers both match).
fn subscribe_to_writer(node: &mut Ros2Node, topic: &str) -> Result<Commands, BackendError> {
    let writers: Vec<String> = node
        .others()
        .into_iter()
        .filter(|e| !e.reader && e.topic == topic)
        .map(|e| e.type_name)
        .collect();
    for ty in [TWIST_TYPE, TWIST_STAMPED_TYPE] {
        if writers.contains(&dds_type_name(ty)) {
            return Ok(if ty == TWIST_TYPE {
                Commands::Twist(node.subscription(topic, ty, odometry_qos())?)
            } else {
                Commands::Stamped(node.subscription(topic, ty, odometry_qos())?)
            });
        }
    }
    Ok(Commands::Unknown)
}

/// What discovery saw of other participants on `topic`, in words: each writer's and reader's
/// type, or that none was seen there and what was seen elsewhere.
pub fn seen_on_topic(node: &Ros2Node, topic: &str) -> String {
    let others = node.others();
    let here: Vec<String> = others
        .iter()
        .filter(|e| e.topic == topic)
        .map(|e| {
            format!(
                "a {} of {}",
                if e.reader { "reader" } else { "writer" },
                e.type_name
            )
        })
        .collect();
    if !here.is_empty() {
        return format!("discovery saw on {topic} {}", here.join(", "));
    }
    let elsewhere = node.discovered();
    format!(
        "discovery saw no other participant on {topic} (elsewhere: {})",
        if elsewhere.is_empty() {
            "nothing".to_string()
        } else {
            elsewhere.join(", ")
        }
    )
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
    let mut commands = Commands::Unknown;
    let mut command_type = None;
    let mut looked = None::<Instant>;
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
        command_type: None,
        seen: String::new(),
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
        if matches!(commands, Commands::Unknown)
            && looked.is_none_or(|l| now.duration_since(l) >= Duration::from_millis(50))
        {
            looked = Some(now);
            commands = subscribe_to_writer(&mut node, &rec.teleop_topic)?;
            command_type = match &commands {
                Commands::Unknown => None,
                Commands::Twist(_) => Some(ros_type(TWIST_TYPE)),
                Commands::Stamped(_) => Some(ros_type(TWIST_STAMPED_TYPE)),
            };
        }
        if let Some((v, w)) = commands.newest(&mut rec.commands_heard) {
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
                    discovery: node.discovery.describe().into(),
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
    rec.command_type = command_type;
    rec.seen = seen_on_topic(&node, &rec.teleop_topic);
    Ok(rec)
}
