//! The connection loop: accepts TCP connections and serves each with hyper's HTTP/1.1, with
//! the limits a public server needs and `axum::serve` does not set:
//!
//! - a **header-read timeout** ([`HttpConfig::header_timeout`]): a client must send a whole
//!   request head within it, and an idle keep-alive connection is closed after it (slowloris,
//!   sockets held open and silent);
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

use super::{AppError, HttpConfig};
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

/// Bytes of request bodies being received or held at once, process-wide: each request with a
/// body takes its declared length (or the body limit when it declares none) before it is read,
/// and gives it back when answered; past [`HttpConfig::max_body_bytes_in_flight`], `503` with
/// `Retry-After`.
pub struct BodyBudget(Arc<Semaphore>);

impl BodyBudget {
    pub fn new(bytes: usize) -> BodyBudget {
        BodyBudget(Arc::new(Semaphore::new(kib(bytes) as usize)))
    }
}

fn kib(bytes: usize) -> u32 {
    u32::try_from(bytes.div_ceil(1024)).unwrap_or(u32::MAX)
}

/// The middleware of [`BodyBudget`].
pub async fn admit_body(
    axum::extract::State(st): axum::extract::State<super::AppState>,
    req: Request,
    next: Next,
) -> Response {
    let declared = req
        .headers()
        .get(axum::http::header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<usize>().ok());
    let chunked = req
        .headers()
        .contains_key(axum::http::header::TRANSFER_ENCODING);
    // A body of undeclared length is counted at the most it may grow to: a JSON body's limit
    // for JSON, the body limit otherwise.
    let json = super::routes::media_type(req.headers()) == "application/json";
    let most = if json {
        st.cfg.max_json_body.min(st.cfg.max_body)
    } else {
        st.cfg.max_body
    };
    let bytes = match declared {
        Some(n) => n.min(most),
        None if chunked => most,
        None => 0,
    };
    if bytes == 0 {
        return next.run(req).await;
    }
    let Ok(_held) = st.bodies.0.clone().try_acquire_many_owned(kib(bytes)) else {
        return AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "busy",
            "Busy",
            format!(
                "the server is receiving as many request bytes as it holds at once ({} MiB); \
                 retry shortly",
                st.cfg.max_body_bytes_in_flight >> 20
            ),
        )
        .retry_after(1)
        .into_response();
    };
    next.run(req).await
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
    // Connections watch `stop` for the graceful shutdown; `done_rx` clones live as long as
    // they do.
    let (stop_tx, stop_rx) = watch::channel(false);
    let (done_tx, done_rx) = watch::channel(());
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, _addr) = tokio::select! {
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
        match slots.clone().try_acquire_owned() {
            Ok(permit) => {
                stats.accepted.fetch_add(1, Ordering::Relaxed);
                stats.open.fetch_add(1, Ordering::Relaxed);
                let (app, cfg, stats) = (app.clone(), cfg.clone(), stats.clone());
                let (mut stop, done) = (stop_rx.clone(), done_rx.clone());
                tokio::spawn(async move {
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
                    drop((permit, done));
                });
            }
            Err(_) => {
                let slot = match shedding.clone().try_acquire_owned() {
                    Ok(p) => Some((p, SHED_READ)),
                    Err(_) => quick
                        .clone()
                        .try_acquire_owned()
                        .ok()
                        .map(|p| (p, QUICK_READ)),
                };
                match slot {
                    Some((permit, wait)) => {
                        stats.shed.fetch_add(1, Ordering::Relaxed);
                        tokio::spawn(async move {
                            shed(stream, wait).await;
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

/// Answers a connection past the cap: `/healthz` as usual, anything else `503` with
/// `Retry-After`; then closes it. `wait` bounds the wait for the request line, the write of
/// the answer and the lingering close, each.
async fn shed(mut stream: TcpStream, wait: Duration) {
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
