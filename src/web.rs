//! The teacher's view in a browser (issue 37): `advise serve`, and `advise repl --view` beside the
//! REPL. A local HTTP server (axum on a one-thread tokio runtime of its own thread) serves one
//! page, embedded in the binary, that draws the session from its JSON and changes it only by
//! statements: the page's Advise is `advise slow_down(0.2)` run by [`Session::execute`], so it is
//! journalled as the REPL's statements are, and a robot backend behaves as from the REPL.
//!
//! One session, one journal: the [`Hub`] holds the session behind a mutex, taken for one
//! statement at a time by the page's requests and by the REPL's loop ([`crate::repl::Statements`]).
//! A mutex rather than a channel to the REPL's thread: `advise serve` has no REPL thread, and the
//! REPL blocks in rustyline between statements, where a channel would leave the page's statements
//! waiting for the next line typed. Every statement run, from either side, is logged and
//! announced on a broadcast channel the page listens to (server-sent events), so each side sees
//! the other's statements at once. Stop does not wait for the lock: it raises the session's
//! [`StopSignal`], which commands a base to zero from the request's thread and ends a running
//! execution at its next control step, as Ctrl-C does at the REPL.
//!
//! Safe by default ([`guard`]): 127.0.0.1 unless `--listen` says otherwise, a per-session token,
//! `Host`/`Origin` checked, bodies at most [`MAX_BODY`] bytes.
//!
//! Bounded whoever connects (issue 47; [`Limits`]): the view's own accept loop holds at most
//! [`MAX_CONNECTIONS`] connections, and at the cap a new one closes the oldest connection that has
//! not yet sent a request with the token (half-open ones first), so a flood of connections from
//! anyone on the machine neither exhausts the process's file descriptors nor locks out the page;
//! headers must arrive within [`HEADER_TIMEOUT`] (hyper's header read timeout, also closing idle
//! connections), and a refused request closes its connection. Each connection buffers at most
//! [`MAX_BUFFER`] bytes of a response it does not read. At most [`MAX_SUBSCRIBERS`] event streams
//! are open (a new one closes the oldest), each event a shared, pre-serialized log entry whose
//! texts are cut at [`LOG_TEXT_KEPT`] bytes. A state carries the newest [`LOG_SHOWN`] log entries
//! (all the page draws) and is serialized once per change of the session and shared by every
//! request for it; the work waiting for the session runs on at most [`BLOCKING_THREADS`] threads.
//! A statement's reply is its own: taken from its execution under the lock, never read back
//! from the log.

pub mod guard;
pub mod pad;

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use axum::Router;
use axum::body::{Body, Bytes};
use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde::Serialize;
use serde_json::{Value, json};
use tokio::sync::{Notify, broadcast, watch};

use crate::repl::helper::Facts;
use crate::repl::{Statements, Typed};
use advise::backend::StopSignal;
use advise::session::{Reply, Session};

/// The largest request body accepted (a statement, an operator definition typed in the page).
pub const MAX_BODY: usize = 64 * 1024;
/// Statements kept in the log the page shows (older ones are in the journal).
pub const LOG_KEPT: usize = 1000;
/// Evaluations kept for the curve.
pub const EVALS_KEPT: usize = 1000;
/// The newest log entries a state carries (the page draws these).
pub const LOG_SHOWN: usize = 200;
/// The most bytes of a statement's text or of its reply kept in the log and sent in an event (the
/// statement's own reply is whole; the journal keeps every statement whole).
pub const LOG_TEXT_KEPT: usize = 4096;
/// The most connections the view holds open at once.
pub const MAX_CONNECTIONS: usize = 128;
/// The most event streams (`/api/events`) open at once.
pub const MAX_SUBSCRIBERS: usize = 16;
/// How long a client may take to send a request's headers (and an idle connection may stay open).
pub const HEADER_TIMEOUT: Duration = Duration::from_secs(10);
/// The most bytes one connection buffers (a request's headers, a response it does not read).
pub const MAX_BUFFER: usize = 64 * 1024;
/// Threads for the work that waits for the session (statements, states, Stop's wait for the base).
pub const BLOCKING_THREADS: usize = 8;

/// The view's bounds on what clients may hold ([`start_with`]; [`start`] uses the defaults).
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// At the cap, a new connection closes the oldest one without a tokened request yet, or is
    /// closed itself when every open one has sent the token.
    pub connections: usize,
    /// At the cap, a new event stream closes the oldest one.
    pub subscribers: usize,
    pub header_timeout: Duration,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            connections: MAX_CONNECTIONS,
            subscribers: MAX_SUBSCRIBERS,
            header_timeout: HEADER_TIMEOUT,
        }
    }
}

const PAGE_HTML: &str = include_str!("web/page.html");
const PAGE_CSS: &str = include_str!("web/page.css");
const PAGE_JS: &str = include_str!("web/page.js");

/// Why the view could not start.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum WebError {
    #[error("cannot listen on {addr}: {source}")]
    #[diagnostic(
        code(advise::web::listen),
        help(
            "choose another address or port with `--listen 127.0.0.1:PORT` (port 0 picks a free one)"
        )
    )]
    Listen {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("no random token could be made for the view: {0}")]
    #[diagnostic(
        code(advise::web::token),
        help(
            "the operating system's random source is not readable; the view does not start without a token"
        )
    )]
    Token(String),
}

/// One statement the session ran, as the page's log shows it.
#[derive(Clone, Debug, Serialize)]
pub struct Logged {
    /// Counts statements from 1 in this session's view.
    pub seq: u64,
    /// `page` or `repl`.
    pub from: &'static str,
    pub statement: String,
    pub ok: bool,
    /// The reply or the diagnostic, as plain text.
    pub reply: String,
}

/// A point of the eval curve: the dataset's size and the figures of one `eval`.
#[derive(Clone, Debug, Serialize)]
struct EvalPoint {
    seq: u64,
    points: usize,
    success_rate: f64,
    mean_position_error_m: f64,
}

struct Live {
    session: Session,
    log: Vec<Logged>,
    evals: Vec<EvalPoint>,
    seq: u64,
    /// Counts every time the session may have changed (statements, [`Hub::with`]).
    generation: u64,
    /// The last state served: its generation, the execution asked for, its JSON.
    snapshot: Option<(u64, Option<usize>, Bytes)>,
    /// Set by [`Hub::close`]: no statement runs after it.
    closed: bool,
}

struct Inner {
    live: Mutex<Live>,
    stop: StopSignal,
    /// The hold-to-drive pad: the session's live takeover, held outside its lock.
    pad: advise::session::Hold,
    events: broadcast::Sender<Arc<str>>,
}

/// The session shared by the page and the REPL (cheap to clone).
#[derive(Clone)]
pub struct Hub {
    inner: Arc<Inner>,
}

impl Hub {
    pub fn new(mut session: Session) -> Hub {
        let stop = session.stop_signal();
        let pad = pad::pad();
        session.set_live_takeover(Some(Box::new(pad.clone())));
        let (events, _) = broadcast::channel(256);
        Hub {
            inner: Arc::new(Inner {
                live: Mutex::new(Live {
                    session,
                    log: Vec::new(),
                    evals: Vec::new(),
                    seq: 0,
                    generation: 0,
                    snapshot: None,
                    closed: false,
                }),
                stop,
                pad,
                events,
            }),
        }
    }

    /// The page's hold-to-drive pad.
    pub fn pad(&self) -> &advise::session::Hold {
        &self.inner.pad
    }

    fn live(&self) -> MutexGuard<'_, Live> {
        // A statement that panicked leaves the session as it was when it did: keep serving it.
        self.inner.live.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Work on the session (the lock is held meanwhile).
    pub fn with<R>(&self, f: impl FnOnce(&mut Session) -> R) -> R {
        let mut live = self.live();
        live.generation += 1;
        f(&mut live.session)
    }

    /// End the session's statements: wait for the one running (a page's, taken from the lock),
    /// and refuse any that comes after. The REPL's loop calls it when it ends (`quit` or end of
    /// input), so a page's statement under way is journalled and answered before the process
    /// leaves ([`Server::shutdown`] then lets its reply out).
    pub fn close(&self) {
        self.live().closed = true;
    }

    pub fn stop_signal(&self) -> StopSignal {
        self.inner.stop.clone()
    }

    /// Run one statement on the session, log it and announce it; `colour` renders its
    /// diagnostic for a terminal.
    pub fn execute(&self, text: &str, origin: &str, from: &'static str, colour: bool) -> Typed {
        self.execute_logged(text, origin, from, colour).0
    }

    /// [`Hub::execute`], with the statement's own log entry (its `seq`, its whole reply as plain
    /// text): what a page's request answers, whatever other statements run meanwhile.
    pub fn execute_logged(
        &self,
        text: &str,
        origin: &str,
        from: &'static str,
        colour: bool,
    ) -> (Typed, Logged) {
        match self.execute_with(text, from, colour, |s| (s.execute(text, origin), ())) {
            Some((typed, (), logged)) => (typed, logged),
            None => ended(text, from),
        }
    }

    /// Run `preview INVOCATION` (or any statement) as [`Hub::execute`] does, under the same one
    /// lock, with the points a preview would add as data ([`Session::execute_previewing`]).
    pub fn preview(&self, text: &str, origin: &str, from: &'static str) -> (Typed, Value) {
        match self.execute_with(text, from, false, |s| s.execute_previewing(text, origin)) {
            Some((typed, data, _)) => (typed, data),
            None => (ended(text, from).0, Value::Null),
        }
    }

    /// [`Hub::execute`] with the statement run by `run`, which may give more than the reply;
    /// nothing when the hub is closed.
    fn execute_with<T>(
        &self,
        text: &str,
        from: &'static str,
        colour: bool,
        run: impl FnOnce(&mut Session) -> (Result<Reply, advise::session::SessionError>, T),
    ) -> Option<(Typed, T, Logged)> {
        let mut live = self.live();
        if live.closed {
            return None;
        }
        live.generation += 1;
        self.inner.stop.clear();
        let (result, more) = run(&mut live.session);
        let eval = match &result {
            Ok(Reply::Evaluated(e)) => {
                Some((e.report.success_rate, e.report.mean_position_error_m))
            }
            _ => None,
        };
        // The log is plain text; the terminal may want colour.
        let plain = match &result {
            Err(e) if colour => crate::repl::render(live.session.sources(), e, false),
            _ => String::new(),
        };
        let typed = crate::repl::shown(&live.session, result, colour);
        live.seq += 1;
        let seq = live.seq;
        if let Some((success_rate, mean_position_error_m)) = eval {
            let points = live.session.learner().len();
            let point = EvalPoint {
                seq,
                points,
                success_rate,
                mean_position_error_m,
            };
            push_bounded(&mut live.evals, point, EVALS_KEPT);
        }
        let plain = match &typed.shown {
            Ok(t) => t.clone(),
            Err(d) if !colour => d.clone(),
            Err(_) => plain,
        };
        let logged = Logged {
            seq,
            from,
            statement: text.trim_end().to_string(),
            ok: typed.shown.is_ok(),
            reply: plain,
        };
        let kept = Logged {
            statement: cut(&logged.statement),
            reply: cut(&logged.reply),
            ..logged.clone()
        };
        let event: Arc<str> = serde_json::to_string(&kept).unwrap_or_default().into();
        push_bounded(&mut live.log, kept, LOG_KEPT);
        drop(live);
        // No page listening is not an error.
        let _ = self.inner.events.send(event);
        Some((typed, more, logged))
    }

    /// The state the page draws: the session's view, the newest [`LOG_SHOWN`] log entries and
    /// the eval curve.
    pub fn state_json(&self, execution: Option<usize>) -> Value {
        state_of(&self.live(), execution)
    }

    /// [`Hub::state_json`] serialized, built once per change of the session (and execution asked
    /// for) and shared by every request that asks for it meanwhile.
    pub fn state_bytes(&self, execution: Option<usize>) -> Bytes {
        let mut live = self.live();
        if let Some((g, e, bytes)) = &live.snapshot
            && *g == live.generation
            && *e == execution
        {
            return bytes.clone();
        }
        let bytes =
            Bytes::from(serde_json::to_vec(&state_of(&live, execution)).unwrap_or_default());
        live.snapshot = Some((live.generation, execution, bytes.clone()));
        bytes
    }

    /// The statements logged so far (tests read it).
    pub fn log(&self) -> Vec<Logged> {
        self.live().log.clone()
    }

    /// Stop the robot from any thread, without waiting for a running statement: the signal
    /// commands a base to zero and ends the execution; when no statement holds the session,
    /// its base is also told to stop and waited for (bounded), as Ctrl-C at the prompt does.
    pub fn stop(&self) -> String {
        self.inner.stop.raise();
        match self.inner.live.try_lock() {
            Ok(mut live) => live.session.stop_robot(),
            Err(_) => "stop raised: the running statement ends at its next control step".into(),
        }
    }
}

fn state_of(live: &Live, execution: Option<usize>) -> Value {
    let mut v = live.session.view_json(execution);
    let shown = &live.log[live.log.len().saturating_sub(LOG_SHOWN)..];
    v["log"] = json!(shown);
    v["evals"] = json!(live.evals);
    v["seq"] = json!(live.seq);
    v
}

/// What a statement gets once the hub is closed: nothing ran.
fn ended(text: &str, from: &'static str) -> (Typed, Logged) {
    let reply = "the session has ended: the statement was not run".to_string();
    let logged = Logged {
        seq: 0,
        from,
        statement: text.trim_end().to_string(),
        ok: false,
        reply: reply.clone(),
    };
    let typed = Typed {
        shown: Err(reply),
        quit: false,
    };
    (typed, logged)
}

/// `text` cut to at most [`LOG_TEXT_KEPT`] bytes (at a character boundary), saying how much
/// was left out.
fn cut(text: &str) -> String {
    if text.len() <= LOG_TEXT_KEPT {
        return text.to_string();
    }
    let mut end = LOG_TEXT_KEPT;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!(
        "{}… ({} more bytes not kept in the view's log)",
        &text[..end],
        text.len() - end
    )
}

fn push_bounded<T>(v: &mut Vec<T>, item: T, kept: usize) {
    if v.len() >= kept {
        v.remove(0);
    }
    v.push(item);
}

/// The REPL of `advise repl --view` drives the shared session through the hub.
pub struct ReplSide(pub Hub);

impl Statements for ReplSide {
    fn execute(&mut self, text: &str, origin: &str, colour: bool) -> Typed {
        self.0.execute(text, origin, "repl", colour)
    }

    fn stop_robot(&mut self) -> String {
        self.0.stop()
    }

    fn facts(&self) -> Facts {
        self.0.with(|s| Statements::facts(s))
    }
}

/// A running view.
pub struct Server {
    pub addr: SocketAddr,
    /// The page's address, with the token: what to open on this machine (or through an SSH
    /// tunnel, with the tunnel's local port).
    pub url: String,
    /// Listening beyond loopback: the page's addresses for another machine (by this machine's
    /// name, and by its address on the network), with the token.
    pub remote_urls: Vec<String>,
    thread: std::thread::JoinHandle<()>,
    shutdown: watch::Sender<bool>,
    ended: std::sync::mpsc::Receiver<()>,
    conns: Arc<Conns>,
}

impl Server {
    /// How many connections and event streams the view holds now.
    pub fn connections(&self) -> (usize, usize) {
        self.conns.counts()
    }

    /// Wait until the server ends (it ends only with the process).
    pub fn wait(self) {
        let _ = self.thread.join();
    }

    /// Stop taking connections and requests, and give the requests under way up to `grace` to
    /// be answered (event streams end at once). Call [`Hub::close`] first, so no statement
    /// starts meanwhile.
    pub fn shutdown(self, grace: Duration) {
        let _ = self.shutdown.send(true);
        let _ = self.ended.recv_timeout(grace);
    }
}

#[derive(Clone)]
struct App {
    hub: Hub,
    token: Arc<str>,
    port: u16,
    /// Host names accepted besides loopback and IP literals ([`guard::host_allowed`]).
    allowed: Arc<[String]>,
    conns: Arc<Conns>,
    shutdown: watch::Receiver<bool>,
}

/// Start serving `hub`'s session on `listen` (port 0 picks a free port), on a thread of its own,
/// with the default [`Limits`].
pub fn start(hub: Hub, listen: SocketAddr) -> Result<Server, WebError> {
    start_with(hub, listen, Limits::default())
}

/// [`start`] with other bounds (tests use small ones).
pub fn start_with(hub: Hub, listen: SocketAddr, limits: Limits) -> Result<Server, WebError> {
    start_allowing(hub, listen, limits, Vec::new())
}

/// [`start_with`], accepting requests that name this server `allow_hosts` (`--allow-host NAME`);
/// listening beyond loopback, the machine's own name (and `NAME.local`) is accepted too.
pub fn start_allowing(
    hub: Hub,
    listen: SocketAddr,
    limits: Limits,
    mut allow_hosts: Vec<String>,
) -> Result<Server, WebError> {
    let token = guard::new_token().map_err(|e| WebError::Token(e.to_string()))?;
    let failed = |source| WebError::Listen {
        addr: listen,
        source,
    };
    let listener = std::net::TcpListener::bind(listen).map_err(failed)?;
    let addr = listener.local_addr().map_err(failed)?;
    listener.set_nonblocking(true).map_err(failed)?;
    let shown = if addr.ip().is_unspecified() {
        SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), addr.port())
    } else {
        addr
    };
    let url = format!("http://{shown}/?token={token}");
    let mut remote_urls = Vec::new();
    if !addr.ip().is_loopback() {
        let port = addr.port();
        if let Some(name) = machine_name() {
            remote_urls.push(format!("http://{name}:{port}/?token={token}"));
            allow_hosts.push(format!("{name}.local"));
            allow_hosts.push(name);
        }
        let ip = if addr.ip().is_unspecified() {
            outward_ip()
        } else {
            Some(addr.ip())
        };
        if let Some(ip) = ip {
            remote_urls.push(format!(
                "http://{}/?token={token}",
                SocketAddr::new(ip, port)
            ));
        }
        for name in &allow_hosts {
            let u = format!("http://{name}:{port}/?token={token}");
            if !name.ends_with(".local") && !remote_urls.contains(&u) {
                remote_urls.push(u);
            }
        }
    }
    let (shutdown, shutdown_rx) = watch::channel(false);
    let conns = Arc::new(Conns::new(limits));
    let app = App {
        hub,
        token: token.into(),
        port: addr.port(),
        allowed: allow_hosts.into(),
        conns: conns.clone(),
        shutdown: shutdown_rx,
    };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .max_blocking_threads(BLOCKING_THREADS)
        .build()
        .map_err(failed)?;
    let (ended_tx, ended) = std::sync::mpsc::channel();
    let thread = std::thread::Builder::new()
        .name("advise-web".into())
        .spawn(move || {
            runtime.block_on(async move {
                if let Ok(listener) = tokio::net::TcpListener::from_std(listener) {
                    serve(listener, app).await;
                }
            });
            let _ = ended_tx.send(());
        })
        .map_err(failed)?;
    Ok(Server {
        addr,
        url,
        remote_urls,
        thread,
        shutdown,
        ended,
        conns,
    })
}

/// The connections the view holds: each one's place in the order they came, whether it has
/// sent the token, whether it is an event stream, and how to close it.
struct Conns {
    limits: Limits,
    table: Mutex<ConnTable>,
}

#[derive(Default)]
struct ConnTable {
    next: u64,
    open: BTreeMap<u64, Slot>,
}

struct Slot {
    authorized: bool,
    subscriber: bool,
    close: Arc<Notify>,
}

/// One connection, as a request on it knows it (a request extension).
#[derive(Clone)]
struct Conn {
    id: u64,
    conns: Arc<Conns>,
}

impl Conns {
    fn new(limits: Limits) -> Conns {
        Conns {
            limits,
            table: Mutex::new(ConnTable::default()),
        }
    }

    fn table(&self) -> MutexGuard<'_, ConnTable> {
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A place for a new connection: at the cap, the oldest one without the token is closed to
    /// make room; nothing when every open connection has sent the token.
    fn admit(&self) -> Option<(u64, Arc<Notify>)> {
        let mut t = self.table();
        if t.open.len() >= self.limits.connections.max(1) {
            let oldest = t
                .open
                .iter()
                .find(|(_, s)| !s.authorized)
                .map(|(id, _)| *id)?;
            if let Some(slot) = t.open.remove(&oldest) {
                slot.close.notify_one();
            }
        }
        let id = t.next;
        t.next += 1;
        let close = Arc::new(Notify::new());
        t.open.insert(
            id,
            Slot {
                authorized: false,
                subscriber: false,
                close: close.clone(),
            },
        );
        Some((id, close))
    }

    fn authorize(&self, id: u64) {
        if let Some(slot) = self.table().open.get_mut(&id) {
            slot.authorized = true;
        }
    }

    /// Make connection `id` an event stream: at the cap, the oldest stream is closed.
    fn subscribe(&self, id: u64) {
        let mut t = self.table();
        let streams = t.open.values().filter(|s| s.subscriber).count();
        if streams >= self.limits.subscribers.max(1) {
            let oldest = t
                .open
                .iter()
                .find(|(i, s)| s.subscriber && **i != id)
                .map(|(i, _)| *i);
            if let Some(slot) = oldest.and_then(|i| t.open.remove(&i)) {
                slot.close.notify_one();
            }
        }
        if let Some(slot) = t.open.get_mut(&id) {
            slot.subscriber = true;
        }
    }

    fn remove(&self, id: u64) {
        self.table().open.remove(&id);
    }

    /// How many connections and event streams are open (tests read it).
    fn counts(&self) -> (usize, usize) {
        let t = self.table();
        let streams = t.open.values().filter(|s| s.subscriber).count();
        (t.open.len(), streams)
    }
}

/// The view's accept loop: each connection admitted ([`Conns::admit`]) is served on a task of
/// its own; on shutdown, every connection finishes the request under way and the loop ends when
/// all have.
async fn serve(listener: tokio::net::TcpListener, app: App) {
    let router = router(app.clone());
    let mut tasks = tokio::task::JoinSet::new();
    let mut shutdown = app.shutdown.clone();
    loop {
        let accepted = tokio::select! {
            a = listener.accept() => a,
            _ = shutdown.wait_for(|s| *s) => break,
        };
        while tasks.try_join_next().is_some() {}
        let stream = match accepted {
            Ok((stream, _)) => stream,
            Err(e) => {
                // Out of file descriptors (or another failure of the listener): wait a little
                // rather than spin; a connection error is the client's and needs no wait.
                if !matches!(
                    e.kind(),
                    std::io::ErrorKind::ConnectionRefused
                        | std::io::ErrorKind::ConnectionAborted
                        | std::io::ErrorKind::ConnectionReset
                ) {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
                continue;
            }
        };
        // Refused: closed at once.
        let Some((id, close)) = app.conns.admit() else {
            continue;
        };
        let conn = Conn {
            id,
            conns: app.conns.clone(),
        };
        tasks.spawn(serve_connection(
            stream,
            router.clone(),
            conn,
            close,
            app.shutdown.clone(),
        ));
    }
    while tasks.join_next().await.is_some() {}
}

async fn serve_connection(
    stream: tokio::net::TcpStream,
    router: Router,
    conn: Conn,
    close: Arc<Notify>,
    mut shutdown: watch::Receiver<bool>,
) {
    use hyper::service::Service as _;
    let (id, conns) = (conn.id, conn.conns.clone());
    let tower = hyper_util::service::TowerToHyperService::new(router);
    let service = hyper::service::service_fn(move |mut req: hyper::Request<_>| {
        req.extensions_mut().insert(conn.clone());
        tower.call(req)
    });
    let mut builder = hyper::server::conn::http1::Builder::new();
    builder
        .timer(hyper_util::rt::TokioTimer::new())
        .header_read_timeout(conns.limits.header_timeout)
        .max_buf_size(MAX_BUFFER);
    let connection = builder.serve_connection(hyper_util::rt::TokioIo::new(stream), service);
    let mut connection = std::pin::pin!(connection);
    let mut ending = false;
    loop {
        tokio::select! {
            _ = connection.as_mut() => break,
            // Closed to make room (or an event stream replaced): dropped, its socket with it.
            _ = close.notified() => break,
            _ = shutdown.wait_for(|s| *s), if !ending => {
                ending = true;
                connection.as_mut().graceful_shutdown();
            }
        }
    }
    conns.remove(id);
}

/// Whether `addr` is reachable from this machine only; otherwise the caller warns.
pub fn is_private(addr: &SocketAddr) -> bool {
    addr.ip().is_loopback()
}

/// This machine's name (Linux's `/proc/sys/kernel/hostname`, else `/etc/hostname`), if it is a
/// plain host name.
fn machine_name() -> Option<String> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let name = read("/proc/sys/kernel/hostname").or_else(|| read("/etc/hostname"))?;
    let name = name.trim();
    let plain = !name.is_empty()
        && name.len() <= 253
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '.');
    (plain && name != "localhost").then(|| name.to_string())
}

/// The address other machines reach this one by: the one the kernel would send from toward
/// another network. A UDP `connect` only chooses the route; nothing is sent.
fn outward_ip() -> Option<std::net::IpAddr> {
    let s = std::net::UdpSocket::bind("0.0.0.0:0").ok()?;
    // TEST-NET-1 (RFC 5737): never a real peer.
    s.connect("192.0.2.1:9").ok()?;
    let ip = s.local_addr().ok()?.ip();
    (!ip.is_unspecified() && !ip.is_loopback()).then_some(ip)
}

fn router(app: App) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/api/state", get(state))
        .route("/api/statement", post(statement))
        .route("/api/preview", post(preview))
        .route("/api/stop", post(stop))
        .route("/api/takeover", post(takeover))
        .route("/api/events", get(events))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .layer(middleware::from_fn_with_state(app.clone(), checked))
        .with_state(app)
}

/// Every request passes here first: refused with 403 (and nothing run, the connection closed)
/// unless [`guard::check`] accepts it; accepted, its connection counts as the page's.
async fn checked(State(app): State<App>, req: Request, next: Next) -> Response {
    match guard::check(
        &app.token,
        app.port,
        &app.allowed,
        req.uri().query(),
        req.headers(),
    ) {
        Ok(()) => {
            if let Some(conn) = req.extensions().get::<Conn>() {
                app.conns.authorize(conn.id);
            }
            let mut res = next.run(req).await;
            let h = res.headers_mut();
            // The token is in the page's URL: never send it on as a referrer; never framed.
            h.insert(
                header::REFERRER_POLICY,
                "no-referrer".parse().unwrap_or_else(|_| unreachable!()),
            );
            h.insert(
                header::X_FRAME_OPTIONS,
                header::HeaderValue::from_static("DENY"),
            );
            h.insert(
                header::CACHE_CONTROL,
                header::HeaderValue::from_static("no-store"),
            );
            res
        }
        Err(refusal) => (
            StatusCode::FORBIDDEN,
            [(header::CONNECTION, "close")],
            refusal.text(),
        )
            .into_response(),
    }
}

fn json_response(v: &Value) -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        serde_json::to_string(v).unwrap_or_default(),
    )
        .into_response()
}

/// The page: HTML with its style and script inlined (one request, nothing to build).
async fn page() -> Response {
    let html = PAGE_HTML
        .replace("/*STYLE*/", PAGE_CSS)
        .replace("/*SCRIPT*/", PAGE_JS);
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (
                header::CONTENT_SECURITY_POLICY,
                "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; connect-src 'self'; img-src 'self' data:",
            ),
        ],
        html,
    )
        .into_response()
}

fn query_usize(req: &Request, key: &str) -> Option<usize> {
    req.uri()
        .query()?
        .split('&')
        .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
        .and_then(|v| v.parse().ok())
}

async fn state(State(app): State<App>, req: Request) -> Response {
    let execution = query_usize(&req, "execution");
    let hub = app.hub.clone();
    match tokio::task::spawn_blocking(move || hub.state_bytes(execution)).await {
        Ok(bytes) => (
            [(header::CONTENT_TYPE, "application/json")],
            Body::from(bytes),
        )
            .into_response(),
        Err(_) => StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    }
}

/// Run the body as a statement of the session, from the page; the reply and `seq` are its own.
async fn statement(State(app): State<App>, body: String) -> Response {
    let hub = app.hub.clone();
    let run = move || {
        let (typed, logged) = hub.execute_logged(&body, "<page>", "page", false);
        json!({
            "ok": typed.shown.is_ok(),
            "reply": logged.reply,
            "seq": (logged.seq > 0).then_some(logged.seq),
        })
    };
    match tokio::task::spawn_blocking(run).await {
        Ok(v) => json_response(&v),
        Err(_) => StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    }
}

/// Run `preview INVOCATION` (the body) as a statement, and give its synthesized points as data.
async fn preview(State(app): State<App>, body: String) -> Response {
    let hub = app.hub.clone();
    let run = move || {
        let (typed, data) = hub.preview(&body, "<page>", "page");
        json!({"ok": typed.shown.is_ok(), "reply": typed.shown.unwrap_or_else(|e| e), "preview": data})
    };
    match tokio::task::spawn_blocking(run).await {
        Ok(v) => json_response(&v),
        Err(_) => StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    }
}

async fn stop(State(app): State<App>) -> Response {
    // Raised here at once, even when every thread for blocking work waits for the session.
    app.hub.inner.stop.raise();
    let hub = app.hub.clone();
    match tokio::task::spawn_blocking(move || hub.stop()).await {
        Ok(text) => json_response(&json!({"ok": true, "reply": text})),
        Err(_) => StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    }
}

/// The hold-to-drive pad (`{"speed": S, "turn": T}` as fractions of the base's limits while
/// held, `{"release": true}` when let go): answered at once, without the session's lock, which
/// a running run holds.
async fn takeover(State(app): State<App>, body: String) -> Response {
    let post: pad::Post = match serde_json::from_str(&body) {
        Ok(p) => p,
        Err(e) => {
            return (StatusCode::BAD_REQUEST, format!("not a pad's post: {e}")).into_response();
        }
    };
    match pad::post(&app.hub.inner.pad, &post) {
        Ok(()) => json_response(&json!({"ok": true})),
        Err(why) => (StatusCode::BAD_REQUEST, why).into_response(),
    }
}

/// Server-sent events: one `statement` event per statement run, from the page or the REPL. The
/// stream ends when the view shuts down or when [`MAX_SUBSCRIBERS`] newer ones replace it.
async fn events(State(app): State<App>, req: Request) -> Response {
    if let Some(conn) = req.extensions().get::<Conn>() {
        app.conns.subscribe(conn.id);
    }
    let rx = app.hub.inner.events.subscribe();
    let stream = futures_util::stream::unfold(
        (rx, app.shutdown.clone()),
        |(mut rx, mut shutdown)| async move {
            loop {
                let received = tokio::select! {
                    r = rx.recv() => r,
                    _ = shutdown.wait_for(|s| *s) => return None,
                };
                match received {
                    Ok(data) => {
                        let ev = Event::default().event("statement").data(&*data);
                        return Some((Ok::<_, std::convert::Infallible>(ev), (rx, shutdown)));
                    }
                    // A slow page missed some: it re-reads the whole state on the next one anyway.
                    Err(broadcast::error::RecvError::Lagged(_)) => continue,
                    Err(broadcast::error::RecvError::Closed) => return None,
                }
            }
        },
    );
    Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response()
}
