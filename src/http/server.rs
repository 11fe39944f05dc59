//! The connection loop: accepts TCP connections and serves each with hyper's HTTP/1.1, with
//! the limits a public server needs and `axum::serve` does not set:
//!
//! - a **header-read timeout** ([`HttpConfig::header_timeout`]): a client must send a whole
//!   request head within it, and an idle keep-alive connection is closed after it (slowloris,
//!   sockets held open and silent);
//! - a **per-address connection cap** ([`HttpConfig::max_connections_per_client`]): past it
//!   the address's next connection is shed with `429 too-many` (as below);
//! - a **connection cap** ([`HttpConfig::max_connections`]): past it a connection is shed: it
//!   gets `503` problem+json with `Retry-After` at once, except `GET /healthz`, which is still
//!   answered, so a flood of idle sockets cannot make the process look dead; past
//!   [`HttpConfig::shed_slots`] connections being shed (each with half a second to send its
//!   request line), [`QUICK_SHEDDING`] more get 50 ms, and past those new ones are closed
//!   unanswered;
//! - request heads larger than our limits are refused by [`limit_head`] as problem+json
//!   (`414` for a long URI, `431` for too many or too large headers); heads hyper cannot
//!   parse or buffer at all get hyper's own `400`/`414`/`431`, which [`super::wire`] gives
//!   a problem+json body.
//!
//! Body-read deadlines are applied where bodies are read (`routes::body_bytes`).

use super::{AppError, HttpConfig, limits};
use axum::Router;
use axum::extract::Request;
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use std::future::Future;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::{Semaphore, watch};

/// Longest request target, bytes (414 past it).
pub const MAX_URI: usize = 8 << 10;
/// Most header fields in a request (431 past it).
pub const MAX_HEADERS: usize = 100;
/// Most bytes of header names and values together (431 past it).
pub const MAX_HEADER_BYTES: usize = 32 << 10;
/// Connections being shed at once with [`SHED_READ`] (the default of
/// [`HttpConfig::shed_slots`]).
pub const MAX_SHEDDING: usize = 1024;
/// How long a shed connection gets to send its request line, and to take its answer.
const SHED_READ: Duration = Duration::from_millis(500);
/// Connections shed at once with only [`QUICK_READ`], once [`HttpConfig::shed_slots`] are
/// taken (a flood of silent sockets): a prober that sends its request as it connects is still
/// answered; past these, new connections are closed unanswered.
pub const QUICK_SHEDDING: usize = 1024;
const QUICK_READ: Duration = Duration::from_millis(50);

/// Raises the open-file limit to its hard limit and returns the connection cap that fits in
/// it: `wanted`, or less when the limit leaves no room for that many connections besides those
/// being shed, the database, artifacts and the GPU driver (then logged).
pub fn fit_file_limit(wanted: usize) -> usize {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit/setrlimit read and write the one struct passed.
    if unsafe { libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) } != 0 {
        return wanted;
    }
    if lim.rlim_cur < lim.rlim_max {
        let raised = libc::rlimit {
            rlim_cur: lim.rlim_max,
            rlim_max: lim.rlim_max,
        };
        if unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &raised) } == 0 {
            lim = raised;
        }
    }
    let room = (lim.rlim_cur as usize).saturating_sub(MAX_SHEDDING + QUICK_SHEDDING + 256);
    if room < wanted {
        tracing::warn!(
            wanted,
            open_files = lim.rlim_cur,
            cap = room.max(1),
            "the open-file limit leaves room for fewer connections than asked; capping"
        );
    }
    wanted.min(room).max(1)
}

/// Connection counters, for `/metrics`.
#[derive(Default, Debug)]
pub struct ConnStats {
    pub open: AtomicU64,
    pub accepted: AtomicU64,
    pub shed: AtomicU64,
    pub dropped: AtomicU64,
}

/// Refuses request heads over [`MAX_URI`], [`MAX_HEADERS`] or [`MAX_HEADER_BYTES`] with a
/// problem (hyper's own, higher limits answer without a body).
pub async fn limit_head(req: Request, next: Next) -> Response {
    let uri = req.uri().to_string().len();
    if uri > MAX_URI {
        return AppError::new(
            StatusCode::URI_TOO_LONG,
            "uri-too-long",
            "URI too long",
            format!("the request target is {uri} bytes; the limit is {MAX_URI}"),
        )
        .into_response();
    }
    let h = req.headers();
    let bytes: usize = h.iter().map(|(k, v)| k.as_str().len() + v.len()).sum();
    if h.len() > MAX_HEADERS || bytes > MAX_HEADER_BYTES {
        return AppError::new(
            StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
            "headers-too-large",
            "Request header fields too large",
            format!(
                "the request has {} header fields of {bytes} bytes; the limits are \
                 {MAX_HEADERS} fields and {MAX_HEADER_BYTES} bytes",
                h.len()
            ),
        )
        .into_response();
    }
    next.run(req).await
}

/// Bytes of request bodies being received or held at once, process-wide: each body takes one
/// permit per KiB as its bytes arrive ([`super::limits::ChargedBody`]) and gives them back when
/// it is answered; past [`HttpConfig::max_body_bytes_in_flight`], `503 busy` with
/// `Retry-After`.
pub struct BodyBudget(Arc<Semaphore>);

impl BodyBudget {
    pub fn new(bytes: usize) -> BodyBudget {
        BodyBudget(Arc::new(Semaphore::new(kib(bytes) as usize)))
    }

    /// Bytes free now.
    pub fn available(&self) -> usize {
        self.0.available_permits() << 10
    }
}

fn kib(bytes: usize) -> u32 {
    u32::try_from(bytes.div_ceil(1024)).unwrap_or(u32::MAX)
}

/// `r` with `Connection: close`: the request's body is left unread, so the connection cannot
/// carry another request (as for a 413).
fn closing(mut r: Response) -> Response {
    r.headers_mut().insert(
        axum::http::header::CONNECTION,
        axum::http::HeaderValue::from_static("close"),
    );
    r
}

fn busy(cfg: &HttpConfig) -> Response {
    closing(
        AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "busy",
            "Busy",
            format!(
                "the server is receiving as many request bytes as it holds at once ({} MiB); \
             retry shortly",
                cfg.max_body_bytes_in_flight >> 20
            ),
        )
        .retry_after(1)
        .into_response(),
    )
}

/// The middleware of [`BodyBudget`] and of the per-client upload cap: a request body counts
/// as one of its client's uploads until it has been read ([`HttpConfig::max_uploads_per_client`],
/// `429` past it), and its bytes are charged to the budget as they arrive. It also names the
/// request's client ([`limits::Client`]) for the handlers. A declared length the budget
/// has no room for now is refused at once (`503`) rather than read and refused midway.
pub async fn admit_body(
    axum::extract::State(st): axum::extract::State<super::AppState>,
    mut req: Request,
    next: Next,
) -> Response {
    let client = limits::client_of(&req);
    req.extensions_mut().insert(limits::Client(client.clone()));
    let declared = req
        .headers()
        .get(axum::http::header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<usize>().ok());
    let chunked = req
        .headers()
        .contains_key(axum::http::header::TRANSFER_ENCODING);
    if !(chunked || declared.is_some_and(|n| n > 0)) {
        return next.run(req).await;
    }
    let upload = match st
        .limits
        .uploads
        .take(&client, st.cfg.max_uploads_per_client)
    {
        Ok(h) => h,
        Err(n) => {
            return closing(
                limits::too_many("uploads", n, "CAUSTICA_MAX_UPLOADS_PER_CLIENT").into_response(),
            );
        }
    };
    // Only what can be received is checked up front; what a body takes is what it sends.
    if declared.is_some_and(|n| n.min(st.cfg.max_body) > st.bodies.available()) {
        return busy(&st.cfg);
    }
    let charge = Arc::new(limits::Charge::default());
    let (parts, body) = req.into_parts();
    let body = limits::ChargedBody::new(body, st.bodies.0.clone(), charge.clone(), Some(upload));
    let r = next
        .run(Request::from_parts(parts, axum::body::Body::new(body)))
        .await;
    // The handler saw its body end early; whatever it answered, the cause is the budget.
    if charge.exhausted.load(Ordering::SeqCst) {
        return busy(&st.cfg);
    }
    r
}

/// Serves `app` on `listener` until `shutdown` resolves, then stops accepting, asks every
/// connection to close after its request in flight, and waits for them.
pub async fn run(
    listener: tokio::net::TcpListener,
    app: Router,
    cfg: Arc<HttpConfig>,
    stats: Arc<ConnStats>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) {
    let slots = Arc::new(Semaphore::new(cfg.max_connections));
    let shedding = Arc::new(Semaphore::new(cfg.shed_slots));
    let quick = Arc::new(Semaphore::new(QUICK_SHEDDING));
    let per_client = Arc::new(limits::PerClient::default());
    // Connections watch `stop` for the graceful shutdown; `done_rx` clones live as long as
    // they do.
    let (stop_tx, stop_rx) = watch::channel(false);
    let (done_tx, done_rx) = watch::channel(());
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, addr) = tokio::select! {
            _ = &mut shutdown => break,
            r = listener.accept() => match r {
                Ok(c) => c,
                Err(e) => {
                    // Out of file descriptors (or a connection reset before accept): back off
                    // briefly instead of spinning; the loop goes on.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
        };
        let _ = stream.set_nodelay(true);
        let client = format!("ip:{}", addr.ip());
        let mine = per_client.take(&client, cfg.max_connections_per_client);
        let slot = match mine {
            Ok(mine) => slots
                .clone()
                .try_acquire_owned()
                .map(|p| (p, mine))
                .map_err(|_| Shed::Overloaded),
            Err(n) => Err(Shed::PerClient(n)),
        };
        match slot {
            Ok((permit, mine)) => {
                stats.accepted.fetch_add(1, Ordering::Relaxed);
                stats.open.fetch_add(1, Ordering::Relaxed);
                let (app, cfg, stats) = (app.clone(), cfg.clone(), stats.clone());
                let (mut stop, done) = (stop_rx.clone(), done_rx.clone());
                tokio::spawn(async move {
                    use tower::ServiceExt;
                    let app = app.map_request(move |mut r: Request<hyper::body::Incoming>| {
                        r.extensions_mut().insert(axum::extract::ConnectInfo(addr));
                        r
                    });
                    let svc = TowerToHyperService::new(app);
                    let mut b = hyper::server::conn::http1::Builder::new();
                    b.timer(TokioTimer::new())
                        .header_read_timeout(cfg.header_timeout)
                        .max_headers(2 * MAX_HEADERS)
                        .keep_alive(true);
                    let io = TokioIo::new(super::wire::ProblemIo::new(stream));
                    let conn = b.serve_connection(io, svc);
                    let mut conn = std::pin::pin!(conn);
                    let r = tokio::select! {
                        r = conn.as_mut() => r,
                        _ = async { let _ = stop.wait_for(|s| *s).await; } => {
                            conn.as_mut().graceful_shutdown();
                            // Serve out the request in flight, then end.
                            conn.as_mut().await
                        }
                    };
                    if let Err(e) = r {
                        tracing::debug!(error = %e, "connection ended");
                    }
                    stats.open.fetch_sub(1, Ordering::Relaxed);
                    drop((permit, mine, done));
                });
            }
            Err(why) => {
                // An address over its own cap gets only the quick slots: its reconnects do not
                // take the slots that answer everyone else's overload.
                let first = match why {
                    Shed::Overloaded => shedding.clone().try_acquire_owned().ok(),
                    Shed::PerClient(_) => None,
                };
                let slot = match first {
                    Some(p) => Some((p, SHED_READ)),
                    None => quick
                        .clone()
                        .try_acquire_owned()
                        .ok()
                        .map(|p| (p, QUICK_READ)),
                };
                match slot {
                    Some((permit, wait)) => {
                        stats.shed.fetch_add(1, Ordering::Relaxed);
                        tokio::spawn(async move {
                            shed(stream, wait, why).await;
                            drop(permit);
                        });
                    }
                    None => {
                        stats.dropped.fetch_add(1, Ordering::Relaxed);
                        drop(stream);
                    }
                }
            }
        }
    }
    drop(listener);
    stop_tx.send_replace(true);
    drop(done_rx);
    // Requests in flight get the shutdown grace; a client that stops reading its answer does
    // not hold the process past it.
    if tokio::time::timeout(cfg.shutdown_grace, done_tx.closed())
        .await
        .is_err()
    {
        tracing::warn!("connections still open after the grace; closing them");
    }
}

/// Why a connection is shed.
#[derive(Clone, Copy)]
enum Shed {
    /// The server holds [`HttpConfig::max_connections`].
    Overloaded,
    /// Its address holds [`HttpConfig::max_connections_per_client`] (this many).
    PerClient(usize),
}

/// Answers a connection past a cap: `/healthz` as usual, anything else `503` (the server's
/// cap) or `429` (its address's) with `Retry-After`; then closes it. `wait` bounds the wait
/// for the request line, the write of the answer and the lingering close, each.
async fn shed(mut stream: TcpStream, wait: Duration, why: Shed) {
    let mut buf = [0u8; 256];
    let mut n = 0;
    let read = async {
        while n < buf.len() && !buf[..n].contains(&b'\n') {
            match stream.read(&mut buf[n..]).await {
                Ok(0) | Err(_) => break,
                Ok(k) => n += k,
            }
        }
    };
    if tokio::time::timeout(wait, read).await.is_err() {
        return;
    }
    let line = &buf[..n];
    let health = line.starts_with(b"GET /healthz ") || line.starts_with(b"GET /healthz?");
    let (status, ctype, body, extra) = if health {
        (
            "200 OK",
            "application/json",
            serde_json::json!({"status": "ok"}).to_string(),
            "",
        )
    } else if let Shed::PerClient(n) = why {
        let p = limits::too_many("connections", n, "CAUSTICA_MAX_CONNECTIONS_PER_CLIENT");
        (
            "429 Too Many Requests",
            "application/problem+json",
            p.body().to_string(),
            "retry-after: 1\r\n",
        )
    } else {
        let p = AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "overloaded",
            "Too many connections",
            "the server has as many connections open as it accepts; retry shortly",
        );
        (
            "503 Service Unavailable",
            "application/problem+json",
            p.body().to_string(),
            "retry-after: 1\r\n",
        )
    };
    let head = format!(
        "HTTP/1.1 {status}\r\ncontent-type: {ctype}\r\ncontent-length: {}\r\n{extra}\
         connection: close\r\n\r\n",
        body.len()
    );
    let write = async {
        stream.write_all(head.as_bytes()).await?;
        stream.write_all(body.as_bytes()).await?;
        stream.shutdown().await
    };
    let _ = tokio::time::timeout(wait, write).await;
    // A lingering close: read what the client still sends (the rest of its head, a body) for
    // a moment, so that closing with unread data does not reset the connection and lose the
    // answer on its way.
    let drain = async {
        let mut sink = [0u8; 4096];
        let mut left = 64 << 10;
        while left > 0 {
            match stream.read(&mut sink).await {
                Ok(0) | Err(_) => break,
                Ok(k) => left -= k.min(left),
            }
        }
    };
    let _ = tokio::time::timeout(wait, drain).await;
}
