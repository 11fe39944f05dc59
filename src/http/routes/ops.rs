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

/// Readiness: not ready (`503 store-unavailable`) while the job store cannot be reached, nor
/// while the GPU worker probes its adapter; `storage_warnings` (and the end of a 503's detail)
/// says what looked wrong with the data directory at start (an empty database, a garbage
/// write-ahead log). `/healthz` asks nothing of the store: a process whose database is down
/// is alive, only not ready.
pub async fn readyz(State(st): State<AppState>) -> Result<Json<serde_json::Value>, AppError> {
    st.jobs.store.reachable()?;
    let warnings = &st.jobs.store.warnings;
    let note = |e: AppError| {
        if warnings.is_empty() {
            e
        } else {
            let d = format!("{}; storage: {}", e.detail, warnings.join("; "));
            AppError::new(e.status, e.kind, e.title, d)
        }
    };
    let adapter = match st.jobs.readiness() {
        Readiness::Ready { adapter } => adapter,
        Readiness::NoGpuLane => "none in this process (worker processes run the jobs)".into(),
        Readiness::Starting => {
            return Err(note(AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "not-ready",
                "Not ready",
                "the GPU worker is still probing the adapter",
            ))
            .retry_after(1));
        }
        Readiness::NoGpu { error } => {
            return Err(note(AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "no-gpu",
                "No GPU",
                format!("no GPU adapter renders: {error}"),
            )));
        }
    };
    let (qb, qr) = st.jobs.queued();
    let (rb, rr) = st.jobs.running();
    Ok(Json(serde_json::json!({
        "status": "ready",
        "adapter": adapter,
        "storage_warnings": warnings,
        "queued": {"bakes": qb, "renders": qr},
        "running": {"bakes": rb, "renders": rr},
    })))
}

pub async fn metrics(State(st): State<AppState>) -> Response {
    use std::sync::atomic::Ordering::Relaxed;
    let c = &st.conns;
    let now = crate::jobs::metrics::Snapshot {
        queue: st.jobs.queue_depth(),
        running: st.jobs.running(),
        connections_open: c.open.load(Relaxed),
        connections: [
            c.accepted.load(Relaxed),
            c.shed.load(Relaxed),
            c.dropped.load(Relaxed),
        ],
    };
    let body = st.jobs.metrics.render(now);
    (
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
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
