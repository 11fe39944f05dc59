//! `POST /v1/scenes`, `GET /v1/scenes/{id}`, and scenes given inline in other requests.

use super::{
    blocking, body_bytes, check_length, json_bytes, media_type, principal, valid_scene_id,
};
use crate::http::auth::Principal;
use crate::http::{AppError, AppState};
use crate::jobs::scenes::{SceneInfo, SceneInput};
use crate::jobs::store::Held;
use axum::extract::{FromRequest, Multipart, Path, Request, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json};

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
            if data.len() > st.cfg.max_json_body {
                return Err(AppError::invalid(
                    "scene",
                    format!(
                        "multipart part 'scene': {} bytes of scene JSON, more than the {} this \
                         server accepts",
                        data.len(),
                        st.cfg.max_json_body
                    ),
                ));
            }
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

async fn ingest(st: &AppState, input: SceneInput, p: &Principal) -> Result<SceneInfo, AppError> {
    let jobs = st.jobs.clone();
    let owner = p.owner.clone();
    blocking(move || Ok(jobs.scenes.ingest(input, &owner)?)).await
}

pub async fn post_scene(State(st): State<AppState>, req: Request) -> Result<Response, AppError> {
    let p = principal(&req);
    let mt = media_type(req.headers());
    let input = match mt.as_str() {
        "application/json" => SceneInput::Json {
            scene: json_bytes(&st, req).await?.to_vec(),
            files: vec![],
        },
        "model/gltf-binary" => SceneInput::Gltf {
            bytes: body_bytes(&st, req, st.cfg.max_body).await?.to_vec(),
            binary: true,
        },
        "model/gltf+json" => SceneInput::Gltf {
            bytes: body_bytes(&st, req, st.cfg.max_body).await?.to_vec(),
            binary: false,
        },
        "multipart/form-data" => {
            let limit = st.cfg.body_timeout;
            tokio::time::timeout(limit, read_multipart(&st, req))
                .await
                .map_err(|_| AppError::body_timeout(limit))??
        }
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
    crate::http::auth::within_storage(&st, &p, input.bytes())?;
    let info = ingest(&st, input, &p).await?;
    let loc = format!("/v1/scenes/{}", info.id);
    Ok((StatusCode::CREATED, [(header::LOCATION, loc)], Json(info)).into_response())
}

/// `GET /v1/scenes/{id}`: with `ETag` (the content-addressed id and the server's version, as
/// what the server says of a scene may change with its version) and `Cache-Control: no-cache`
/// (a scene may be deleted): `If-None-Match` with that tag answers 304 without loading it.
pub async fn get_scene(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
    headers: axum::http::HeaderMap,
) -> Result<Response, AppError> {
    use axum::http::HeaderValue;
    if !valid_scene_id(&id) || !(p.admin || st.jobs.store.holds(Held::Scene, &id, &p.owner)?) {
        return Err(AppError::not_found("scene", &id));
    }
    let tag = format!("\"{id}.{}\"", env!("CARGO_PKG_VERSION"));
    let cache = |r: &mut Response| {
        let h = r.headers_mut();
        if let Ok(v) = HeaderValue::from_str(&tag) {
            h.insert(header::ETAG, v);
        }
        h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    };
    let matches = headers
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| super::jobs::none_match(v, &tag));
    if matches && st.jobs.store.scene_exists(&id)? {
        let mut r = StatusCode::NOT_MODIFIED.into_response();
        cache(&mut r);
        return Ok(r);
    }
    let jobs = st.jobs.clone();
    let id2 = id.clone();
    let info = blocking(move || Ok(jobs.scenes.info(&id2)?)).await?;
    let info = info.ok_or_else(|| AppError::not_found("scene", &id))?;
    let mut r = Json(info).into_response();
    cache(&mut r);
    Ok(r)
}

/// `DELETE /v1/scenes/{id}`: drops the caller's hold on the scene (an admin's: every hold);
/// once nobody holds it and no queued or running job uses it, the scene and its files are
/// deleted (a scene a job still uses goes with the retention sweep after the job). 409 when the
/// caller is the last holder, or an admin, and a queued or running job uses it; 204 otherwise.
pub async fn delete_scene(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    let store = &st.jobs.store;
    let visible = valid_scene_id(&id) && (p.admin || store.holds(Held::Scene, &id, &p.owner)?);
    if !visible || store.get_scene(&id)?.is_none() {
        return Err(AppError::not_found("scene", &id));
    }
    let last = p.admin || store.holders(Held::Scene, &id)? <= 1;
    if last && store.scene_in_use(&id)? {
        return Err(AppError::new(
            StatusCode::CONFLICT,
            "scene-in-use",
            "Scene in use",
            format!("scene {id} is used by a queued or running job; cancel it first"),
        ));
    }
    if p.admin {
        store.release_all(Held::Scene, &id)?;
    } else {
        store.release(Held::Scene, &id, &p.owner)?;
    }
    if store.delete_scene(&id)? {
        st.jobs.scenes.forget(&id);
    }
    Ok(StatusCode::NO_CONTENT.into_response())
}

/// A scene given inline (object) or by id (string): the stored id. `p` must hold a scene given
/// by id (an unknown one and another client's answer alike); an inline one becomes theirs.
pub(super) async fn scene_ref(
    st: &AppState,
    v: &serde_json::Value,
    field: &str,
    p: &Principal,
) -> Result<String, AppError> {
    match v {
        serde_json::Value::String(id) => {
            let visible = valid_scene_id(id)
                && (p.admin || st.jobs.store.holds(Held::Scene, id, &p.owner)?);
            if !visible || st.jobs.store.get_scene(id)?.is_none() {
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
                p,
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
