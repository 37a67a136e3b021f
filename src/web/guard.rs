//! Who may talk to the view: a request carries the session's token, and a browser's request
//! comes from the view's own origin. Checked before any route runs, so a refused request
//! executes nothing.
//!
//! The token is 128 bits from the operating system's random source, in the URL the server prints
//! (so the page and its event stream, which cannot set headers, carry it in the query). The
//! `Host` header must name this server: a loopback name (`localhost`, `127.0.0.1`, `[::1]`) on
//! any port (an SSH tunnel forwards another local port to this one), a name the server was told
//! to allow (`--allow-host NAME`, and the machine's own name when it listens beyond loopback) on
//! any port, or an IP literal with this server's port. A page on another domain that rebinds its
//! name to 127.0.0.1 (DNS rebinding) sends its own name and is refused.
//! An `Origin` header, which browsers send with every cross-origin request and with every
//! `POST`, must be `http://` and the request's own `Host`; a browser that says the request is
//! cross-site (`Sec-Fetch-Site`) is refused too.

use std::net::IpAddr;

use axum::http::{HeaderMap, header};

/// Why a request was refused (the body of the 403 says it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    NoToken,
    WrongToken,
    ForeignHost,
    ForeignOrigin,
}

impl Refusal {
    pub fn text(self) -> &'static str {
        match self {
            Refusal::NoToken => "refused: no token (open the URL `advise serve` printed)",
            Refusal::WrongToken => "refused: wrong token (open the URL `advise serve` printed)",
            Refusal::ForeignHost => "refused: the Host header is not this server",
            Refusal::ForeignOrigin => "refused: a request from another origin",
        }
    }
}

/// A fresh token: 16 bytes from the OS's random source, as 32 hex digits.
pub fn new_token() -> Result<String, rand::rand_core::OsError> {
    use rand::TryRngCore;
    let mut bytes = [0u8; 16];
    rand::rngs::OsRng.try_fill_bytes(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// The value of `token=` in a query string.
fn query_token(query: Option<&str>) -> Option<&str> {
    query?.split('&').find_map(|kv| kv.strip_prefix("token="))
}

/// Equal in time independent of where they differ (the token is a secret).
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// Whether `host` (a `Host` header's value) names this server: a loopback name or one of
/// `allowed` on any port, or an IP literal with the port it listens on.
pub fn host_allowed(host: &str, port: u16, allowed: &[String]) -> bool {
    // `[::1]:8000`, `[::1]`, `name:8000`, `name` (a port left out is the scheme's: not ours).
    let (name, p) = match host.strip_prefix('[') {
        Some(rest) => match rest.split_once(']') {
            Some((name, "")) => (name, None),
            Some((name, tail)) => match tail.strip_prefix(':') {
                Some(p) => (name, Some(p)),
                None => return false,
            },
            None => return false,
        },
        None => match host.rsplit_once(':') {
            Some((name, p)) => (name, Some(p)),
            None => (host, None),
        },
    };
    let p = match p.map(str::parse::<u16>) {
        Some(Ok(p)) => Some(p),
        Some(Err(_)) => return false,
        None => None,
    };
    if name.is_empty() {
        return false;
    }
    let ip = name.parse::<IpAddr>().ok();
    if name.eq_ignore_ascii_case("localhost")
        || ip.is_some_and(|ip| ip.is_loopback())
        || allowed.iter().any(|a| a.eq_ignore_ascii_case(name))
    {
        return true;
    }
    ip.is_some() && p == Some(port)
}

/// Check one request's token, `Host`, `Origin` and `Sec-Fetch-Site`.
pub fn check(
    token: &str,
    port: u16,
    allowed: &[String],
    query: Option<&str>,
    headers: &HeaderMap,
) -> Result<(), Refusal> {
    let text = |name| headers.get(name).and_then(|v| v.to_str().ok());
    let host = text(header::HOST).ok_or(Refusal::ForeignHost)?;
    if !host_allowed(host, port, allowed) {
        return Err(Refusal::ForeignHost);
    }
    if headers.contains_key(header::ORIGIN) {
        let origin = text(header::ORIGIN).ok_or(Refusal::ForeignOrigin)?;
        if origin.strip_prefix("http://") != Some(host) {
            return Err(Refusal::ForeignOrigin);
        }
    }
    if text(header::HeaderName::from_static("sec-fetch-site")) == Some("cross-site") {
        return Err(Refusal::ForeignOrigin);
    }
    let given = query_token(query).ok_or(Refusal::NoToken)?;
    if !same(given.as_bytes(), token.as_bytes()) {
        return Err(Refusal::WrongToken);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (k, v) in pairs {
            h.insert(*k, v.parse().unwrap());
        }
        h
    }

    #[test]
    fn tokens_are_fresh_hex() {
        let (a, b) = (new_token().unwrap(), new_token().unwrap());
        assert_eq!(a.len(), 32);
        assert!(a.bytes().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
    }

    #[test]
    fn hosts_are_this_port_on_localhost_or_an_ip() {
        let none: &[String] = &[];
        assert!(host_allowed("127.0.0.1:8000", 8000, none));
        assert!(host_allowed("localhost:8000", 8000, none));
        assert!(host_allowed("[::1]:8000", 8000, none));
        // Loopback on another port: an SSH tunnel's local end.
        assert!(host_allowed("127.0.0.1:8001", 8000, none));
        assert!(host_allowed("LocalHost:9999", 8000, none));
        assert!(host_allowed("[::1]:9999", 8000, none));
        assert!(host_allowed("127.0.0.1", 8000, none));
        assert!(host_allowed("192.168.1.20:8000", 8000, none));
        assert!(!host_allowed("192.168.1.20:8001", 8000, none));
        assert!(!host_allowed("evil.example:8000", 8000, none));
        assert!(!host_allowed("localhost.evil.example:8000", 8000, none));
        assert!(!host_allowed("labpc:8000", 8000, none));
        let lab = &["labpc".to_string()];
        assert!(host_allowed("labpc:8000", 8000, lab));
        assert!(host_allowed("LABPC:8000", 8000, lab));
        assert!(!host_allowed("labpc.evil.example:8000", 8000, lab));
        for bad in ["", ":8000", "[::1", "[::1]x", "localhost:http", "[]:8000"] {
            assert!(!host_allowed(bad, 8000, lab), "{bad}");
        }
    }

    #[test]
    fn each_refusal() {
        let ok = [("host", "127.0.0.1:9")];
        let t = "abc";
        assert_eq!(check(t, 9, &[], Some("token=abc"), &headers(&ok)), Ok(()));
        assert_eq!(check(t, 9, &[], None, &headers(&ok)), Err(Refusal::NoToken));
        assert_eq!(
            check(t, 9, &[], Some("x=1&token=abd"), &headers(&ok)),
            Err(Refusal::WrongToken)
        );
        assert_eq!(
            check(
                t,
                9,
                &[],
                Some("token=abc"),
                &headers(&[("host", "rebound.example:9")])
            ),
            Err(Refusal::ForeignHost)
        );
        let foreign = [("host", "127.0.0.1:9"), ("origin", "http://evil.example")];
        assert_eq!(
            check(t, 9, &[], Some("token=abc"), &headers(&foreign)),
            Err(Refusal::ForeignOrigin)
        );
        let same_origin = [("host", "127.0.0.1:9"), ("origin", "http://127.0.0.1:9")];
        assert_eq!(
            check(t, 9, &[], Some("token=abc"), &headers(&same_origin)),
            Ok(())
        );
    }
}
