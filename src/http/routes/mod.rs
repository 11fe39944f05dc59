//! Handlers and DTOs of API v1, one file per resource: [`scenes`], [`bakes`], [`renders`],
//! [`compare`],
//! the job views both bakes and renders answer with ([`jobs`]), and the operational
//! endpoints ([`ops`]). The request helpers shared by the handlers are here.

pub mod bakes;
pub mod compare;
pub mod events;
pub mod jobs;
pub mod lists;
pub mod negotiate;
pub mod ops;
pub mod renders;
pub mod scenes;

pub use bakes::{delete_bake, get_bake, get_bake_artifact, post_bake};
pub use compare::post_compare;
pub use events::{bake_events, render_events};
pub use jobs::{JobView, Timing, server_timing};
pub use lists::{list_bakes, list_renders, list_scenes};
pub use ops::{healthz, method_not_allowed, metrics, not_found, openapi_json, readyz};
pub use renders::{delete_render, get_render, get_render_image, post_render};
pub use scenes::{delete_scene, get_scene, post_scene};

use super::auth::Principal;
use super::{AppError, AppState};
use crate::scene::shape::{ShapeLimits, check_shape};
use axum::body::Bytes;
use axum::extract::Request;
use axum::http::{HeaderMap, header};
use serde::de::DeserializeOwned;

/// The media type of the request, lowercased, without parameters.
pub(crate) fn media_type(headers: &HeaderMap) -> String {
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
pub(super) fn check_length(headers: &HeaderMap, limit: usize) -> Result<(), AppError> {
    let len = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    match len {
        Some(n) if n > limit as u64 => Err(AppError::too_large(limit)),
        _ => Ok(()),
    }
}

/// The whole body, at most `limit` bytes, read within [`HttpConfig::body_timeout`]
/// (a client that promises more than it sends gets a 408, not a connection held for ever).
///
/// [`HttpConfig::body_timeout`]: crate::http::HttpConfig
pub(super) async fn body_bytes(
    st: &AppState,
    req: Request,
    limit: usize,
) -> Result<Bytes, AppError> {
    let limit = limit.min(st.cfg.max_body);
    check_length(req.headers(), limit)?;
    let read = axum::body::to_bytes(req.into_body(), limit);
    match tokio::time::timeout(st.cfg.body_timeout, read).await {
        Err(_) => Err(AppError::body_timeout(st.cfg.body_timeout)),
        Ok(Ok(b)) => Ok(b),
        Ok(Err(e)) => {
            let too_large = std::error::Error::source(&e)
                .is_some_and(|s| s.is::<http_body_util::LengthLimitError>());
            if too_large {
                Err(AppError::too_large(limit))
            } else {
                Err(AppError::bad_request(format!(
                    "reading the request body failed: {e}"
                )))
            }
        }
    }
}

/// A JSON body, at most [`HttpConfig::max_json_body`](crate::http::HttpConfig) bytes.
pub(super) async fn json_bytes(st: &AppState, req: Request) -> Result<Bytes, AppError> {
    body_bytes(st, req, st.cfg.max_json_body).await
}

/// Parses a JSON body; the detail names the field at fault. The body's shape is checked
/// first ([`check_shape`]), so a hostile document is refused before it is built.
pub(super) fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, AppError> {
    check_shape(bytes, &ShapeLimits::default()).map_err(|e| {
        let field = if e.path == "." { "body".into() } else { e.path };
        AppError::invalid(&field, format!("{field}: {}", e.message))
    })?;
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

pub(super) async fn json_body<T: DeserializeOwned>(
    st: &AppState,
    req: Request,
) -> Result<T, AppError> {
    let mt = media_type(req.headers());
    if mt != "application/json" {
        return Err(AppError::unsupported_media(format!(
            "Content-Type must be application/json, not '{mt}'"
        )));
    }
    let b = json_bytes(st, req).await?;
    parse_json(&b)
}

/// The request's `Idempotency-Key` (1..=255 visible ASCII characters), in the namespace of
/// the client's key (each client's idempotency keys are its own).
pub(super) fn idempotency_key(
    headers: &HeaderMap,
    p: &Principal,
) -> Result<Option<String>, AppError> {
    let key = headers
        .get("idempotency-key")
        .map(|v| v.to_str().map(str::to_string))
        .transpose()
        .map_err(|_| AppError::bad_request("Idempotency-Key must be visible ASCII"))?;
    if key.as_ref().is_some_and(|k| k.is_empty() || k.len() > 255) {
        return Err(AppError::bad_request(
            "Idempotency-Key must be 1..=255 characters",
        ));
    }
    Ok(key.map(|k| {
        if p.owner.is_empty() {
            k
        } else {
            format!("{}\u{1f}{k}", p.owner)
        }
    }))
}

/// The answer to an `Idempotency-Key` first used with another request.
pub(super) fn idempotency_key_reused() -> AppError {
    AppError::new(
        axum::http::StatusCode::UNPROCESSABLE_ENTITY,
        "idempotency-key-reused",
        "Idempotency key reused",
        "Idempotency-Key was already used for a different request",
    )
    .field("Idempotency-Key")
}

/// Runs blocking work (scene import, store reads) off the async threads.
pub(super) async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, AppError> + Send + 'static,
) -> Result<T, AppError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| AppError::internal(format!("worker task failed: {e}")))?
}

/// Who sent `req` (put there by [`crate::http::auth::authenticate`]).
pub(super) fn principal(req: &Request) -> Principal {
    req.extensions()
        .get::<Principal>()
        .cloned()
        .unwrap_or(Principal {
            owner: String::new(),
            admin: false,
        })
}

pub(super) fn valid_id(id: &str, prefix: &str) -> bool {
    id.len() == prefix.len() + 32
        && id.starts_with(prefix)
        && id[prefix.len()..].bytes().all(|b| b.is_ascii_hexdigit())
}

pub(super) fn valid_scene_id(id: &str) -> bool {
    id.len() == 64 && id.bytes().all(|b| b.is_ascii_hexdigit())
}
