//! `advise lsp`: a language server for operator files (and session scripts) over stdio.
//!
//! Its own crate on `advise-lang` alone (issue 32): what the server knows is what the language
//! knows, and the compiler keeps it so. The application re-exports it as `advise::lsp`.
//!
//! The messages are `lsp-server`'s (rust-analyzer's synchronous scaffold) with `lsp-types`, but
//! the framing is ours ([`frame`]: every size bounded before it is allocated, every broken frame a
//! coded error) and so are the handshake and shutdown ([`serve_io`]); what the server knows is
//! [`analysis`], in byte offsets, and this module converts to the protocol's positions (lines
//! and UTF-16 code units, or UTF-8 or characters when the client offers no UTF-16) and back
//! through the document's [`LineIndex`]. Documents are synced whole and held up to
//! [`MAX_DOCUMENT_BYTES`]; each version is analysed once, when it arrives, and every request
//! reads that analysis. Capabilities:
//! diagnostics on open and change (the same codes, messages, help and labels as `advise check`),
//! hover, completion, go to definition (the standard library is written once into a cache folder
//! so any editor can open it), formatting (`advise fmt`) and document symbols.
#![forbid(unsafe_code)]

pub mod analysis;
pub mod frame;

use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::ops::Range;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::str::FromStr;
use std::sync::{Arc, Mutex};

use lsp_server::{Connection, ErrorCode, Message, Notification, Request, RequestId, Response};
use lsp_types::notification::{
    DidChangeTextDocument, DidCloseTextDocument, DidOpenTextDocument, Exit,
    Notification as NotificationTrait, PublishDiagnostics,
};
use lsp_types::request::{
    Completion, DocumentSymbolRequest, Formatting, GotoDefinition, HoverRequest, Initialize,
    Request as RequestTrait, Shutdown,
};
use lsp_types::{
    CompletionItem, CompletionItemKind, CompletionOptions, CompletionParams, CompletionResponse,
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, DidChangeTextDocumentParams,
    DidCloseTextDocumentParams, DidOpenTextDocumentParams, DocumentFormattingParams,
    DocumentSymbol, DocumentSymbolParams, DocumentSymbolResponse, GotoDefinitionParams,
    GotoDefinitionResponse, Hover, HoverContents, HoverParams, HoverProviderCapability, Location,
    MarkupContent, MarkupKind, NumberOrString, OneOf, Position, PositionEncodingKind,
    PublishDiagnosticsParams, ServerCapabilities, ServerInfo, TextDocumentSyncCapability,
    TextDocumentSyncKind, TextEdit, Uri,
};
use thiserror::Error;

use advise_lang::diag::{Encoding, LineCol, LineIndex};
use analysis::{CompletionKind, SymbolKind, Target};
use frame::{Frame, FrameError, FrameReader};

/// Serve the language server protocol on stdin and stdout until the client exits.
pub fn run_stdio() -> miette::Result<()> {
    serve_io(std::io::BufReader::new(std::io::stdin()), std::io::stdout())
}

/// What ends a connection, besides a broken frame.
#[derive(Debug, Error, miette::Diagnostic)]
pub enum LspError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    Frame(#[from] FrameError),
    #[error("the client closed the connection {when}")]
    #[diagnostic(
        code(advise::lsp::closed),
        help("a client ends a session with a `shutdown` request and then an `exit` notification")
    )]
    Closed { when: &'static str },
    #[error("the client sent `exit` without `shutdown` first")]
    #[diagnostic(
        code(advise::lsp::exit_without_shutdown),
        help("the protocol asks a server to exit with code 1 then; send `shutdown` before `exit`")
    )]
    ExitWithoutShutdown,
    #[error("cannot write to the client")]
    #[diagnostic(code(advise::lsp::write))]
    Write {
        #[source]
        source: std::io::Error,
    },
}

/// How the message loop ended.
#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    /// The client's `exit`, after a `shutdown` or not.
    Exit { shut_down: bool },
    /// The input ended (or broke) before an `exit`.
    Closed { initialized: bool, shut_down: bool },
}

/// Serve the protocol on `input` and `output`: [`frame::FrameReader`] reads the frames (on a
/// thread of its own, one message in flight), the server answers them in order, and a writer
/// thread frames the answers. A broken frame ends the session with its coded error; a frame
/// that is not a message is answered with a JSON-RPC error, logged on stderr, and skipped.
pub fn serve_io<R, W>(input: R, output: W) -> miette::Result<()>
where
    R: BufRead + Send + 'static,
    W: Write + Send + 'static,
{
    let output = Arc::new(Mutex::new(output));
    // Rendezvous channels, as `lsp-server`'s own transport has: the reader holds at most one
    // message the server has not taken.
    let (to_server, server_inbox) = crossbeam_channel::bounded::<Message>(0);
    let (server_outbox, to_client) = crossbeam_channel::bounded::<Message>(0);
    let writer = {
        let output = Arc::clone(&output);
        std::thread::spawn(move || write_messages(&to_client, &output))
    };
    let reader = {
        let output = Arc::clone(&output);
        std::thread::spawn(move || read_messages(input, &to_server, &output))
    };
    let connection = Connection {
        sender: server_outbox,
        receiver: server_inbox,
    };
    let end = Server::default().run(&connection);
    drop(connection);
    let written = writer
        .join()
        .unwrap_or_else(|_| Err(std::io::Error::other("the writer thread panicked")));
    let read = match end {
        // The reader may be waiting for input that never comes; the process ends it.
        End::Exit { .. } => Ok(()),
        End::Closed { .. } => reader.join().unwrap_or_else(|_| {
            Err(FrameError::Io {
                source: std::io::Error::other("the reader thread panicked"),
            })
        }),
    };
    read.map_err(LspError::from)?;
    written.map_err(|source| LspError::Write { source })?;
    match end {
        End::Exit { shut_down: true }
        | End::Closed {
            shut_down: true, ..
        } => Ok(()),
        End::Exit { shut_down: false } => Err(LspError::ExitWithoutShutdown.into()),
        End::Closed {
            initialized: false, ..
        } => Err(LspError::Closed {
            when: "before `initialize`",
        }
        .into()),
        End::Closed { .. } => Err(LspError::Closed {
            when: "without `shutdown` and `exit`",
        }
        .into()),
    }
}

/// Read frames from `input` and hand their messages to the server until the input ends, breaks,
/// or brings `exit`. A frame that is not a message is answered here (the server never sees it)
/// and its diagnostic logged on stderr.
fn read_messages<R: BufRead, W: Write>(
    input: R,
    to_server: &crossbeam_channel::Sender<Message>,
    output: &Mutex<W>,
) -> Result<(), FrameError> {
    let mut frames = FrameReader::new(input);
    while let Some(frame) = frames.next_frame()? {
        match frame {
            Frame::Message(message) => {
                let exit = matches!(&message, Message::Notification(n) if n.method == Exit::METHOD);
                if to_server.send(message).is_err() || exit {
                    break;
                }
            }
            Frame::Bad(e) => {
                // A closed stderr (the editor stopped reading it) drops the message, never a panic.
                let _ = writeln!(
                    std::io::stderr().lock(),
                    "{}",
                    advise_lang::diag::render_with_width(
                        &advise_lang::diag::SourceMap::new(),
                        &e,
                        false,
                        100
                    )
                );
                let answer = e.response().to_string();
                // A client that is gone is noticed by the writer.
                let _ = write_frame(output, &answer);
            }
        }
    }
    Ok(())
}

/// Write the server's messages to `output` until the server drops its sender. After a failed
/// write the rest are taken and dropped, so the server never blocks on a client that is gone;
/// the first error is the result.
fn write_messages<W: Write>(
    from_server: &crossbeam_channel::Receiver<Message>,
    output: &Mutex<W>,
) -> std::io::Result<()> {
    let mut result = Ok(());
    for message in from_server {
        if result.is_ok() {
            let mut out = output.lock().unwrap_or_else(|p| p.into_inner());
            result = message.write(&mut *out);
        }
    }
    result
}

/// One frame of `body` on `output`, whole (the writer thread frames under the same lock).
fn write_frame<W: Write>(output: &Mutex<W>, body: &str) -> std::io::Result<()> {
    let mut out = output.lock().unwrap_or_else(|p| p.into_inner());
    write!(out, "Content-Length: {}\r\n\r\n{body}", body.len())?;
    out.flush()
}

const PANICKED: &str = "advise lsp failed on this request (a bug; please report it with the file)";

/// The largest document the server holds and analyses, in bytes (16 MiB, about 250,000
/// operators): each analysis parses and checks the whole text, so this bounds the memory and
/// time of every answer. A larger document is not held; it gets one diagnostic saying so, and
/// `advise check FILE` checks it.
pub const MAX_DOCUMENT_BYTES: usize = 16 * 1024 * 1024;

/// An open document: the client's version of it, analysed ([`analysis::Analysis`]), or the size
/// of a text too large to hold ([`MAX_DOCUMENT_BYTES`]).
struct Doc {
    version: i32,
    state: Held,
}

enum Held {
    Analysed(Box<analysis::Analysis>),
    TooLarge(usize),
}

/// A document's text while changes are applied to it, before it is analysed again.
enum Editing {
    Text(String),
    TooLarge(usize),
}

impl Editing {
    /// A whole new text (not held when too large).
    fn whole(text: String) -> Editing {
        if text.len() > MAX_DOCUMENT_BYTES {
            Editing::TooLarge(text.len())
        } else {
            Editing::Text(text)
        }
    }
}

/// The one diagnostic of a document too large to hold, at its start.
fn too_large(size: usize) -> Diagnostic {
    Diagnostic {
        range: lsp_types::Range::default(),
        severity: Some(DiagnosticSeverity::ERROR),
        code: Some(NumberOrString::String(
            "advise::lsp::document_too_large".into(),
        )),
        source: Some("advise".into()),
        message: format!(
            "this document is {size} bytes, more than the {MAX_DOCUMENT_BYTES} bytes `advise lsp` analyses, so it is not checked here\nhelp: check it with `advise check FILE`"
        ),
        ..Default::default()
    }
}

/// The open documents, and how positions count columns.
#[derive(Default)]
struct Server {
    docs: HashMap<String, Doc>,
    encoding: Encoding,
    /// How many times a document was analysed (parsed and checked): once per version, never per
    /// request (the tests count them).
    analysed: usize,
}

impl Server {
    /// The handshake (`initialize`; requests before it are refused as the protocol says), then
    /// [`Server::serve`].
    fn run(&mut self, connection: &Connection) -> End {
        let send = |m: Message| {
            // The writer takes every message while the connection lives.
            let _ = connection.sender.send(m);
        };
        let id = loop {
            match connection.receiver.recv() {
                Err(_) => {
                    return End::Closed {
                        initialized: false,
                        shut_down: false,
                    };
                }
                Ok(Message::Request(req)) if req.method == Initialize::METHOD => {
                    self.encoding = negotiate(&req.params);
                    break req.id;
                }
                Ok(Message::Request(req)) => send(Message::Response(error(
                    req.id,
                    ErrorCode::ServerNotInitialized,
                    format!("`{}` before `initialize`", req.method),
                ))),
                Ok(Message::Notification(n)) if n.method == Exit::METHOD => {
                    return End::Exit { shut_down: false };
                }
                Ok(_) => {}
            }
        };
        let capabilities = ServerCapabilities {
            text_document_sync: Some(TextDocumentSyncCapability::Kind(TextDocumentSyncKind::FULL)),
            hover_provider: Some(HoverProviderCapability::Simple(true)),
            completion_provider: Some(CompletionOptions::default()),
            definition_provider: Some(OneOf::Left(true)),
            document_formatting_provider: Some(OneOf::Left(true)),
            document_symbol_provider: Some(OneOf::Left(true)),
            // UTF-16, the protocol's default, goes unsaid.
            position_encoding: match self.encoding {
                Encoding::Utf16 => None,
                Encoding::Utf8 => Some(PositionEncodingKind::UTF8),
                Encoding::Utf32 => Some(PositionEncodingKind::UTF32),
            },
            ..Default::default()
        };
        let init = serde_json::json!({
            "capabilities": capabilities,
            "serverInfo": ServerInfo { name: "advise".into(), version: Some(env!("CARGO_PKG_VERSION").into()) },
        });
        send(Message::Response(Response::new_ok(id, init)));
        self.serve(connection)
    }

    fn serve(&mut self, connection: &Connection) -> End {
        let send = |m: Message| {
            let _ = connection.sender.send(m);
        };
        let mut shut_down = false;
        for message in &connection.receiver {
            match message {
                Message::Request(req) if req.method == Shutdown::METHOD => {
                    shut_down = true;
                    send(Message::Response(Response::new_ok(req.id, ())));
                }
                Message::Request(req) if shut_down || req.method == Initialize::METHOD => {
                    let why = if shut_down {
                        format!("`{}` after `shutdown`", req.method)
                    } else {
                        "the server is already initialized".to_string()
                    };
                    send(Message::Response(error(
                        req.id,
                        ErrorCode::InvalidRequest,
                        why,
                    )));
                }
                Message::Request(req) => {
                    // A bug must cost one answer, not the editor's server.
                    let id = req.id.clone();
                    let response = catch_unwind(AssertUnwindSafe(|| self.respond(req)))
                        .unwrap_or_else(|_| {
                            error(id, ErrorCode::InternalError, PANICKED.to_string())
                        });
                    send(Message::Response(response));
                }
                Message::Notification(n) if n.method == Exit::METHOD => {
                    return End::Exit { shut_down };
                }
                Message::Notification(n) => {
                    if let Some(uri) = self.notify(n)
                        && let Ok(d) = catch_unwind(AssertUnwindSafe(|| self.diagnostics(&uri)))
                    {
                        send(Message::Notification(d));
                    }
                }
                Message::Response(_) => {}
            }
        }
        End::Closed {
            initialized: true,
            shut_down,
        }
    }

    /// Apply a document notification; the document whose diagnostics to publish (again).
    fn notify(&mut self, n: Notification) -> Option<String> {
        match n.method.as_str() {
            DidOpenTextDocument::METHOD => {
                let p: DidOpenTextDocumentParams = serde_json::from_value(n.params).ok()?;
                let uri = p.text_document.uri.as_str().to_string();
                let editing = Editing::whole(p.text_document.text);
                let doc = self.analyse(&uri, p.text_document.version, editing);
                self.docs.insert(uri.clone(), doc);
                Some(uri)
            }
            DidChangeTextDocument::METHOD => {
                let p: DidChangeTextDocumentParams = serde_json::from_value(n.params).ok()?;
                let uri = p.text_document.uri.as_str().to_string();
                let mut editing = match self.docs.remove(&uri).map(|d| d.state) {
                    None => Editing::Text(String::new()),
                    Some(Held::Analysed(a)) => Editing::Text(a.into_text()),
                    Some(Held::TooLarge(size)) => Editing::TooLarge(size),
                };
                // The server asks for whole texts, but a change with a range is applied as one.
                for change in p.content_changes {
                    editing = match (change.range, editing) {
                        (None, _) => Editing::whole(change.text),
                        // A document not held has no text to apply a range to: it stays too
                        // large until a whole text comes.
                        (Some(_), Editing::TooLarge(size)) => Editing::TooLarge(size),
                        (Some(range), Editing::Text(mut text)) => {
                            let lines = LineIndex::new(&text);
                            let at = |p| offset(&text, &lines, self.encoding, p);
                            let (start, end) = (at(range.start), at(range.end));
                            let end = end.max(start);
                            let size = text.len() - (end - start) + change.text.len();
                            if size > MAX_DOCUMENT_BYTES {
                                Editing::TooLarge(size)
                            } else {
                                text.replace_range(start..end, &change.text);
                                Editing::Text(text)
                            }
                        }
                    };
                }
                let doc = self.analyse(&uri, p.text_document.version, editing);
                self.docs.insert(uri.clone(), doc);
                Some(uri)
            }
            DidCloseTextDocument::METHOD => {
                let p: DidCloseTextDocumentParams = serde_json::from_value(n.params).ok()?;
                // Published once more, empty: a closed file's diagnostics leave the editor.
                let uri = p.text_document.uri.as_str().to_string();
                self.docs.remove(&uri);
                Some(uri)
            }
            _ => None,
        }
    }

    /// Version `version` of document `uri`, analysed (once: every request reads it).
    fn analyse(&mut self, uri: &str, version: i32, editing: Editing) -> Doc {
        let state = match editing {
            Editing::TooLarge(size) => Held::TooLarge(size),
            Editing::Text(text) => {
                self.analysed += 1;
                let name = uri.strip_prefix("file://").unwrap_or(uri);
                // A bug in the checker must cost this version's answers, not the server: the
                // text is kept, unanalysed, for the next change to apply to.
                let kept = text.clone();
                let a = catch_unwind(AssertUnwindSafe(|| analysis::Analysis::new(name, text)))
                    .unwrap_or_else(|_| analysis::Analysis::unanalysed(kept));
                Held::Analysed(Box::new(a))
            }
        };
        Doc { version, state }
    }

    /// The diagnostics of `uri` (none when it is not open; one when it is too large to hold).
    fn diagnostics(&self, uri: &str) -> Notification {
        let doc = self.docs.get(uri);
        let diagnostics = match doc.map(|d| &d.state) {
            None => Vec::new(),
            Some(Held::TooLarge(size)) => vec![too_large(*size)],
            Some(Held::Analysed(a)) => publish_analysis(uri, a, self.encoding),
        };
        let params = PublishDiagnosticsParams {
            uri: parse_uri(uri),
            diagnostics,
            version: doc.map(|d| d.version),
        };
        Notification::new(PublishDiagnostics::METHOD.to_string(), params)
    }

    fn respond(&self, req: Request) -> Response {
        let id = req.id.clone();
        let result = match req.method.as_str() {
            HoverRequest::METHOD => self.hover(req).map(|r| serde_json::to_value(r).ok()),
            Completion::METHOD => self.completion(req).map(|r| serde_json::to_value(r).ok()),
            GotoDefinition::METHOD => self.definition(req).map(|r| serde_json::to_value(r).ok()),
            Formatting::METHOD => self.formatting(req).map(|r| serde_json::to_value(r).ok()),
            DocumentSymbolRequest::METHOD => {
                self.symbols(req).map(|r| serde_json::to_value(r).ok())
            }
            _ => Err((
                ErrorCode::MethodNotFound,
                format!("`advise lsp` does not handle `{}`", req.method),
            )),
        };
        match result {
            Ok(value) => Response::new_ok(id, value.unwrap_or(serde_json::Value::Null)),
            Err((code, message)) => error(id, code, message),
        }
    }

    /// The analysis of open document `uri`.
    fn analysis<'s>(&'s self, uri: &Uri) -> Result<&'s analysis::Analysis, (ErrorCode, String)> {
        match self.docs.get(uri.as_str()).map(|d| &d.state) {
            None => Err((
                ErrorCode::InvalidParams,
                format!("`{}` is not open", uri.as_str()),
            )),
            Some(Held::TooLarge(size)) => Err((
                ErrorCode::RequestFailed,
                format!(
                    "`{}` is {size} bytes, more than the {MAX_DOCUMENT_BYTES} bytes `advise lsp` analyses",
                    uri.as_str()
                ),
            )),
            Some(Held::Analysed(a)) => Ok(a),
        }
    }

    /// The protocol's positions in `a`'s text.
    fn at<'a>(&self, a: &'a analysis::Analysis) -> Positions<'a> {
        Positions::new(a.text(), a.lines(), self.encoding)
    }

    fn hover(&self, req: Request) -> Result<Option<Hover>, (ErrorCode, String)> {
        let p: HoverParams = params(req)?;
        let doc = &p.text_document_position_params;
        let a = self.analysis(&doc.text_document.uri)?;
        let lines = self.at(a);
        Ok(a.hover(lines.offset(doc.position))
            .map(|(range, value)| Hover {
                contents: HoverContents::Markup(MarkupContent {
                    kind: MarkupKind::Markdown,
                    value,
                }),
                range: Some(lines.range(range)),
            }))
    }

    fn completion(&self, req: Request) -> Result<Option<CompletionResponse>, (ErrorCode, String)> {
        let p: CompletionParams = params(req)?;
        let doc = &p.text_document_position;
        let a = self.analysis(&doc.text_document.uri)?;
        let items = a
            .completion(self.at(a).offset(doc.position))
            .into_iter()
            .map(|c| CompletionItem {
                label: c.label,
                kind: Some(match c.kind {
                    CompletionKind::Keyword => CompletionItemKind::KEYWORD,
                    CompletionKind::Operator => CompletionItemKind::FUNCTION,
                    CompletionKind::Parameter => CompletionItemKind::VARIABLE,
                    CompletionKind::Dimension => CompletionItemKind::FIELD,
                    CompletionKind::Function => CompletionItemKind::FUNCTION,
                    CompletionKind::Command => CompletionItemKind::KEYWORD,
                }),
                detail: Some(c.detail),
                ..Default::default()
            })
            .collect();
        Ok(Some(CompletionResponse::Array(items)))
    }

    fn definition(
        &self,
        req: Request,
    ) -> Result<Option<GotoDefinitionResponse>, (ErrorCode, String)> {
        let p: GotoDefinitionParams = params(req)?;
        let doc = &p.text_document_position_params;
        let a = self.analysis(&doc.text_document.uri)?;
        let lines = self.at(a);
        let location = match a.definition(lines.offset(doc.position)) {
            None => return Ok(None),
            Some(Target::Here(range)) => Location {
                uri: doc.text_document.uri.clone(),
                range: lines.range(range),
            },
            Some(Target::Standard { file, range }) => {
                let (path, std_text) =
                    standard_file(file).map_err(|e| (ErrorCode::InternalError, e))?;
                let std_lines = LineIndex::new(std_text);
                Location {
                    uri: file_uri(&path),
                    range: Positions::new(std_text, &std_lines, self.encoding).range(range),
                }
            }
        };
        Ok(Some(GotoDefinitionResponse::Scalar(location)))
    }

    fn formatting(&self, req: Request) -> Result<Option<Vec<TextEdit>>, (ErrorCode, String)> {
        let p: DocumentFormattingParams = params(req)?;
        let a = self.analysis(&p.text_document.uri)?;
        let text = a.text();
        let (map, id) = advise_lang::diag::SourceMap::single("document", text);
        let formatted = advise_lang::syntax::script::format_file(map.src(id)).map_err(|e| {
            (
                ErrorCode::RequestFailed,
                format!(
                    "the file does not parse as an operator file or a session script, so it is not formatted: {e}"
                ),
            )
        })?;
        if formatted == text {
            return Ok(Some(Vec::new()));
        }
        let lines = self.at(a);
        Ok(Some(vec![TextEdit {
            range: lines.range(0..text.len()),
            new_text: formatted,
        }]))
    }

    fn symbols(&self, req: Request) -> Result<Option<DocumentSymbolResponse>, (ErrorCode, String)> {
        let p: DocumentSymbolParams = params(req)?;
        let a = self.analysis(&p.text_document.uri)?;
        let lines = self.at(a);
        let symbols = a.symbols().into_iter().map(|s| symbol(&lines, s)).collect();
        Ok(Some(DocumentSymbolResponse::Nested(symbols)))
    }
}

#[allow(deprecated)] // `DocumentSymbol::deprecated` must be written, as `None`.
fn symbol(lines: &Positions<'_>, s: analysis::Symbol) -> DocumentSymbol {
    DocumentSymbol {
        name: s.name,
        detail: Some(s.detail),
        kind: match s.kind {
            SymbolKind::Domain => lsp_types::SymbolKind::NAMESPACE,
            SymbolKind::Dimension => lsp_types::SymbolKind::FIELD,
            SymbolKind::Operator => lsp_types::SymbolKind::FUNCTION,
            SymbolKind::Parameter => lsp_types::SymbolKind::VARIABLE,
        },
        tags: None,
        deprecated: None,
        range: lines.range(s.range),
        selection_range: lines.range(s.selection),
        children: Some(s.children.into_iter().map(|c| symbol(lines, c)).collect()),
    }
}

fn params<P: serde::de::DeserializeOwned>(req: Request) -> Result<P, (ErrorCode, String)> {
    serde_json::from_value(req.params).map_err(|e| {
        (
            ErrorCode::InvalidParams,
            format!("bad parameters for `{}`: {e}", req.method),
        )
    })
}

fn error(id: RequestId, code: ErrorCode, message: String) -> Response {
    Response::new_err(id, code as i32, message)
}

fn parse_uri(s: &str) -> Uri {
    Uri::from_str(s)
        .or_else(|_| Uri::from_str(&s.replace(' ', "%20")))
        .unwrap_or_else(|_| Uri::from_str("file:///").expect("a valid URI"))
}

/// The diagnostics of document `uri` in the protocol's form: what the server publishes after
/// each change (public for the latency bench, `benches/lsp.rs`).
pub fn publish(uri: &str, text: &str) -> Vec<Diagnostic> {
    let name = uri.strip_prefix("file://").unwrap_or(uri);
    let a = analysis::Analysis::new(name, text.to_string());
    publish_analysis(uri, &a, Encoding::Utf16)
}

/// [`publish`] of a document already analysed.
fn publish_analysis(uri: &str, a: &analysis::Analysis, enc: Encoding) -> Vec<Diagnostic> {
    let lines = Positions::new(a.text(), a.lines(), enc);
    a.diagnostics()
        .iter()
        .cloned()
        .map(|d| Diagnostic {
            range: lines.range(d.range),
            severity: Some(if d.warning {
                DiagnosticSeverity::WARNING
            } else {
                DiagnosticSeverity::ERROR
            }),
            code: d.code.map(NumberOrString::String),
            source: Some("advise".into()),
            message: d.message,
            related_information: (!d.related.is_empty()).then(|| {
                d.related
                    .into_iter()
                    .map(|(range, message)| DiagnosticRelatedInformation {
                        location: Location {
                            uri: parse_uri(uri),
                            range: lines.range(range),
                        },
                        message,
                    })
                    .collect()
            }),
            ..Default::default()
        })
        .collect()
}

/// The standard library file `name`, written once into the first writable of
/// `$XDG_CACHE_HOME/advise/std-VERSION/`, `~/.cache/advise/std-VERSION/` and the temporary
/// folder's; its path and text.
fn standard_file(name: &str) -> Result<(PathBuf, &'static str), String> {
    let (_, text) = advise_lang::check::STANDARD_SOURCES
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| format!("no standard file `{name}`"))?;
    let bases = [
        std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from),
        std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")),
        Some(std::env::temp_dir()),
    ];
    let file = name.rsplit('/').next().unwrap_or(name);
    let mut why = Vec::new();
    for base in bases.into_iter().flatten() {
        let dir = base
            .join("advise")
            .join(concat!("std-", env!("CARGO_PKG_VERSION")));
        let path = dir.join(file);
        if std::fs::read_to_string(&path).ok().as_deref() == Some(*text) {
            return Ok((path, text));
        }
        let written = std::fs::create_dir_all(&dir)
            .map_err(|e| format!("{}: {e}", dir.display()))
            .and_then(|()| {
                advise_lang::files::write_bytes(&path, text.as_bytes()).map_err(|e| e.to_string())
            });
        match written {
            Ok(()) => return Ok((path, text)),
            Err(e) => why.push(e),
        }
    }
    Err(format!(
        "the standard library could not be written: {}",
        why.join("; ")
    ))
}

/// The `file://` URI of an absolute path, percent-encoding every byte but the unreserved ones
/// and `/` (a cache folder may hold spaces or non-ASCII letters).
fn file_uri(path: &std::path::Path) -> Uri {
    let text = path.to_string_lossy().replace('\\', "/");
    let mut uri = String::from("file://");
    if !text.starts_with('/') {
        uri.push('/');
    }
    for b in text.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    parse_uri(&uri)
}

/// The position encoding to use: UTF-16 (the protocol's default, which every client supports)
/// unless the client's `general.positionEncodings` leaves it out, then the first of its choices
/// the server knows.
fn negotiate(params: &serde_json::Value) -> Encoding {
    let Some(offered) = params
        .pointer("/capabilities/general/positionEncodings")
        .and_then(|v| v.as_array())
    else {
        return Encoding::Utf16;
    };
    let kinds: Vec<&str> = offered.iter().filter_map(|v| v.as_str()).collect();
    if kinds.is_empty() || kinds.contains(&"utf-16") {
        return Encoding::Utf16;
    }
    kinds
        .iter()
        .find_map(|k| match *k {
            "utf-8" => Some(Encoding::Utf8),
            "utf-32" => Some(Encoding::Utf32),
            _ => None,
        })
        .unwrap_or(Encoding::Utf16)
}

/// The byte offset of protocol position `p` in `text` (see [`LineIndex::offset`]: total, on a
/// character boundary).
fn offset(text: &str, lines: &LineIndex, enc: Encoding, p: Position) -> usize {
    let pos = LineCol {
        line: p.line as usize,
        col: p.character as usize,
    };
    lines.offset(text, pos, enc)
}

/// Byte offsets of one text to the protocol's positions and back, through its [`LineIndex`].
pub struct Positions<'t> {
    text: &'t str,
    lines: &'t LineIndex,
    enc: Encoding,
}

impl<'t> Positions<'t> {
    pub fn new(text: &'t str, lines: &'t LineIndex, enc: Encoding) -> Positions<'t> {
        Positions { text, lines, enc }
    }

    /// The position of byte `offset` (clamped to the text, and back to a character boundary).
    pub fn position(&self, offset: usize) -> Position {
        let p = self.lines.line_col(self.text, offset, self.enc);
        let clamp = |x: usize| u32::try_from(x).unwrap_or(u32::MAX);
        Position::new(clamp(p.line), clamp(p.col))
    }

    pub fn range(&self, r: Range<usize>) -> lsp_types::Range {
        lsp_types::Range::new(self.position(r.start), self.position(r.end))
    }

    /// The byte offset of `p` (a position past a line's end is its end; past the last line, the
    /// text's end).
    pub fn offset(&self, p: Position) -> usize {
        offset(self.text, self.lines, self.enc, p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_count_utf16_units_and_round_trip() {
        let text = "é😀x\nab\n";
        let index = LineIndex::new(text);
        let l = Positions::new(text, &index, Encoding::Utf16);
        // é is 2 bytes and 1 unit; 😀 is 4 bytes and 2 units.
        assert_eq!(l.position(2), Position::new(0, 1));
        assert_eq!(l.position(6), Position::new(0, 3));
        assert_eq!(l.position(8), Position::new(1, 0));
        assert_eq!(
            l.position(3),
            Position::new(0, 1),
            "inside a character: its start"
        );
        for offset in [0, 2, 6, 7, 8, 9, 10, 11] {
            assert_eq!(l.offset(l.position(offset)), offset);
        }
        assert_eq!(
            l.offset(Position::new(0, 99)),
            7,
            "past the end: the line's end"
        );
        assert_eq!(l.offset(Position::new(9, 0)), text.len());
    }

    /// A document whose lines hold multi-byte text before the names: a unit with `°` and `²`,
    /// a comment with an astral character.
    const WIDE: &str = "domain wide {\n  observe free \"°\", d \"m²\" in [0, 1]\n  act u \"m/s\" in [-1, 1]\n}\n// ✓😀 wide\noperator nudge(gain = 0.5 in [0, 1]) for wide on action where d < 1 { u = gain * d }\n";

    fn request(id: i32, method: &str, params: serde_json::Value) -> Request {
        Request::new(RequestId::from(id), method.into(), params)
    }

    /// The protocol position (UTF-16) of the `nth` occurrence of `needle` in `text`, `delta`
    /// bytes into it.
    fn utf16_at(text: &str, needle: &str, nth: usize, delta: usize) -> Position {
        let at = text.match_indices(needle).nth(nth).unwrap().0 + delta;
        let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
        let line = text[..at].matches('\n').count() as u32;
        Position::new(line, text[line_start..at].encode_utf16().count() as u32)
    }

    fn hover_at(server: &Server, uri: &str, p: Position) -> Option<Hover> {
        let req = request(
            1,
            HoverRequest::METHOD,
            serde_json::json!({"textDocument": {"uri": uri}, "position": p}),
        );
        let r = serde_json::to_value(server.respond(req)).unwrap();
        assert!(r.get("error").is_none(), "{r}");
        serde_json::from_value(r["result"].clone()).unwrap()
    }

    #[test]
    fn hovers_resolve_from_spans_after_multi_byte_text_and_never_check_again() {
        let uri = "file:///wide.adv";
        let mut server = Server::default();
        server.notify(Notification::new(
            DidOpenTextDocument::METHOD.into(),
            serde_json::json!({"textDocument": {"uri": uri, "languageId": "advise", "version": 1, "text": WIDE}}),
        ));
        assert_eq!(server.analysed, 1);
        let before = analysis::work_on_this_thread();
        let n = server.diagnostics(uri);
        let p: PublishDiagnosticsParams = serde_json::from_value(n.params).unwrap();
        assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics);
        let value = |h: Option<Hover>| match h.expect("a hover").contents {
            HoverContents::Markup(m) => m.value,
            other => panic!("{other:?}"),
        };
        // A domain field after `°` on its line: its range is in UTF-16 units.
        let h = hover_at(&server, uri, utf16_at(WIDE, "d \"m²", 0, 0));
        let range = h.as_ref().unwrap().range.unwrap();
        assert_eq!(range.start, utf16_at(WIDE, "d \"m²", 0, 0));
        assert_eq!(range.end, utf16_at(WIDE, "d \"m²", 0, 1));
        assert_eq!(
            value(h),
            "observation dimension `d` of `wide`, in m², limits [0, 1]"
        );
        // The same field read in the operator's body, and its parameter, and its name.
        let body = WIDE.rfind("gain * d").unwrap();
        let h = hover_at(&server, uri, utf16_at(WIDE, "gain * d", 0, 7));
        assert_eq!(
            value(h),
            "observation dimension `d` of `wide`, in m², limits [0, 1]"
        );
        assert!(body > WIDE.find('😀').unwrap());
        let h = hover_at(&server, uri, utf16_at(WIDE, "gain * d", 0, 2));
        assert_eq!(value(h), "parameter `gain = 0.5 in [0, 1]`");
        let h = hover_at(&server, uri, utf16_at(WIDE, "nudge", 0, 5));
        assert!(value(h).contains("nudge(gain = 0.5 in [0, 1])"));
        let h = hover_at(&server, uri, utf16_at(WIDE, "free", 0, 1));
        assert_eq!(value(h), "observation dimension `free` of `wide`, in °");
        // A name in a comment is no node: no hover, though the word names the domain.
        assert!(hover_at(&server, uri, utf16_at(WIDE, "wide\n", 0, 1)).is_none());
        assert!(hover_at(&server, uri, utf16_at(WIDE, "😀", 0, 0)).is_none());
        // Many hovers later, the document was still analysed once.
        for i in 0..200 {
            let _ = hover_at(&server, uri, Position::new(i % 7, i));
        }
        assert_eq!(server.analysed, 1, "a hover must not analyse the document");
        let (checks, parses) = analysis::work_on_this_thread();
        assert_eq!(checks, before.0, "no hover checks the document again");
        assert_eq!(
            parses,
            before.1 + 1,
            "the first hover parses the tree, the others keep it"
        );
        server.notify(Notification::new(
            DidChangeTextDocument::METHOD.into(),
            serde_json::json!({"textDocument": {"uri": uri, "version": 2}, "contentChanges": [{"text": WIDE.replace("gain * d", "gain")}]}),
        ));
        assert_eq!(server.analysed, 2, "a change is analysed once");
    }

    #[test]
    fn a_client_without_utf16_gets_the_encoding_it_offers() {
        let offer = |kinds: serde_json::Value| {
            negotiate(
                &serde_json::json!({"capabilities": {"general": {"positionEncodings": kinds}}}),
            )
        };
        assert_eq!(
            offer(serde_json::json!(["utf-8", "utf-16"])),
            Encoding::Utf16
        );
        assert_eq!(
            offer(serde_json::json!(["utf-32", "utf-8"])),
            Encoding::Utf32
        );
        assert_eq!(offer(serde_json::json!(["utf-8"])), Encoding::Utf8);
        assert_eq!(offer(serde_json::json!(["latin-1"])), Encoding::Utf16);
        assert_eq!(negotiate(&serde_json::json!({})), Encoding::Utf16);
        assert_eq!(negotiate(&serde_json::json!(null)), Encoding::Utf16);
        // In UTF-8, a column is a byte count.
        let text = "é😀x";
        let index = LineIndex::new(text);
        let l = Positions::new(text, &index, Encoding::Utf8);
        assert_eq!(l.position(6), Position::new(0, 6));
        assert_eq!(l.offset(Position::new(0, 4)), 2, "inside 😀: its start");
    }

    #[test]
    fn changes_with_ranges_are_applied_and_diagnostics_carry_the_version() {
        let note =
            |method: &str, params: serde_json::Value| Notification::new(method.into(), params);
        let uri = "file:///x.adv";
        let mut server = Server::default();
        let text = "// é\noperator x for positioning on action { rot = 0 }\n";
        server.notify(note(
            DidOpenTextDocument::METHOD,
            serde_json::json!({"textDocument": {"uri": uri, "languageId": "advise", "version": 1, "text": text}}),
        ));
        // `rot` becomes `rott` (one character inserted after the non-ASCII line).
        let col = "operator x for positioning on action { rot".len();
        server.notify(note(
            DidChangeTextDocument::METHOD,
            serde_json::json!({"textDocument": {"uri": uri, "version": 2}, "contentChanges": [
                {"range": {"start": {"line": 1, "character": col}, "end": {"line": 1, "character": col}}, "text": "t"}
            ]}),
        ));
        let Held::Analysed(a) = &server.docs[uri].state else {
            panic!("not held")
        };
        assert_eq!(a.text(), text.replace("rot", "rott"));
        let n = server.diagnostics(uri);
        let p: PublishDiagnosticsParams = serde_json::from_value(n.params).unwrap();
        assert_eq!(p.version, Some(2));
        assert_eq!(p.diagnostics.len(), 1);
        server.notify(note(
            DidCloseTextDocument::METHOD,
            serde_json::json!({"textDocument": {"uri": uri}}),
        ));
        let n = server.diagnostics(uri);
        let p: PublishDiagnosticsParams = serde_json::from_value(n.params).unwrap();
        assert!(p.diagnostics.is_empty());
    }

    #[test]
    fn cache_paths_become_percent_encoded_file_uris() {
        let uri = file_uri(std::path::Path::new("/home/ana maría/.cache/advise/x.adv"));
        assert_eq!(
            uri.as_str(),
            "file:///home/ana%20mar%C3%ADa/.cache/advise/x.adv"
        );
    }

    proptest::proptest! {
        #[test]
        fn offsets_and_positions_round_trip(text in "(a|é|\u{1F600}|\n|\r\n| ){0,40}", at in 0usize..200) {
            let index = LineIndex::new(&text);
            let l = Positions::new(&text, &index, Encoding::Utf16);
            let p = l.position(at);
            let back = l.offset(p);
            proptest::prop_assert!(text.is_char_boundary(back));
            // The same position, or the end of its line's text when `at` was in its `\r\n`.
            let again = l.position(back);
            let ending = text[back..].starts_with("\r\n") && again.line == p.line;
            proptest::prop_assert!(again == p || ending, "{:?} {:?}", again, p);
        }
    }

    #[test]
    fn published_diagnostics_point_past_non_ascii_text() {
        let text = "// café 😀\noperator x for positioning on action { rott = 0 }\n";
        let d = publish("file:///x.adv", text);
        assert_eq!(d.len(), 1);
        let col = "operator x for positioning on action { ".len() as u32;
        assert_eq!(d[0].range.start, Position::new(1, col));
        assert_eq!(
            d[0].code,
            Some(NumberOrString::String(
                "advise::check::unknown_dimension".into()
            ))
        );
    }
}
