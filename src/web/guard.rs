//! Who may talk to the view: a request carries the session's token, and a browser's request
//! comes from the view's own origin. Checked before any route runs, so a refused request
//! executes nothing.
//!
//! The token is 128 bits from the operating system's random source, in the URL the server prints
//! (so the page and its event stream, which cannot set headers, carry it in the query). The
//! `Host` header must name this server's port on `localhost` or an IP literal: a page on another
//! domain that rebinds its name to 127.0.0.1 (DNS rebinding) sends its own name and is refused.
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

/// Whether `host` (a `Host` header's value) names this server: `localhost` or an IP literal,
/// with the port it listens on.
pub fn host_allowed(host: &str, port: u16) -> bool {
    let Some((name, p)) = host.rsplit_once(':') else {
        return false;
    };
    if p.parse::<u16>() != Ok(port) {
        return false;
    }
    let name = name
        .strip_prefix('[')
        .and_then(|n| n.strip_suffix(']'))
        .unwrap_or(name);
    name.eq_ignore_ascii_case("localhost") || name.parse::<IpAddr>().is_ok()
}

/// Check one request's token, `Host`, `Origin` and `Sec-Fetch-Site`.
pub fn check(
    token: &str,
    port: u16,
    query: Option<&str>,
    headers: &HeaderMap,
) -> Result<(), Refusal> {
    let text = |name| headers.get(name).and_then(|v| v.to_str().ok());
    let host = text(header::HOST).ok_or(Refusal::ForeignHost)?;
    if !host_allowed(host, port) {
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
        assert!(host_allowed("127.0.0.1:8000", 8000));
        assert!(host_allowed("localhost:8000", 8000));
        assert!(host_allowed("[::1]:8000", 8000));
        assert!(!host_allowed("127.0.0.1:8001", 8000));
        assert!(!host_allowed("evil.example:8000", 8000));
        assert!(!host_allowed("127.0.0.1", 8000));
    }

    #[test]
    fn each_refusal() {
        let ok = [("host", "127.0.0.1:9")];
        let t = "abc";
        assert_eq!(check(t, 9, Some("token=abc"), &headers(&ok)), Ok(()));
        assert_eq!(check(t, 9, None, &headers(&ok)), Err(Refusal::NoToken));
        assert_eq!(
            check(t, 9, Some("x=1&token=abd"), &headers(&ok)),
            Err(Refusal::WrongToken)
        );
        assert_eq!(
            check(
                t,
                9,
                Some("token=abc"),
                &headers(&[("host", "rebound.example:9")])
            ),
            Err(Refusal::ForeignHost)
        );
        let foreign = [("host", "127.0.0.1:9"), ("origin", "http://evil.example")];
        assert_eq!(
            check(t, 9, Some("token=abc"), &headers(&foreign)),
            Err(Refusal::ForeignOrigin)
        );
        let same_origin = [("host", "127.0.0.1:9"), ("origin", "http://127.0.0.1:9")];
        assert_eq!(
            check(t, 9, Some("token=abc"), &headers(&same_origin)),
            Ok(())
        );
    }
}
