//! Which base to drive, as the user writes it: `sim`, `rmp:HOST:PORT` or `ros2[:NAMESPACE][?OPTIONS]`.
//!
//! This module owns the parsing of a backend choice (for `--backend` on the command line and the
//! session's `backend` command) and opening it, so every place that picks a base accepts the same
//! spellings and reports the same diagnostics. It resolves a host name once, here; it never sends
//! anything (opening an RMP runs the driver's start-up sequence, in the driver; opening a ROS 2
//! base waits for its odometry, in the ROS 2 driver).
//!
//! A ROS 2 base: `ros2` drives `/cmd_vel` and reads `/odom`; `ros2:/robot1` drives
//! `/robot1/cmd_vel` and reads `/robot1/odom`. Options follow a `?`, separated by `&`:
//! `cmd=TOPIC` and `odom=TOPIC` (relative to the namespace unless they begin with `/`),
//! `domain=N` (else `ROS_DOMAIN_ID`, else 0), `wait=SECONDS` (how long connecting waits for the
//! first odometry, 5 s), `odom_timeout=SECONDS` (odometry older than this ends a run, 0.3 s) and
//! `stamped` (`stamped=true|false|auto`: send `geometry_msgs/TwistStamped` rather than `Twist`;
//! by default the type of the base's command reader, as discovery reports it).
//! Example: `ros2:/robot1?cmd=/teleop/cmd_vel&odom_timeout=0.5&stamped`.

use std::fmt;
use std::net::{SocketAddr, ToSocketAddrs};
use std::str::FromStr;

use miette::Diagnostic;
use thiserror::Error;

use super::rmp::{RmpBackend, RmpConfig};
use super::ros2::{Ros2Backend, Ros2Config};
use super::sim::{SimBackend, SimParams};
use super::{Backend, BackendError};

/// The address and port of an RMP v3 on the vendor's default network (Stanley Innovation
/// segway_v3, `segway_config_RMP_220.bash`: `SEGWAY_IP_ADDRESS`, `SEGWAY_IP_PORT_NUM`).
pub const RMP_DEFAULT_ADDRESS: &str = "10.66.171.5";
pub const RMP_DEFAULT_PORT: u16 = 8080;

/// A base to drive.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BackendSpec {
    /// The in-process simulator.
    Sim,
    /// A Segway RMP v3 (or the emulator) at this UDP address.
    Rmp(SocketAddr),
    /// A ROS 2 base (or `advise ros2-sim`): `cmd_vel` in, `odom` out.
    Ros2(Ros2Spec),
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
    pub fn domain(&self) -> Result<u16, BackendSpecError> {
        if let Some(d) = self.domain_id {
            return Ok(d);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => {
                parse_domain(v.trim()).ok_or_else(|| BackendSpecError::Ros2Domain {
                    value: v.clone(),
                    from: "ROS_DOMAIN_ID".into(),
                })
            }
            _ => Ok(0),
        }
    }
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

/// A backend spelling that names no base.
#[derive(Debug, Error, Diagnostic, PartialEq, Eq)]
pub enum BackendSpecError {
    #[error("unknown backend `{spec}`")]
    #[diagnostic(code(advise::backend::unknown), help("{help}"))]
    Unknown { spec: String, help: String },
    #[error("`{spec}`: an RMP address needs a host and a port")]
    #[diagnostic(
        code(advise::backend::rmp_address),
        help(
            "write `rmp:HOST:PORT`, e.g. `rmp:{RMP_DEFAULT_ADDRESS}:{RMP_DEFAULT_PORT}` (a v3 RMP's default address and port), or `rmp:127.0.0.1:PORT` for `advise rmp-emulator`"
        )
    )]
    MissingAddress { spec: String },
    #[error("`{spec}`: `{port}` is not a UDP port")]
    #[diagnostic(
        code(advise::backend::rmp_port),
        help("the port is a number from 1 to 65535, e.g. `rmp:{host}:{RMP_DEFAULT_PORT}`")
    )]
    BadPort {
        spec: String,
        host: String,
        port: String,
    },
    #[error("`{spec}`: cannot resolve the host `{host}`")]
    #[diagnostic(
        code(advise::backend::rmp_host),
        help(
            "use the base's IP address (e.g. `rmp:{RMP_DEFAULT_ADDRESS}:{RMP_DEFAULT_PORT}`), or check the name"
        )
    )]
    Unresolved {
        spec: String,
        host: String,
        detail: String,
    },
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
}

/// The options a `ros2` spec takes after `?`.
const ROS2_OPTIONS: [&str; 6] = ["cmd", "odom", "domain", "wait", "odom_timeout", "stamped"];

fn parse_ros2(spec: &str, rest: &str) -> Result<Ros2Spec, BackendSpecError> {
    let mut out = Ros2Spec::default();
    let (ns, options) = rest.split_once('?').unwrap_or((rest, ""));
    let ns = ns.trim();
    let name_err = |name: &str, why: String| BackendSpecError::Ros2Name {
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
        let bad_value = |wants: &str| BackendSpecError::Ros2Value {
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
            _ => {
                let near = ROS2_OPTIONS
                    .iter()
                    .min_by_key(|o| strsim::osa_distance(key, o))
                    .filter(|o| strsim::osa_distance(key, o) <= 2);
                let help = match near {
                    Some(o) => format!("did you mean `{o}`?"),
                    None => format!(
                        "the options are {}",
                        ROS2_OPTIONS.map(|o| format!("`{o}`")).join(", ")
                    ),
                };
                return Err(BackendSpecError::Ros2Option {
                    spec: spec.to_string(),
                    option: key.to_string(),
                    help,
                });
            }
        }
    }
    Ok(out)
}

impl FromStr for BackendSpec {
    type Err = BackendSpecError;

    fn from_str(s: &str) -> Result<BackendSpec, BackendSpecError> {
        let spec = s.trim();
        if spec == "sim" {
            return Ok(BackendSpec::Sim);
        }
        if let Some(rest) = spec.strip_prefix("ros2")
            && (rest.is_empty() || rest.starts_with([':', '?']))
        {
            let rest = rest.strip_prefix(':').unwrap_or(rest);
            return parse_ros2(spec, rest).map(BackendSpec::Ros2);
        }
        let Some(addr) = spec.strip_prefix("rmp:").or_else(|| {
            // `rmp` alone, or `rmp HOST:PORT` typed with a space.
            spec.strip_prefix("rmp")
                .filter(|r| r.is_empty() || r.starts_with(' '))
        }) else {
            // Typos: one or two edits (a swap counts as one) from a backend's name.
            let sim_d = strsim::osa_distance(spec, "sim");
            let rmp_d = strsim::osa_distance(spec.split(':').next().unwrap_or(spec), "rmp");
            let ros2_d =
                strsim::osa_distance(spec.split([':', '?']).next().unwrap_or(spec), "ros2");
            let help = if sim_d <= 1 || (sim_d == 2 && sim_d < rmp_d) {
                "did you mean `sim`?".to_string()
            } else if rmp_d <= 1 {
                "did you mean `rmp:HOST:PORT`?".to_string()
            } else if ros2_d <= 1 || spec.starts_with("ros") {
                "did you mean `ros2` (or `ros2:NAMESPACE`)?".to_string()
            } else {
                "the backends are `sim` (the simulator), `rmp:HOST:PORT` (a Segway RMP, or `advise rmp-emulator`) and `ros2[:NAMESPACE]` (a ROS 2 base, or `advise ros2-sim`)".to_string()
            };
            return Err(BackendSpecError::Unknown {
                spec: spec.to_string(),
                help,
            });
        };
        let addr = addr.trim();
        let missing = || BackendSpecError::MissingAddress {
            spec: spec.to_string(),
        };
        if addr.is_empty() {
            return Err(missing());
        }
        // `[v6]:port` or `host:port`; the port is after the last colon.
        let (host, port) = match addr.rsplit_once(':') {
            Some((h, p)) if !h.is_empty() && (!h.contains(':') || h.starts_with('[')) => (h, p),
            _ => return Err(missing()),
        };
        let port_num: u16 =
            port.parse()
                .ok()
                .filter(|p| *p != 0)
                .ok_or_else(|| BackendSpecError::BadPort {
                    spec: spec.to_string(),
                    host: host.to_string(),
                    port: port.to_string(),
                })?;
        let bare = host.trim_start_matches('[').trim_end_matches(']');
        let resolved = (bare, port_num)
            .to_socket_addrs()
            .map_err(|e| BackendSpecError::Unresolved {
                spec: spec.to_string(),
                host: host.to_string(),
                detail: e.to_string(),
            })?
            // A name may resolve to both families; the RMP speaks IPv4.
            .min_by_key(|a| !a.is_ipv4())
            .ok_or_else(|| BackendSpecError::Unresolved {
                spec: spec.to_string(),
                host: host.to_string(),
                detail: "no address".into(),
            })?;
        Ok(BackendSpec::Rmp(resolved))
    }
}

impl fmt::Display for BackendSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BackendSpec::Sim => f.write_str("sim"),
            BackendSpec::Rmp(a) => write!(f, "rmp:{a}"),
            BackendSpec::Ros2(r) => {
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
                if !options.is_empty() {
                    write!(f, "?{}", options.join("&"))?;
                }
                Ok(())
            }
        }
    }
}

impl BackendSpec {
    /// Open the base: a simulator seeded with `seed`, or a link to the RMP (which runs the
    /// vendor's start-up sequence and fails with a diagnostic if nothing answers).
    pub fn open(
        &self,
        sim: &SimParams,
        seed: u64,
        rmp: &RmpConfig,
    ) -> Result<Box<dyn Backend + Send>, BackendError> {
        Ok(match self {
            BackendSpec::Sim => Box::new(SimBackend::new(sim.clone(), seed)),
            BackendSpec::Rmp(addr) => Box::new(RmpBackend::connect(*addr, rmp.clone())?),
            BackendSpec::Ros2(spec) => {
                Box::new(Ros2Backend::connect(spec, Ros2Config::for_sim(sim))?)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_spellings() {
        assert_eq!("sim".parse(), Ok(BackendSpec::Sim));
        assert_eq!(
            "rmp:127.0.0.1:8080".parse(),
            Ok(BackendSpec::Rmp("127.0.0.1:8080".parse().unwrap()))
        );
        assert_eq!(
            "rmp:[::1]:9000".parse(),
            Ok(BackendSpec::Rmp("[::1]:9000".parse().unwrap()))
        );
        assert_eq!(
            "rmp:localhost:8080".parse::<BackendSpec>().unwrap(),
            BackendSpec::Rmp("127.0.0.1:8080".parse().unwrap())
        );
        let s: BackendSpec = "rmp:10.0.0.2:8080".parse().unwrap();
        assert_eq!(s.to_string(), "rmp:10.0.0.2:8080");
    }

    #[test]
    fn parses_ros2_spellings() {
        let BackendSpec::Ros2(r) = "ros2".parse().unwrap() else {
            panic!()
        };
        assert_eq!(r, Ros2Spec::default());
        assert_eq!((r.cmd(), r.odom()), ("/cmd_vel".into(), "/odom".into()));
        let BackendSpec::Ros2(r) = "ros2:/robot1".parse().unwrap() else {
            panic!()
        };
        assert_eq!(
            (r.cmd(), r.odom()),
            ("/robot1/cmd_vel".into(), "/robot1/odom".into())
        );
        let spec =
            "ros2:robot1/?cmd=/teleop/cmd_vel&odom=wheel_odom&domain=7&wait=0.5&odom_timeout=1";
        let s: BackendSpec = spec.parse().unwrap();
        let BackendSpec::Ros2(r) = &s else { panic!() };
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
            s.to_string(),
            "ros2:/robot1?cmd=/teleop/cmd_vel&odom=wheel_odom&domain=7&wait=0.5&odom_timeout=1"
        );
        assert_eq!(s.to_string().parse::<BackendSpec>().unwrap(), s);
        match "ros2?odom_timout=1".parse::<BackendSpec>() {
            Err(BackendSpecError::Ros2Option { help, .. }) => {
                assert_eq!(help, "did you mean `odom_timeout`?")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_spellings_say_what_to_write() {
        for (spec, code) in [
            ("rmp", "MissingAddress"),
            ("rmp:", "MissingAddress"),
            ("rmp:10.0.0.2", "MissingAddress"),
            ("rmp:::1:80", "MissingAddress"),
            ("rmp:10.0.0.2:http", "BadPort"),
            ("rmp:10.0.0.2:0", "BadPort"),
            ("rmp:10.0.0.2:70000", "BadPort"),
            ("simulator", "Unknown"),
            ("robot", "Unknown"),
            ("ros2:/robot 1", "Ros2Name"),
            ("ros2:/1robot", "Ros2Name"),
            ("ros2://x", "Ros2Name"),
            ("ros2?cmd=a//b", "Ros2Name"),
            ("ros2?speed=1", "Ros2Option"),
            ("ros2?domain=300", "Ros2Value"),
            ("ros2?wait=-1", "Ros2Value"),
            ("ros2?odom_timeout=soon", "Ros2Value"),
            ("ros", "Unknown"),
        ] {
            let e = spec.parse::<BackendSpec>().unwrap_err();
            assert!(format!("{e:?}").starts_with(code), "{spec}: {e:?}");
        }
        match "smi".parse::<BackendSpec>() {
            Err(BackendSpecError::Unknown { help, .. }) => assert_eq!(help, "did you mean `sim`?"),
            other => panic!("{other:?}"),
        }
        match "rpm:1.2.3.4:5".parse::<BackendSpec>() {
            Err(BackendSpecError::Unknown { help, .. }) => {
                assert_eq!(help, "did you mean `rmp:HOST:PORT`?")
            }
            other => panic!("{other:?}"),
        }
    }
}
