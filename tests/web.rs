//! The web view's guard over loopback HTTP (issue 37): a request without the token, with a wrong
//! token, from a foreign Origin or for a foreign Host is refused with 403 and runs nothing; the
//! right one runs its statement on the shared session.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use advise::session::{Session, SessionOptions};
use advise::web::{Hub, start};

/// One HTTP/1.1 request on 127.0.0.1 (bounded by a 20 s timeout); the status line and the body.
fn request(port: u16, raw: &str) -> String {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    s.write_all(raw.as_bytes()).unwrap();
    let mut out = String::new();
    let _ = s.read_to_string(&mut out);
    out
}

fn post(port: u16, query: &str, host: &str, origin: Option<&str>, body: &str) -> String {
    let origin = origin
        .map(|o| format!("Origin: {o}\r\n"))
        .unwrap_or_default();
    request(
        port,
        &format!(
            "POST /api/statement{query} HTTP/1.1\r\nHost: {host}\r\n{origin}Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
            body.len()
        ),
    )
}

#[test]
fn refused_requests_run_nothing_and_the_token_runs_a_statement() {
    let session = Session::new(SessionOptions {
        default_demos: 1,
        ..SessionOptions::default()
    })
    .unwrap();
    let hub = Hub::new(session);
    let server = start(hub.clone(), "127.0.0.1:0".parse().unwrap()).unwrap();
    let port = server.addr.port();
    let token = server.url.split("token=").nth(1).unwrap().to_string();
    let host = format!("127.0.0.1:{port}");
    let good = format!("?token={token}");
    let stmt = "run goal 1 0 0";
    let before = hub.with(|s| s.status());
    for (query, host, origin) in [
        ("", host.as_str(), None),
        (
            "?token=0123456789abcdef0123456789abcdef",
            host.as_str(),
            None,
        ),
        (good.as_str(), host.as_str(), Some("http://evil.example")),
        (good.as_str(), "rebound.example:80", None),
    ] {
        let res = post(port, query, host, origin, stmt);
        assert!(res.starts_with("HTTP/1.1 403"), "{res}");
        assert!(hub.log().is_empty());
        assert_eq!(hub.with(|s| s.status()), before);
    }
    let big = "#".repeat(advise::web::MAX_BODY + 1);
    let res = post(port, &good, &host, None, &big);
    assert!(res.starts_with("HTTP/1.1 413"), "{res}");
    assert!(hub.log().is_empty());
    let res = post(port, &good, &host, Some(&format!("http://{host}")), stmt);
    assert!(res.starts_with("HTTP/1.1 200"), "{res}");
    assert_eq!(hub.log().len(), 1);
    assert!(hub.with(|s| s.status()).ends_with("1 executions"));
    let page = request(
        port,
        &format!("GET /{good} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"),
    );
    assert!(
        page.contains("/api/events"),
        "the page's script is embedded"
    );
}
