//! `POST /v1/renders` (the image, or 202 with the job past the wait), `GET /v1/renders/{id}`,
//! `GET /v1/renders/{id}/image`.

use super::jobs::{
    JobView, accepted, artifact_response, cancel_job, job_view, load_job, not_finished,
    serve_artifact, server_timing, view, wait_terminal,
};
use super::scenes::scene_ref;
use super::{blocking, idempotency_key, idempotency_key_reused, json_body, principal};
use crate::http::auth::Principal;
use crate::http::{AppError, AppState};
use crate::jobs::scenes::sha256_hex;
use crate::jobs::store::Held;
use crate::jobs::{JobKind, JobSpec, JobState};
use crate::methods::Method;
use axum::extract::{Path, Request, State};
use axum::http::{HeaderValue, header};
use axum::response::Response;
use axum::{Extension, Json};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

static RENDER_SEQ: AtomicU64 = AtomicU64::new(0);

/// Held while a render with an `Idempotency-Key` is looked up and submitted: one lock of 64,
/// by the key's hash, so that two requests with one key make one render while other keys'
/// submissions (almost always under another lock) do not wait for them.
static IDEMPOTENT_RENDERS: [tokio::sync::Mutex<()>; 64] =
    [const { tokio::sync::Mutex::const_new(()) }; 64];

/// The lock of idempotency key `k` among [`IDEMPOTENT_RENDERS`].
fn idempotency_lock(k: &str) -> &'static tokio::sync::Mutex<()> {
    let h = sha256_hex(k.as_bytes());
    let i = usize::from_str_radix(&h[..4], 16).unwrap_or(0) % IDEMPOTENT_RENDERS.len();
    &IDEMPOTENT_RENDERS[i]
}

fn render_id() -> String {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(RENDER_SEQ.fetch_add(1, Ordering::Relaxed));
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let seed = format!(
        "{}-{}-{}-{}",
        h.finish(),
        nanos,
        std::process::id(),
        RENDER_SEQ.load(Ordering::Relaxed)
    );
    format!("rn_{}", &sha256_hex(seed.as_bytes())[..32])
}

pub async fn post_render(State(st): State<AppState>, req: Request) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let p = principal(&req);
    let headers = req.headers().clone();
    let key = idempotency_key(&headers, &p)?;
    let body: serde_json::Value = json_body(&st, req).await?;
    let serde_json::Value::Object(mut o) = body else {
        return Err(AppError::invalid("body", "body: a JSON object"));
    };
    if let Some(f) = super::negotiate::render_format(&headers, o.get("format"))? {
        o.insert("format".into(), f.into());
    }
    let scene = o
        .remove("scene")
        .ok_or_else(|| AppError::invalid("scene", "scene: required (a scene object or id)"))?;
    // The default is `auto`, as the CLI's.
    let method = match o.remove("method") {
        None => Method::Auto,
        Some(serde_json::Value::String(m)) => Method::parse(&m)?,
        Some(_) => return Err(AppError::invalid("method", "method: a string")),
    };
    let wait = match o.remove("wait") {
        None => true,
        Some(serde_json::Value::Bool(b)) => b,
        Some(_) => return Err(AppError::invalid("wait", "wait: true or false")),
    };
    let scene_id = scene_ref(&st, &scene, "scene", &p).await?;
    let spec = JobSpec {
        kind: JobKind::Render,
        method,
        scene_id,
        object: None,
        params: serde_json::Value::Object(o),
    };
    if *st.shutdown.borrow() {
        return Err(crate::jobs::SubmitError::ShuttingDown.into());
    }
    // With an Idempotency-Key: the render first made with it (while it exists), checked and
    // submitted under one lock so that two such requests at once make one render.
    let hash = sha256_hex(&serde_json::to_vec(&spec).expect("spec serialises"));
    let _one_at_a_time = match &key {
        Some(k) => Some(idempotency_lock(k).lock().await),
        None => None,
    };
    let replay = match &key {
        Some(k) => match st.jobs.store.idempotency(k)? {
            Some((h, job)) if h == hash => st.jobs.store.get_job(&job)?.is_some().then_some(job),
            Some(_) => return Err(idempotency_key_reused()),
            None => None,
        },
        None => None,
    };
    let (id, h) = match replay {
        Some(id) => {
            let h = st.jobs.handle(&id);
            (id, h)
        }
        None => {
            let id = render_id();
            let jobs = st.jobs.clone();
            let (id2, spec2) = (id.clone(), spec.clone());
            // Held before it exists, so that it is never a job nobody holds.
            crate::http::auth::within_storage(&st, &p, 0)?;
            crate::http::auth::hold_within_quota(&st, &p, &id)?;
            let submitted = blocking(move || Ok(jobs.submit(&id2, &spec2)?)).await;
            let (h, _) = submitted.inspect_err(|_| {
                let _ = st.jobs.store.release(Held::Job, &id, &p.owner);
            })?;
            if let Some(k) = &key {
                st.jobs.store.replace_idempotency(k, &hash, &id)?;
            }
            (id, h)
        }
    };
    drop(_one_at_a_time);
    let loc = format!("/v1/renders/{id}");
    // Reading the body, the scene, the quota and the job's submission.
    let accept = t0.elapsed();
    let done = match (&h, wait) {
        (Some(h), true) => wait_terminal(&st, h, st.cfg.render_wait).await,
        _ => false,
    };
    let t_done = std::time::Instant::now();
    let r = load_job(&st, &id, JobKind::Render, &p)?;
    if !done && !matches!(r.state, JobState::Succeeded | JobState::Failed) {
        let v = view(r, h.as_deref());
        return Ok(accepted(loc, v));
    }
    if r.state != JobState::Succeeded {
        let code = match r.state {
            JobState::Canceled => Some(crate::jobs::ErrorCode::Canceled),
            _ => r.error_code(),
        };
        let err = r.error.as_deref().unwrap_or_default();
        return Err(AppError::failed_render(&id, code, err).instance(loc));
    }
    let mut resp = artifact_response(&st, &r).await?;
    // Around the job's own stages: its acceptance, and the record and image read back once it
    // finished.
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    let mut timings = vec![("accept".to_string(), ms(accept))];
    timings.extend(r.timings.iter().cloned());
    timings.push(("respond".to_string(), ms(t_done.elapsed())));
    let v = server_timing(&timings, Some(t0.elapsed()));
    if let Ok(v) = HeaderValue::from_str(&v) {
        resp.headers_mut().insert("server-timing", v);
    }
    resp.headers_mut().insert(
        header::LOCATION,
        HeaderValue::from_str(&loc).expect("ascii id"),
    );
    // The render's warnings (the record keeps them all): a header each, where it is one.
    for w in r.info["warnings"].as_array().into_iter().flatten() {
        if let Some(v) = w.as_str().and_then(|w| HeaderValue::from_str(w).ok()) {
            resp.headers_mut().append("caustica-warning", v);
        }
    }
    st.jobs
        .metrics
        .render_latency(r.method.name(), t0.elapsed());
    Ok(resp)
}

pub async fn get_render(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
) -> Result<Json<JobView>, AppError> {
    Ok(Json(job_view(&st, &id, JobKind::Render, &p)?))
}

/// `DELETE /v1/renders/{id}`: cancels a render (see `cancel_job`).
pub async fn delete_render(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    cancel_job(&st, &id, JobKind::Render, &p).await
}

pub async fn get_render_image(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
    headers: axum::http::HeaderMap,
) -> Result<Response, AppError> {
    let r = load_job(&st, &id, JobKind::Render, &p)?;
    if r.state != JobState::Succeeded {
        return Err(not_finished(JobKind::Render, &id, r.state));
    }
    serve_artifact(&st, &r, &headers).await
}
