//! Bakes and renders are jobs: how the API shows one ([`JobView`]), finds one by id, waits for
//! one, and serves its artifact with its timings.

use crate::http::auth::Principal;
use crate::http::{AppError, AppState};
use crate::jobs::store::{Held, JobRecord};
use crate::jobs::{JobHandle, JobKind, JobState};
use crate::methods::Method;
use axum::body::Bytes;
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use std::sync::Arc;
use std::time::Duration;

/// A job as the API shows it.
#[derive(Serialize, schemars::JsonSchema)]
#[schemars(rename = "Job")]
pub struct JobView {
    pub id: String,
    pub kind: JobKind,
    pub method: Method,
    pub scene_id: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub object: Option<String>,
    /// The method's parameters with their defaults filled in (a bake's `params`; a render's
    /// request fields other than scene, method and wait).
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub params: serde_json::Value,
    pub state: JobState,
    #[schemars(range(min = 0, max = 1))]
    pub progress: f32,
    /// What it is doing now (a method's stage name; `queued`, `done` and the like otherwise).
    pub stage: String,
    /// While running: milliseconds it may still take, from its progress so far (its time
    /// running × (1 − progress) / progress); absent before 1 % of progress and otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_ms: Option<i64>,
    /// Stage → milliseconds, in order.
    pub timings: Vec<Timing>,
    /// What the job learned: adapter, statistics, image size, notes...; for a failed job
    /// `error_code`, one of canceled, timeout, interrupted, invalid_input, invalid_params,
    /// no_gpu, render, encode, panic, store, worker_lost.
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub info: serde_json::Value,
    /// Why it failed or was canceled; null otherwise.
    pub error: Option<String>,
    /// Where the result is, once succeeded.
    pub artifact: Option<String>,
    /// Milliseconds since the Unix epoch.
    pub created_at: i64,
    pub started_at: Option<i64>,
    pub finished_at: Option<i64>,
}

/// One stage of a job and the milliseconds it took.
#[derive(Serialize, schemars::JsonSchema)]
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
    let eta_ms = match (state, r.started_at) {
        (JobState::Running, Some(t0)) => eta(crate::jobs::store::now_ms() - t0, progress),
        _ => None,
    };
    JobView {
        eta_ms,
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

/// What remains of a job that has run `elapsed_ms` and got `progress` (0..1) of the way, if
/// it got far enough to tell.
fn eta(elapsed_ms: i64, progress: f32) -> Option<i64> {
    (0.01..1.0).contains(&progress).then(|| {
        let p = f64::from(progress);
        (elapsed_ms.max(0) as f64 * (1.0 - p) / p).round() as i64
    })
}

/// `202 Accepted` with the job, its `Location`, and while it is not finished `Retry-After`:
/// its ETA within 1..=10 s, else 1 s for a render and 2 s for a bake.
pub(super) fn accepted(loc: String, v: JobView) -> Response {
    let retry = (!v.state.is_terminal()).then(|| {
        let fallback = match v.kind {
            JobKind::Render => 1,
            JobKind::Bake => 2,
        };
        v.eta_ms
            .map_or(fallback, |ms| ((ms + 999) / 1000).clamp(1, 10))
    });
    let mut resp = (
        StatusCode::ACCEPTED,
        [(header::LOCATION, loc)],
        axum::Json(v),
    )
        .into_response();
    if let Some(secs) = retry {
        resp.headers_mut()
            .insert(header::RETRY_AFTER, HeaderValue::from(secs));
    }
    resp
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

/// The artifact of succeeded job `r` as the whole body, with its type, `ETag` (its SHA-256)
/// and caching headers. It is checked against the stored length and hash first, then
/// streamed from disk.
pub(super) async fn artifact_response(st: &AppState, r: &JobRecord) -> Result<Response, AppError> {
    let (ty, file, len) = open_artifact(st, r).await?;
    let mut resp = file_response(StatusCode::OK, ty, file, 0, len);
    cache_headers(resp.headers_mut(), r);
    Ok(resp)
}

/// The artifact's media type, its file (checked, off the async workers) and its length.
async fn open_artifact(
    st: &AppState,
    r: &JobRecord,
) -> Result<(String, std::fs::File, u64), AppError> {
    let Some(ty) = r.artifact_type.clone() else {
        return Err(AppError::internal("succeeded job without an artifact"));
    };
    let (jobs, rec) = (st.jobs.clone(), r.clone());
    let (file, len) =
        super::blocking(move || jobs.artifact(&rec).map_err(|e| AppError::artifact(&rec, e)))
            .await?;
    Ok((ty, file, len))
}

/// Bytes read from disk a chunk at a time for a streamed body.
const CHUNK: u64 = 256 << 10;

/// `len` bytes of `file` from offset `start` as a body read from disk a chunk at a time (off
/// the async workers), so that serving an artifact holds one chunk of it in memory, not all.
fn file_body(file: std::fs::File, start: u64, len: u64) -> axum::body::Body {
    let file = Arc::new(file);
    let chunks = futures_util::stream::try_unfold((start, len), move |(at, left)| {
        let file = file.clone();
        async move {
            if left == 0 {
                return Ok(None);
            }
            let n = left.min(CHUNK) as usize;
            let buf = tokio::task::spawn_blocking(move || {
                use std::os::unix::fs::FileExt;
                let mut buf = vec![0u8; n];
                file.read_exact_at(&mut buf, at).map(|()| buf)
            })
            .await
            .map_err(std::io::Error::other)??;
            Ok::<_, std::io::Error>(Some((Bytes::from(buf), (at + n as u64, left - n as u64))))
        }
    });
    axum::body::Body::from_stream(chunks)
}

/// `len` bytes of `file` from `start` ([`file_body`]) as an answer of `status` with its media
/// type and length.
fn file_response(
    status: StatusCode,
    ty: String,
    file: std::fs::File,
    start: u64,
    len: u64,
) -> Response {
    let mut resp = (
        status,
        [(header::CONTENT_TYPE, ty)],
        file_body(file, start, len),
    )
        .into_response();
    resp.headers_mut()
        .insert(header::CONTENT_LENGTH, HeaderValue::from(len));
    resp
}

/// `ETag`, `Cache-Control` (artifacts never change) and `Accept-Ranges`.
fn cache_headers(h: &mut HeaderMap, r: &JobRecord) {
    if let Some(tag) = etag(r).and_then(|t| HeaderValue::from_str(&t).ok()) {
        h.insert(header::ETAG, tag);
    }
    h.insert(
        header::CACHE_CONTROL,
        HeaderValue::from_static("public, max-age=31536000, immutable"),
    );
    h.insert(header::ACCEPT_RANGES, HeaderValue::from_static("bytes"));
}

fn etag(r: &JobRecord) -> Option<String> {
    r.artifact_sha256.as_ref().map(|h| format!("\"{h}\""))
}

/// Whether an `If-None-Match` value matches entity tag `tag` (weak comparison: `W/` ignored).
pub(super) fn none_match(value: &str, tag: &str) -> bool {
    value
        .split(',')
        .map(str::trim)
        .any(|t| t == "*" || t.strip_prefix("W/").unwrap_or(t) == tag)
}

/// What a `Range` header asks of a body of `len` bytes.
#[derive(Debug, PartialEq)]
enum RangeAsk {
    /// No usable range (absent, malformed, several, or not bytes): the whole body.
    Whole,
    /// Bytes `start..=end`.
    Part(u64, u64),
    /// A single byte range that lies wholly past the end.
    Unsatisfiable,
}

fn range_ask(value: &str, len: u64) -> RangeAsk {
    let Some(spec) = value.trim().strip_prefix("bytes=") else {
        return RangeAsk::Whole;
    };
    if spec.contains(',') {
        return RangeAsk::Whole;
    }
    let Some((a, b)) = spec.trim().split_once('-') else {
        return RangeAsk::Whole;
    };
    let num = |s: &str| -> Option<u64> {
        (!s.is_empty() && s.bytes().all(|c| c.is_ascii_digit()))
            .then(|| s.parse().ok())
            .flatten()
    };
    match (a.trim(), b.trim()) {
        ("", n) => match num(n) {
            Some(0) => RangeAsk::Unsatisfiable,
            Some(_) if len == 0 => RangeAsk::Unsatisfiable,
            Some(n) => RangeAsk::Part(len.saturating_sub(n), len - 1),
            None => RangeAsk::Whole,
        },
        (a, "") => match num(a) {
            Some(a) if a >= len => RangeAsk::Unsatisfiable,
            Some(a) => RangeAsk::Part(a, len - 1),
            None => RangeAsk::Whole,
        },
        (a, b) => match (num(a), num(b)) {
            (Some(a), Some(b)) if a <= b => {
                if a >= len {
                    RangeAsk::Unsatisfiable
                } else {
                    RangeAsk::Part(a, b.min(len - 1))
                }
            }
            _ => RangeAsk::Whole,
        },
    }
}

/// `GET` of an artifact: `304` when `If-None-Match` names its ETag (without reading it), one
/// byte range as `206` (`If-Range` honoured; several ranges get the whole body), `416` past
/// its end, else `200` with the whole body.
pub(super) async fn serve_artifact(
    st: &AppState,
    r: &JobRecord,
    req: &HeaderMap,
) -> Result<Response, AppError> {
    let tag = etag(r);
    let header_str = |name: header::HeaderName| req.get(name).and_then(|v| v.to_str().ok());
    if let (Some(tag), Some(v)) = (&tag, header_str(header::IF_NONE_MATCH))
        && none_match(v, tag)
    {
        // Served from the client's copy: counts as a use for the least-recently-served eviction.
        if let Err(e) = st.jobs.store.used(&r.id) {
            tracing::warn!(job = %r.id, error = %e, "last use not recorded");
        }
        let mut resp = StatusCode::NOT_MODIFIED.into_response();
        cache_headers(resp.headers_mut(), r);
        return Ok(resp);
    }
    let (ty, file, len) = open_artifact(st, r).await?;
    let range_applies = match header_str(header::IF_RANGE) {
        None => true,
        Some(v) => tag.as_deref() == Some(v.trim()),
    };
    let ask = header_str(header::RANGE)
        .filter(|_| range_applies)
        .map_or(RangeAsk::Whole, |v| range_ask(v, len));
    let mut resp = match ask {
        RangeAsk::Whole => file_response(StatusCode::OK, ty, file, 0, len),
        RangeAsk::Unsatisfiable => {
            let mut e = AppError::new(
                StatusCode::RANGE_NOT_SATISFIABLE,
                "range-not-satisfiable",
                "Range not satisfiable",
                format!("the artifact has {len} bytes; the range asked for lies past its end"),
            )
            .into_response();
            if let Ok(v) = HeaderValue::from_str(&format!("bytes */{len}")) {
                e.headers_mut().insert(header::CONTENT_RANGE, v);
            }
            return Ok(e);
        }
        RangeAsk::Part(a, b) => {
            let range = format!("bytes {a}-{b}/{len}");
            let mut resp = file_response(StatusCode::PARTIAL_CONTENT, ty, file, a, b - a + 1);
            if let Ok(v) = HeaderValue::from_str(&range) {
                resp.headers_mut().insert(header::CONTENT_RANGE, v);
            }
            resp
        }
    };
    cache_headers(resp.headers_mut(), r);
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

#[cfg(test)]
mod tests {
    use super::{RangeAsk, eta, none_match, range_ask};

    #[tokio::test]
    async fn a_file_body_streams_exactly_the_bytes_asked_for() {
        let dir = std::env::temp_dir().join(format!("caustica-file-body-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.bin");
        let data: Vec<u8> = (0..600_000u32).map(|i| (i * 7 + i / 251) as u8).collect();
        std::fs::write(&path, &data).unwrap();
        // Whole, inside, across chunk boundaries, the last byte, nothing.
        let chunk = super::CHUNK as usize;
        for (start, len) in [
            (0, data.len()),
            (100, 300_000),
            (chunk - 1, 2),
            (chunk, chunk + 1),
            (data.len() - 1, 1),
            (5, 0),
        ] {
            let f = std::fs::File::open(&path).unwrap();
            let body = super::file_body(f, start as u64, len as u64);
            let got = axum::body::to_bytes(body, usize::MAX).await.unwrap();
            assert!(got[..] == data[start..start + len], "{start} +{len}");
        }
        // Past the end of the file: the body fails instead of coming out short.
        let f = std::fs::File::open(&path).unwrap();
        let body = super::file_body(f, data.len() as u64 - 10, 20);
        assert!(axum::body::to_bytes(body, usize::MAX).await.is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn byte_ranges_follow_rfc_9110() {
        use RangeAsk::*;
        let cases = [
            ("bytes=0-9", 100, Part(0, 9)),
            ("bytes=90-", 100, Part(90, 99)),
            ("bytes=-10", 100, Part(90, 99)),
            ("bytes=-500", 100, Part(0, 99)),
            ("bytes=50-500", 100, Part(50, 99)),
            ("bytes=99-99", 100, Part(99, 99)),
            ("bytes=100-", 100, Unsatisfiable),
            ("bytes=100-200", 100, Unsatisfiable),
            ("bytes=-0", 100, Unsatisfiable),
            ("bytes=9-0", 100, Whole),
            ("bytes=0-1,5-6", 100, Whole),
            ("items=0-1", 100, Whole),
            ("bytes=a-b", 100, Whole),
            ("bytes=-", 100, Whole),
            ("bytes=+1-2", 100, Whole),
        ];
        for (v, len, want) in cases {
            assert_eq!(range_ask(v, len), want, "{v}");
        }
    }

    #[test]
    fn if_none_match_compares_weakly_and_takes_lists() {
        let tag = "\"abc\"";
        assert!(none_match("\"abc\"", tag));
        assert!(none_match("W/\"abc\"", tag));
        assert!(none_match("\"x\", \"abc\"", tag));
        assert!(none_match("*", tag));
        assert!(!none_match("\"abcd\"", tag));
        assert!(!none_match("abc", tag));
    }

    #[test]
    fn the_eta_scales_the_time_so_far_by_what_is_left() {
        assert_eq!(eta(1000, 0.25), Some(3000));
        assert_eq!(eta(1000, 0.5), Some(1000));
        assert_eq!(eta(1000, 0.005), None);
        assert_eq!(eta(1000, 1.0), None);
    }
}
