//! Which base to drive, as the user writes it: `sim` or `rmp:HOST:PORT`.
//!
//! This module owns the parsing of a backend choice (for `--backend` on the command line and the
//! session's `backend` command) and opening it, so every place that picks a base accepts the same
//! spellings and reports the same diagnostics. It resolves a host name once, here; it never sends
//! anything (opening an RMP runs the driver's start-up sequence, in the driver).

use std::fmt;
use std::net::{SocketAddr, ToSocketAddrs};
use std::str::FromStr;

use miette::Diagnostic;
use thiserror::Error;

use super::rmp::{RmpBackend, RmpConfig};
use super::sim::{SimBackend, SimParams};
use super::{Backend, BackendError};

/// The address and port of an RMP v3 on the vendor's default network (Stanley Innovation
/// segway_v3, `segway_config_RMP_220.bash`: `SEGWAY_IP_ADDRESS`, `SEGWAY_IP_PORT_NUM`).
pub const RMP_DEFAULT_ADDRESS: &str = "10.66.171.5";
pub const RMP_DEFAULT_PORT: u16 = 8080;

/// A base to drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendSpec {
    /// The in-process simulator.
    Sim,
    /// A Segway RMP v3 (or the emulator) at this UDP address.
    Rmp(SocketAddr),
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
}

impl FromStr for BackendSpec {
    type Err = BackendSpecError;

    fn from_str(s: &str) -> Result<BackendSpec, BackendSpecError> {
        let spec = s.trim();
        if spec == "sim" {
            return Ok(BackendSpec::Sim);
        }
        let Some(addr) = spec.strip_prefix("rmp:").or_else(|| {
            // `rmp` alone, or `rmp HOST:PORT` typed with a space.
            spec.strip_prefix("rmp")
                .filter(|r| r.is_empty() || r.starts_with(' '))
        }) else {
            // Typos: one or two edits (a swap counts as one) from a backend's name.
            let sim_d = strsim::osa_distance(spec, "sim");
            let rmp_d = strsim::osa_distance(spec.split(':').next().unwrap_or(spec), "rmp");
            let help = if sim_d <= 1 || (sim_d == 2 && sim_d < rmp_d) {
                "did you mean `sim`?".to_string()
            } else if rmp_d <= 1 {
                "did you mean `rmp:HOST:PORT`?".to_string()
            } else {
                "the backends are `sim` (the simulator) and `rmp:HOST:PORT` (a Segway RMP, or `advise rmp-emulator`)".to_string()
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
