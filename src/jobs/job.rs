//! What a job is: its kind and state, its spec (what is persisted to rebuild it after a
//! restart), the [`Job`] trait the two job types implement ([`super::render::RenderJob`] and
//! [`super::bake::BakeJob`], both thin over [`crate::methods`]), its artifact, and why it
//! failed ([`JobError`], with a stable [`ErrorCode`] kept in the record).

use super::worker::JobCtx;
use crate::methods::{Lane, Method, MethodError, ParamError};
use crate::scene::{Limits, SceneError, World};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;

/// The two kinds of job.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobKind {
    /// Precomputation whose artifact is kept (`POST /v1/bakes`).
    Bake,
    /// A frame (`POST /v1/renders`).
    Render,
}

impl JobKind {
    pub fn as_str(self) -> &'static str {
        match self {
            JobKind::Bake => "bake",
            JobKind::Render => "render",
        }
    }

    pub fn parse(s: &str) -> Option<JobKind> {
        [JobKind::Bake, JobKind::Render]
            .into_iter()
            .find(|k| k.as_str() == s)
    }

    /// The prefix of this kind's job ids.
    pub fn id_prefix(self) -> &'static str {
        match self {
            JobKind::Bake => "bk_",
            JobKind::Render => "rn_",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    Queued,
    Running,
    Succeeded,
    Failed,
    Canceled,
}

impl JobState {
    pub const ALL: [JobState; 5] = [
        JobState::Queued,
        JobState::Running,
        JobState::Succeeded,
        JobState::Failed,
        JobState::Canceled,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Canceled => "canceled",
        }
    }

    pub fn parse(s: &str) -> Option<JobState> {
        JobState::ALL.into_iter().find(|k| k.as_str() == s)
    }

    pub fn is_terminal(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Canceled
        )
    }
}

impl std::fmt::Display for JobState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Lower runs first: small renders, then other renders, then bakes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Priority {
    /// A render small enough to be interactive ([`Job::small`]): besides the other workers,
    /// a worker of its own takes only these, so they flow while big renders and bakes run.
    Small = 0,
    Render = 1,
    Bake = 2,
}

/// What a job produces: bytes to store and serve, plus timings and facts for the record.
#[derive(Clone, Debug)]
pub struct Artifact {
    pub content_type: &'static str,
    /// File extension of the stored artifact.
    pub ext: &'static str,
    pub bytes: Vec<u8>,
    pub timings: Vec<(String, Duration)>,
    /// Adapter, statistics...: shown in the job record.
    pub info: serde_json::Value,
}

/// The kind of a failure, kept in the record (`info.error_code`); `http` maps it to a status.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    Canceled,
    Timeout,
    Interrupted,
    InvalidInput,
    InvalidParams,
    NoGpu,
    Render,
    Encode,
    Panic,
    Store,
    /// The workers that took it stopped answering (their leases ran out) too many times.
    WorkerLost,
}

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("canceled")]
    Canceled,
    #[error("the job ran past its time limit of {0:?}")]
    Timeout(Duration),
    /// The server is shutting down; the job goes back to the queue for the next start.
    #[error("interrupted by shutdown")]
    Interrupted,
    #[error("scene: {0}")]
    Scene(#[from] SceneError),
    #[error("scene {0} is not stored")]
    UnknownScene(String),
    #[error("no object named '{0}' in the scene")]
    UnknownObject(String),
    #[error("invalid parameters: {0}")]
    Params(#[from] ParamError),
    #[error("no usable GPU: {0}")]
    NoGpu(String),
    #[error("render failed: {0}")]
    Render(String),
    #[error(transparent)]
    Encode(#[from] crate::encode::EncodeError),
    #[error("the job panicked: {0}")]
    Panic(String),
    #[error(transparent)]
    Store(#[from] super::store::StoreError),
}

impl JobError {
    /// The kind of failure.
    pub fn code(&self) -> ErrorCode {
        match self {
            JobError::Canceled => ErrorCode::Canceled,
            JobError::Timeout(_) => ErrorCode::Timeout,
            JobError::Interrupted => ErrorCode::Interrupted,
            JobError::Scene(_) | JobError::UnknownScene(_) | JobError::UnknownObject(_) => {
                ErrorCode::InvalidInput
            }
            JobError::Params(_) => ErrorCode::InvalidParams,
            JobError::NoGpu(_) => ErrorCode::NoGpu,
            JobError::Render(_) => ErrorCode::Render,
            JobError::Encode(_) => ErrorCode::Encode,
            JobError::Panic(_) => ErrorCode::Panic,
            JobError::Store(_) => ErrorCode::Store,
        }
    }
}

impl From<MethodError> for JobError {
    /// A cancelled method stops as [`JobError::Canceled`]; [`JobCtx::method_error`] tells the
    /// real reason (timeout, shutdown) when there is a context.
    fn from(e: MethodError) -> Self {
        match e {
            MethodError::Params(p) => JobError::Params(p),
            MethodError::UnknownObject(o) => JobError::UnknownObject(o),
            // Not reachable from the service, which gives no bake files.
            MethodError::GivenBake(m) => JobError::Params(ParamError::new("bake", m)),
            MethodError::NoGpu(m) => JobError::NoGpu(m),
            MethodError::Render(m) => JobError::Render(m),
            MethodError::Canceled => JobError::Canceled,
        }
    }
}

/// One kind of work. Implementations hold their inputs (the resolved world and their plan)
/// and must poll [`JobCtx::check`] (or [`JobCtx::keep_going`]) often enough for cancellation
/// and timeouts to be prompt.
pub trait Job: Send + Sync {
    fn kind(&self) -> JobKind;
    /// The method that runs (for an `auto` render, the one it chose).
    fn method(&self) -> Method;
    fn lane(&self) -> Lane;
    /// Whether this is a small render (a preview, a cached bake's frame): see
    /// [`Priority::Small`].
    fn small(&self) -> bool {
        false
    }
    /// A generous estimate of the memory it holds while it runs, bytes (for the job memory
    /// budget, [`super::JobConfig::job_memory`]).
    fn memory(&self) -> u64 {
        128 << 20
    }
    fn priority(&self) -> Priority {
        match self.kind() {
            JobKind::Bake => Priority::Bake,
            JobKind::Render if self.small() => Priority::Small,
            JobKind::Render => Priority::Render,
        }
    }
    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError>;
}

/// What is persisted about a job's inputs; enough to rebuild it after a restart. Its JSON
/// (field order included) is what a bake's id is the hash of.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct JobSpec {
    pub kind: JobKind,
    pub method: Method,
    pub scene_id: String,
    pub object: Option<String>,
    pub params: serde_json::Value,
}

impl JobSpec {
    /// A bake's id: `bk_` and the SHA-256 of its spec's JSON (the same bake asked for twice,
    /// by anyone, is one job).
    pub fn bake_id(&self) -> String {
        let json = serde_json::to_vec(self).expect("spec serialises");
        format!("bk_{}", &super::scenes::sha256_hex(&json)[..32])
    }
}

/// Builds the job for a spec. A render's progressive methods (`photons`, `reference`) trace for
/// at most `budget` (the request may ask for less), so that they return their frame within the
/// server's render timeout rather than fail at it.
pub fn build_job(
    spec: &JobSpec,
    world: Arc<World>,
    limits: &Limits,
    budget: Duration,
) -> Result<Box<dyn Job>, JobError> {
    Ok(match spec.kind {
        JobKind::Bake => Box::new(super::bake::BakeJob::new(
            world,
            spec.method,
            spec.object.as_deref(),
            &spec.params,
            limits,
        )?),
        JobKind::Render => Box::new(super::render::RenderJob::new(
            world,
            spec.method,
            &spec.params,
            limits,
            budget,
        )?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_as_stored() {
        for s in JobState::ALL {
            assert_eq!(JobState::parse(s.as_str()), Some(s));
            assert_eq!(serde_json::to_value(s).unwrap(), s.as_str());
        }
        for k in [JobKind::Bake, JobKind::Render] {
            assert_eq!(JobKind::parse(k.as_str()), Some(k));
            assert_eq!(serde_json::to_value(k).unwrap(), k.as_str());
        }
        assert_eq!(
            serde_json::to_value(ErrorCode::InvalidParams).unwrap(),
            "invalid_params"
        );
    }

    #[test]
    fn a_spec_serialises_as_before() {
        // Bake ids are hashes of this JSON: it must not change.
        let spec = JobSpec {
            kind: JobKind::Bake,
            method: Method::Csl,
            scene_id: "ab".into(),
            object: Some("glass".into()),
            params: serde_json::json!({"grid": 64}),
        };
        assert_eq!(
            serde_json::to_string(&spec).unwrap(),
            r#"{"kind":"bake","method":"csl","scene_id":"ab","object":"glass","params":{"grid":64}}"#
        );
    }
}
