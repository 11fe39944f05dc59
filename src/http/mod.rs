//! The HTTP API (v1): axum routes and DTOs. Handlers validate, talk to [`crate::jobs`] and
//! shape answers; they never trace rays or touch wgpu. Errors are [`AppError`]s, answered as
//! RFC 9457 problem+json.
//!
//! [`app`] builds the router from an [`AppState`] (testable without a socket); [`serve`] runs
//! it on a listener with graceful shutdown.

pub mod auth;
pub mod docs;
pub mod error;
pub mod limits;
pub mod problems;
pub mod routes;
pub mod server;
pub mod spec;
pub mod viewer;
pub mod wire;

pub use error::AppError;

use crate::jobs::{JobConfig, JobSystem};
use axum::Router;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::middleware::Next;
use axum::response::Response;
use axum::routing::get;
use std::future::Future;
use std::sync::Arc;
use std::time::Duration;
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::trace::{DefaultMakeSpan, DefaultOnResponse};
use tracing::Level;

/// Every route served, as (method, path template): checked against `api/openapi.yaml`.
pub const ROUTES: &[(&str, &str)] = &[
    ("GET", "/v1/scenes"),
    ("POST", "/v1/scenes"),
    ("GET", "/v1/scenes/{id}"),
    ("DELETE", "/v1/scenes/{id}"),
    ("GET", "/v1/bakes"),
    ("POST", "/v1/bakes"),
    ("GET", "/v1/bakes/{id}"),
    ("DELETE", "/v1/bakes/{id}"),
    ("GET", "/v1/bakes/{id}/artifact"),
    ("GET", "/v1/bakes/{id}/events"),
    ("GET", "/v1/renders"),
    ("POST", "/v1/renders"),
    ("GET", "/v1/renders/{id}"),
    ("DELETE", "/v1/renders/{id}"),
    ("GET", "/v1/renders/{id}/image"),
    ("GET", "/v1/renders/{id}/events"),
    ("POST", "/v1/compare"),
    ("GET", "/healthz"),
    ("GET", "/readyz"),
    ("GET", "/metrics"),
    ("GET", "/openapi.json"),
    ("GET", "/docs"),
    ("GET", "/problems"),
    ("GET", "/problems/{type}"),
    ("GET", "/"),
    ("GET", "/viewer/viewer.js"),
    ("GET", "/viewer/pixels.js"),
    ("GET", "/viewer/caustica.js"),
    ("GET", "/viewer/viewer.css"),
    ("GET", "/viewer/example.json"),
];

/// HTTP settings.
#[derive(Clone, Debug)]
pub struct HttpConfig {
    /// Largest request body, bytes.
    pub max_body: usize,
    /// Largest JSON body (a render, a bake, a scene), bytes: a JSON document is parsed into a
    /// tree, so it gets less room than a GLB.
    pub max_json_body: usize,
    /// Longest a request body may take to arrive (408 past it).
    pub body_timeout: Duration,
    /// Longest a client may take to send a request head, and longest an idle keep-alive
    /// connection is kept.
    pub header_timeout: Duration,
    /// Most connections served at once; past it they are shed ([`server`]).
    pub max_connections: usize,
    /// Connections past the cap shed at once with half a second to send their request line;
    /// past it, [`server::QUICK_SHEDDING`] more get 50 ms, and the rest are closed unanswered.
    pub shed_slots: usize,
    /// Most connections one address holds ([`limits`]); past it `429`.
    pub max_connections_per_client: usize,
    /// Most bytes of request bodies held at once ([`server::BodyBudget`]), charged as they
    /// arrive.
    pub max_body_bytes_in_flight: usize,
    /// Most request bodies one client (key, or address without keys) sends at once (counted
    /// until each has been read); past it `429`.
    pub max_uploads_per_client: usize,
    /// Most event streams one client follows at once; past it `429`.
    pub max_streams_per_client: usize,
    /// Longest an event stream stays open: then it ends, and its `retry:` field tells the
    /// client (an `EventSource` does it by itself) to connect again.
    pub stream_lifetime: Duration,
    /// How long `POST /v1/renders` waits for the image before answering 202 with the job.
    pub render_wait: Duration,
    /// How long running jobs get to finish at shutdown before they are put back in the queue.
    pub shutdown_grace: Duration,
    /// API keys ([`auth`]); none: every client is the anonymous admin (loopback only).
    pub keys: auth::Keys,
    /// Most queued or running jobs one user key may hold (admin keys and a server without
    /// keys: no quota); past it `429`.
    pub max_jobs_per_key: usize,
    /// Most bytes of scenes and results one user key may hold (0: no quota); past it a new
    /// scene or job is refused `429`.
    pub max_bytes_per_key: u64,
    /// Requests a second one client may send (`/healthz`, `/readyz`, `/metrics` aside), a
    /// second's worth at once; past it a request waits its turn up to a second, then `429`
    /// (0: no pacing).
    pub requests_per_client: u32,
    /// Origins whose web pages may call the API (CORS; `*`: any); empty, the default: no CORS
    /// headers, so browsers refuse cross-origin calls.
    pub cors_origins: Vec<String>,
    /// Sees every answer of the application (the integration tests check each against the
    /// OpenAPI document); none by default.
    pub observe: Option<Observer>,
}

/// An answer as an [`Observer`] sees it.
pub struct Observed {
    pub method: axum::http::Method,
    /// The route's path template; None for a request no route matched.
    pub route: Option<String>,
    pub status: u16,
    pub content_type: Option<String>,
    /// The whole body of a JSON or text answer (before compression); None for images,
    /// artifacts and event streams, which are passed on unread.
    pub body: Option<axum::body::Bytes>,
}

/// A function shown every answer ([`HttpConfig::observe`]).
#[derive(Clone)]
pub struct Observer(pub Arc<dyn Fn(Observed) + Send + Sync>);

impl std::fmt::Debug for Observer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Observer")
    }
}

impl Default for HttpConfig {
    fn default() -> Self {
        HttpConfig {
            max_body: 64 << 20,
            max_json_body: 8 << 20,
            body_timeout: Duration::from_secs(60),
            header_timeout: Duration::from_secs(10),
            max_connections: 1024,
            shed_slots: server::MAX_SHEDDING,
            max_connections_per_client: 512,
            max_body_bytes_in_flight: 512 << 20,
            max_uploads_per_client: 8,
            max_streams_per_client: 16,
            stream_lifetime: Duration::from_secs(300),
            render_wait: Duration::from_secs(60),
            shutdown_grace: Duration::from_secs(20),
            keys: auth::Keys::default(),
            max_jobs_per_key: 32,
            max_bytes_per_key: 4 << 30,
            requests_per_client: 500,
            cors_origins: Vec::new(),
            observe: None,
        }
    }
}

impl HttpConfig {
    /// Overrides from the environment: `CAUSTICA_MAX_BODY`, `CAUSTICA_MAX_JSON_BODY` (bytes),
    /// `CAUSTICA_BODY_TIMEOUT_S`, `CAUSTICA_HEADER_TIMEOUT_S`, `CAUSTICA_MAX_CONNECTIONS`,
    /// `CAUSTICA_MAX_CONNECTIONS_PER_CLIENT`, `CAUSTICA_MAX_UPLOADS_PER_CLIENT`,
    /// `CAUSTICA_MAX_STREAMS_PER_CLIENT`, `CAUSTICA_STREAM_LIFETIME_S`,
    /// `CAUSTICA_MAX_BODY_BYTES_IN_FLIGHT`, `CAUSTICA_MAX_JOBS_PER_KEY`,
    /// `CAUSTICA_MAX_BYTES_PER_KEY`, `CAUSTICA_REQUESTS_PER_CLIENT`,
    /// `CAUSTICA_RENDER_WAIT_S`, `CAUSTICA_SHUTDOWN_GRACE_S`, `CAUSTICA_CORS_ORIGINS` (a
    /// comma-separated list of origins, `https://host[:port]`, or `*`). An unparsable or
    /// out-of-range value is an error naming it.
    pub fn apply_env(&mut self, get: &dyn Fn(&str) -> Option<String>) -> Result<(), String> {
        use crate::jobs::env_num;
        if let Some(v) = env_num(get, "CAUSTICA_MAX_BODY", 1024.0, 4e9, true)? {
            self.max_body = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_JSON_BODY", 1024.0, 4e9, true)? {
            self.max_json_body = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_BODY_TIMEOUT_S", 0.1, 86400.0, false)? {
            self.body_timeout = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_HEADER_TIMEOUT_S", 0.1, 3600.0, false)? {
            self.header_timeout = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_CONNECTIONS", 1.0, 1e6, true)? {
            self.max_connections = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_CONNECTIONS_PER_CLIENT", 1.0, 1e6, true)? {
            self.max_connections_per_client = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_UPLOADS_PER_CLIENT", 1.0, 1e6, true)? {
            self.max_uploads_per_client = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_STREAMS_PER_CLIENT", 1.0, 1e6, true)? {
            self.max_streams_per_client = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_STREAM_LIFETIME_S", 1.0, 86400.0, false)? {
            self.stream_lifetime = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_BODY_BYTES_IN_FLIGHT", 1024.0, 1e12, true)? {
            self.max_body_bytes_in_flight = v as usize;
        }
        if self.max_body_bytes_in_flight < self.max_body {
            return Err(format!(
                "CAUSTICA_MAX_BODY_BYTES_IN_FLIGHT ({}) must be at least CAUSTICA_MAX_BODY ({}): \
                 a body of the largest size could never be admitted",
                self.max_body_bytes_in_flight, self.max_body
            ));
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_JOBS_PER_KEY", 1.0, 1e6, true)? {
            self.max_jobs_per_key = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_BYTES_PER_KEY", 0.0, 1e15, true)? {
            self.max_bytes_per_key = v as u64;
        }
        if let Some(v) = env_num(get, "CAUSTICA_REQUESTS_PER_CLIENT", 0.0, 1e6, true)? {
            self.requests_per_client = v as u32;
        }
        if let Some(v) = env_num(get, "CAUSTICA_RENDER_WAIT_S", 0.0, 86400.0, false)? {
            self.render_wait = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_SHUTDOWN_GRACE_S", 0.0, 86400.0, false)? {
            self.shutdown_grace = Duration::from_secs_f64(v);
        }
        if let Some(v) = get("CAUSTICA_CORS_ORIGINS") {
            self.cors_origins =
                parse_origins(&v).map_err(|e| format!("CAUSTICA_CORS_ORIGINS: {e}"))?;
        }
        if let Some(v) = get("CAUSTICA_ANSWER_LOG") {
            self.observe = Some(answer_log(std::path::Path::new(&v))?);
        }
        Ok(())
    }
}

/// An [`Observer`] that appends every answer to the file at `path` as a JSON line (`method`,
/// `route`, `status`, `content_type`, and `body` for JSON and text answers): what the tests
/// check against the OpenAPI document for a server running as its own process
/// (`CAUSTICA_ANSWER_LOG`; bodies are written as they are, so it is for testing only).
fn answer_log(path: &std::path::Path) -> Result<Observer, String> {
    use std::io::Write;
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| format!("CAUSTICA_ANSWER_LOG: cannot open {}: {e}", path.display()))?;
    let file = std::sync::Mutex::new(file);
    Ok(Observer(Arc::new(move |o: Observed| {
        let line = serde_json::json!({
            "method": o.method.as_str(),
            "route": o.route,
            "status": o.status,
            "content_type": o.content_type,
            "body": o.body.as_ref().map(|b| String::from_utf8_lossy(b).into_owned()),
        });
        // One write per line on an append-only file: lines stay whole.
        let mut f = file.lock().unwrap_or_else(|e| e.into_inner());
        if let Err(e) = f.write_all(format!("{line}\n").as_bytes()) {
            tracing::warn!(error = %e, "CAUSTICA_ANSWER_LOG: answer not written");
        }
    })))
}

/// A CORS allow-list: origins (`http://` or `https://`, a host, an optional port, nothing
/// after) separated by commas, or `*` alone.
fn parse_origins(v: &str) -> Result<Vec<String>, String> {
    let list: Vec<String> = v
        .split(',')
        .map(|o| o.trim().to_string())
        .filter(|o| !o.is_empty())
        .collect();
    if list.iter().any(|o| o == "*") {
        return if list.len() == 1 {
            Ok(list)
        } else {
            Err("'*' allows every origin and cannot be listed with others".into())
        };
    }
    for o in &list {
        let rest = o
            .strip_prefix("https://")
            .or_else(|| o.strip_prefix("http://"))
            .ok_or_else(|| {
                format!("'{o}' is not an origin: it must start with http:// or https://")
            })?;
        let ok = !rest.is_empty()
            && rest
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"-.:[]".contains(&b));
        if !ok {
            return Err(format!(
                "'{o}' is not an origin: a scheme, a host and an optional port, with no path \
                 (no trailing '/')"
            ));
        }
    }
    Ok(list)
}

/// The CORS layer for `origins` (none: no layer). Preflights are answered before the key check
/// (browsers send them without credentials); what a page may send and read back is what the
/// API uses: keys, idempotency keys, conditional and range requests; `Location`,
/// `Retry-After`, `ETag`, `Content-Range`, `Server-Timing`, `Caustica-Warning`.
fn cors(origins: &[String]) -> Option<tower_http::cors::CorsLayer> {
    use axum::http::{HeaderName, Method, header};
    use tower_http::cors::{AllowOrigin, CorsLayer};
    if origins.is_empty() {
        return None;
    }
    let allow = if origins.iter().any(|o| o == "*") {
        AllowOrigin::any()
    } else {
        AllowOrigin::list(
            origins
                .iter()
                .filter_map(|o| axum::http::HeaderValue::from_str(o).ok()),
        )
    };
    Some(
        CorsLayer::new()
            .allow_origin(allow)
            .allow_methods([Method::GET, Method::POST, Method::DELETE])
            .allow_headers([
                header::CONTENT_TYPE,
                header::AUTHORIZATION,
                header::RANGE,
                header::IF_NONE_MATCH,
                header::IF_RANGE,
                HeaderName::from_static("idempotency-key"),
            ])
            .expose_headers([
                header::LOCATION,
                header::RETRY_AFTER,
                header::ETAG,
                header::CONTENT_RANGE,
                HeaderName::from_static("server-timing"),
                HeaderName::from_static("caustica-warning"),
            ])
            .max_age(Duration::from_secs(600)),
    )
}

/// What every handler sees.
#[derive(Clone)]
pub struct AppState {
    pub jobs: Arc<JobSystem>,
    pub cfg: Arc<HttpConfig>,
    /// Flips to true when shutdown begins: waiting handlers answer at once.
    pub shutdown: tokio::sync::watch::Receiver<bool>,
    shutdown_tx: Arc<tokio::sync::watch::Sender<bool>>,
    /// Connections open, accepted, shed.
    pub conns: Arc<server::ConnStats>,
    /// Request body bytes held ([`server::admit_body`]).
    pub bodies: Arc<server::BodyBudget>,
    /// What each client holds ([`limits`]).
    pub limits: Arc<Limits>,
}

/// Per-client counts ([`limits::PerClient`]).
#[derive(Default)]
pub struct Limits {
    /// Requests with a body being received or answered.
    pub uploads: Arc<limits::PerClient>,
    /// Event streams open.
    pub streams: Arc<limits::PerClient>,
    /// Each client's requests a second ([`HttpConfig::requests_per_client`]; none: 0).
    pub pace: Option<limits::Pace>,
    /// Bytes each key held when last counted, and when ([`auth::within_storage`]).
    pub held: std::sync::Mutex<std::collections::HashMap<String, (u64, std::time::Instant)>>,
}

impl AppState {
    pub fn new(jobs: Arc<JobSystem>, cfg: HttpConfig) -> AppState {
        let (tx, rx) = tokio::sync::watch::channel(false);
        jobs.set_quota(auth::quota(&cfg.keys, cfg.max_jobs_per_key));
        AppState {
            jobs,
            shutdown: rx,
            shutdown_tx: Arc::new(tx),
            conns: Arc::default(),
            bodies: Arc::new(server::BodyBudget::new(cfg.max_body_bytes_in_flight)),
            limits: Arc::new(Limits {
                pace: limits::Pace::new(cfg.requests_per_client),
                ..Default::default()
            }),
            cfg: Arc::new(cfg),
        }
    }

    /// Starts the job system on `data_dir` and wraps it.
    pub fn start(jobs: JobConfig, http: HttpConfig) -> anyhow::Result<AppState> {
        let sys = JobSystem::start(jobs)?;
        Ok(AppState::new(sys, http))
    }
}

/// The OpenAPI document ([`spec::document`]), made once.
pub fn openapi() -> &'static serde_json::Value {
    static DOC: std::sync::OnceLock<serde_json::Value> = std::sync::OnceLock::new();
    DOC.get_or_init(spec::document)
}

/// Shows each answer to the configured [`Observer`].
async fn observe(State(st): State<AppState>, req: Request, next: Next) -> Response {
    let Some(obs) = st.cfg.observe.clone() else {
        return next.run(req).await;
    };
    let method = req.method().clone();
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string());
    let r = next.run(req).await;
    let content_type = r
        .headers()
        .get(axum::http::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .map(str::to_string);
    let text = content_type.as_deref().is_some_and(is_text);
    let status = r.status().as_u16();
    if !text {
        obs.0(Observed {
            method,
            route,
            status,
            content_type,
            body: None,
        });
        return r;
    }
    let (parts, body) = r.into_parts();
    let bytes = axum::body::to_bytes(body, usize::MAX)
        .await
        .unwrap_or_default();
    obs.0(Observed {
        method,
        route,
        status,
        content_type,
        body: Some(bytes.clone()),
    });
    Response::from_parts(parts, axum::body::Body::from(bytes))
}

async fn count_requests(State(st): State<AppState>, req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string())
        .unwrap_or_else(|| "unmatched".into());
    let t0 = std::time::Instant::now();
    let r = next.run(req).await;
    st.jobs
        .metrics
        .request(&route, r.status().as_u16(), t0.elapsed());
    r
}

fn panic_problem(p: Box<dyn std::any::Any + Send + 'static>) -> Response {
    use axum::response::IntoResponse;
    let msg = crate::jobs::panic_message(p);
    tracing::error!(panic = %msg, "handler panicked");
    AppError::internal("the server hit an internal error handling this request").into_response()
}

/// Whether an answer of media type `ty` is text the server writes whole (JSON, problems, pages):
/// what is gzipped, and what an [`Observer`] is shown the body of.
fn is_text(ty: &str) -> bool {
    [
        "application/json",
        "application/problem+json",
        "text/html",
        "text/plain",
    ]
    .iter()
    .any(|t| ty.starts_with(t))
}

/// Which answers are gzipped for a client that accepts it: text (JSON, problems, pages,
/// metrics), unless it declares a length of at most 1 KiB; never images, artifacts, byte
/// ranges or event streams.
fn compressible(
    status: axum::http::StatusCode,
    _: axum::http::Version,
    h: &axum::http::HeaderMap,
    _: &axum::http::Extensions,
) -> bool {
    use axum::http::header;
    let ty = h
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    let text = is_text(ty);
    let big = h
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok())
        .is_none_or(|n| n > 1024);
    text && big && status != axum::http::StatusCode::PARTIAL_CONTENT
}

/// The application: every route, the body limit, request logging and metrics.
pub fn app(state: AppState) -> Router {
    use routes::*;
    let cors = cors(&state.cfg.cors_origins);
    let router = Router::new()
        .route("/v1/scenes", get(list_scenes).post(post_scene))
        .route("/v1/scenes/{id}", get(get_scene).delete(delete_scene))
        .route("/v1/bakes", get(list_bakes).post(post_bake))
        .route("/v1/bakes/{id}", get(get_bake).delete(delete_bake))
        .route("/v1/bakes/{id}/artifact", get(get_bake_artifact))
        .route("/v1/bakes/{id}/events", get(bake_events))
        .route("/v1/renders", get(list_renders).post(post_render))
        .route("/v1/renders/{id}", get(get_render).delete(delete_render))
        .route("/v1/renders/{id}/image", get(get_render_image))
        .route("/v1/renders/{id}/events", get(render_events))
        .route("/v1/compare", axum::routing::post(post_compare))
        .route("/healthz", get(healthz))
        .route("/readyz", get(readyz))
        .route("/metrics", get(metrics))
        .route("/openapi.json", get(openapi_json))
        .route("/docs", get(docs::page))
        .route("/problems", get(problems::index))
        .route("/problems/{type}", get(problems::show))
        .route("/", get(viewer::page))
        .route("/viewer/viewer.js", get(viewer::script))
        .route("/viewer/pixels.js", get(viewer::pixels))
        .route("/viewer/caustica.js", get(viewer::client))
        .route("/viewer/viewer.css", get(viewer::styles))
        .route("/viewer/example.json", get(viewer::example))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            server::admit_body,
        ))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            limits::pace,
        ))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            auth::authenticate,
        ));
    // Outside the key check: a preflight carries no key.
    let router = match cors {
        Some(c) => router.layer(c),
        None => router,
    };
    router
        .layer(axum::middleware::from_fn(server::limit_head))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            count_requests,
        ))
        // The explicit check in the handlers answers with a problem; this is the backstop.
        .layer(DefaultBodyLimit::max(state.cfg.max_body))
        .layer(
            tower_http::trace::TraceLayer::new_for_http()
                .make_span_with(DefaultMakeSpan::new().level(Level::INFO))
                .on_response(DefaultOnResponse::new().level(Level::INFO)),
        )
        // A panic in a handler becomes a 500 problem instead of a dropped connection.
        .layer(CatchPanicLayer::custom(panic_problem))
        .layer(axum::middleware::from_fn_with_state(state.clone(), observe))
        .layer(tower_http::compression::CompressionLayer::new().compress_when(compressible))
        .with_state(state)
}

/// Serves `state` on `listener` ([`server::run`]: timeouts, connection cap) until `shutdown`
/// resolves; then stops accepting, lets requests in flight finish, and gives running jobs
/// `shutdown_grace` before putting them back in the queue.
pub async fn serve(
    listener: tokio::net::TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let tx = state.shutdown_tx.clone();
    let jobs = state.jobs.clone();
    let grace = state.cfg.shutdown_grace;
    let signal = async move {
        shutdown.await;
        tracing::info!("shutting down: no new connections, waiting for requests in flight");
        tx.send_replace(true);
    };
    let (cfg, conns) = (state.cfg.clone(), state.conns.clone());
    server::run(listener, app(state), cfg, conns, signal).await;
    tracing::info!(grace_s = grace.as_secs_f64(), "waiting for running jobs");
    tokio::task::spawn_blocking(move || jobs.shutdown(grace))
        .await
        .map_err(std::io::Error::other)?;
    tracing::info!("stopped");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{HttpConfig, parse_origins};

    #[test]
    fn cors_origins_are_checked_when_read() {
        assert_eq!(
            parse_origins("https://a.example, http://localhost:5173,").unwrap(),
            vec!["https://a.example", "http://localhost:5173"]
        );
        assert_eq!(parse_origins("*").unwrap(), vec!["*"]);
        assert!(parse_origins("").unwrap().is_empty());
        for bad in [
            "a.example",
            "https://a.example/",
            "https://a.example/app",
            "*,https://a.example",
            "ftp://a",
            "https://",
        ] {
            assert!(parse_origins(bad).is_err(), "{bad}");
        }
        let mut c = HttpConfig::default();
        let e = c
            .apply_env(&|k| (k == "CAUSTICA_CORS_ORIGINS").then(|| "example.com".to_string()))
            .unwrap_err();
        assert!(
            e.contains("CAUSTICA_CORS_ORIGINS") && e.contains("example.com"),
            "{e}"
        );
        assert!(c.cors_origins.is_empty());
    }
}
