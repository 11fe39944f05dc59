//! [`AppError`]: every error the API answers, as RFC 9457 `application/problem+json`. This is
//! the one place where domain errors become status codes.

use crate::jobs::scenes::IngestError;
use crate::jobs::store::{JobRecord, StoreError};
use crate::jobs::{ArtifactError, ErrorCode, JobError, JobKind, SubmitError};
use crate::methods::ParamError;
use crate::scene::SceneError;
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};

/// Base of the problem type URIs: a reference relative to the server, whose page at
/// `/problems/{type}` documents the type ([`super::problems`]).
pub const TYPE_BASE: &str = "/problems/";

/// An error answer; boxed so that `Result<_, AppError>` stays small.
#[derive(Debug)]
pub struct AppError(Box<Problem>);

/// The fields of a problem answer.
#[derive(Debug)]
pub struct Problem {
    pub status: StatusCode,
    /// Slug appended to [`TYPE_BASE`].
    pub kind: &'static str,
    pub title: &'static str,
    pub detail: String,
    /// The request field at fault, when there is one.
    pub field: Option<String>,
    pub retry_after: Option<u64>,
    pub instance: Option<String>,
}

impl AppError {
    pub fn new(
        status: StatusCode,
        kind: &'static str,
        title: &'static str,
        detail: impl Into<String>,
    ) -> Self {
        debug_assert!(
            super::problems::find(kind).is_some_and(|d| d.status.contains(&status.as_u16())),
            "problem type '{kind}' with status {status} is not documented in http::problems"
        );
        AppError(Box::new(Problem {
            status,
            kind,
            title,
            detail: detail.into(),
            field: None,
            retry_after: None,
            instance: None,
        }))
    }

    pub fn field(mut self, f: impl Into<String>) -> Self {
        self.field = Some(f.into());
        self
    }

    pub fn instance(mut self, i: impl Into<String>) -> Self {
        self.instance = Some(i.into());
        self
    }

    pub fn retry_after(mut self, s: u64) -> Self {
        self.retry_after = Some(s);
        self
    }

    pub fn not_found(what: &str, id: &str) -> Self {
        AppError::new(
            StatusCode::NOT_FOUND,
            "not-found",
            "Not found",
            format!("no {what} with id '{id}'"),
        )
    }

    pub fn bad_request(detail: impl Into<String>) -> Self {
        AppError::new(
            StatusCode::BAD_REQUEST,
            "bad-request",
            "Malformed request",
            detail,
        )
    }

    /// 422 about one field of the request.
    pub fn invalid(field: &str, detail: impl Into<String>) -> Self {
        AppError::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid-request",
            "Invalid request",
            detail,
        )
        .field(field)
    }

    pub fn unsupported_media(detail: impl Into<String>) -> Self {
        AppError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "unsupported-media-type",
            "Unsupported media type",
            detail,
        )
    }

    pub fn too_large(limit: usize) -> Self {
        AppError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "payload-too-large",
            "Request body too large",
            format!("the request body is over the limit of {limit} bytes"),
        )
    }

    /// The body did not arrive within the time allowed.
    pub fn body_timeout(limit: std::time::Duration) -> Self {
        AppError::new(
            StatusCode::REQUEST_TIMEOUT,
            "request-timeout",
            "Request body too slow",
            format!(
                "the request body did not arrive within {} s",
                limit.as_secs_f64()
            ),
        )
    }

    pub fn internal(detail: impl Into<String>) -> Self {
        AppError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            "internal",
            "Internal error",
            detail,
        )
    }
}

impl std::ops::Deref for AppError {
    type Target = Problem;
    fn deref(&self) -> &Problem {
        &self.0
    }
}

impl std::ops::DerefMut for AppError {
    fn deref_mut(&mut self) -> &mut Problem {
        &mut self.0
    }
}

/// RFC 9457 problem details: the body of every error answer.
#[derive(serde::Serialize, schemars::JsonSchema)]
#[schemars(rename = "Problem")]
pub struct ProblemBody {
    /// A reference relative to the server (`/problems/{slug}`) whose page documents the type.
    #[serde(rename = "type")]
    #[schemars(extend("format" = "uri-reference"))]
    pub kind: String,
    pub title: String,
    /// The HTTP status.
    pub status: u16,
    /// Names the field, file or limit at fault.
    pub detail: String,
    /// The JSON path of the request field at fault, when there is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instance: Option<String>,
}

impl AppError {
    /// The problem+json body.
    pub fn body(&self) -> serde_json::Value {
        serde_json::to_value(ProblemBody {
            kind: format!("{TYPE_BASE}{}", self.kind),
            title: self.title.into(),
            status: self.status.as_u16(),
            detail: self.detail.clone(),
            field: self.field.clone(),
            instance: self.instance.clone(),
        })
        .expect("a problem serialises")
    }
}

impl IntoResponse for AppError {
    fn into_response(self) -> Response {
        let mut r = (self.status, self.body().to_string()).into_response();
        r.headers_mut().insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/problem+json"),
        );
        if let Some(s) = self.retry_after {
            r.headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        if matches!(
            self.status,
            StatusCode::PAYLOAD_TOO_LARGE | StatusCode::REQUEST_TIMEOUT
        ) {
            // The rest of the body is never read: the connection cannot carry another request,
            // so say so and let the client open a fresh one instead of reusing a broken pipe.
            r.headers_mut()
                .insert(header::CONNECTION, HeaderValue::from_static("close"));
        }
        r
    }
}

impl From<SceneError> for AppError {
    fn from(e: SceneError) -> Self {
        let field = e.field().to_string();
        if let SceneError::Syntax { .. } = e {
            return AppError::bad_request(e.to_string());
        }
        if let SceneError::Busy { .. } = e {
            return AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "busy",
                "Busy",
                e.to_string(),
            )
            .retry_after(5);
        }
        let (kind, title) = match &e {
            SceneError::Limit { .. } => ("limit-exceeded", "A limit was exceeded"),
            _ => ("invalid-scene", "Invalid scene"),
        };
        AppError::new(StatusCode::UNPROCESSABLE_ENTITY, kind, title, e.to_string()).field(field)
    }
}

/// Whether `e` says the disk (or the database's file system) is full.
fn disk_full(e: &StoreError) -> bool {
    match e {
        StoreError::Io(io) => io.kind() == std::io::ErrorKind::StorageFull,
        StoreError::Db(rusqlite::Error::SqliteFailure(f, _)) => {
            f.code == rusqlite::ErrorCode::DiskFull
        }
        StoreError::Pg(p) => p.code() == Some(&::postgres::error::SqlState::DISK_FULL),
        _ => false,
    }
}

impl From<StoreError> for AppError {
    fn from(e: StoreError) -> Self {
        tracing::error!(error = %e, "storage error");
        if disk_full(&e) {
            return AppError::new(
                StatusCode::INSUFFICIENT_STORAGE,
                "storage-full",
                "Storage full",
                format!("the server's storage is full: {e}"),
            )
            .retry_after(60);
        }
        if let StoreError::Unavailable(why) = &e {
            return AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "store-unavailable",
                "Job store unavailable",
                format!("the job store cannot be reached: {why}"),
            )
            .retry_after(5);
        }
        AppError::internal(format!("storage: {e}"))
    }
}

impl AppError {
    /// The artifact of job `r` cannot be served.
    pub fn artifact(r: &JobRecord, e: ArtifactError) -> Self {
        match e {
            ArtifactError::Lost { why, requeued } => {
                let path = match r.kind {
                    JobKind::Bake => "bakes",
                    JobKind::Render => "renders",
                };
                let then = if requeued {
                    format!("the job was queued again: poll /v1/{path}/{}", r.id)
                } else {
                    "the job could not be queued again".into()
                };
                let e = AppError::new(
                    StatusCode::INTERNAL_SERVER_ERROR,
                    "artifact-lost",
                    "Artifact lost",
                    format!(
                        "the stored result of {} failed its check ({why}); {then}",
                        r.id
                    ),
                );
                if requeued { e.retry_after(5) } else { e }
            }
            ArtifactError::Store(s) => s.into(),
        }
    }
}

impl From<IngestError> for AppError {
    fn from(e: IngestError) -> Self {
        match e {
            IngestError::Scene(s) => s.into(),
            IngestError::Store(s) => s.into(),
        }
    }
}

impl From<JobError> for AppError {
    fn from(e: JobError) -> Self {
        match e {
            JobError::Scene(s) => s.into(),
            JobError::UnknownScene(id) => {
                AppError::invalid("scene_id", format!("scene_id: no stored scene '{id}'"))
            }
            JobError::UnknownObject(o) => AppError::invalid(
                "object",
                format!("object: no object named '{o}' in the scene"),
            ),
            JobError::Params(p) => p.into(),
            JobError::NoGpu(m) => AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "no-gpu",
                "No GPU",
                format!("no usable GPU adapter: {m}"),
            ),
            JobError::Store(s) => s.into(),
            other => AppError::internal(other.to_string()),
        }
    }
}

impl From<ParamError> for AppError {
    fn from(p: ParamError) -> Self {
        AppError::invalid(&p.field, p.to_string())
    }
}

impl AppError {
    /// The answer to a render that failed while running (the record keeps why, as `code`).
    pub fn failed_render(id: &str, code: Option<ErrorCode>, error: &str) -> Self {
        let (status, kind, title) = match code {
            Some(ErrorCode::NoGpu) => (StatusCode::SERVICE_UNAVAILABLE, "no-gpu", "No GPU"),
            Some(ErrorCode::Timeout) => {
                (StatusCode::GATEWAY_TIMEOUT, "job-timeout", "Job time limit")
            }
            Some(ErrorCode::Canceled) => (StatusCode::CONFLICT, "canceled", "Canceled"),
            // Input that only the work itself finds unworkable (e.g. more illumination volumes
            // than a frame may hold).
            Some(ErrorCode::InvalidParams | ErrorCode::InvalidInput) => (
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
        AppError::new(status, kind, title, format!("render {id} failed: {error}"))
    }
}

impl From<SubmitError> for AppError {
    fn from(e: SubmitError) -> Self {
        match e {
            SubmitError::QueueFull(kind, n) => AppError::new(
                StatusCode::TOO_MANY_REQUESTS,
                "queue-full",
                "Queue full",
                format!(
                    "the {} queue is full ({n} waiting, the limit); retry later",
                    kind.as_str()
                ),
            )
            .retry_after(5),
            e @ SubmitError::NoMemory { .. } => AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "no-memory",
                "Job memory full",
                format!("{e}; retry later"),
            )
            .retry_after(5),
            e @ SubmitError::TooBig { .. } => AppError::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                "too-big",
                "Job too big",
                format!("{e} (a smaller image or scene fits)"),
            ),
            SubmitError::ShuttingDown => AppError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "shutting-down",
                "Shutting down",
                "the server is shutting down and takes no new jobs",
            )
            .retry_after(10),
            SubmitError::Job(j) => j.into(),
            SubmitError::Store(s) => s.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_disk_is_507_with_retry_after() {
        let io = std::io::Error::from(std::io::ErrorKind::StorageFull);
        let e = AppError::from(StoreError::Io(io));
        assert_eq!(e.status, StatusCode::INSUFFICIENT_STORAGE);
        assert_eq!((e.kind, e.retry_after), ("storage-full", Some(60)));
        let sqlite = rusqlite::Error::SqliteFailure(
            rusqlite::ffi::Error::new(rusqlite::ffi::SQLITE_FULL),
            None,
        );
        assert_eq!(AppError::from(StoreError::Db(sqlite)).kind, "storage-full");
        let other = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        assert_eq!(AppError::from(StoreError::Io(other)).status, 500);
    }
}
