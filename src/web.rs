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

pub mod guard;

use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};

use axum::Router;
use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde::Serialize;
use serde_json::{Value, json};
use tokio::sync::broadcast;

use crate::backend::StopSignal;
use crate::repl::helper::Facts;
use crate::repl::{Statements, Typed};
use crate::session::{Reply, Session};

/// The largest request body accepted (a statement, an operator definition typed in the page).
pub const MAX_BODY: usize = 64 * 1024;
/// Statements kept in the log the page shows (older ones are in the journal).
pub const LOG_KEPT: usize = 1000;
/// Evaluations kept for the curve.
pub const EVALS_KEPT: usize = 1000;

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
}

struct Inner {
    live: Mutex<Live>,
    stop: StopSignal,
    events: broadcast::Sender<String>,
}

/// The session shared by the page and the REPL (cheap to clone).
#[derive(Clone)]
pub struct Hub {
    inner: Arc<Inner>,
}

impl Hub {
    pub fn new(session: Session) -> Hub {
        let stop = session.stop_signal();
        let (events, _) = broadcast::channel(256);
        Hub {
            inner: Arc::new(Inner {
                live: Mutex::new(Live {
                    session,
                    log: Vec::new(),
                    evals: Vec::new(),
                    seq: 0,
                }),
                stop,
                events,
            }),
        }
    }

    fn live(&self) -> MutexGuard<'_, Live> {
        // A statement that panicked leaves the session as it was when it did: keep serving it.
        self.inner.live.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Work on the session (the lock is held meanwhile).
    pub fn with<R>(&self, f: impl FnOnce(&mut Session) -> R) -> R {
        f(&mut self.live().session)
    }

    pub fn stop_signal(&self) -> StopSignal {
        self.inner.stop.clone()
    }

    /// Run one statement on the session, log it and announce it; `colour` renders its
    /// diagnostic for a terminal.
    pub fn execute(&self, text: &str, origin: &str, from: &'static str, colour: bool) -> Typed {
        self.execute_with(text, from, colour, |s| (s.execute(text, origin), ()))
            .0
    }

    /// Run `preview INVOCATION` (or any statement) as [`Hub::execute`] does, under the same one
    /// lock, with the points a preview would add as data ([`Session::execute_previewing`]).
    pub fn preview(&self, text: &str, origin: &str, from: &'static str) -> (Typed, Value) {
        self.execute_with(text, from, false, |s| s.execute_previewing(text, origin))
    }

    /// [`Hub::execute`] with the statement run by `run`, which may give more than the reply.
    fn execute_with<T>(
        &self,
        text: &str,
        from: &'static str,
        colour: bool,
        run: impl FnOnce(&mut Session) -> (Result<Reply, crate::session::SessionError>, T),
    ) -> (Typed, T) {
        let mut live = self.live();
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
        push_bounded(&mut live.log, logged.clone(), LOG_KEPT);
        drop(live);
        // No page listening is not an error.
        let _ = self
            .inner
            .events
            .send(serde_json::to_string(&logged).unwrap_or_default());
        (typed, more)
    }

    /// The state the page draws: the session's view, the statement log and the eval curve.
    pub fn state_json(&self, execution: Option<usize>) -> Value {
        let live = self.live();
        let mut v = live.session.view_json(execution);
        v["log"] = json!(live.log);
        v["evals"] = json!(live.evals);
        v["seq"] = json!(live.seq);
        v
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
    /// The page's address, with the token: what to open.
    pub url: String,
    thread: std::thread::JoinHandle<()>,
}

impl Server {
    /// Wait until the server ends (it ends only with the process).
    pub fn wait(self) {
        let _ = self.thread.join();
    }
}

#[derive(Clone)]
struct App {
    hub: Hub,
    token: Arc<str>,
    port: u16,
}

/// Start serving `hub`'s session on `listen` (port 0 picks a free port), on a thread of its own.
pub fn start(hub: Hub, listen: SocketAddr) -> Result<Server, WebError> {
    let token = guard::new_token().map_err(|e| WebError::Token(e.to_string()))?;
    let listener = std::net::TcpListener::bind(listen).map_err(|source| WebError::Listen {
        addr: listen,
        source,
    })?;
    let addr = listener.local_addr().map_err(|source| WebError::Listen {
        addr: listen,
        source,
    })?;
    listener
        .set_nonblocking(true)
        .map_err(|source| WebError::Listen {
            addr: listen,
            source,
        })?;
    let shown = if addr.ip().is_unspecified() {
        SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), addr.port())
    } else {
        addr
    };
    let url = format!("http://{shown}/?token={token}");
    let app = App {
        hub,
        token: token.into(),
        port: addr.port(),
    };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|source| WebError::Listen {
            addr: listen,
            source,
        })?;
    let thread = std::thread::Builder::new()
        .name("advise-web".into())
        .spawn(move || {
            runtime.block_on(async move {
                let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                    return;
                };
                let _ = axum::serve(listener, router(app)).await;
            });
        })
        .map_err(|source| WebError::Listen {
            addr: listen,
            source,
        })?;
    Ok(Server { addr, url, thread })
}

/// Whether `addr` is reachable from this machine only; otherwise the caller warns.
pub fn is_private(addr: &SocketAddr) -> bool {
    addr.ip().is_loopback()
}

fn router(app: App) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/api/state", get(state))
        .route("/api/statement", post(statement))
        .route("/api/preview", post(preview))
        .route("/api/stop", post(stop))
        .route("/api/events", get(events))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .layer(middleware::from_fn_with_state(app.clone(), checked))
        .with_state(app)
}

/// Every request passes here first: refused with 403 (and nothing run) unless [`guard::check`]
/// accepts it.
async fn checked(State(app): State<App>, req: Request, next: Next) -> Response {
    match guard::check(&app.token, app.port, req.uri().query(), req.headers()) {
        Ok(()) => {
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
        Err(refusal) => (StatusCode::FORBIDDEN, refusal.text()).into_response(),
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
    match tokio::task::spawn_blocking(move || hub.state_json(execution)).await {
        Ok(v) => json_response(&v),
        Err(_) => StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    }
}

/// Run the body as a statement of the session, from the page.
async fn statement(State(app): State<App>, body: String) -> Response {
    let hub = app.hub.clone();
    let run = move || {
        let typed = hub.execute(&body, "<page>", "page", false);
        let logged = hub.log().pop();
        json!({
            "ok": typed.shown.is_ok(),
            "reply": logged.as_ref().map(|l| l.reply.clone()),
            "seq": logged.map(|l| l.seq),
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
    let hub = app.hub.clone();
    match tokio::task::spawn_blocking(move || hub.stop()).await {
        Ok(text) => json_response(&json!({"ok": true, "reply": text})),
        Err(_) => StatusCode::INTERNAL_SERVER_ERROR.into_response(),
    }
}

/// Server-sent events: one `statement` event per statement run, from the page or the REPL.
async fn events(State(app): State<App>) -> Response {
    let rx = app.hub.inner.events.subscribe();
    let stream = futures_util::stream::unfold(rx, |mut rx| async move {
        loop {
            match rx.recv().await {
                Ok(data) => {
                    let ev = Event::default().event("statement").data(data);
                    return Some((Ok::<_, std::convert::Infallible>(ev), rx));
                }
                // A slow page missed some: it re-reads the whole state on the next one anyway.
                Err(broadcast::error::RecvError::Lagged(_)) => continue,
                Err(broadcast::error::RecvError::Closed) => return None,
            }
        }
    });
    Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response()
}
