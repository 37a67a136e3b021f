//! ROS 2 bases: a `geometry_msgs/Twist` on `cmd_vel` in, a `nav_msgs/Odometry` on `odom` out.
//!
//! This module owns everything that speaks DDS: the messages ([`msg`]), opening a node on a
//! domain with the QoS a base expects ([`Ros2Node`]), the driver that makes a ROS 2 base a
//! [`Backend`](crate::backend::Backend) with the RMP's safety rules ([`driver`]), the simulator as
//! a ROS 2 robot for rehearsals (`advise ros2-sim`, [`robot`]), and recording a person's
//! teleoperation as a demonstration ([`teleop`]). It uses `ros2-client` (RustDDS), so no ROS
//! installation is needed on either side. Reading the user's spelling (`ros2:/robot1?...`) and the
//! registry's ROS 2 entry are [`spec`]'s; task logic is the tasks'.
//!
//! QoS: commands are published reliable (what a base's `cmd_vel` subscription accepts whether it
//! asks for reliable or best-effort); odometry is read best-effort, which matches both reliable and
//! best-effort publishers.

use std::time::Duration;

use ros2_client::dds::rustdds::policy::Durability;
use ros2_client::dds::rustdds::{GUID, RTPSEntity, Topic};
use ros2_client::qos::{History, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile,
    Subscription,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

use super::BackendError;
use super::sim::SimParams;

pub mod driver;
pub mod msg;
pub mod record;
pub mod robot;
pub mod spec;

pub use driver::{Ros2Backend, Ros2StopHandle};
pub use spec::{DiscoveryRange, Ros2Kind, Ros2Spec};

/// The driver's limits and timing, from the task's simulator parameters and the spec.
#[derive(Clone, Debug, PartialEq)]
pub struct Ros2Config {
    /// Every command is clamped to these before it is published.
    pub max_speed_mps: f64,
    pub max_rot_radps: f64,
    /// The control period, s (the task's rate).
    pub period_s: f64,
    /// The watchdog publishes zero when no command came for this long, s.
    pub watchdog_s: f64,
    /// How long zero is repeated at the end of a run, s.
    pub stop_repeat_s: f64,
}

impl Ros2Config {
    /// The task's limits and rate, as the simulator and the RMP driver use them.
    pub fn for_sim(sim: &SimParams) -> Ros2Config {
        Ros2Config {
            max_speed_mps: sim.max_speed_mps,
            max_rot_radps: sim.max_rot_radps,
            period_s: sim.period_s(),
            watchdog_s: 0.25,
            stop_repeat_s: 0.5,
        }
    }

    /// A command clamped to the limits; a non-finite command is zero.
    pub fn clamp(&self, speed_mps: f64, rot_radps: f64) -> (f64, f64) {
        if speed_mps.is_finite() && rot_radps.is_finite() {
            (
                speed_mps.clamp(-self.max_speed_mps, self.max_speed_mps),
                rot_radps.clamp(-self.max_rot_radps, self.max_rot_radps),
            )
        } else {
            (0.0, 0.0)
        }
    }
}

/// A DDS participant and one ROS 2 node on the spec's domain, with typed topic helpers.
pub struct Ros2Node {
    pub context: Context,
    pub node: Node,
    pub domain_id: u16,
    /// How far discovery looks (for diagnostics).
    pub discovery: DiscoveryRange,
    /// Whether this participant is one of `advise`'s own (listed in [`OWN`]).
    own: bool,
}

/// The participants of this process that are `advise` itself (the driver's, the recorder's):
/// left out of every "discovery saw" list and never taken for a base or a teleoperation (a
/// session's backend publishes on the `cmd_vel` that `record demo` listens to).
static OWN: std::sync::Mutex<Vec<GUID>> = std::sync::Mutex::new(Vec::new());

fn own_participants() -> Vec<GUID> {
    OWN.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

impl Drop for Ros2Node {
    fn drop(&mut self) {
        if self.own {
            let me = self.context.domain_participant().guid();
            OWN.lock()
                .unwrap_or_else(|e| e.into_inner())
                .retain(|g| *g != me);
        }
    }
}

/// QoS for commands: reliable, volatile, the last 10 (the ROS 2 default publisher profile).
pub fn command_qos() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: 10 })
}

/// QoS for reading odometry: best-effort, so any publisher matches; the newest few kept.
pub fn odometry_qos() -> QosProfile {
    QosProfile::subscription_default().history(History::KeepLast { depth: 10 })
}

/// QoS for publishing odometry (the simulator as a robot): reliable, as most base drivers do.
pub fn odometry_publisher_qos() -> QosProfile {
    QosProfile::publisher_default().reliability_reliable(WhenFull::Wait(Duration::from_millis(5)))
}

fn dds_error(what: &str, e: impl std::fmt::Display) -> BackendError {
    BackendError::Ros2 {
        what: format!("{what}: {e}"),
    }
}

impl Ros2Node {
    /// Join the spec's domain as node `node_name` in the spec's namespace, as one of `advise`'s
    /// own participants ([`OWN`]).
    pub fn open(spec: &Ros2Spec, node_name: &str) -> Result<Ros2Node, BackendError> {
        Ros2Node::open_with(spec, node_name, true)
    }

    /// [`Ros2Node::open`]; `own: false` for a participant that plays another party (the
    /// simulator as a robot), which the others must discover as such.
    pub fn open_with(
        spec: &Ros2Spec,
        node_name: &str,
        own: bool,
    ) -> Result<Ros2Node, BackendError> {
        let domain_id = spec.domain().map_err(|e| BackendError::Ros2 {
            what: e.to_string(),
        })?;
        let discovery = spec.discovery_range()?;
        // RustDDS's default is SUBNET; LOCALHOST keeps its multicast and advertised locators to
        // loopback and its unicast SPDP to this host; OFF uses no interface at all.
        let builder = ros2_client::dds::rustdds::DomainParticipantBuilder::new(domain_id);
        let builder = match discovery {
            DiscoveryRange::Subnet => builder,
            DiscoveryRange::Localhost => builder
                .with_only_networks([std::net::IpAddr::V4(std::net::Ipv4Addr::LOCALHOST)])
                .same_host_loopback(true),
            DiscoveryRange::Off => builder
                .with_only_networks(Vec::<std::net::IpAddr>::new())
                .same_host_loopback(false),
        };
        let participant = builder
            .build()
            .map_err(|e| dds_error("cannot join the DDS domain", e))?;
        let context = Context::from_domain_participant(participant)
            .map_err(|e| dds_error("cannot join the DDS domain", e))?;
        let name =
            NodeName::new(&spec.namespace, node_name).map_err(|e| dds_error("bad node name", e))?;
        // No rosout: the node only drives; its diagnostics go to the user's terminal.
        let node = context
            .new_node(name, NodeOptions::new().enable_rosout(false))
            .map_err(|e| dds_error("cannot create the node", e))?;
        if own {
            OWN.lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(context.domain_participant().guid());
        }
        Ok(Ros2Node {
            context,
            node,
            domain_id,
            discovery,
            own,
        })
    }

    fn topic(
        &mut self,
        full_name: &str,
        ty: (&str, &str),
        qos: &QosProfile,
    ) -> Result<Topic, BackendError> {
        let name = Name::parse(full_name).map_err(|e| dds_error(full_name, e))?;
        self.node
            .create_topic(&name, MessageTypeName::new(ty.0, ty.1), qos)
            .map_err(|e| dds_error(&format!("cannot create the topic {full_name}"), e))
    }

    /// A publisher of `ty` on `full_name` (e.g. `/robot1/cmd_vel`).
    pub fn publisher<M: Serialize>(
        &mut self,
        full_name: &str,
        ty: (&str, &str),
        qos: QosProfile,
    ) -> Result<Publisher<M>, BackendError> {
        let topic = self.topic(full_name, ty, &qos)?;
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| dds_error(&format!("cannot publish on {full_name}"), e))
    }

    /// A subscription to `ty` on `full_name`.
    pub fn subscription<M: DeserializeOwned + 'static>(
        &mut self,
        full_name: &str,
        ty: (&str, &str),
        qos: QosProfile,
    ) -> Result<Subscription<M>, BackendError> {
        let topic = self.topic(full_name, ty, &qos)?;
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| dds_error(&format!("cannot subscribe to {full_name}"), e))
    }

    /// The ROS 2 readers and writers other participants announced (ours, and those of every
    /// other `advise` participant of this process, are left out, so a list of what discovery saw
    /// never shows our own topics as if a base were there).
    pub fn others(&self) -> Vec<Endpoint> {
        let participant = self.context.domain_participant();
        let mut mine = own_participants();
        mine.push(participant.guid());
        let ours = |g: &GUID| mine.iter().any(|m| m.prefix == g.prefix);
        let ros_name = |dds: &str| dds.strip_prefix("rt").map(str::to_string);
        let mut out: Vec<Endpoint> = participant
            .discovered_readers()
            .into_iter()
            .filter(|r| !ours(&r.reader_proxy.remote_reader_guid))
            .filter_map(|r| {
                let t = &r.subscription_topic_data;
                Some(Endpoint {
                    topic: ros_name(t.topic_name())?,
                    type_name: t.type_name().clone(),
                    reader: true,
                    transient: t
                        .qos()
                        .durability()
                        .is_some_and(|d| d != Durability::Volatile),
                })
            })
            .collect();
        out.extend(
            participant
                .discovered_writers()
                .into_iter()
                .filter(|w| !ours(&w.writer_proxy.remote_writer_guid))
                .filter_map(|w| {
                    let t = &w.publication_topic_data;
                    Some(Endpoint {
                        topic: ros_name(&t.topic_name)?,
                        type_name: t.type_name.clone(),
                        reader: false,
                        transient: t.durability.is_some_and(|d| d != Durability::Volatile),
                    })
                }),
        );
        out.sort_by(|a, b| {
            (&a.topic, &a.type_name, a.reader).cmp(&(&b.topic, &b.type_name, b.reader))
        });
        out.dedup();
        out
    }

    /// What discovery has seen of other participants so far, `name (type)`, ROS 2 topics only,
    /// sorted.
    pub fn discovered(&self) -> Vec<String> {
        let mut seen: Vec<String> = self
            .others()
            .into_iter()
            .map(|e| format!("{} ({})", e.topic, e.type_name))
            .collect();
        seen.dedup();
        seen
    }
}

/// A reader or writer another DDS participant announced.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Endpoint {
    /// The ROS 2 topic name, `/robot1/cmd_vel`.
    pub topic: String,
    /// The DDS type name, `geometry_msgs::msg::dds_::Twist_`.
    pub type_name: String,
    /// A reader (a subscription), else a writer.
    pub reader: bool,
    /// Its durability is more than volatile (`transient_local` and up): a reader asking for it
    /// does not match a volatile command publisher.
    pub transient: bool,
}
