//! The protocol's base layer read by us, not by `lsp-server`: `Content-Length` framing over any
//! [`BufRead`], with every size bounded before anything is allocated.
//!
//! `lsp-server`'s reader allocates whatever `Content-Length` says before reading a byte of the
//! body (so `18446744073709551615` panicked, `1e18` aborted, and `3e9` held 2.9 GB while it
//! waited) and ends every bad frame in an uncoded "disconnected channel". Here a header is read
//! line by line within [`MAX_HEADER_BYTES`], a length above [`MAX_MESSAGE_BYTES`] is refused as
//! soon as it is read, and a body is read through `take` (so a client that promises a megabyte
//! and sends ten bytes costs ten bytes).
//!
//! Two kinds of mistakes, because the protocol can recover from one and not from the other:
//! - a broken frame ([`FrameError`]: no or a bad `Content-Length`, a header too long or not
//!   `name: value\r\n`, the input ending inside a frame) loses the frame boundaries, so nothing
//!   after it can be read: the server reports it (coded) and exits 1;
//! - a whole frame whose body is not a message ([`BodyError`]: bad UTF-8, bad JSON, JSON that is
//!   no JSON-RPC message) leaves the stream in step: JSON-RPC 2.0 says to answer it (`-32700`
//!   parse error, `-32600` invalid request, with the request's id when it can be read), so the
//!   server answers, logs the coded diagnostic on stderr and reads on.
//!
//! This module is pure (a function of the bytes read; no threads, no stdout): the fuzz target
//! `fuzz/fuzz_targets/lsp_frame.rs` runs it on arbitrary input.

use std::io::{self, BufRead, Read};

use lsp_server::{Message, Notification, Request, Response};
use miette::Diagnostic;
use thiserror::Error;

/// The largest message body accepted, in bytes (64 MiB): far above any document an editor sends
/// (the whole standard library is 30 KB), and small enough that one message in flight is modest.
pub const MAX_MESSAGE_BYTES: u64 = 64 * 1024 * 1024;

/// The most bytes a message's header may take, all its lines together (8 KiB, as web servers
/// bound theirs; the protocol's header is two short lines).
pub const MAX_HEADER_BYTES: usize = 8 * 1024;

/// How much of a header line a diagnostic quotes.
const QUOTED: usize = 60;

/// A frame that cannot be read: the frame boundaries are lost, so the connection ends.
#[derive(Debug, Error, Diagnostic)]
pub enum FrameError {
    #[error("message {message} has no `Content-Length` header (its header ends at byte {at})")]
    #[diagnostic(
        code(advise::lsp::no_content_length),
        help(
            "each message starts with `Content-Length: N\\r\\n\\r\\n` and then N bytes of JSON; is the client speaking the language server protocol?"
        )
    )]
    NoContentLength { message: u64, at: u64 },
    #[error("message {message}: `Content-Length: {value}` is not a number of bytes")]
    #[diagnostic(
        code(advise::lsp::bad_content_length),
        help("the length is written in decimal digits: `Content-Length: 52`")
    )]
    BadContentLength { message: u64, value: String },
    #[error("message {message} has two `Content-Length` headers ({first} and {second})")]
    #[diagnostic(
        code(advise::lsp::two_content_lengths),
        help("a message has one `Content-Length`")
    )]
    TwoContentLengths {
        message: u64,
        first: u64,
        second: String,
    },
    #[error(
        "message {message} would be {length} bytes, more than the {max} bytes `advise lsp` accepts"
    )]
    #[diagnostic(
        code(advise::lsp::message_too_large),
        help(
            "the limit (64 MiB) is far above any operator file; check a larger file with `advise check FILE`"
        )
    )]
    TooLarge {
        message: u64,
        /// As written (it may not even fit 64 bits).
        length: String,
        max: u64,
    },
    #[error("the header of message {message} is longer than {max} bytes")]
    #[diagnostic(
        code(advise::lsp::header_too_long),
        help("a header is a few `name: value` lines, each ending in `\\r\\n`, then an empty line")
    )]
    HeaderTooLong { message: u64, max: usize },
    #[error("message {message}: header line {line:?} is not `name: value` ending in `\\r\\n`")]
    #[diagnostic(
        code(advise::lsp::bad_header),
        help(
            "each header line is `name: value\\r\\n` (ASCII), and an empty line `\\r\\n` ends the header"
        )
    )]
    BadHeader { message: u64, line: String },
    #[error("the input ended inside the header of message {message}")]
    #[diagnostic(
        code(advise::lsp::truncated_header),
        help("the client closed the connection in the middle of a message")
    )]
    EndInHeader { message: u64 },
    #[error("the input ended {got} bytes into the {length}-byte body of message {message}")]
    #[diagnostic(
        code(advise::lsp::truncated),
        help(
            "the client closed the connection in the middle of a message, or its `Content-Length` counts more bytes than it sent"
        )
    )]
    EndInBody { message: u64, length: u64, got: u64 },
    #[error("cannot read the client's messages")]
    #[diagnostic(code(advise::lsp::read))]
    Io {
        #[source]
        source: io::Error,
    },
}

/// A whole frame whose body is not a JSON-RPC message; answered, and the stream goes on.
#[derive(Debug, Error, Diagnostic, Clone, PartialEq)]
pub enum BodyError {
    #[error("the body of message {message} is not UTF-8 (byte {at} of it)")]
    #[diagnostic(
        code(advise::lsp::bad_utf8),
        help(
            "the protocol's bodies are UTF-8 JSON; the message was answered with a parse error and skipped"
        )
    )]
    BadUtf8 { message: u64, at: usize },
    #[error("the body of message {message} is not JSON: {reason}")]
    #[diagnostic(
        code(advise::lsp::bad_json),
        help("the message was answered with a JSON-RPC parse error (-32700) and skipped")
    )]
    BadJson { message: u64, reason: String },
    #[error(
        "message {message} is JSON but not a JSON-RPC request, response or notification: {reason}"
    )]
    #[diagnostic(
        code(advise::lsp::not_a_message),
        help(
            "the message was answered with a JSON-RPC invalid request error (-32600) and skipped"
        )
    )]
    NotAMessage {
        message: u64,
        reason: String,
        /// The request's id when it could be read (a number or a string), for the answer.
        id: Option<serde_json::Value>,
    },
}

impl BodyError {
    /// The JSON-RPC 2.0 answer to this body: an error response whose id is the request's when it
    /// could be read, `null` otherwise (JSON-RPC 2.0, section 5).
    pub fn response(&self) -> serde_json::Value {
        let (code, id) = match self {
            BodyError::BadUtf8 { .. } | BodyError::BadJson { .. } => (-32700, None),
            BodyError::NotAMessage { id, .. } => (-32600, id.clone()),
        };
        serde_json::json!({
            "jsonrpc": "2.0",
            "id": id.unwrap_or(serde_json::Value::Null),
            "error": { "code": code, "message": self.to_string() },
        })
    }
}

/// What one frame held.
#[derive(Debug)]
pub enum Frame {
    Message(Message),
    /// A whole frame that is not a message (to be answered).
    Bad(BodyError),
}

/// Reads frames one after another from `input`, counting them (from 1) for the diagnostics.
pub struct FrameReader<R> {
    input: R,
    /// Frames read so far.
    count: u64,
    /// Bytes read so far.
    offset: u64,
}

impl<R: BufRead> FrameReader<R> {
    pub fn new(input: R) -> FrameReader<R> {
        FrameReader {
            input,
            count: 0,
            offset: 0,
        }
    }

    /// The next frame, or `None` when the input ends between frames.
    pub fn next_frame(&mut self) -> Result<Option<Frame>, FrameError> {
        let Some(body) = self.next_body()? else {
            return Ok(None);
        };
        Ok(Some(match parse_body(self.count, body) {
            Ok(m) => Frame::Message(m),
            Err(e) => Frame::Bad(e),
        }))
    }

    /// The next frame's body, its length checked before it is read.
    pub fn next_body(&mut self) -> Result<Option<Vec<u8>>, FrameError> {
        let message = self.count + 1;
        let mut length: Option<u64> = None;
        let mut header_bytes = 0;
        let mut line = Vec::new();
        loop {
            line.clear();
            let budget = (MAX_HEADER_BYTES - header_bytes) as u64;
            let n = (&mut self.input)
                .take(budget)
                .read_until(b'\n', &mut line)
                .map_err(|source| FrameError::Io { source })?;
            self.offset += n as u64;
            header_bytes += n;
            if !line.ends_with(b"\n") {
                if n == 0 && header_bytes == 0 {
                    return Ok(None);
                }
                if header_bytes >= MAX_HEADER_BYTES {
                    return Err(FrameError::HeaderTooLong {
                        message,
                        max: MAX_HEADER_BYTES,
                    });
                }
                return Err(FrameError::EndInHeader { message });
            }
            let Some(text) = line
                .strip_suffix(b"\r\n")
                .and_then(|l| std::str::from_utf8(l).ok())
                .filter(|l| l.is_ascii())
            else {
                return Err(FrameError::BadHeader {
                    message,
                    line: quoted(&line),
                });
            };
            if text.is_empty() {
                break;
            }
            let Some((name, value)) = text.split_once(':') else {
                return Err(FrameError::BadHeader {
                    message,
                    line: quoted(&line),
                });
            };
            if !name.eq_ignore_ascii_case("Content-Length") {
                // `Content-Type` (and anything else) is not needed: bodies are UTF-8 JSON.
                continue;
            }
            let value = value.trim_matches([' ', '\t']);
            if let Some(first) = length {
                return Err(FrameError::TwoContentLengths {
                    message,
                    first,
                    second: value.chars().take(QUOTED).collect(),
                });
            }
            length = Some(content_length(message, value)?);
        }
        let Some(length) = length else {
            return Err(FrameError::NoContentLength {
                message,
                at: self.offset,
            });
        };
        // Grown as the bytes come, never reserved on the client's word alone.
        let mut body = Vec::with_capacity(length.min(1 << 20) as usize);
        let got = (&mut self.input)
            .take(length)
            .read_to_end(&mut body)
            .map_err(|source| FrameError::Io { source })? as u64;
        self.offset += got;
        if got < length {
            return Err(FrameError::EndInBody {
                message,
                length,
                got,
            });
        }
        self.count = message;
        Ok(Some(body))
    }
}

/// A `Content-Length` value: decimal digits, at most [`MAX_MESSAGE_BYTES`].
fn content_length(message: u64, value: &str) -> Result<u64, FrameError> {
    if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
        return Err(FrameError::BadContentLength {
            message,
            value: value.chars().take(QUOTED).collect(),
        });
    }
    match value.parse::<u64>() {
        Ok(n) if n <= MAX_MESSAGE_BYTES => Ok(n),
        // All digits, so only too many of them fails to parse.
        _ => Err(FrameError::TooLarge {
            message,
            length: value.chars().take(QUOTED).collect(),
            max: MAX_MESSAGE_BYTES,
        }),
    }
}

/// A header line as a diagnostic shows it: its first characters, lossily decoded.
fn quoted(line: &[u8]) -> String {
    let text = String::from_utf8_lossy(&line[..line.len().min(QUOTED)]);
    if line.len() > QUOTED {
        format!("{text}...")
    } else {
        text.into_owned()
    }
}

/// The message in frame `message`'s body: UTF-8, JSON, then one of JSON-RPC's three shapes
/// (a request has a method and an id, a notification a method and no id, a response an id and no
/// method).
pub fn parse_body(message: u64, body: Vec<u8>) -> Result<Message, BodyError> {
    let text = String::from_utf8(body).map_err(|e| BodyError::BadUtf8 {
        message,
        at: e.utf8_error().valid_up_to(),
    })?;
    // serde_json bounds nesting (128 levels), so no body can exhaust the stack.
    let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| BodyError::BadJson {
        message,
        reason: e.to_string(),
    })?;
    drop(text);
    let not_a_message = |reason: String, id: Option<serde_json::Value>| BodyError::NotAMessage {
        message,
        reason,
        id,
    };
    let Some(object) = value.as_object() else {
        return Err(not_a_message("it is not an object".into(), None));
    };
    // An id JSON-RPC allows (a number or a string) is echoed in the answer to a bad request.
    let id = object
        .get("id")
        .filter(|id| id.is_number() || id.is_string())
        .cloned();
    let has_id = object.get("id").is_some_and(|id| !id.is_null());
    let reason = |e: serde_json::Error| {
        let mut s = e.to_string();
        s.truncate(200);
        s
    };
    match (object.contains_key("method"), has_id) {
        (true, true) => serde_json::from_value::<Request>(value)
            .map(Message::Request)
            .map_err(|e| not_a_message(format!("a bad request: {}", reason(e)), id)),
        (true, false) => serde_json::from_value::<Notification>(value)
            .map(Message::Notification)
            .map_err(|e| not_a_message(format!("a bad notification: {}", reason(e)), None)),
        (false, true) => serde_json::from_value::<Response>(value)
            .map(Message::Response)
            .map_err(|e| not_a_message(format!("a bad response: {}", reason(e)), id)),
        (false, false) => Err(not_a_message(
            "it has neither a `method` nor an `id`".into(),
            None,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(input: &[u8]) -> Vec<Result<Frame, String>> {
        let mut r = FrameReader::new(input);
        let mut out = Vec::new();
        loop {
            match r.next_frame() {
                Ok(Some(f)) => out.push(Ok(f)),
                Ok(None) => return out,
                Err(e) => {
                    out.push(Err(format!(
                        "{}: {e}",
                        e.code().map(|c| c.to_string()).unwrap_or_default()
                    )));
                    return out;
                }
            }
        }
    }

    fn frame(body: &str) -> Vec<u8> {
        format!("Content-Length: {}\r\n\r\n{body}", body.len()).into_bytes()
    }

    fn last_error(input: &[u8]) -> String {
        match frames(input).pop() {
            Some(Err(e)) => e,
            other => panic!("no error: {other:?}"),
        }
    }

    #[test]
    fn messages_follow_one_another_and_the_end_between_frames_is_clean() {
        let mut input = frame(r#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{}}"#);
        input.extend(b"Content-Type: application/vscode-jsonrpc; charset=utf-8\r\n");
        input.extend(frame(
            r#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#,
        ));
        input.extend(frame(r#"{"jsonrpc":"2.0","id":"x","result":null}"#));
        let got = frames(&input);
        assert_eq!(got.len(), 3);
        assert!(
            matches!(&got[0], Ok(Frame::Message(Message::Request(r))) if r.method == "initialize")
        );
        assert!(matches!(
            &got[1],
            Ok(Frame::Message(Message::Notification(_)))
        ));
        assert!(matches!(&got[2], Ok(Frame::Message(Message::Response(_)))));
    }

    #[test]
    fn a_huge_length_is_refused_before_anything_is_allocated() {
        for length in [
            "18446744073709551615",
            "1000000000000000000",
            "3000000000",
            "99999999999999999999999999",
        ] {
            let e = last_error(format!("Content-Length: {length}\r\n\r\n{{}}").as_bytes());
            assert!(e.starts_with("advise::lsp::message_too_large"), "{e}");
        }
        let at_limit = format!("Content-Length: {MAX_MESSAGE_BYTES}\r\n\r\n{{}}");
        assert!(last_error(at_limit.as_bytes()).starts_with("advise::lsp::truncated"));
    }

    #[test]
    fn every_broken_header_has_its_code() {
        let cases: [(&[u8], &str); 10] = [
            (b"\r\n{}", "no_content_length"),
            (b"Content-Type: x\r\n\r\n{}", "no_content_length"),
            (b"Content-Length: abc\r\n\r\n{}", "bad_content_length"),
            (b"Content-Length: -5\r\n\r\n{}", "bad_content_length"),
            (b"Content-Length: +5\r\n\r\n{}", "bad_content_length"),
            (
                b"Content-Length: 2\r\nContent-Length: 2\r\n\r\n{}",
                "two_content_lengths",
            ),
            (b"Content-Length: 2\n\n{}", "bad_header"),
            (b"Content-Length 2\r\n\r\n{}", "bad_header"),
            (b"Content-Length: 2\r\n", "truncated_header"),
            (b"Content-Length: 10\r\n\r\n{}", "truncated"),
        ];
        for (input, code) in cases {
            let e = last_error(input);
            assert!(
                e.starts_with(&format!("advise::lsp::{code}")),
                "{input:?}: {e}"
            );
        }
        let long = vec![b'x'; MAX_HEADER_BYTES * 4];
        assert!(last_error(&long).starts_with("advise::lsp::header_too_long"));
        let mut many = b"Content-Length: 2\r\n".to_vec();
        many.extend(b"X: y\r\n".repeat(MAX_HEADER_BYTES));
        assert!(last_error(&many).starts_with("advise::lsp::header_too_long"));
        assert!(last_error(b"Content-Le").starts_with("advise::lsp::truncated_header"));
        assert!(last_error(b"\xff\xfe: 1\r\n\r\n").starts_with("advise::lsp::bad_header"));
    }

    #[test]
    fn a_bad_body_is_answered_and_reading_goes_on() {
        let mut input = frame("{not json");
        input.extend(b"Content-Length: 2\r\n\r\n\xff\xff");
        input.extend(frame("[1, 2]"));
        input.extend(frame(r#"{"jsonrpc":"2.0","id":7,"method":42}"#));
        input.extend(frame(r#"{"jsonrpc":"2.0","method":"exit"}"#));
        let got = frames(&input);
        let bad: Vec<&BodyError> = got
            .iter()
            .filter_map(|f| match f {
                Ok(Frame::Bad(e)) => Some(e),
                _ => None,
            })
            .collect();
        assert_eq!(bad.len(), 4);
        let codes: Vec<String> = bad.iter().map(|e| e.code().unwrap().to_string()).collect();
        assert_eq!(
            codes,
            [
                "advise::lsp::bad_json",
                "advise::lsp::bad_utf8",
                "advise::lsp::not_a_message",
                "advise::lsp::not_a_message"
            ]
        );
        assert_eq!(bad[0].response()["error"]["code"], -32700);
        assert_eq!(bad[0].response()["id"], serde_json::Value::Null);
        assert_eq!(bad[3].response()["error"]["code"], -32600);
        assert_eq!(bad[3].response()["id"], 7);
        assert!(matches!(
            got.last(),
            Some(Ok(Frame::Message(Message::Notification(_))))
        ));
    }

    #[test]
    fn deep_json_is_refused_without_exhausting_the_stack() {
        let deep = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
        let got = frames(&frame(&deep));
        assert!(matches!(&got[0], Ok(Frame::Bad(BodyError::BadJson { .. }))));
    }

    proptest::proptest! {
        /// Any bytes: frames, coded errors or the end, never a panic; every frame read consumed
        /// bytes, so reading ends.
        #[test]
        fn any_input_is_read_to_an_end(
            input in proptest::collection::vec(
                proptest::prop_oneof![
                    proptest::strategy::Just(b"Content-Length: 2\r\n\r\n{}".to_vec()),
                    proptest::strategy::Just(b"\r\n".to_vec()),
                    proptest::strategy::Just(b"Content-Length: 99999999999\r\n".to_vec()),
                    proptest::collection::vec(proptest::prelude::any::<u8>(), 0..8),
                ],
                0..12,
            )
        ) {
            let input: Vec<u8> = input.concat();
            let mut r = FrameReader::new(input.as_slice());
            let mut n = 0;
            while let Ok(Some(f)) = r.next_frame() {
                if let Frame::Bad(e) = f {
                    let _ = e.response().to_string();
                }
                n += 1;
                proptest::prop_assert!(n <= input.len());
            }
        }
    }
}
