//! Bakes and renders are jobs: how the API shows one ([`JobView`]), finds one by id, waits for
//! one, and serves its artifact with its timings.

use crate::http::auth::Principal;
use crate::http::{AppError, AppState};
use crate::jobs::store::{Held, JobRecord};
use crate::jobs::{JobHandle, JobKind, JobState};
use crate::methods::Method;
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use std::sync::Arc;
use std::time::Duration;

/// A job as the API shows it.
#[derive(Serialize)]
pub struct JobView {
    pub id: String,
    pub kind: JobKind,
    pub method: Method,
    pub scene_id: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub object: Option<String>,
    pub params: serde_json::Value,
    pub state: JobState,
    pub progress: f32,
    pub stage: String,
    /// Stage → milliseconds, in order.
    pub timings: Vec<Timing>,
    pub info: serde_json::Value,
    pub error: Option<String>,
    /// Where the result is, once succeeded.
    pub artifact: Option<String>,
    pub created_at: i64,
    pub started_at: Option<i64>,
    pub finished_at: Option<i64>,
}

#[derive(Serialize)]
pub struct Timing {
    pub stage: String,
    pub ms: f64,
}

pub(super) fn view(r: JobRecord, live: Option<&JobHandle>) -> JobView {
    let (mut state, mut progress, mut stage) = (r.state, r.progress, r.stage);
    if let Some(h) = live {
        let s = h.state();
        if !s.is_terminal() {
            state = s;
            let (p, st) = h.progress();
            progress = p;
            stage = st;
        }
    }
    let artifact = (state == JobState::Succeeded).then(|| match r.kind {
        JobKind::Bake => format!("/v1/bakes/{}/artifact", r.id),
        JobKind::Render => format!("/v1/renders/{}/image", r.id),
    });
    JobView {
        timings: r
            .timings
            .into_iter()
            .map(|(stage, ms)| Timing { stage, ms })
            .collect(),
        id: r.id,
        kind: r.kind,
        method: r.method,
        scene_id: r.scene_id,
        object: r.object,
        params: r.params,
        state,
        progress,
        stage,
        info: r.info,
        error: r.error,
        artifact,
        created_at: r.created_at,
        started_at: r.started_at,
        finished_at: r.finished_at,
    }
}

/// Job `id` of `kind`, if `p` may see it (an admin, or one who holds it; 404 otherwise, as
/// for an unknown id).
pub(super) fn load_job(
    st: &AppState,
    id: &str,
    kind: JobKind,
    p: &Principal,
) -> Result<JobRecord, AppError> {
    let what = kind.as_str();
    if !super::valid_id(id, kind.id_prefix()) {
        return Err(AppError::not_found(what, id));
    }
    if !p.admin && !st.jobs.store.holds(Held::Job, id, &p.owner)? {
        return Err(AppError::not_found(what, id));
    }
    match st.jobs.store.get_job(id)? {
        Some(r) if r.kind == kind => Ok(r),
        _ => Err(AppError::not_found(what, id)),
    }
}

pub(super) fn job_view(
    st: &AppState,
    id: &str,
    kind: JobKind,
    p: &Principal,
) -> Result<JobView, AppError> {
    let r = load_job(st, id, kind, p)?;
    let h = st.jobs.handle(id);
    Ok(view(r, h.as_deref()))
}

/// Waits until the job ends, `wait` passes or shutdown begins. True when it ended.
/// `DELETE` of a bake or a render: a queued job is dropped, a running one stops at its next
/// progress check (waited for, up to 30 s, so that the answer tells the final state); a
/// finished render is deleted, its record and image (204); 409 for a bake that already
/// succeeded, 404 when there is no such job. A user other than an admin drops only their own
/// hold: the job is canceled (or deleted) once nobody holds it, and until then the answer shows
/// it going on.
pub(super) async fn cancel_job(
    st: &AppState,
    id: &str,
    kind: JobKind,
    p: &Principal,
) -> Result<Response, AppError> {
    let r = load_job(st, id, kind, p)?;
    if r.state == JobState::Succeeded && kind == JobKind::Bake {
        return Err(AppError::new(
            StatusCode::CONFLICT,
            "already-finished",
            "Already finished",
            format!("bake {id} already succeeded; there is nothing to cancel"),
        ));
    }
    if !p.admin {
        let view = job_view(st, id, kind, p)?;
        if st.jobs.store.release(Held::Job, id, &p.owner)? > 0 {
            return Ok(axum::Json(view).into_response());
        }
    }
    if kind == JobKind::Render && r.state.is_terminal() {
        st.jobs.store.delete_job(id)?;
        return Ok(StatusCode::NO_CONTENT.into_response());
    }
    if let Some(h) = st.jobs.handle(id) {
        st.jobs.cancel(id)?;
        wait_terminal(st, &h, Duration::from_secs(30)).await;
    }
    let r = st
        .jobs
        .store
        .get_job(id)?
        .ok_or_else(|| AppError::not_found(kind.as_str(), id))?;
    let h = st.jobs.handle(id);
    Ok(axum::Json(view(r, h.as_deref())).into_response())
}

pub(super) async fn wait_terminal(st: &AppState, h: &Arc<JobHandle>, wait: Duration) -> bool {
    let mut rx = h.subscribe();
    let mut stop = st.shutdown.clone();
    tokio::select! {
        r = tokio::time::timeout(wait, rx.wait_for(|s| s.is_terminal())) => {
            matches!(r, Ok(Ok(_)))
        }
        _ = stop.wait_for(|s| *s) => false,
    }
}

pub(super) fn not_finished(kind: JobKind, id: &str, state: JobState) -> AppError {
    AppError::new(
        StatusCode::CONFLICT,
        "not-ready",
        "Result not available",
        format!(
            "{} {id} is {state}: its result exists only once it has succeeded",
            kind.as_str()
        ),
    )
}

pub(super) fn artifact_response(st: &AppState, r: &JobRecord) -> Result<Response, AppError> {
    let Some(ty) = &r.artifact_type else {
        return Err(AppError::internal("succeeded job without an artifact"));
    };
    let bytes = st.jobs.artifact(r).map_err(|e| AppError::artifact(r, e))?;
    let mut resp = (
        [
            (header::CONTENT_TYPE, ty.clone()),
            (
                header::CACHE_CONTROL,
                "public, max-age=31536000, immutable".into(),
            ),
        ],
        bytes,
    )
        .into_response();
    if let Ok(v) = HeaderValue::from_str(&server_timing(&r.timings, None)) {
        resp.headers_mut().insert("server-timing", v);
    }
    Ok(resp)
}

/// `Server-Timing` value: every stage as `name;dur=ms` (names made into tokens).
pub fn server_timing(timings: &[(String, f64)], request: Option<Duration>) -> String {
    let token = |s: &str| -> String {
        s.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "!#$%&'*+-.^_`|~".contains(c) {
                    c
                } else {
                    '-'
                }
            })
            .collect()
    };
    let mut parts: Vec<String> = timings
        .iter()
        .map(|(n, ms)| format!("{};dur={:.3}", token(n), ms))
        .collect();
    if let Some(d) = request {
        parts.push(format!("request;dur={:.3}", d.as_secs_f64() * 1e3));
    }
    parts.join(", ")
}
