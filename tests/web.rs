//! The web view's guard over loopback HTTP (issue 37): a request without the token, with a wrong
//! token, from a foreign Origin or for a foreign Host is refused with 403 and runs nothing; the
//! right one runs its statement on the shared session.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use advise::session::{Session, SessionOptions};
use advise_cli::web::{Hub, Limits, start, start_allowing, start_with};

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
    let big = "#".repeat(advise_cli::web::MAX_BODY + 1);
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

/// The page through an SSH tunnel (a loopback name on another port) and by a name given with
/// `--allow-host` is served; a foreign Host, and an Origin other than the request's own Host, are
/// still refused. Over loopback only: the Host header is what a browser elsewhere would send.
#[test]
fn a_tunnel_and_allowed_host_names_open_the_view_and_foreign_ones_do_not() {
    let hub = Hub::new(session());
    let server = start_allowing(
        hub.clone(),
        "127.0.0.1:0".parse().unwrap(),
        Limits::default(),
        vec!["labpc.example".into()],
    )
    .unwrap();
    assert!(
        server.remote_urls.is_empty(),
        "loopback only: {:?}",
        server.remote_urls
    );
    let port = server.addr.port();
    let token = token_of(&server);
    let get = |host: &str, origin: Option<&str>| {
        let origin = origin
            .map(|o| format!("Origin: {o}\r\n"))
            .unwrap_or_default();
        request(
            port,
            &format!(
                "GET /api/state?token={token} HTTP/1.1\r\nHost: {host}\r\n{origin}Connection: close\r\n\r\n"
            ),
        )
    };
    let here = format!("labpc.example:{port}");
    for (host, origin) in [
        ("localhost:9999", None),
        ("localhost:9999", Some("http://localhost:9999")),
        ("127.0.0.1:9999", None),
        ("[::1]:9999", Some("http://[::1]:9999")),
        (here.as_str(), None),
        (here.as_str(), Some(format!("http://{here}").as_str())),
    ] {
        let res = get(host, origin);
        assert!(res.starts_with("HTTP/1.1 200"), "{host} {origin:?}: {res}");
    }
    let foreign = format!("evil.example:{port}");
    for (host, origin) in [
        (foreign.as_str(), None),
        ("labpc.example.evil.example:9999", None),
        ("localhost:9999", Some("http://evil.example")),
        ("localhost:9999", Some("http://localhost:9998")),
        (here.as_str(), Some("http://localhost:9999")),
    ] {
        let res = get(host, origin);
        assert!(res.starts_with("HTTP/1.1 403"), "{host} {origin:?}: {res}");
    }
}

fn session() -> Session {
    Session::new(SessionOptions {
        default_demos: 1,
        ..SessionOptions::default()
    })
    .unwrap()
}

fn token_of(server: &advise_cli::web::Server) -> String {
    server.url.split("token=").nth(1).unwrap().to_string()
}

/// The body of an HTTP response (after its headers).
fn body(res: &str) -> &str {
    res.split_once("\r\n\r\n").map_or("", |(_, b)| b)
}

/// Poll `ok` every 20 ms for at most `limit`.
fn eventually(limit: Duration, mut ok: impl FnMut() -> bool) -> bool {
    let start = std::time::Instant::now();
    while start.elapsed() < limit {
        if ok() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    ok()
}

/// Whether the server closed `s` (end of file or reset), waiting at most `limit`.
fn closed_by_server(s: &mut TcpStream, limit: Duration) -> bool {
    s.set_read_timeout(Some(limit)).unwrap();
    let mut sink = Vec::new();
    match s.read_to_end(&mut sink) {
        Ok(_) => true,
        Err(e) => !matches!(
            e.kind(),
            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
        ),
    }
}

/// Issue 47: the reply was read back as the log's last entry after the lock was released, so
/// with the REPL typing at the same time a page could get the REPL's reply and `seq`.
#[test]
fn a_pages_statement_gets_its_own_reply_while_the_repl_types() {
    let hub = Hub::new(session());
    let server = start(hub.clone(), "127.0.0.1:0".parse().unwrap()).unwrap();
    let port = server.addr.port();
    let token = token_of(&server);
    let host = format!("127.0.0.1:{port}");
    let expected = hub
        .execute("help run", "<test>", "repl", false)
        .shown
        .unwrap();
    let repl = {
        let hub = hub.clone();
        std::thread::spawn(move || {
            for _ in 0..40 {
                hub.execute("help select", "<repl>", "repl", false)
                    .shown
                    .unwrap();
            }
        })
    };
    let mut seqs = Vec::new();
    for _ in 0..40 {
        let res = post(port, &format!("?token={token}"), &host, None, "help run");
        assert!(res.starts_with("HTTP/1.1 200"), "{res}");
        let v: serde_json::Value = serde_json::from_str(body(&res)).unwrap();
        assert_eq!(v["reply"].as_str(), Some(expected.as_str()));
        seqs.push(v["seq"].as_u64().unwrap());
    }
    repl.join().unwrap();
    let log = hub.log();
    for seq in seqs {
        let entry = log.iter().find(|l| l.seq == seq).unwrap();
        assert_eq!((entry.from, entry.statement.as_str()), ("page", "help run"));
    }
}

fn small_limits() -> Limits {
    Limits {
        connections: 16,
        subscribers: 4,
        header_timeout: Duration::from_secs(2),
    }
}

/// Issue 47: 1,100 half-open connections without the token exhausted the process's file
/// descriptors; the page timed out and the REPL's `save` failed. Now the oldest connection
/// without the token makes room for a new one, and headers must come within the timeout.
#[test]
fn half_open_connections_without_the_token_leave_the_page_and_the_repl_working() {
    let hub = Hub::new(session());
    let limits = small_limits();
    let server = start_with(hub.clone(), "127.0.0.1:0".parse().unwrap(), limits).unwrap();
    let port = server.addr.port();
    let token = token_of(&server);
    let host = format!("127.0.0.1:{port}");
    let mut flood: Vec<TcpStream> = (0..4 * limits.connections)
        .map(|_| {
            let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
            s.write_all(format!("GET / HTTP/1.1\r\nHost: {host}\r\nX-Slow: ").as_bytes())
                .unwrap();
            s
        })
        .collect();
    assert!(eventually(Duration::from_secs(5), || {
        server.connections().0 <= limits.connections
    }));
    // The page gets in (its connection makes room), and the REPL works, files and all.
    let res = post(
        port,
        &format!("?token={token}"),
        &host,
        None,
        "run goal 1 0 0",
    );
    assert!(res.starts_with("HTTP/1.1 200"), "{res}");
    let dir = tempfile::tempdir().unwrap();
    let save = format!("save {}/during.json", dir.path().display());
    assert!(hub.execute(&save, "<repl>", "repl", false).shown.is_ok());
    assert!(server.connections().0 <= limits.connections);
    // Every one of the flood is closed: made room for, or out of time for its headers.
    for s in &mut flood {
        assert!(closed_by_server(s, Duration::from_secs(10)));
    }
    assert!(eventually(Duration::from_secs(5), || server
        .connections()
        .0
        == 0));
}

/// Issue 47: 4,000 event streams that never read held about 1.1 MB each, and 60 states of a log
/// of 1,000 statements of 64 KB took 66 MB each, until the process aborted. Now at most
/// `subscribers` streams stay open (a new one closes the oldest), the log's texts are cut, a
/// state carries the newest entries only and is serialized once for every request.
#[test]
fn event_streams_and_states_are_bounded_and_the_repl_keeps_working() {
    let hub = Hub::new(session());
    let limits = small_limits();
    let server = start_with(hub.clone(), "127.0.0.1:0".parse().unwrap(), limits).unwrap();
    let port = server.addr.port();
    let token = token_of(&server);
    let host = format!("127.0.0.1:{port}");
    let mut streams: Vec<TcpStream> = (0..3 * limits.subscribers)
        .map(|i| {
            let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
            s.write_all(
                format!("GET /api/events?token={token} HTTP/1.1\r\nHost: {host}\r\n\r\n")
                    .as_bytes(),
            )
            .unwrap();
            // One at a time, so which are the oldest is known.
            let open = (i + 1).min(limits.subscribers);
            assert!(eventually(Duration::from_secs(5), || {
                server.connections().1 == open && server.connections().0 == open
            }));
            s
        })
        .collect();
    assert!(eventually(Duration::from_secs(5), || {
        server.connections().1 == limits.subscribers
    }));
    let big = format!("// {}", "x".repeat(64 * 1024));
    for _ in 0..advise_cli::web::LOG_SHOWN + 50 {
        hub.execute(&big, "<repl>", "repl", false);
    }
    let kept = 2 * advise_cli::web::LOG_TEXT_KEPT + 200;
    assert!(
        hub.log()
            .iter()
            .all(|l| l.statement.len() + l.reply.len() < kept)
    );
    // The oldest streams were closed; the newest are still open.
    let newest = streams.split_off(streams.len() - limits.subscribers);
    for s in &mut streams {
        assert!(closed_by_server(s, Duration::from_secs(5)));
    }
    assert_eq!(server.connections().1, limits.subscribers);
    // Concurrent states: all answered, the same bytes, bounded by what the log keeps.
    let states: Vec<String> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..12)
            .map(|_| {
                let (host, token) = (host.clone(), token.clone());
                scope.spawn(move || {
                    request(
                        port,
                        &format!(
                            "GET /api/state?token={token} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
                        ),
                    )
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for s in &states {
        assert!(s.starts_with("HTTP/1.1 200"), "{}", &s[..s.len().min(200)]);
        assert_eq!(body(s), body(&states[0]));
    }
    let state: serde_json::Value = serde_json::from_str(body(&states[0])).unwrap();
    assert_eq!(
        state["log"].as_array().unwrap().len(),
        advise_cli::web::LOG_SHOWN
    );
    assert!(body(&states[0]).len() < advise_cli::web::LOG_SHOWN * kept + 200_000);
    // The REPL still works.
    assert!(
        hub.execute("run goal 1 0 0", "<repl>", "repl", false)
            .shown
            .is_ok()
    );
    drop(newest);
}

/// Issue 47: in `advise repl --view`, end of input while a page's statement ran left at once:
/// the statement was neither journalled nor answered. Now the REPL's end waits for it (as `quit`
/// did) and the view lets its reply out before the process leaves.
#[test]
fn end_of_input_waits_for_the_pages_statement_journals_and_answers_it() {
    use std::io::BufRead;
    use std::process::{Command, Stdio};
    let home = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(["repl", "--view", "--listen", "127.0.0.1:0", "--demos", "1"])
        .env("NO_COLOR", "1")
        .env("ADVISE_HOME", home.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let url = lines
        .by_ref()
        .take(20)
        .map_while(Result::ok)
        .find_map(|l| l.strip_prefix("view: ").map(str::to_string))
        .expect("the view's URL");
    // The rest of stdout is drained so the REPL never blocks on it.
    let drain = std::thread::spawn(move || lines.map_while(Result::ok).count());
    let (addr, token) = url
        .strip_prefix("http://")
        .unwrap()
        .split_once("/?token=")
        .unwrap();
    let port: u16 = addr.rsplit_once(':').unwrap().1.parse().unwrap();
    let host = addr.to_string();
    let statement = "load demos teacher:2000";
    let page = {
        let (token, host) = (token.to_string(), host.clone());
        std::thread::spawn(move || post(port, &format!("?token={token}"), &host, None, statement))
    };
    // Ctrl-D once the statement is under way: a state, which waits for the session's lock, is
    // not answered at once.
    let running = eventually(Duration::from_secs(30), || {
        let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(300)))
            .unwrap();
        let get = format!(
            "GET /api/state?token={token} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
        );
        s.write_all(get.as_bytes()).unwrap();
        let mut first = [0u8; 1];
        matches!(
            s.read(&mut first),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut)
        )
    });
    assert!(running, "the page's statement never held the session");
    drop(child.stdin.take());
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "advise did not end"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.success(), "{status}");
    let res = page.join().unwrap();
    assert!(res.starts_with("HTTP/1.1 200"), "{res}");
    let v: serde_json::Value = serde_json::from_str(body(&res)).unwrap();
    assert_eq!(v["ok"], true, "{v}");
    assert!(v["seq"].as_u64().is_some(), "{v}");
    let journalled = std::fs::read_dir(home.path())
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "jsonl"))
        .any(|e| {
            std::fs::read_to_string(e.path())
                .unwrap()
                .contains(statement)
        });
    assert!(journalled, "the page's statement is in the journal");
    drain.join().unwrap();
}

/// The hold-to-drive pad (issue 53) on the RMP emulator: while a page posts the pad held at 0.2
/// of the speed limit, the run is the person's and the base settles at 0.2 m/s (the page's
/// posts answered while the run holds the session); when the posts stop the learner drives
/// again; the window is kept as a takeover; a pad's post without the token is refused and a
/// value off the pad is a 400.
#[test]
fn the_pad_takes_over_a_robots_run_while_it_is_held() {
    use advise::backend::rmp::{Emulator, EmulatorConfig};
    let emu = Emulator::bind_sim(
        "127.0.0.1:0".parse().unwrap(),
        EmulatorConfig {
            init_s: 0.05,
            ..EmulatorConfig::default()
        },
        advise::backend::sim::SimParams::default(),
        0,
    )
    .unwrap();
    let session = Session::new(SessionOptions {
        default_demos: 9,
        ..SessionOptions::default()
    })
    .unwrap();
    let hub = Hub::new(session);
    hub.execute(
        &format!("backend rmp:{}", emu.addr()),
        "<test>",
        "test",
        false,
    )
    .shown
    .unwrap();
    let server = start(hub.clone(), "127.0.0.1:0".parse().unwrap()).unwrap();
    let port = server.addr.port();
    let token = token_of(&server);
    let pad = |query: &str, body: &str| {
        request(
            port,
            &format!(
                "POST /api/takeover{query} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                body.len()
            ),
        )
    };
    let good = format!("?token={token}");
    assert!(pad("", r#"{"speed":0.2}"#).starts_with("HTTP/1.1 403"));
    assert!(pad(&good, r#"{"speed":2}"#).starts_with("HTTP/1.1 400"));
    assert!(pad(&good, r#"{"sped":0.2}"#).starts_with("HTTP/1.1 400"));
    let wait_for = |for_s: f64, done: &dyn Fn() -> bool| {
        let t0 = std::time::Instant::now();
        while t0.elapsed().as_secs_f64() < for_s {
            if done() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        done()
    };
    let said = std::thread::scope(|scope| {
        let run = scope.spawn(|| hub.execute("run goal 3 1 0", "<test>", "test", false));
        assert!(
            wait_for(30.0, &|| emu.snapshot().speed_mps > 0.2),
            "{:?}",
            emu.snapshot()
        );
        // Held for 2 s, posted every 100 ms as the page does.
        let t0 = std::time::Instant::now();
        let mut settled = false;
        while t0.elapsed() < Duration::from_secs(2) {
            let res = pad(&good, r#"{"speed":0.2,"turn":0}"#);
            assert!(res.starts_with("HTTP/1.1 200"), "{res}");
            settled |= t0.elapsed() > Duration::from_millis(1500)
                && (emu.snapshot().speed_mps - 0.2).abs() < 0.03;
            std::thread::sleep(Duration::from_millis(100));
        }
        assert!(
            settled,
            "the pad did not drive the base: {:?}",
            emu.snapshot()
        );
        // Let go by going silent (a closed tab): the learner drives again, then stop the run.
        std::thread::sleep(Duration::from_millis(1000));
        hub.stop();
        run.join().unwrap()
    });
    let shown = match said.shown {
        Ok(t) | Err(t) => t,
    };
    assert!(shown.contains("the teacher drove steps"), "{shown}");
    let history = hub
        .execute("history", "<test>", "test", false)
        .shown
        .unwrap();
    assert!(history.contains("#1 takeover of execution 0"), "{history}");
    let state = hub.with(|s| s.view_json(None));
    assert!(
        state["shown"]["teacher"]
            .as_array()
            .is_some_and(|w| w.len() == 1),
        "the web view marks the window: {}",
        state["shown"]["teacher"]
    );
}
