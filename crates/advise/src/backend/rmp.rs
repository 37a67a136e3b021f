//! The Segway RMP backend: a driver for the RMP v3 UDP protocol (Stanley Innovation command set)
//! and an emulator that speaks the same protocol on loopback.
//!
//! This module owns everything RMP: [`codec`] (bytes), [`config`] (limits, timeouts, the machine
//! configuration), [`driver`] (the [`Backend`](crate::backend::Backend) that talks to a real or
//! emulated base) and [`emulator`] (a fake platform for tests and rehearsal), and here the
//! registry's RMP entry: [`RmpKind`] reads `rmp:HOST:PORT` (resolving a host name once, here) and
//! connects the driver. Tasks never see any of it: they get speeds in and odometry out, as from
//! the simulator. Nothing here may send to an address the user did not give.

pub mod codec;
pub mod config;
pub mod driver;
pub mod emulator;

use std::fmt;
use std::net::{SocketAddr, ToSocketAddrs};

use miette::Diagnostic;
use thiserror::Error;

pub use config::{EmulatorConfig, RmpConfig};
pub use driver::RmpBackend;
pub use emulator::{Emulator, EmulatorHandle};

use super::registry::BackendKind;
use super::spec::{BackendSpecError, Connect, Spec};
use super::{BackendError, Base};

/// The address and port of an RMP v3 on the vendor's default network (Stanley Innovation
/// segway_v3, `segway_config_RMP_220.bash`: `SEGWAY_IP_ADDRESS`, `SEGWAY_IP_PORT_NUM`).
pub const RMP_DEFAULT_ADDRESS: &str = "10.66.171.5";
pub const RMP_DEFAULT_PORT: u16 = 8080;

/// The registry's RMP kind: `rmp:HOST:PORT` (also `rmp HOST:PORT` on a command line).
pub struct RmpKind;

impl BackendKind for RmpKind {
    fn name(&self) -> &'static str {
        "rmp"
    }

    fn syntax(&self) -> &'static str {
        "rmp:HOST:PORT"
    }

    fn about(&self) -> &'static str {
        "a Segway RMP, or `advise rmp-emulator`"
    }

    fn completions(&self) -> Vec<String> {
        vec!["rmp:".into()]
    }

    fn claims(&self, spec: &str) -> bool {
        spec.strip_prefix("rmp")
            .is_some_and(|r| r.is_empty() || r.starts_with([':', ' ']))
    }

    fn parse(&self, spec: &str) -> Result<Box<dyn Spec>, BackendSpecError> {
        match parse_rmp(spec) {
            Ok(addr) => Ok(Box::new(RmpSpec(addr))),
            Err(e) => Err(BackendSpecError::of(e)),
        }
    }
}

/// A Segway RMP v3 (or the emulator) at this UDP address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RmpSpec(pub SocketAddr);

impl fmt::Display for RmpSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rmp:{}", self.0)
    }
}

impl Spec for RmpSpec {
    /// The vendor's start-up sequence; the base is left in standby.
    fn connect(&self, with: &Connect<'_>) -> Result<Box<dyn Base>, BackendError> {
        Ok(Box::new(RmpBackend::connect(
            self.0,
            RmpConfig::for_sim(with.sim),
        )?))
    }
}

/// An `rmp` spelling that names no RMP.
#[derive(Clone, Debug, Error, Diagnostic, PartialEq, Eq)]
pub enum RmpSpecError {
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
}

/// The address of `rmp:HOST:PORT` (or `rmp HOST:PORT`), resolved.
fn parse_rmp(spec: &str) -> Result<SocketAddr, RmpSpecError> {
    let addr = spec.strip_prefix("rmp").unwrap_or(spec);
    let addr = addr.strip_prefix(':').unwrap_or(addr).trim();
    let missing = || RmpSpecError::MissingAddress {
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
            .ok_or_else(|| RmpSpecError::BadPort {
                spec: spec.to_string(),
                host: host.to_string(),
                port: port.to_string(),
            })?;
    let bare = host.trim_start_matches('[').trim_end_matches(']');
    let unresolved = |detail: String| RmpSpecError::Unresolved {
        spec: spec.to_string(),
        host: host.to_string(),
        detail,
    };
    (bare, port_num)
        .to_socket_addrs()
        .map_err(|e| unresolved(e.to_string()))?
        // A name may resolve to both families; the RMP speaks IPv4.
        .min_by_key(|a| !a.is_ipv4())
        .ok_or_else(|| unresolved("no address".into()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::BackendSpec;

    fn rmp(spec: &str) -> SocketAddr {
        let s: BackendSpec = spec.parse().unwrap();
        s.get::<RmpSpec>().unwrap().0
    }

    #[test]
    fn parses_the_spellings() {
        assert_eq!(rmp("rmp:127.0.0.1:8080"), "127.0.0.1:8080".parse().unwrap());
        assert_eq!(rmp("rmp:[::1]:9000"), "[::1]:9000".parse().unwrap());
        assert_eq!(rmp("rmp:localhost:8080"), "127.0.0.1:8080".parse().unwrap());
        let s: BackendSpec = "rmp:10.0.0.2:8080".parse().unwrap();
        assert_eq!(s.to_string(), "rmp:10.0.0.2:8080");
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
        ] {
            let e = spec.parse::<BackendSpec>().unwrap_err();
            let e = e.downcast_ref::<RmpSpecError>().unwrap();
            assert!(format!("{e:?}").starts_with(code), "{spec}: {e:?}");
        }
    }
}
