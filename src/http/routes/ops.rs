//! Operations: `/healthz`, `/readyz`, `/metrics`, `/openapi.json`, and the answers to unknown
//! routes and methods.

use crate::http::{AppError, AppState};
use crate::jobs::Readiness;
use axum::Json;
use axum::extract::{Request, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

pub async fn healthz() -> Json<serde_json::Value> {
    Json(serde_json::json!({"status": "ok"}))
}

/// Readiness; `storage_warnings` (and the end of a 503's detail) says what looked wrong with
/// the data directory at start (an empty database, a garbage write-ahead log).
pub async fn readyz(State(st): State<AppState>) -> Result<Json<serde_json::Value>, AppError> {
    let warnings = &st.jobs.store.warnings;
    let note = |e: AppError| {
        if warnings.is_empty() {
            e
        } else {
            let d = format!("{}; storage: {}", e.detail, warnings.join("; "));
            AppError::new(e.status, e.kind, e.title, d)
        }
    };
    match st.jobs.readiness() {
        Readiness::Ready { adapter } => Ok(Json(serde_json::json!({
            "status": "ready",
            "adapter": adapter,
            "storage_warnings": warnings,
        }))),
        Readiness::Starting => Err(note(AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "not-ready",
            "Not ready",
            "the GPU worker is still probing the adapter",
        ))
        .retry_after(1)),
        Readiness::NoGpu { error } => Err(note(AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "no-gpu",
            "No GPU",
            format!("no GPU adapter renders: {error}"),
        ))),
    }
}

pub async fn metrics(State(st): State<AppState>) -> Response {
    use std::fmt::Write;
    use std::sync::atomic::Ordering::Relaxed;
    let mut body = st.jobs.metrics.render(st.jobs.queue_depth());
    let c = &st.conns;
    body.push_str("# HELP caustica_connections_open HTTP connections being served.\n");
    body.push_str("# TYPE caustica_connections_open gauge\n");
    let _ = writeln!(body, "caustica_connections_open {}", c.open.load(Relaxed));
    body.push_str(
        "# HELP caustica_connections_total HTTP connections accepted, by outcome (served; shed \
         with 503 past the connection cap; dropped unanswered past the shedding cap).\n",
    );
    body.push_str("# TYPE caustica_connections_total counter\n");
    for (k, v) in [
        ("served", &c.accepted),
        ("shed", &c.shed),
        ("dropped", &c.dropped),
    ] {
        let _ = writeln!(
            body,
            "caustica_connections_total{{outcome=\"{k}\"}} {}",
            v.load(Relaxed)
        );
    }
    (
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        body,
    )
        .into_response()
}

pub async fn openapi_json() -> Json<serde_json::Value> {
    Json(crate::http::openapi().clone())
}

pub async fn not_found(req: Request) -> AppError {
    AppError::new(
        StatusCode::NOT_FOUND,
        "not-found",
        "Not found",
        format!("no route {} {}", req.method(), req.uri().path()),
    )
}

pub async fn method_not_allowed(req: Request) -> AppError {
    AppError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "method-not-allowed",
        "Method not allowed",
        format!("{} is not allowed on {}", req.method(), req.uri().path()),
    )
}
