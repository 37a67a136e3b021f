//! A ROS 2 base as a [`Backend`]: publishes `Twist` commands, reads `Odometry`, and keeps the
//! RMP driver's safety rules.
//!
//! This module owns the link's threads and its safety state. A reader thread keeps the newest
//! odometry and when it arrived; a watchdog thread publishes zero when the session stops
//! commanding a moving base for [`Ros2Config::watchdog_s`] and repeats zero for
//! [`Ros2Config::stop_repeat_s`] after every stop. Every command is clamped before it is
//! published; odometry older than the spec's `odom_timeout` ends a run with
//! [`BackendError::LinkLost`] after commanding zero; [`Ros2StopHandle`] (Ctrl-C) commands zero
//! from any thread; dropping the backend commands zero before the threads end. A base's own
//! command timeout is never relied on. It knows nothing of tasks.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use ros2_client::{Publisher, Subscription};

use super::msg::{
    Header, ODOMETRY_TYPE, Odometry, TWIST_STAMPED_TYPE, TWIST_TYPE, Time, Twist, TwistStamped,
    dds_type_name,
};
use super::spec::Ros2Spec;
use super::{Endpoint, Ros2Config, Ros2Node, command_qos, odometry_qos};
use crate::backend::{Backend, BackendError, Base, BaseState, BaseStop};
use crate::trace::Pose;

/// How often the reader looks for odometry and the watchdog for a silent session.
const POLL: Duration = Duration::from_millis(2);
/// How often zero is repeated while a stop lasts (50 Hz).
const ZERO_EVERY: Duration = Duration::from_millis(20);
/// A base slower than this is at rest (what `reset` waits for before re-zeroing).
const REST_MPS: f64 = 0.02;
const REST_RADPS: f64 = 0.05;
/// The longest `reset` waits for a moving base to come to rest.
const REST_WAIT: Duration = Duration::from_secs(3);
/// How often a run checks that the base's command reader is still there.
const READER_CHECK: Duration = Duration::from_millis(500);
/// The least a new command publisher waits before its first command. The base's reader accepts
/// data only from writers it has discovered, and a volatile writer's samples from before that
/// are not delivered; ros2-client does not report the remote side's match without an async
/// spinner. The wait is therefore as long as the other direction took (from joining the domain
/// to the first odometry: the base discovering our subscription), and at least this.
const PUBLISHER_SETTLE: Duration = Duration::from_millis(500);
/// A jump between two odometry samples beyond what the base could drive in the time between them
/// (at twice its speed limit) plus this margin is a corrupt value, not motion.
const ODOM_JUMP_MARGIN_M: f64 = 0.5;

/// The newest odometry, as received.
#[derive(Clone, Debug)]
pub struct OdomSample {
    pub pose: Pose,
    pub speed_mps: f64,
    pub rot_radps: f64,
    pub frame_id: String,
    pub child_frame_id: String,
    /// When it arrived here (the base's clock may differ from ours, so its stamp is not used).
    pub received: Instant,
}

impl OdomSample {
    /// Why this sample cannot be a base's odometry: what [`crate::backend::odometry_fault`]
    /// refuses, or a jump from `previous` farther than the base could have driven.
    pub fn fault(&self, previous: Option<&OdomSample>, max_speed_mps: f64) -> Option<String> {
        if let Some(why) = crate::backend::odometry_fault(self.pose, self.speed_mps, self.rot_radps)
        {
            return Some(why);
        }
        let previous = previous?;
        let jump_m = (self.pose.x_m - previous.pose.x_m).hypot(self.pose.y_m - previous.pose.y_m);
        let dt_s = self
            .received
            .saturating_duration_since(previous.received)
            .as_secs_f64();
        let reach_m = 2.0 * max_speed_mps * dt_s + ODOM_JUMP_MARGIN_M;
        (jump_m > reach_m).then(|| {
            format!(
                "it jumped {jump_m:.3} m in {:.0} ms (the base reaches {reach_m:.3} m at most)",
                dt_s * 1000.0
            )
        })
    }

    pub(super) fn from_msg(o: &Odometry, received: Instant) -> OdomSample {
        OdomSample {
            pose: o.planar_pose(),
            speed_mps: o.twist.twist.linear.x,
            rot_radps: o.twist.twist.angular.z,
            frame_id: o.header.frame_id.clone(),
            child_frame_id: o.child_frame_id.clone(),
            received,
        }
    }
}

/// What the link's threads and the control loop share.
#[derive(Debug)]
struct Safety {
    latest: Option<OdomSample>,
    odom_count: u64,
    last_command_at: Instant,
    /// The last command published was not zero.
    moving: bool,
    /// Zero is repeated until then.
    zero_until: Option<Instant>,
    last_zero_at: Option<Instant>,
    /// Set by the stop handle (Ctrl-C): commands are refused until the next reset.
    stopped: Option<String>,
    /// Set by the reader on a corrupt odometry sample (the base is zeroed at once): the run ends
    /// and commands are refused until the next reset.
    bad_odometry: Option<String>,
    /// Whether the newest sample received was corrupt (a reset waits for a good one).
    last_was_bad: bool,
    watchdog_trips: u64,
    published: u64,
}

/// The command publisher, of the type the base's reader takes.
enum CommandPublisher {
    Twist(Publisher<Twist>),
    /// `TwistStamped` in the base's frame (odometry's child frame, e.g. `base_link`).
    Stamped(Publisher<TwistStamped>, String),
}

impl CommandPublisher {
    fn publish(&self, t: Twist) -> Result<(), String> {
        match self {
            CommandPublisher::Twist(p) => p.publish(t).map_err(|e| e.to_string()),
            CommandPublisher::Stamped(p, frame) => {
                let header = Header {
                    stamp: Time::now(),
                    frame_id: frame.clone(),
                };
                p.publish(TwistStamped { header, twist: t })
                    .map_err(|e| e.to_string())
            }
        }
    }
}

/// The link to the base: the command publisher and the shared safety state.
struct Link {
    safety: Mutex<Safety>,
    /// `None` until connecting has found the base's command reader.
    publisher: Mutex<Option<CommandPublisher>>,
    config: Ros2Config,
    shutdown: AtomicBool,
}

impl Link {
    fn lock(&self) -> MutexGuard<'_, Safety> {
        self.safety.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn publish(&self, t: Twist) -> Result<(), BackendError> {
        let guard = self.publisher.lock().unwrap_or_else(|e| e.into_inner());
        let Some(p) = guard.as_ref() else {
            // Nothing to command yet: connecting has not found the base's reader.
            return Ok(());
        };
        p.publish(t).map_err(|e| BackendError::Ros2 {
            what: format!("cannot publish a command: {e}"),
        })?;
        drop(guard);
        self.lock().published += 1;
        Ok(())
    }

    /// Publish zero now and keep repeating it for the stop's length (by the watchdog thread).
    fn zero_now(&self) {
        let now = Instant::now();
        {
            let mut s = self.lock();
            s.moving = false;
            s.zero_until = Some(now + Duration::from_secs_f64(self.config.stop_repeat_s));
            s.last_zero_at = Some(now);
        }
        // A failed publish is retried by the repeats.
        let _ = self.publish(Twist::ZERO);
    }

    /// Take one odometry sample. A corrupt one (see [`OdomSample::fault`]) is never used: the
    /// base is zeroed here, on the reader's thread within a poll of its arrival, rather than a
    /// control period later, and the run is ended by the next `step` or `command`.
    fn receive(&self, sample: OdomSample) {
        let fault = {
            let mut s = self.lock();
            s.odom_count += 1;
            let fault = sample.fault(s.latest.as_ref(), self.config.max_speed_mps);
            s.last_was_bad = fault.is_some();
            match &fault {
                Some(why) => {
                    if s.bad_odometry.is_none() {
                        s.bad_odometry = Some(why.clone());
                    }
                }
                None => s.latest = Some(sample),
            }
            fault.is_some()
        };
        if fault {
            self.zero_now();
        }
    }

    /// One watchdog round: repeat zero while a stop lasts; stop a base the session left moving.
    fn watch(&self) {
        let now = Instant::now();
        let (repeat, trip) = {
            let mut s = self.lock();
            let repeat = s.zero_until.is_some_and(|u| now < u)
                && s.last_zero_at.is_none_or(|z| now - z >= ZERO_EVERY);
            if repeat {
                s.last_zero_at = Some(now);
            }
            let trip = s.moving
                && now - s.last_command_at > Duration::from_secs_f64(self.config.watchdog_s);
            if trip {
                s.watchdog_trips += 1;
            }
            (repeat, trip)
        };
        if trip {
            self.zero_now();
        } else if repeat {
            let _ = self.publish(Twist::ZERO);
        }
    }
}

/// Stops the base from any thread (a Ctrl-C handler): zero now, and commands are refused until
/// the next reset.
#[derive(Clone)]
pub struct Ros2StopHandle {
    link: Arc<Link>,
}

impl std::fmt::Debug for Ros2StopHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Ros2StopHandle")
    }
}

impl Ros2StopHandle {
    pub fn stop(&self) {
        self.link.lock().stopped = Some("interrupted (Ctrl-C)".into());
        self.link.zero_now();
    }
}

/// How many messages went each way and how often the watchdog stopped the base.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ros2Counts {
    pub odometry: u64,
    pub commands: u64,
    pub watchdog_trips: u64,
}

/// A ROS 2 base driven at the task's rate (see the module docs).
pub struct Ros2Backend {
    spec: Ros2Spec,
    config: Ros2Config,
    link: Arc<Link>,
    threads: Vec<JoinHandle<()>>,
    /// `(odometry where the run began, the start pose it stands for)`.
    frame: Option<(Pose, Pose)>,
    t0: Instant,
    next_deadline: Instant,
    frames: (String, String),
    domain_id: u16,
    /// The command type the base's reader takes (`Twist` or `TwistStamped`).
    command_type: (&'static str, &'static str),
    /// When the run last found the base's command reader.
    reader_seen: Instant,
    /// `takeover=TOPIC`: the person's commands that take over a run.
    takeover: Option<Arc<Mutex<Subscription<Twist>>>>,
    // Last: the node outlives the threads that use its publisher and subscription.
    _node: Ros2Node,
}

impl std::fmt::Debug for Ros2Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Backend")
            .field("spec", &self.spec)
            .field("frames", &self.frames)
            .field("domain_id", &self.domain_id)
            .finish_non_exhaustive()
    }
}

impl Ros2Backend {
    /// Join the domain, publish on the command topic, subscribe to odometry, and wait (the spec's
    /// `wait`) for the first odometry message; without one, the diagnostic names the topic, the
    /// domain and what discovery saw.
    pub fn connect(spec: &Ros2Spec, config: Ros2Config) -> Result<Ros2Backend, BackendError> {
        let mut node = Ros2Node::open(spec, "advise")?;
        let subscription: Subscription<Odometry> =
            node.subscription(&spec.odom(), ODOMETRY_TYPE, odometry_qos())?;
        let now = Instant::now();
        let link = Arc::new(Link {
            safety: Mutex::new(Safety {
                latest: None,
                odom_count: 0,
                last_command_at: now,
                moving: false,
                zero_until: None,
                last_zero_at: None,
                stopped: None,
                bad_odometry: None,
                last_was_bad: false,
                watchdog_trips: 0,
                published: 0,
            }),
            publisher: Mutex::new(None),
            config: config.clone(),
            shutdown: AtomicBool::new(false),
        });
        let reader = {
            let link = link.clone();
            std::thread::Builder::new()
                .name("ros2-odom".into())
                .spawn(move || {
                    while !link.shutdown.load(Ordering::Relaxed) {
                        let mut n = 0;
                        // Bounded: a flood cannot keep this loop from checking `shutdown`.
                        while n < 1000 {
                            match subscription.take() {
                                Ok(Some((o, _))) => {
                                    n += 1;
                                    link.receive(OdomSample::from_msg(&o, Instant::now()));
                                }
                                // An undecodable sample is skipped; silence shows as staleness.
                                Ok(None) | Err(_) => break,
                            }
                        }
                        std::thread::sleep(POLL);
                    }
                })?
        };
        let watchdog = {
            let link = link.clone();
            std::thread::Builder::new()
                .name("ros2-watchdog".into())
                .spawn(move || {
                    while !link.shutdown.load(Ordering::Relaxed) {
                        link.watch();
                        std::thread::sleep(POLL);
                    }
                })?
        };
        let mut backend = Ros2Backend {
            spec: spec.clone(),
            config,
            link,
            threads: vec![reader, watchdog],
            frame: None,
            t0: now,
            next_deadline: now,
            frames: (String::new(), String::new()),
            domain_id: node.domain_id,
            command_type: TWIST_TYPE,
            reader_seen: now,
            takeover: None,
            _node: node,
        };
        if let Some(topic) = &spec.takeover {
            let sub: Subscription<Twist> =
                backend
                    ._node
                    .subscription(&spec.resolve(topic), TWIST_TYPE, odometry_qos())?;
            backend.takeover = Some(Arc::new(Mutex::new(sub)));
        }
        let wait = Duration::from_millis(spec.wait_ms);
        // How long the first odometry took: the base discovering our subscription.
        let odometry_after = loop {
            if let Some(o) = backend.link.lock().latest.clone() {
                backend.frames = (o.frame_id, o.child_frame_id);
                break now.elapsed();
            }
            if now.elapsed() >= wait {
                if let Some(what) = backend.link.lock().bad_odometry.clone() {
                    return Err(BackendError::BadOdometry {
                        topic: spec.odom(),
                        what,
                    });
                }
                let discovered = backend._node.discovered();
                return Err(BackendError::NoOdometry {
                    topic: spec.odom(),
                    domain_id: backend.domain_id,
                    waited_ms: spec.wait_ms,
                    discovered: if discovered.is_empty() {
                        "nothing".into()
                    } else {
                        discovered.join(", ")
                    },
                    discovery: backend._node.discovery.describe().into(),
                });
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        backend.command_type = backend.find_command_reader(wait)?;
        let publisher = if backend.command_type == TWIST_STAMPED_TYPE {
            CommandPublisher::Stamped(
                backend
                    ._node
                    .publisher(&spec.cmd(), TWIST_STAMPED_TYPE, command_qos())?,
                backend.frames.1.clone(),
            )
        } else {
            CommandPublisher::Twist(backend._node.publisher(
                &spec.cmd(),
                TWIST_TYPE,
                command_qos(),
            )?)
        };
        *backend
            .link
            .publisher
            .lock()
            .unwrap_or_else(|e| e.into_inner()) = Some(publisher);
        std::thread::sleep(odometry_after.clamp(PUBLISHER_SETTLE, wait.max(PUBLISHER_SETTLE)));
        backend.reader_seen = Instant::now();
        Ok(backend)
    }

    /// The other participants' readers of the command topic.
    fn command_readers(&self) -> Vec<Endpoint> {
        let topic = self.spec.cmd();
        self._node
            .others()
            .into_iter()
            .filter(|e| e.reader && e.topic == topic)
            .collect()
    }

    /// Wait (at most `wait`) until a reader of the command topic that our publisher matches is
    /// discovered, and say which type it takes: the spec's `stamped`, else the reader's. Without
    /// one, the diagnostic says what the readers that were found want instead, or where readers
    /// of commands are, so commands never go where no one reads them.
    fn find_command_reader(
        &self,
        wait: Duration,
    ) -> Result<(&'static str, &'static str), BackendError> {
        let wanted: &[(&str, &str)] = match self.spec.stamped {
            Some(true) => &[TWIST_STAMPED_TYPE],
            Some(false) => &[TWIST_TYPE],
            None => &[TWIST_TYPE, TWIST_STAMPED_TYPE],
        };
        let began = Instant::now();
        loop {
            let readers = self.command_readers();
            for ty in wanted {
                let name = dds_type_name(*ty);
                if readers.iter().any(|r| r.type_name == name && !r.transient) {
                    return Ok(*ty);
                }
            }
            if began.elapsed() >= wait {
                return Err(BackendError::NoCommandReader {
                    topic: self.spec.cmd(),
                    domain_id: self.domain_id,
                    waited_ms: wait.as_millis() as u64,
                    why: self.why_no_reader(&readers),
                });
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Why none of `readers` (the command topic's) takes our commands, in words.
    fn why_no_reader(&self, readers: &[Endpoint]) -> String {
        let twist = dds_type_name(TWIST_TYPE);
        let stamped = dds_type_name(TWIST_STAMPED_TYPE);
        let mut why = Vec::new();
        for r in readers {
            if r.transient {
                why.push(format!(
                    "a reader of {} asks for transient_local durability, which a command publisher does not offer (a base joining late would get stale commands): make its cmd_vel subscription volatile",
                    r.type_name
                ));
            } else if r.type_name == stamped && self.spec.stamped == Some(false) {
                why.push(
                    "a reader takes TwistStamped: drop `stamped=false` (or use `?stamped`)".into(),
                );
            } else if r.type_name == twist && self.spec.stamped == Some(true) {
                why.push("a reader takes Twist: drop `?stamped`".into());
            } else if r.type_name != twist && r.type_name != stamped {
                why.push(format!(
                    "a reader takes {}, not geometry_msgs Twist or TwistStamped",
                    r.type_name
                ));
            }
        }
        if readers.is_empty() {
            let elsewhere: Vec<String> = self
                ._node
                .others()
                .into_iter()
                .filter(|e| e.reader && (e.type_name == twist || e.type_name == stamped))
                .map(|e| e.topic)
                .collect();
            why.push(if elsewhere.is_empty() {
                format!(
                    "no other participant reads it; discovery saw: {}",
                    match self._node.discovered() {
                        d if d.is_empty() => "nothing".to_string(),
                        d => d.join(", "),
                    }
                )
            } else {
                format!(
                    "no other participant reads it, but commands are read on {}: check the namespace (`ros2:NAMESPACE`) or `?cmd=TOPIC`",
                    elsewhere.join(", ")
                )
            });
        }
        why.join("; ")
    }

    /// During a run, every [`READER_CHECK`]: the base's command reader is still there, else the
    /// base is zeroed (should it still listen) and the run ends.
    fn check_reader(&mut self) -> Result<(), BackendError> {
        if self.reader_seen.elapsed() < READER_CHECK {
            return Ok(());
        }
        let name = dds_type_name(self.command_type);
        if self
            .command_readers()
            .iter()
            .any(|r| r.type_name == name && !r.transient)
        {
            self.reader_seen = Instant::now();
            return Ok(());
        }
        self.link.zero_now();
        Err(BackendError::CommandReaderGone {
            topic: self.spec.cmd(),
        })
    }

    /// The odometry's frames: `(header.frame_id, child_frame_id)`, e.g. `(odom, base_link)`.
    pub fn frames(&self) -> (&str, &str) {
        (&self.frames.0, &self.frames.1)
    }

    pub fn domain_id(&self) -> u16 {
        self.domain_id
    }

    pub fn spec(&self) -> &Ros2Spec {
        &self.spec
    }

    /// One line for the user: topics, domain and frames.
    pub fn topics(&self) -> String {
        let takeover = match &self.spec.takeover {
            Some(t) => format!(
                "; Twist commands on {} take over a run while they keep coming",
                self.spec.resolve(t)
            ),
            None => String::new(),
        };
        format!(
            "{} commands on {}, odometry from {} (frame {}, child {}), domain {}{takeover}",
            self.command_type.1,
            self.spec.cmd(),
            self.spec.odom(),
            self.frames.0,
            self.frames.1,
            self.domain_id
        )
    }

    pub fn stop_handle(&self) -> Ros2StopHandle {
        Ros2StopHandle {
            link: self.link.clone(),
        }
    }

    pub fn counts(&self) -> Ros2Counts {
        let s = self.link.lock();
        Ros2Counts {
            odometry: s.odom_count,
            commands: s.published,
            watchdog_trips: s.watchdog_trips,
        }
    }

    /// The newest odometry, if any arrived.
    pub fn latest(&self) -> Option<OdomSample> {
        self.link.lock().latest.clone()
    }

    fn odom_timeout(&self) -> Duration {
        Duration::from_millis(self.spec.odom_timeout_ms)
    }

    /// The error that ends a run the stop handle or the odometry reader halted (the base is
    /// already zeroed), if either did.
    fn refuse_if_halted(&self) -> Result<(), BackendError> {
        let s = self.link.lock();
        if let Some(reason) = s.stopped.clone() {
            return Err(BackendError::Stopped { reason });
        }
        if let Some(what) = s.bad_odometry.clone() {
            return Err(BackendError::BadOdometry {
                topic: self.spec.odom(),
                what,
            });
        }
        Ok(())
    }

    /// The newest odometry if it is fresh and the newest sample was not corrupt; else zero is
    /// commanded and the run cannot go on.
    fn fresh(&self) -> Result<OdomSample, BackendError> {
        let (latest, bad) = {
            let s = self.link.lock();
            (
                s.latest.clone(),
                s.last_was_bad.then(|| s.bad_odometry.clone()),
            )
        };
        if let Some(what) = bad {
            self.link.zero_now();
            return Err(BackendError::BadOdometry {
                topic: self.spec.odom(),
                what: what.unwrap_or_else(|| "the newest sample is corrupt".into()),
            });
        }
        match latest {
            Some(o) if o.received.elapsed() <= self.odom_timeout() => Ok(o),
            other => {
                self.link.zero_now();
                let waited = other.map_or(self.odom_timeout(), |o| o.received.elapsed());
                Err(BackendError::LinkLost {
                    waited_ms: waited.as_millis() as u64,
                })
            }
        }
    }
}

impl Backend for Ros2Backend {
    fn name(&self) -> String {
        self.spec.to_string()
    }

    fn period_s(&self) -> f64 {
        self.config.period_s
    }

    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        {
            let mut s = self.link.lock();
            s.stopped = None;
            s.bad_odometry = None;
        }
        // A base still moving is stopped and allowed to come to rest before odometry is re-zeroed.
        let began = Instant::now();
        loop {
            let o = self.fresh()?;
            if o.speed_mps.abs() < REST_MPS && o.rot_radps.abs() < REST_RADPS {
                break;
            }
            if self
                .link
                .lock()
                .zero_until
                .is_none_or(|u| Instant::now() >= u)
            {
                self.link.zero_now();
            }
            if began.elapsed() > REST_WAIT {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let o = self.fresh()?;
        self.frame = Some((o.pose, start));
        let now = Instant::now();
        self.t0 = now;
        self.next_deadline = now + Duration::from_secs_f64(self.config.period_s);
        self.link.lock().last_command_at = now;
        Ok(BaseState {
            t_s: 0.0,
            pose: start,
            speed_mps: o.speed_mps,
            rot_radps: o.rot_radps,
        })
    }

    fn command(&mut self, speed_mps: f64, rot_radps: f64) -> Result<(), BackendError> {
        self.refuse_if_halted()?;
        let (v, w) = self.config.clamp(speed_mps, rot_radps);
        {
            let mut s = self.link.lock();
            s.last_command_at = Instant::now();
            s.moving = v != 0.0 || w != 0.0;
            if s.moving {
                s.zero_until = None;
            }
        }
        self.link.publish(Twist::planar(v, w))?;
        if speed_mps.is_finite() && rot_radps.is_finite() {
            Ok(())
        } else {
            Err(BackendError::InvalidCommand {
                speed_mps,
                rot_radps,
            })
        }
    }

    fn step(&mut self) -> Result<BaseState, BackendError> {
        crate::backend::wait_for_tick(&mut self.next_deadline, self.config.period_s);
        self.refuse_if_halted()?;
        self.check_reader()?;
        let o = self.fresh()?;
        let pose = match self.frame {
            Some((origin, start)) => crate::geometry::rezero(origin, start, o.pose),
            None => o.pose,
        };
        Ok(BaseState {
            t_s: self.t0.elapsed().as_secs_f64(),
            pose,
            speed_mps: o.speed_mps,
            rot_radps: o.rot_radps,
        })
    }

    /// Zero, repeated for [`Ros2Config::stop_repeat_s`] before returning.
    fn stop(&mut self) -> Result<(), BackendError> {
        self.link.zero_now();
        std::thread::sleep(Duration::from_secs_f64(self.config.stop_repeat_s));
        Ok(())
    }
}

/// What the session holds: the topics said on connecting, the Ctrl-C stop from any thread.
impl Base for Ros2Backend {
    fn describe(&self) -> Option<String> {
        Some(format!(
            "{}; `run` drives it, Ctrl-C stops it",
            self.topics()
        ))
    }

    fn remote_stop(&self) -> Option<BaseStop> {
        let handle = self.stop_handle();
        Some(BaseStop::new(move || handle.stop()))
    }

    fn stop_now(&mut self) -> String {
        match self.stop() {
            Ok(()) => format!("{} stopped (zero commanded for half a second)", self.name()),
            Err(e) => format!("{} was told to stop but: {e}", self.name()),
        }
    }

    fn takeover_commands(&mut self) -> Option<Box<dyn crate::backend::teleop::Commands>> {
        let sub = self.takeover.clone()?;
        let mut topic = TopicTakeover {
            sub,
            held: None,
            timeout: Duration::from_millis(self.spec.takeover_timeout_ms),
        };
        // Commands from before the run are not a person taking it over.
        topic.drain();
        Some(Box::new(topic))
    }
}

/// A person's `Twist` commands on the takeover topic: they drive while they keep coming, and a
/// pause longer than the timeout hands back.
struct TopicTakeover {
    sub: Arc<Mutex<Subscription<Twist>>>,
    /// The newest command and when it came.
    held: Option<(Instant, (f64, f64))>,
    timeout: Duration,
}

impl TopicTakeover {
    /// The newest command waiting, if any (bounded: a flood cannot hold up the control loop).
    fn drain(&mut self) -> Option<Twist> {
        let sub = self.sub.lock().unwrap_or_else(|e| e.into_inner());
        let mut last = None;
        for _ in 0..1000 {
            match sub.take() {
                Ok(Some((m, _))) => last = Some(m),
                Ok(None) | Err(_) => break,
            }
        }
        last
    }
}

impl crate::backend::teleop::Commands for TopicTakeover {
    fn command(&mut self, _now: (f64, f64)) -> Option<(f64, f64)> {
        if let Some(t) = self.drain() {
            self.held = Some((Instant::now(), (t.linear.x, t.angular.z)));
        }
        match self.held {
            Some((at, c)) if at.elapsed() <= self.timeout => Some(c),
            _ => {
                self.held = None;
                None
            }
        }
    }
}

impl Drop for Ros2Backend {
    /// Zero first, repeated while the watchdog thread still runs, then the threads end.
    fn drop(&mut self) {
        self.link.zero_now();
        std::thread::sleep(Duration::from_secs_f64(self.config.stop_repeat_s));
        self.link.shutdown.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}
/// A ROS 2 spec connects this driver (here, beside the driver, so that the spec's reading does
/// not reach for the driver: issue 50).
impl crate::backend::spec::Spec for Ros2Spec {
    /// Join the domain and wait (the spec's `wait`) for the base's odometry.
    fn connect(
        &self,
        with: &crate::backend::spec::Connect<'_>,
    ) -> Result<Box<dyn Base>, BackendError> {
        Ok(Box::new(Ros2Backend::connect(
            self,
            super::Ros2Config::for_sim(with.sim),
        )?))
    }
}
