//! A ROS 2 base as the user names it: `ros2[:NAMESPACE][?OPTIONS]`, and its registration.
//!
//! `ros2` drives `/cmd_vel` and reads `/odom`; `ros2:/robot1` drives `/robot1/cmd_vel` and reads
//! `/robot1/odom`. Options follow a `?`, separated by `&`: `cmd=TOPIC` and `odom=TOPIC` (relative
//! to the namespace unless they begin with `/`), `domain=N` (else `ROS_DOMAIN_ID`, else 0),
//! `wait=SECONDS` (how long connecting waits for the first odometry, 5 s), `odom_timeout=SECONDS`
//! (odometry older than this ends a run, 0.3 s) and `stamped` (`stamped=true|false|auto`: send
//! `geometry_msgs/TwistStamped` rather than `Twist`; by default the type of the base's command
//! reader, as discovery reports it), `discovery=localhost|subnet|off` (else
//! `ROS_AUTOMATIC_DISCOVERY_RANGE`, else `subnet`: [`DiscoveryRange`]) and `peers=HOST;HOST` (else
//! `ROS_STATIC_PEERS`; only this host's addresses are reachable, see
//! [`Ros2SpecError::Ros2StaticPeers`]), and `takeover=TOPIC` (`geometry_msgs/Twist` commands on
//! that topic take over a run while they keep coming; `takeover_timeout=SECONDS` without one
//! hands back, 0.5 s). Example: `ros2:/robot1?cmd=/teleop/cmd_vel&odom_timeout=0.5&stamped`.
//!
//! This module owns [`Ros2Kind`] (the registry's ROS 2 entry), [`Ros2Spec`] and its diagnostics.
//! It sends nothing: connecting is the driver's ([`super::driver::Ros2Backend::connect`]).

use std::fmt;

use miette::Diagnostic;
use thiserror::Error;

use crate::backend::registry::BackendKind;
use crate::backend::spec::{BackendSpecError, Spec};
use crate::diag::suggest::hint;

/// The registry's ROS 2 kind.
pub struct Ros2Kind;

impl BackendKind for Ros2Kind {
    fn name(&self) -> &'static str {
        "ros2"
    }

    fn syntax(&self) -> &'static str {
        "ros2[:NAMESPACE]"
    }

    fn about(&self) -> &'static str {
        "a ROS 2 base, or `advise ros2-sim`"
    }

    fn completions(&self) -> Vec<String> {
        vec!["ros2".into(), "ros2:".into()]
    }

    fn parse(&self, spec: &str) -> Result<Box<dyn Spec>, BackendSpecError> {
        let rest = spec.strip_prefix("ros2").unwrap_or(spec);
        let rest = rest.strip_prefix(':').unwrap_or(rest);
        match parse_ros2(spec, rest) {
            Ok(s) => Ok(Box::new(s)),
            Err(e) => Err(BackendSpecError::of(e)),
        }
    }
}

/// Where a ROS 2 base is: its topics, its DDS domain and the backend's two timeouts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ros2Spec {
    /// The namespace, `/` or `/robot1` (always absolute, no trailing slash).
    pub namespace: String,
    /// The command topic as written (`cmd_vel`, or absolute `/x/cmd_vel`).
    pub cmd_topic: String,
    /// The odometry topic as written.
    pub odom_topic: String,
    /// `domain=N`; `None` means `ROS_DOMAIN_ID`, else 0.
    pub domain_id: Option<u16>,
    /// How long connecting waits for the first odometry, ms.
    pub wait_ms: u64,
    /// Odometry older than this ends a run (`advise::backend::link_lost`), ms.
    pub odom_timeout_ms: u64,
    /// `stamped`: send `TwistStamped` (`Some(true)`), `Twist` (`Some(false)`), or whichever the
    /// base's command reader takes (`None`, the default).
    pub stamped: Option<bool>,
    /// `discovery=...`; `None` means `ROS_AUTOMATIC_DISCOVERY_RANGE`, else SUBNET.
    pub discovery: Option<DiscoveryRange>,
    /// `peers=HOST;HOST`; `None` means `ROS_STATIC_PEERS`.
    pub peers: Option<Vec<String>>,
    /// `takeover=TOPIC`: a person's `Twist` commands there take over a run while they keep
    /// coming (relative to the namespace unless it begins with `/`).
    pub takeover: Option<String>,
    /// `takeover_timeout=SECONDS`: no command for this long hands back to the learner, ms.
    pub takeover_timeout_ms: u64,
}

/// How far discovery looks, as ROS 2's `ROS_AUTOMATIC_DISCOVERY_RANGE` says, in what RustDDS 0.15
/// offers: SUBNET is its default (multicast on every interface, and SPDP by unicast to this
/// host's well-known ports of participants 0-11); LOCALHOST keeps to 127.0.0.1 (the unicast
/// part only, with multicast and advertised locators on loopback); OFF finds no one (no
/// interface, no unicast).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiscoveryRange {
    Subnet,
    Localhost,
    Off,
}

impl DiscoveryRange {
    fn parse(s: &str) -> Option<DiscoveryRange> {
        match s.to_ascii_uppercase().as_str() {
            "SUBNET" | "SYSTEM_DEFAULT" => Some(DiscoveryRange::Subnet),
            "LOCALHOST" => Some(DiscoveryRange::Localhost),
            "OFF" => Some(DiscoveryRange::Off),
            _ => None,
        }
    }

    pub fn word(self) -> &'static str {
        match self {
            DiscoveryRange::Subnet => "subnet",
            DiscoveryRange::Localhost => "localhost",
            DiscoveryRange::Off => "off",
        }
    }

    /// What this range reaches, in words, for a diagnostic.
    pub fn describe(self) -> &'static str {
        match self {
            DiscoveryRange::Subnet => {
                "discovery is SUBNET: multicast on every interface (a network without a multicast route reaches no one that way), and unicast to this host's participants 0-11 on 127.0.0.1"
            }
            DiscoveryRange::Localhost => {
                "discovery is LOCALHOST: unicast to this host's participants 0-11 on 127.0.0.1 only (the base must listen on its well-known port: Cyclone DDS with `ParticipantIndex` auto, as ROS 2's LOCALHOST sets it)"
            }
            DiscoveryRange::Off => {
                "discovery is OFF (`discovery=off` or ROS_AUTOMATIC_DISCOVERY_RANGE=OFF): no other participant can be found"
            }
        }
    }
}

/// Whether `host` names this host's loopback (`localhost`, `127.x.y.z`, `::1`).
fn is_loopback(host: &str) -> bool {
    host.eq_ignore_ascii_case("localhost")
        || host
            .parse::<std::net::IpAddr>()
            .is_ok_and(|a| a.is_loopback())
}

impl Default for Ros2Spec {
    fn default() -> Self {
        Ros2Spec {
            namespace: "/".into(),
            cmd_topic: "cmd_vel".into(),
            odom_topic: "odom".into(),
            domain_id: None,
            wait_ms: 5_000,
            odom_timeout_ms: 300,
            stamped: None,
            discovery: None,
            peers: None,
            takeover: None,
            takeover_timeout_ms: 500,
        }
    }
}

impl Ros2Spec {
    /// A topic's full name: `topic` if absolute, else under the namespace.
    pub fn resolve(&self, topic: &str) -> String {
        if topic.starts_with('/') {
            topic.to_string()
        } else if self.namespace == "/" {
            format!("/{topic}")
        } else {
            format!("{}/{topic}", self.namespace)
        }
    }

    /// The full name of the command topic, e.g. `/robot1/cmd_vel`.
    pub fn cmd(&self) -> String {
        self.resolve(&self.cmd_topic)
    }

    /// The full name of the odometry topic, e.g. `/robot1/odom`.
    pub fn odom(&self) -> String {
        self.resolve(&self.odom_topic)
    }

    /// The DDS domain: `domain=N`, else `ROS_DOMAIN_ID` (as ROS 2 reads it), else 0.
    pub fn domain(&self) -> Result<u16, Ros2SpecError> {
        if let Some(d) = self.domain_id {
            return Ok(d);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => {
                parse_domain(v.trim()).ok_or_else(|| Ros2SpecError::Ros2Domain {
                    value: v.clone(),
                    from: "ROS_DOMAIN_ID".into(),
                })
            }
            _ => Ok(0),
        }
    }

    /// How far discovery looks: `discovery=`, else `ROS_AUTOMATIC_DISCOVERY_RANGE`, else SUBNET;
    /// static peers (`peers=`, else `ROS_STATIC_PEERS`) must be on this host (RustDDS 0.15 has no
    /// list of initial peers: [`Ros2SpecError::Ros2StaticPeers`]).
    pub fn discovery_range(&self) -> Result<DiscoveryRange, Ros2SpecError> {
        let peers = match &self.peers {
            Some(p) => p.clone(),
            None => split_peers(&std::env::var("ROS_STATIC_PEERS").unwrap_or_default()),
        };
        let from = if self.peers.is_some() {
            "`peers=`"
        } else {
            "ROS_STATIC_PEERS"
        };
        if let Some(peer) = peers.iter().find(|p| !is_loopback(p)) {
            return Err(Ros2SpecError::Ros2StaticPeers {
                peer: peer.clone(),
                from: from.into(),
            });
        }
        if let Some(d) = self.discovery {
            return Ok(d);
        }
        match std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE") {
            Ok(v) if !v.trim().is_empty() => DiscoveryRange::parse(v.trim())
                .ok_or_else(|| Ros2SpecError::Ros2Discovery { value: v.clone() }),
            _ => Ok(DiscoveryRange::Subnet),
        }
    }
}

/// `ROS_STATIC_PEERS`' list: addresses separated by `;` (or `,`), blanks dropped.
fn split_peers(s: &str) -> Vec<String> {
    s.split([';', ','])
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .map(str::to_string)
        .collect()
}

/// A DDS domain id usable with the default port mapping (0 to 232, as ROS 2 documents).
fn parse_domain(s: &str) -> Option<u16> {
    s.parse::<u16>().ok().filter(|d| *d <= 232)
}

/// Check a ROS 2 name (namespace or topic): letters, digits, `_` and `/`, no empty token, no
/// token starting with a digit, no `__`. Returns the offending part on failure.
fn check_ros_name(name: &str) -> Result<(), String> {
    let body = name.strip_prefix('/').unwrap_or(name);
    if body.is_empty() {
        return Err("an empty name".into());
    }
    for token in body.split('/') {
        if token.is_empty() {
            return Err("an empty part between slashes".into());
        }
        if let Some(c) = token
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
        {
            return Err(format!("the character `{c}`"));
        }
        if token.starts_with(|c: char| c.is_ascii_digit()) {
            return Err(format!("`{token}` begins with a digit"));
        }
        if token.contains("__") {
            return Err(format!("`{token}` has a double underscore"));
        }
    }
    Ok(())
}

/// A `ros2` spelling that names no ROS 2 base.
#[derive(Clone, Debug, Error, Diagnostic, PartialEq, Eq)]
pub enum Ros2SpecError {
    #[error("`{spec}`: `{name}` is not a ROS 2 name ({why})")]
    #[diagnostic(
        code(advise::backend::ros2_name),
        help(
            "ROS 2 names are letters, digits and `_` separated by `/`, e.g. `ros2:/robot1` or `ros2?cmd=/robot1/cmd_vel`"
        )
    )]
    Ros2Name {
        spec: String,
        name: String,
        why: String,
    },
    #[error("`{spec}`: unknown option `{option}`")]
    #[diagnostic(code(advise::backend::ros2_option), help("{help}"))]
    Ros2Option {
        spec: String,
        option: String,
        help: String,
    },
    #[error("`{spec}`: `{option}` wants {wants}, not `{value}`")]
    #[diagnostic(
        code(advise::backend::ros2_value),
        help("e.g. `ros2?domain=3&wait=10&odom_timeout=0.5`")
    )]
    Ros2Value {
        spec: String,
        option: String,
        value: String,
        wants: String,
    },
    #[error("{from} is `{value}`, not a DDS domain id")]
    #[diagnostic(
        code(advise::backend::ros2_domain),
        help("a ROS 2 domain id is a number from 0 to 232; unset ROS_DOMAIN_ID for domain 0")
    )]
    Ros2Domain { value: String, from: String },
    #[error("ROS_AUTOMATIC_DISCOVERY_RANGE is `{value}`, not a discovery range")]
    #[diagnostic(
        code(advise::backend::ros2_discovery),
        help("ROS 2's ranges are SUBNET (the default), LOCALHOST, OFF and SYSTEM_DEFAULT")
    )]
    Ros2Discovery { value: String },
    #[error("{from} names `{peer}`, another host, which `advise` cannot reach without multicast")]
    #[diagnostic(
        code(advise::backend::ros2_static_peers),
        help(
            "RustDDS 0.15, the DDS `advise` speaks ROS 2 through, has no list of initial peers: it finds participants by multicast on the network's interfaces and, on this host, by unicast to 127.0.0.1's well-known ports of participants 0-11. A static peer on this host (`localhost`, 127.0.0.1) is reached that way; for another host give the network a multicast route (ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET) or run `advise` on the robot's computer"
        )
    )]
    Ros2StaticPeers { peer: String, from: String },
}

/// The options a `ros2` spec takes after `?`.
const ROS2_OPTIONS: [&str; 10] = [
    "cmd",
    "odom",
    "domain",
    "wait",
    "odom_timeout",
    "stamped",
    "discovery",
    "peers",
    "takeover",
    "takeover_timeout",
];

fn parse_ros2(spec: &str, rest: &str) -> Result<Ros2Spec, Ros2SpecError> {
    let mut out = Ros2Spec::default();
    let (ns, options) = rest.split_once('?').unwrap_or((rest, ""));
    let ns = ns.trim();
    let name_err = |name: &str, why: String| Ros2SpecError::Ros2Name {
        spec: spec.to_string(),
        name: name.to_string(),
        why,
    };
    if !ns.is_empty() && ns != "/" {
        let trimmed = ns.trim_end_matches('/');
        check_ros_name(trimmed).map_err(|why| name_err(ns, why))?;
        out.namespace = if trimmed.starts_with('/') {
            trimmed.to_string()
        } else {
            format!("/{trimmed}")
        };
    }
    for option in options.split('&').filter(|o| !o.trim().is_empty()) {
        let (key, value) = option.split_once('=').unwrap_or((option, ""));
        let (key, value) = (key.trim(), value.trim());
        let bad_value = |wants: &str| Ros2SpecError::Ros2Value {
            spec: spec.to_string(),
            option: key.to_string(),
            value: value.to_string(),
            wants: wants.to_string(),
        };
        // Seconds, positive and at most an hour, kept as milliseconds.
        let seconds = |v: &str| -> Option<u64> {
            v.parse::<f64>()
                .ok()
                .filter(|s| s.is_finite() && *s > 0.0 && *s <= 3600.0)
                .map(|s| ((s * 1000.0).round() as u64).max(1))
        };
        match key {
            "cmd" | "odom" => {
                check_ros_name(value).map_err(|why| name_err(value, why))?;
                if key == "cmd" {
                    out.cmd_topic = value.to_string();
                } else {
                    out.odom_topic = value.to_string();
                }
            }
            "takeover" => {
                check_ros_name(value).map_err(|why| name_err(value, why))?;
                out.takeover = Some(value.to_string());
            }
            "takeover_timeout" => {
                out.takeover_timeout_ms =
                    seconds(value).ok_or_else(|| bad_value("seconds, up to 3600"))?
            }
            "domain" => {
                out.domain_id = Some(
                    parse_domain(value).ok_or_else(|| bad_value("a domain id from 0 to 232"))?,
                )
            }
            "wait" => {
                out.wait_ms = seconds(value).ok_or_else(|| bad_value("seconds, up to 3600"))?
            }
            "odom_timeout" => {
                out.odom_timeout_ms =
                    seconds(value).ok_or_else(|| bad_value("seconds, up to 3600"))?
            }
            "stamped" => {
                out.stamped = match value {
                    "" | "true" => Some(true),
                    "false" => Some(false),
                    "auto" => None,
                    _ => return Err(bad_value("`true`, `false` or `auto`")),
                }
            }
            "discovery" => {
                out.discovery = Some(
                    DiscoveryRange::parse(value)
                        .ok_or_else(|| bad_value("`localhost`, `subnet` or `off`"))?,
                )
            }
            "peers" => {
                let peers = split_peers(value);
                if let Some(peer) = peers.iter().find(|p| !is_loopback(p)) {
                    return Err(Ros2SpecError::Ros2StaticPeers {
                        peer: peer.clone(),
                        from: format!("`{spec}`"),
                    });
                }
                out.peers = Some(peers);
            }
            _ => {
                let help = hint(key, "options", &ROS2_OPTIONS);
                return Err(Ros2SpecError::Ros2Option {
                    spec: spec.to_string(),
                    option: key.to_string(),
                    help,
                });
            }
        }
    }
    Ok(out)
}

/// As the user writes it: `ros2:/robot1?cmd=/teleop/cmd_vel` (only the options not at their
/// defaults).
impl fmt::Display for Ros2Spec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self;
        let d = Ros2Spec::default();
        write!(f, "ros2:{}", r.namespace)?;
        let mut options = Vec::new();
        if r.cmd_topic != d.cmd_topic {
            options.push(format!("cmd={}", r.cmd_topic));
        }
        if r.odom_topic != d.odom_topic {
            options.push(format!("odom={}", r.odom_topic));
        }
        if let Some(id) = r.domain_id {
            options.push(format!("domain={id}"));
        }
        if r.wait_ms != d.wait_ms {
            options.push(format!("wait={}", r.wait_ms as f64 / 1000.0));
        }
        if r.odom_timeout_ms != d.odom_timeout_ms {
            options.push(format!(
                "odom_timeout={}",
                r.odom_timeout_ms as f64 / 1000.0
            ));
        }
        match r.stamped {
            Some(true) => options.push("stamped".into()),
            Some(false) => options.push("stamped=false".into()),
            None => {}
        }
        if let Some(d) = r.discovery {
            options.push(format!("discovery={}", d.word()));
        }
        if let Some(p) = &r.peers {
            options.push(format!("peers={}", p.join(";")));
        }
        if let Some(t) = &r.takeover {
            options.push(format!("takeover={t}"));
        }
        if r.takeover_timeout_ms != d.takeover_timeout_ms {
            options.push(format!(
                "takeover_timeout={}",
                r.takeover_timeout_ms as f64 / 1000.0
            ));
        }
        if !options.is_empty() {
            write!(f, "?{}", options.join("&"))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::BackendSpec;

    fn ros2(spec: &str) -> Ros2Spec {
        let s: BackendSpec = spec.parse().unwrap();
        s.get::<Ros2Spec>().unwrap().clone()
    }

    #[test]
    fn a_takeover_topic_is_read_and_written_back() {
        let r = ros2("ros2:/robot1?takeover=joy/cmd_vel&takeover_timeout=0.25");
        assert_eq!(r.takeover.as_deref(), Some("joy/cmd_vel"));
        assert_eq!(
            r.resolve(r.takeover.as_deref().unwrap()),
            "/robot1/joy/cmd_vel"
        );
        assert_eq!(r.takeover_timeout_ms, 250);
        assert_eq!(
            r.to_string(),
            "ros2:/robot1?takeover=joy/cmd_vel&takeover_timeout=0.25"
        );
        assert_eq!(ros2("ros2").takeover, None);
        assert!(matches!(
            error("ros2?takeover=a b"),
            Ros2SpecError::Ros2Name { .. }
        ));
        assert!(matches!(
            error("ros2?takeover_timeout=0"),
            Ros2SpecError::Ros2Value { .. }
        ));
    }

    fn error(spec: &str) -> Ros2SpecError {
        let e = spec.parse::<BackendSpec>().unwrap_err();
        e.downcast_ref::<Ros2SpecError>().unwrap().clone()
    }

    #[test]
    fn parses_ros2_spellings() {
        let r = ros2("ros2");
        assert_eq!(r, Ros2Spec::default());
        assert_eq!((r.cmd(), r.odom()), ("/cmd_vel".into(), "/odom".into()));
        let r = ros2("ros2:/robot1");
        assert_eq!(
            (r.cmd(), r.odom()),
            ("/robot1/cmd_vel".into(), "/robot1/odom".into())
        );
        let spec =
            "ros2:robot1/?cmd=/teleop/cmd_vel&odom=wheel_odom&domain=7&wait=0.5&odom_timeout=1";
        let r = ros2(spec);
        assert_eq!(
            (r.cmd(), r.odom(), r.domain(), r.wait_ms, r.odom_timeout_ms),
            (
                "/teleop/cmd_vel".into(),
                "/robot1/wheel_odom".into(),
                Ok(7),
                500,
                1000
            )
        );
        assert_eq!(
            r.to_string(),
            "ros2:/robot1?cmd=/teleop/cmd_vel&odom=wheel_odom&domain=7&wait=0.5&odom_timeout=1"
        );
        assert_eq!(ros2(&r.to_string()), r);
        let r = ros2("ros2?discovery=localhost&peers=127.0.0.1;localhost");
        assert_eq!(r.discovery_range(), Ok(DiscoveryRange::Localhost));
        assert_eq!(
            r.to_string(),
            "ros2:/?discovery=localhost&peers=127.0.0.1;localhost"
        );
        assert_eq!(ros2(&r.to_string()), r);
        assert_eq!(
            ros2("ros2?discovery=OFF").discovery,
            Some(DiscoveryRange::Off)
        );
        match error("ros2?odom_timout=1") {
            Ros2SpecError::Ros2Option { help, .. } => {
                assert_eq!(help, "did you mean `odom_timeout`?")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_spellings_say_what_to_write() {
        for (spec, code) in [
            ("ros2:/robot 1", "Ros2Name"),
            ("ros2:/1robot", "Ros2Name"),
            ("ros2://x", "Ros2Name"),
            ("ros2?cmd=a//b", "Ros2Name"),
            ("ros2?speed=1", "Ros2Option"),
            ("ros2?domain=300", "Ros2Value"),
            ("ros2?wait=-1", "Ros2Value"),
            ("ros2?odom_timeout=soon", "Ros2Value"),
            ("ros2?discovery=lan", "Ros2Value"),
            ("ros2?peers=192.168.1.5", "Ros2StaticPeers"),
            ("ros2?peers=localhost;robot.local", "Ros2StaticPeers"),
        ] {
            let e = error(spec);
            assert!(format!("{e:?}").starts_with(code), "{spec}: {e:?}");
        }
    }
}
