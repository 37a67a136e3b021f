//! Hostile input to `advise lsp` (issue 31), the binary driven as a subprocess: every broken
//! frame ends in a coded diagnostic and exit code 1, with the input still open (so nothing waits
//! for bytes a `Content-Length` promised) and with a small peak memory (so nothing was allocated
//! on a `Content-Length`'s word); a whole frame that is not a message is answered with JSON-RPC's
//! error and the session goes on; a document above the server's limit gets one diagnostic.
//! Also `advise fmt` of a file that is neither an operator file nor a session script.

use std::io::{Read, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod common;

/// How long one server may take: each case ends in well under a second.
const LIMIT: Duration = Duration::from_secs(60);

/// One frame of the base protocol around `body`.
fn frame(body: &str) -> Vec<u8> {
    format!("Content-Length: {}\r\n\r\n{body}", body.len()).into_bytes()
}

fn initialize() -> Vec<u8> {
    let mut out =
        frame(r#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"capabilities":{}}}"#);
    out.extend(frame(
        r#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#,
    ));
    out
}

fn shutdown_and_exit() -> Vec<u8> {
    let mut out = frame(r#"{"jsonrpc":"2.0","id":99,"method":"shutdown"}"#);
    out.extend(frame(r#"{"jsonrpc":"2.0","method":"exit"}"#));
    out
}

/// What a run of the server showed.
struct Run {
    /// The exit code (`None`: a signal ended it, an abort say).
    code: Option<i32>,
    stdout: String,
    stderr: String,
    /// Peak resident memory, in KiB.
    max_rss_kib: i64,
}

/// Run `advise lsp` on `input`; the input is closed after it unless `keep_open` (a server that
/// waits for more fails the test at [`LIMIT`] instead of hanging it).
fn lsp(input: &[u8], keep_open: bool) -> Run {
    let cache = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_advise"))
        .arg("lsp")
        .env("NO_COLOR", "1")
        .env("XDG_CACHE_HOME", cache.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    // Written from a thread: a server that stops reading must not block the test.
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
        let _ = stdin.flush();
        if keep_open {
            std::thread::sleep(LIMIT + Duration::from_secs(5));
        }
    });
    let read = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            let _ = r.read_to_end(&mut bytes);
            String::from_utf8_lossy(&bytes).into_owned()
        })
    };
    let stdout = read(Box::new(child.stdout.take().unwrap()));
    let stderr = read(Box::new(child.stderr.take().unwrap()));
    let (code, max_rss_kib) = wait_with_rusage(&mut child);
    drop(writer); // still sleeping when kept open; it ends with the test process
    Run {
        code,
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
        max_rss_kib,
    }
}

/// Wait (at most [`LIMIT`]) for `child`; its exit code and peak resident memory (KiB).
fn wait_with_rusage(child: &mut Child) -> (Option<i32>, i64) {
    let pid = child.id() as libc::pid_t;
    let deadline = Instant::now() + LIMIT;
    loop {
        let mut status = 0;
        // SAFETY: `rusage` is plain data that wait4 fills in; `pid` is our own child.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        let got = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        if got == pid {
            let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
            return (code, usage.ru_maxrss);
        }
        assert!(
            Instant::now() < deadline,
            "advise lsp did not end within {LIMIT:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The broken frames: each ends the server with its code and exit code 1, the input still open.
#[test]
fn every_broken_frame_ends_in_a_coded_diagnostic_and_exit_code_1() {
    let with_init = |rest: &[u8]| {
        let mut v = initialize();
        v.extend(rest);
        v
    };
    let cases: Vec<(&str, Vec<u8>, &str, bool)> = vec![
        (
            "u64::MAX",
            b"Content-Length: 18446744073709551615\r\n\r\n{}".to_vec(),
            "message_too_large",
            true,
        ),
        (
            "1e18",
            b"Content-Length: 1000000000000000000\r\n\r\n".to_vec(),
            "message_too_large",
            true,
        ),
        (
            "3e9 after initialize",
            with_init(b"Content-Length: 3000000000\r\n\r\n{\"jsonrpc\""),
            "message_too_large",
            true,
        ),
        (
            "more digits than 64 bits",
            b"Content-Length: 123456789012345678901234567890\r\n\r\n".to_vec(),
            "message_too_large",
            true,
        ),
        (
            "no Content-Length",
            b"Content-Type: application/json\r\n\r\n{}".to_vec(),
            "no_content_length",
            true,
        ),
        (
            "not a number",
            b"Content-Length: twelve\r\n\r\n".to_vec(),
            "bad_content_length",
            true,
        ),
        (
            "negative",
            b"Content-Length: -1\r\n\r\n".to_vec(),
            "bad_content_length",
            true,
        ),
        (
            "two lengths",
            b"Content-Length: 2\r\nContent-Length: 3\r\n\r\n{}".to_vec(),
            "two_content_lengths",
            true,
        ),
        (
            "bare newlines",
            b"Content-Length: 2\n\n{}".to_vec(),
            "bad_header",
            true,
        ),
        (
            "no colon",
            b"Content-Length 2\r\n\r\n{}".to_vec(),
            "bad_header",
            true,
        ),
        (
            "header without end of line",
            vec![b'x'; 100_000],
            "header_too_long",
            true,
        ),
        (
            "endless header lines",
            b"X-Pad: y\r\n".repeat(10_000),
            "header_too_long",
            true,
        ),
        (
            "end inside the header",
            b"Content-Length: 52\r\n".to_vec(),
            "truncated_header",
            false,
        ),
        (
            "end inside the body",
            with_init(b"Content-Length: 100\r\n\r\n{\"jsonrpc\":\"2.0\""),
            "truncated",
            false,
        ),
        ("no input at all", Vec::new(), "closed", false),
        ("end without shutdown", initialize(), "closed", false),
        (
            "exit without shutdown",
            with_init(&frame(r#"{"jsonrpc":"2.0","method":"exit"}"#)),
            "exit_without_shutdown",
            true,
        ),
    ];
    let runs: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = cases
            .iter()
            .map(|(name, input, code, open)| s.spawn(move || (*name, *code, lsp(input, *open))))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (name, code, run) in runs {
        assert_eq!(run.code, Some(1), "{name}: {}", run.stderr);
        assert!(
            run.stderr.contains(&format!("advise::lsp::{code}")),
            "{name}: {}",
            run.stderr
        );
        assert!(!run.stderr.contains("panicked"), "{name}: {}", run.stderr);
        // Nothing the size of a promised body (3 GB, 1e18 bytes) was ever allocated.
        assert!(
            run.max_rss_kib < 200 * 1024,
            "{name}: peak {} KiB",
            run.max_rss_kib
        );
    }
}

#[test]
fn a_huge_content_length_is_refused_at_once_with_its_diagnostic() {
    let run = lsp(b"Content-Length: 3000000000\r\n\r\n", true);
    assert_eq!(run.code, Some(1));
    insta::assert_snapshot!(run.stderr, @r"
    advise::lsp::message_too_large

      × message 1 would be 3000000000 bytes, more than the 67108864 bytes `advise
      │ lsp` accepts
      help: the limit (64 MiB) is far above any operator file; check a larger file
            with `advise check FILE`
    ");
}

/// Frames whose bodies are not messages are answered as JSON-RPC says, and the session goes on
/// to a clean shutdown.
#[test]
fn bad_bodies_are_answered_and_the_session_goes_on() {
    let mut input = initialize();
    input.extend(frame("{\"jsonrpc\": \"2.0\", \"id\": 3, \"method\""));
    input.extend(b"Content-Length: 4\r\n\r\n\"\xff\xfe\"");
    input.extend(frame(r#"{"jsonrpc":"2.0","id":5,"method":7}"#));
    input.extend(frame("[]"));
    input.extend(frame(
        r#"{"jsonrpc":"2.0","id":6,"method":"textDocument/hover","params":{"textDocument":{"uri":"file:///x.adv"},"position":{"line":0,"character":0}}}"#,
    ));
    input.extend(shutdown_and_exit());
    let run = lsp(&input, false);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    for code in ["bad_json", "bad_utf8", "not_a_message"] {
        assert!(
            run.stderr.contains(&format!("advise::lsp::{code}")),
            "{}",
            run.stderr
        );
    }
    let answers = responses(&run.stdout);
    let error_of = |id: serde_json::Value| {
        answers
            .iter()
            .filter(|a| a["id"] == id)
            .map(|a| a["error"]["code"].as_i64())
            .collect::<Vec<_>>()
    };
    assert_eq!(
        error_of(serde_json::Value::Null),
        [Some(-32700), Some(-32700), Some(-32600)]
    );
    assert_eq!(error_of(5.into()), [Some(-32600)]);
    // The session went on: the hover was answered (the document is not open) and so was shutdown.
    assert_eq!(error_of(6.into()), [Some(-32602)]);
    assert!(
        answers
            .iter()
            .any(|a| a["id"] == 99 && a["result"].is_null())
    );
}

/// A document above the server's limit is not held or checked: it gets one diagnostic.
#[test]
fn a_document_over_the_limit_gets_a_diagnostic_not_an_abort() {
    let op = "operator o for positioning on action { trans = 0 }\n";
    let text = op.repeat(17 * 1024 * 1024 / op.len() + 1);
    let open = serde_json::json!({
        "jsonrpc": "2.0", "method": "textDocument/didOpen",
        "params": {"textDocument": {"uri": "file:///big.adv", "languageId": "advise", "version": 1, "text": text}},
    });
    let mut input = initialize();
    input.extend(frame(&open.to_string()));
    input.extend(shutdown_and_exit());
    let run = lsp(&input, false);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let published: Vec<_> = responses(&run.stdout)
        .into_iter()
        .filter(|m| m["method"] == "textDocument/publishDiagnostics")
        .collect();
    assert_eq!(published.len(), 1);
    let diagnostics = published[0]["params"]["diagnostics"].as_array().unwrap();
    assert_eq!(diagnostics.len(), 1);
    assert_eq!(diagnostics[0]["code"], "advise::lsp::document_too_large");
    assert!(run.max_rss_kib < 512 * 1024, "peak {} KiB", run.max_rss_kib);
}

/// The messages of the server's output, in order.
fn responses(stdout: &str) -> Vec<serde_json::Value> {
    let mut out = Vec::new();
    let mut rest = stdout;
    while let Some(at) = rest.find("Content-Length: ") {
        let after = &rest[at + "Content-Length: ".len()..];
        let (n, tail) = after.split_once("\r\n\r\n").unwrap();
        let n: usize = n.trim().parse().unwrap();
        out.push(serde_json::from_str(&tail[..n]).unwrap());
        rest = &tail[n..];
    }
    out
}

/// The issue's case: an operator file with a syntax error and one line that reads as a command.
/// `fmt` said "formatted" and rewrote it as a session script; the parse error never showed.
#[test]
fn fmt_shows_the_operator_parse_error_and_leaves_the_file_untouched() {
    let text = "operator creep for positioning on action {\n  trans *= 0.5 +\n}\n\nhistory\n";
    let out = common::Invocation {
        args: vec!["fmt".into(), "broken.adv".into()],
        files: vec![("broken.adv".into(), text.as_bytes().to_vec())],
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.adv");
    std::fs::write(&path, text).unwrap();
    let result = Command::new(env!("CARGO_BIN_EXE_advise"))
        .arg("fmt")
        .arg(&path)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(result.status.code(), Some(1));
    assert_eq!(
        std::fs::read(&path).unwrap(),
        text.as_bytes(),
        "the file was rewritten"
    );
    let run = out.run();
    assert_eq!(run.code, Some(1));
    common::masked(Some(&run.dir)).bind(|| {
        insta::assert_snapshot!(format!("{}\n{}", out.command_line(), run.text));
    });
}
