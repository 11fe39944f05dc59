//! The HTTP API (v1): axum routes and DTOs. Handlers validate, talk to [`crate::jobs`] and
//! shape answers; they never trace rays or touch wgpu. Errors are [`AppError`]s, answered as
//! RFC 9457 problem+json.
//!
//! [`app`] builds the router from an [`AppState`] (testable without a socket); [`serve`] runs
//! it on a listener with graceful shutdown.

pub mod auth;
pub mod error;
pub mod routes;
pub mod server;
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
    ("GET", "/healthz"),
    ("GET", "/readyz"),
    ("GET", "/metrics"),
    ("GET", "/openapi.json"),
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
    /// Most bytes of request bodies held at once ([`server::BodyBudget`]).
    pub max_body_bytes_in_flight: usize,
    /// How long `POST /v1/renders` waits for the image before answering 202 with the job.
    pub render_wait: Duration,
    /// How long running jobs get to finish at shutdown before they are put back in the queue.
    pub shutdown_grace: Duration,
    /// API keys ([`auth`]); none: every client is the anonymous admin (loopback only).
    pub keys: auth::Keys,
    /// Most queued or running jobs one user key may hold (admin keys and a server without
    /// keys: no quota); past it `429`.
    pub max_jobs_per_key: usize,
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
            max_body_bytes_in_flight: 512 << 20,
            render_wait: Duration::from_secs(60),
            shutdown_grace: Duration::from_secs(20),
            keys: auth::Keys::default(),
            max_jobs_per_key: 32,
        }
    }
}

impl HttpConfig {
    /// Overrides from the environment: `CAUSTICA_MAX_BODY`, `CAUSTICA_MAX_JSON_BODY` (bytes),
    /// `CAUSTICA_BODY_TIMEOUT_S`, `CAUSTICA_HEADER_TIMEOUT_S`, `CAUSTICA_MAX_CONNECTIONS`,
    /// `CAUSTICA_MAX_BODY_BYTES_IN_FLIGHT`, `CAUSTICA_MAX_JOBS_PER_KEY`,
    /// `CAUSTICA_RENDER_WAIT_S`, `CAUSTICA_SHUTDOWN_GRACE_S`. An unparsable or out-of-range
    /// value is an error naming it.
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
        if let Some(v) = env_num(get, "CAUSTICA_RENDER_WAIT_S", 0.0, 86400.0, false)? {
            self.render_wait = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_SHUTDOWN_GRACE_S", 0.0, 86400.0, false)? {
            self.shutdown_grace = Duration::from_secs_f64(v);
        }
        Ok(())
    }
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
}

impl AppState {
    pub fn new(jobs: Arc<JobSystem>, cfg: HttpConfig) -> AppState {
        let (tx, rx) = tokio::sync::watch::channel(false);
        AppState {
            jobs,
            shutdown: rx,
            shutdown_tx: Arc::new(tx),
            conns: Arc::default(),
            bodies: Arc::new(server::BodyBudget::new(cfg.max_body_bytes_in_flight)),
            cfg: Arc::new(cfg),
        }
    }

    /// Starts the job system on `data_dir` and wraps it.
    pub fn start(jobs: JobConfig, http: HttpConfig) -> anyhow::Result<AppState> {
        let sys = JobSystem::start(jobs)?;
        Ok(AppState::new(sys, http))
    }
}

/// The OpenAPI document, converted from `api/openapi.yaml` once.
pub fn openapi() -> &'static serde_json::Value {
    static DOC: std::sync::OnceLock<serde_json::Value> = std::sync::OnceLock::new();
    DOC.get_or_init(|| {
        serde_yaml_ng::from_str(include_str!("../../api/openapi.yaml"))
            .expect("api/openapi.yaml parses (checked by the http_openapi tests)")
    })
}

async fn count_requests(State(st): State<AppState>, req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string())
        .unwrap_or_else(|| "unmatched".into());
    let r = next.run(req).await;
    st.jobs.metrics.request(&route, r.status().as_u16());
    r
}

fn panic_problem(p: Box<dyn std::any::Any + Send + 'static>) -> Response {
    use axum::response::IntoResponse;
    let msg = crate::jobs::panic_message(p);
    tracing::error!(panic = %msg, "handler panicked");
    AppError::internal("the server hit an internal error handling this request").into_response()
}

/// The application: every route, the body limit, request logging and metrics.
pub fn app(state: AppState) -> Router {
    use routes::*;
    Router::new()
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
        .route("/healthz", get(healthz))
        .route("/readyz", get(readyz))
        .route("/metrics", get(metrics))
        .route("/openapi.json", get(openapi_json))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            server::admit_body,
        ))
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            auth::authenticate,
        ))
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
