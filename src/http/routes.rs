//! Handlers and DTOs of API v1.

use super::{AppError, AppState};
use crate::jobs::csl_bake::CslBakeParams;
use crate::jobs::reference_bake::ReferenceBakeParams;
use crate::jobs::scenes::{SceneInfo, SceneInput, sha256_hex};
use crate::jobs::store::JobRecord;
use crate::jobs::{JobHandle, JobSpec, Readiness};
use axum::Json;
use axum::body::Bytes;
use axum::extract::{FromRequest, Multipart, Path, Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------------------------------
// Request helpers

/// The media type of the request, lowercased, without parameters.
fn media_type(headers: &HeaderMap) -> String {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .map(|v| {
            v.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .to_ascii_lowercase()
        })
        .unwrap_or_default()
}

/// Refuses a declared body over the limit before reading any of it.
fn check_length(headers: &HeaderMap, limit: usize) -> Result<(), AppError> {
    let len = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    match len {
        Some(n) if n > limit as u64 => Err(AppError::too_large(limit)),
        _ => Ok(()),
    }
}

async fn body_bytes(st: &AppState, req: Request) -> Result<Bytes, AppError> {
    check_length(req.headers(), st.cfg.max_body)?;
    Bytes::from_request(req, st).await.map_err(|r| {
        if r.status() == StatusCode::PAYLOAD_TOO_LARGE {
            AppError::too_large(st.cfg.max_body)
        } else {
            AppError::bad_request(r.body_text())
        }
    })
}

/// Parses a JSON body; the detail names the field at fault.
fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, AppError> {
    let de = &mut serde_json::Deserializer::from_slice(bytes);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        match inner.classify() {
            serde_json::error::Category::Data => {
                let field = if path == "." { "body".into() } else { path };
                AppError::invalid(&field, format!("{field}: {inner}"))
            }
            _ => AppError::bad_request(format!("body is not valid JSON: {inner}")),
        }
    })
}

async fn json_body<T: DeserializeOwned>(st: &AppState, req: Request) -> Result<T, AppError> {
    let mt = media_type(req.headers());
    if mt != "application/json" {
        return Err(AppError::unsupported_media(format!(
            "Content-Type must be application/json, not '{mt}'"
        )));
    }
    let b = body_bytes(st, req).await?;
    parse_json(&b)
}

/// Runs blocking work (scene import, store reads) off the async threads.
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, AppError> + Send + 'static,
) -> Result<T, AppError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| AppError::internal(format!("worker task failed: {e}")))?
}

fn valid_id(id: &str, prefix: &str) -> bool {
    id.len() == prefix.len() + 32
        && id.starts_with(prefix)
        && id[prefix.len()..].bytes().all(|b| b.is_ascii_hexdigit())
}

fn valid_scene_id(id: &str) -> bool {
    id.len() == 64 && id.bytes().all(|b| b.is_ascii_hexdigit())
}

// ---------------------------------------------------------------------------------------------
// Scenes

const MAX_FILES: usize = 64;

async fn read_multipart(st: &AppState, req: Request) -> Result<SceneInput, AppError> {
    check_length(req.headers(), st.cfg.max_body)?;
    let mut mp = Multipart::from_request(req, st)
        .await
        .map_err(|r| AppError::bad_request(r.body_text()))?;
    let mut scene = None;
    let mut files = Vec::new();
    loop {
        let field = match mp.next_field().await {
            Ok(Some(f)) => f,
            Ok(None) => break,
            Err(e) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => {
                return Err(AppError::too_large(st.cfg.max_body));
            }
            Err(e) => {
                return Err(AppError::bad_request(format!(
                    "multipart: {}",
                    e.body_text()
                )));
            }
        };
        let name = field.name().unwrap_or("").to_string();
        if name.is_empty() || name.len() > 255 || name.contains('\0') {
            return Err(AppError::invalid(
                "multipart",
                "multipart: every part needs a name (the file name the scene uses), at most 255 bytes",
            ));
        }
        let data = field.bytes().await.map_err(|e| {
            if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
                AppError::too_large(st.cfg.max_body)
            } else {
                AppError::bad_request(format!("multipart part '{name}': {}", e.body_text()))
            }
        })?;
        if name == "scene" {
            scene = Some(data.to_vec());
        } else {
            if files.len() >= MAX_FILES {
                return Err(AppError::invalid(
                    "multipart",
                    format!("multipart: at most {MAX_FILES} files per scene"),
                ));
            }
            if files.iter().any(|(n, _): &(String, Vec<u8>)| *n == name) {
                return Err(AppError::invalid(
                    "multipart",
                    format!("multipart: two parts named '{name}'"),
                ));
            }
            files.push((name, data.to_vec()));
        }
    }
    let scene = scene.ok_or_else(|| {
        AppError::invalid(
            "scene",
            "multipart: a part named 'scene' with the scene JSON is required",
        )
    })?;
    Ok(SceneInput::Json { scene, files })
}

async fn ingest(st: &AppState, input: SceneInput) -> Result<SceneInfo, AppError> {
    let jobs = st.jobs.clone();
    blocking(move || Ok(jobs.scenes.ingest(input)?)).await
}

pub async fn post_scene(State(st): State<AppState>, req: Request) -> Result<Response, AppError> {
    let mt = media_type(req.headers());
    let input = match mt.as_str() {
        "application/json" => SceneInput::Json {
            scene: body_bytes(&st, req).await?.to_vec(),
            files: vec![],
        },
        "model/gltf-binary" => SceneInput::Gltf {
            bytes: body_bytes(&st, req).await?.to_vec(),
            binary: true,
        },
        "model/gltf+json" => SceneInput::Gltf {
            bytes: body_bytes(&st, req).await?.to_vec(),
            binary: false,
        },
        "multipart/form-data" => read_multipart(&st, req).await?,
        "" => {
            return Err(AppError::unsupported_media(
                "Content-Type is required: application/json, model/gltf-binary, \
                 model/gltf+json or multipart/form-data",
            ));
        }
        other => {
            return Err(AppError::unsupported_media(format!(
                "Content-Type '{other}' is not accepted: use application/json, \
                 model/gltf-binary, model/gltf+json or multipart/form-data"
            )));
        }
    };
    let info = ingest(&st, input).await?;
    let loc = format!("/v1/scenes/{}", info.id);
    Ok((StatusCode::CREATED, [(header::LOCATION, loc)], Json(info)).into_response())
}

pub async fn get_scene(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SceneInfo>, AppError> {
    if !valid_scene_id(&id) {
        return Err(AppError::not_found("scene", &id));
    }
    let jobs = st.jobs.clone();
    let id2 = id.clone();
    let info = blocking(move || Ok(jobs.scenes.info(&id2)?)).await?;
    info.map(Json)
        .ok_or_else(|| AppError::not_found("scene", &id))
}

/// A scene given inline (object) or by id (string): the stored id.
async fn scene_ref(st: &AppState, v: &serde_json::Value, field: &str) -> Result<String, AppError> {
    match v {
        serde_json::Value::String(id) => {
            if !valid_scene_id(id) || st.jobs.store.get_scene(id)?.is_none() {
                return Err(AppError::invalid(
                    field,
                    format!("{field}: no stored scene with id '{id}'"),
                ));
            }
            Ok(id.clone())
        }
        serde_json::Value::Object(_) => {
            let bytes = serde_json::to_vec(v).expect("value serialises");
            let info = ingest(
                st,
                SceneInput::Json {
                    scene: bytes,
                    files: vec![],
                },
            )
            .await
            .map_err(|mut e| {
                // Name the field inside the request: scene.objects[1]...
                if let Some(f) = e.field.clone() {
                    e.detail = format!("{field}.{}", e.detail);
                    e.field = Some(format!("{field}.{f}"));
                }
                e
            })?;
            Ok(info.id)
        }
        _ => Err(AppError::invalid(
            field,
            format!("{field}: a scene object or the id of a stored scene"),
        )),
    }
}

// ---------------------------------------------------------------------------------------------
// Jobs (bakes and renders)

/// A job as the API shows it.
#[derive(Serialize)]
pub struct JobView {
    pub id: String,
    pub kind: String,
    pub method: String,
    pub scene_id: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub object: Option<String>,
    pub params: serde_json::Value,
    pub state: String,
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

fn view(r: JobRecord, live: Option<&JobHandle>) -> JobView {
    let (mut state, mut progress, mut stage) = (r.state, r.progress, r.stage);
    if let Some(h) = live {
        let s = h.state();
        if !s.is_terminal() {
            state = s.as_str().into();
            let (p, st) = h.progress();
            progress = p;
            stage = st;
        }
    }
    let artifact = (state == "succeeded").then(|| {
        if r.kind == "bake" {
            format!("/v1/bakes/{}/artifact", r.id)
        } else {
            format!("/v1/renders/{}/image", r.id)
        }
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

fn load_job(st: &AppState, id: &str, kind: &str) -> Result<JobRecord, AppError> {
    let prefix = if kind == "bake" { "bk_" } else { "rn_" };
    let what = kind;
    if !valid_id(id, prefix) {
        return Err(AppError::not_found(what, id));
    }
    match st.jobs.store.get_job(id)? {
        Some(r) if r.kind == kind => Ok(r),
        _ => Err(AppError::not_found(what, id)),
    }
}

fn job_view(st: &AppState, id: &str, kind: &str) -> Result<JobView, AppError> {
    let r = load_job(st, id, kind)?;
    let h = st.jobs.handle(id);
    Ok(view(r, h.as_deref()))
}

/// Waits until the job ends, `wait` passes or shutdown begins. True when it ended.
async fn wait_terminal(st: &AppState, h: &Arc<JobHandle>, wait: Duration) -> bool {
    let mut rx = h.subscribe();
    let mut stop = st.shutdown.clone();
    tokio::select! {
        r = tokio::time::timeout(wait, rx.wait_for(|s| s.is_terminal())) => {
            matches!(r, Ok(Ok(_)))
        }
        _ = stop.wait_for(|s| *s) => false,
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct BakeRequest {
    #[serde(default)]
    scene: Option<serde_json::Value>,
    #[serde(default)]
    scene_id: Option<String>,
    object: String,
    method: String,
    #[serde(default)]
    params: Option<serde_json::Value>,
}

fn canonical_bake_params(
    method: &str,
    params: Option<serde_json::Value>,
) -> Result<serde_json::Value, AppError> {
    let v = params.unwrap_or_else(|| serde_json::json!({}));
    match method {
        "reference" => {
            Ok(serde_json::to_value(ReferenceBakeParams::from_value(&v)?)
                .expect("params serialise"))
        }
        "csl" => {
            Ok(serde_json::to_value(CslBakeParams::from_value(&v)?).expect("params serialise"))
        }
        "transport" => Ok(serde_json::to_value(
            crate::jobs::transport_bake::TransportBakeParams::from_value(&v)?,
        )
        .expect("params serialise")),
        m => Err(AppError::invalid(
            "method",
            format!("method: unknown bake method '{m}' (available: reference, csl, transport)"),
        )),
    }
}

pub async fn post_bake(State(st): State<AppState>, req: Request) -> Result<Response, AppError> {
    let key = req
        .headers()
        .get("idempotency-key")
        .map(|v| v.to_str().map(str::to_string))
        .transpose()
        .map_err(|_| AppError::bad_request("Idempotency-Key must be visible ASCII"))?;
    if key.as_ref().is_some_and(|k| k.is_empty() || k.len() > 255) {
        return Err(AppError::bad_request(
            "Idempotency-Key must be 1..=255 characters",
        ));
    }
    let b: BakeRequest = json_body(&st, req).await?;
    let scene_id = match (&b.scene, &b.scene_id) {
        (Some(s), None) => scene_ref(&st, s, "scene").await?,
        (None, Some(id)) => {
            scene_ref(&st, &serde_json::Value::String(id.clone()), "scene_id").await?
        }
        _ => {
            return Err(AppError::invalid(
                "scene",
                "scene: give exactly one of `scene` (object or id) and `scene_id`",
            ));
        }
    };
    let params = canonical_bake_params(&b.method, b.params)?;
    let spec = JobSpec {
        kind: "bake".into(),
        method: b.method,
        scene_id,
        object: Some(b.object),
        params,
    };
    let spec_json = serde_json::to_vec(&spec).expect("spec serialises");
    let hash = sha256_hex(&spec_json);
    let mut id = format!("bk_{}", &hash[..32]);
    if let Some(k) = &key {
        match st.jobs.store.idempotency(k)? {
            Some((h, job)) if h == hash => id = job,
            Some(_) => {
                return Err(AppError::new(
                    StatusCode::UNPROCESSABLE_ENTITY,
                    "idempotency-key-reused",
                    "Idempotency key reused",
                    "Idempotency-Key was already used for a different request",
                )
                .field("Idempotency-Key"));
            }
            None => {}
        }
    }
    if *st.shutdown.borrow() {
        return Err(crate::jobs::SubmitError::ShuttingDown.into());
    }
    let jobs = st.jobs.clone();
    let (id2, spec2) = (id.clone(), spec.clone());
    blocking(move || Ok(jobs.submit(&id2, &spec2)?)).await?;
    if let Some(k) = &key {
        st.jobs.store.put_idempotency(k, &hash, &id)?;
    }
    let v = job_view(&st, &id, "bake")?;
    let loc = format!("/v1/bakes/{id}");
    Ok((StatusCode::ACCEPTED, [(header::LOCATION, loc)], Json(v)).into_response())
}

pub async fn get_bake(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<JobView>, AppError> {
    Ok(Json(job_view(&st, &id, "bake")?))
}

pub async fn delete_bake(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<JobView>, AppError> {
    let r = load_job(&st, &id, "bake")?;
    if r.state == "succeeded" {
        return Err(AppError::new(
            StatusCode::CONFLICT,
            "already-finished",
            "Already finished",
            format!("bake {id} already succeeded; there is nothing to cancel"),
        ));
    }
    if let Some(h) = st.jobs.handle(&id) {
        st.jobs.cancel(&id)?;
        // The worker stops at its next progress check; wait for it (bounded) so the answer
        // tells the final state.
        wait_terminal(&st, &h, Duration::from_secs(30)).await;
    }
    Ok(Json(job_view(&st, &id, "bake")?))
}

fn not_finished(kind: &str, id: &str, state: &str) -> AppError {
    AppError::new(
        StatusCode::CONFLICT,
        "not-ready",
        "Result not available",
        format!("{kind} {id} is {state}: its result exists only once it has succeeded"),
    )
}

fn artifact_response(st: &AppState, r: &JobRecord) -> Result<Response, AppError> {
    let (Some(ty), Some(path)) = (&r.artifact_type, &r.artifact_path) else {
        return Err(AppError::internal("succeeded job without an artifact"));
    };
    let bytes = st.jobs.store.read_artifact(path)?;
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

pub async fn get_bake_artifact(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    let r = load_job(&st, &id, "bake")?;
    if r.state != "succeeded" {
        return Err(not_finished("bake", &id, &r.state));
    }
    artifact_response(&st, &r)
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

static RENDER_SEQ: AtomicU64 = AtomicU64::new(0);

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
    let body: serde_json::Value = json_body(&st, req).await?;
    let serde_json::Value::Object(mut o) = body else {
        return Err(AppError::invalid("body", "body: a JSON object"));
    };
    let scene = o
        .remove("scene")
        .ok_or_else(|| AppError::invalid("scene", "scene: required (a scene object or id)"))?;
    let method = match o.remove("method") {
        None => "direct".to_string(),
        Some(serde_json::Value::String(m)) => m,
        Some(_) => return Err(AppError::invalid("method", "method: a string")),
    };
    let wait = match o.remove("wait") {
        None => true,
        Some(serde_json::Value::Bool(b)) => b,
        Some(_) => return Err(AppError::invalid("wait", "wait: true or false")),
    };
    let scene_id = scene_ref(&st, &scene, "scene").await?;
    let spec = JobSpec {
        kind: "render".into(),
        method: method.clone(),
        scene_id,
        object: None,
        params: serde_json::Value::Object(o),
    };
    if *st.shutdown.borrow() {
        return Err(crate::jobs::SubmitError::ShuttingDown.into());
    }
    let id = render_id();
    let jobs = st.jobs.clone();
    let (id2, spec2) = (id.clone(), spec.clone());
    let (h, _) = blocking(move || Ok(jobs.submit(&id2, &spec2)?)).await?;
    let loc = format!("/v1/renders/{id}");
    let done = match (&h, wait) {
        (Some(h), true) => wait_terminal(&st, h, st.cfg.render_wait).await,
        _ => false,
    };
    let r = load_job(&st, &id, "render")?;
    if !done && r.state != "succeeded" && r.state != "failed" {
        let v = view(r, h.as_deref());
        return Ok((StatusCode::ACCEPTED, [(header::LOCATION, loc)], Json(v)).into_response());
    }
    match r.state.as_str() {
        "succeeded" => {
            let mut resp = artifact_response(&st, &r)?;
            let v = server_timing(&r.timings, Some(t0.elapsed()));
            if let Ok(v) = HeaderValue::from_str(&v) {
                resp.headers_mut().insert("server-timing", v);
            }
            resp.headers_mut().insert(
                header::LOCATION,
                HeaderValue::from_str(&loc).expect("ascii id"),
            );
            st.jobs.metrics.render_latency(&method, t0.elapsed());
            Ok(resp)
        }
        _ => {
            let err = r.error.clone().unwrap_or_default();
            let code = r
                .info
                .get("error_code")
                .and_then(|c| c.as_str())
                .unwrap_or("");
            let (status, kind, title) = match code {
                "no_gpu" => (StatusCode::SERVICE_UNAVAILABLE, "no-gpu", "No GPU"),
                "timeout" => (StatusCode::GATEWAY_TIMEOUT, "job-timeout", "Job time limit"),
                "canceled" => (StatusCode::CONFLICT, "canceled", "Canceled"),
                // Input that only the work itself finds unworkable (e.g. more illumination
                // volumes than a frame may hold).
                "invalid_params" | "invalid_input" => (
                    StatusCode::UNPROCESSABLE_ENTITY,
                    "invalid-render",
                    "Render input cannot be rendered",
                ),
                _ => (
                    StatusCode::INTERNAL_SERVER_ERROR,
                    "render-failed",
                    "Render failed",
                ),
            };
            Err(
                AppError::new(status, kind, title, format!("render {id} failed: {err}"))
                    .instance(loc),
            )
        }
    }
}

pub async fn get_render(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<JobView>, AppError> {
    Ok(Json(job_view(&st, &id, "render")?))
}

pub async fn get_render_image(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    let r = load_job(&st, &id, "render")?;
    if r.state != "succeeded" {
        return Err(not_finished("render", &id, &r.state));
    }
    artifact_response(&st, &r)
}

// ---------------------------------------------------------------------------------------------
// Operations

pub async fn healthz() -> Json<serde_json::Value> {
    Json(serde_json::json!({"status": "ok"}))
}

pub async fn readyz(State(st): State<AppState>) -> Result<Json<serde_json::Value>, AppError> {
    match st.jobs.readiness() {
        Readiness::Ready { adapter } => Ok(Json(serde_json::json!({
            "status": "ready",
            "adapter": adapter,
        }))),
        Readiness::Starting => Err(AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "not-ready",
            "Not ready",
            "the GPU worker is still probing the adapter",
        )
        .retry_after(1)),
        Readiness::NoGpu { error } => Err(AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "no-gpu",
            "No GPU",
            format!("no GPU adapter renders: {error}"),
        )),
    }
}

pub async fn metrics(State(st): State<AppState>) -> Response {
    let body = st.jobs.metrics.render(st.jobs.queue_depth());
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
    Json(super::openapi().clone())
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
