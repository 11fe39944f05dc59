//! `POST /v1/bakes`, `GET`/`DELETE /v1/bakes/{id}`, `GET /v1/bakes/{id}/artifact`.

use super::jobs::{
    JobView, accepted, cancel_job, job_view, load_job, not_finished, serve_artifact,
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
use axum::response::Response;
use axum::{Extension, Json};

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BakeRequest {
    #[serde(default)]
    scene: Option<serde_json::Value>,
    #[serde(default)]
    scene_id: Option<String>,
    object: String,
    method: String,
    #[serde(default)]
    params: Option<serde_json::Value>,
}

pub async fn post_bake(State(st): State<AppState>, req: Request) -> Result<Response, AppError> {
    let p = principal(&req);
    let key = idempotency_key(req.headers(), &p)?;
    let b: BakeRequest = json_body(&st, req).await?;
    let scene_id = match (&b.scene, &b.scene_id) {
        (Some(s), None) => scene_ref(&st, s, "scene", &p).await?,
        (None, Some(id)) => {
            scene_ref(&st, &serde_json::Value::String(id.clone()), "scene_id", &p).await?
        }
        _ => {
            return Err(AppError::invalid(
                "scene",
                "scene: give exactly one of `scene` (object or id) and `scene_id`",
            ));
        }
    };
    let method = Method::parse(&b.method)?;
    let params = b.params.unwrap_or_else(|| serde_json::json!({}));
    let params = method.imp().bake_params(&params, "params")?;
    let spec = JobSpec {
        kind: JobKind::Bake,
        method,
        scene_id,
        object: Some(b.object),
        params,
    };
    let spec_json = serde_json::to_vec(&spec).expect("spec serialises");
    let hash = sha256_hex(&spec_json);
    let mut id = spec.bake_id();
    if let Some(k) = &key {
        match st.jobs.store.idempotency(k)? {
            Some((h, job)) if h == hash => id = job,
            Some(_) => return Err(idempotency_key_reused()),
            None => {}
        }
    }
    if *st.shutdown.borrow() {
        return Err(crate::jobs::SubmitError::ShuttingDown.into());
    }
    let jobs = st.jobs.clone();
    let (id2, spec2) = (id.clone(), spec.clone());
    // Held before it is submitted: a holder's DELETE in between cannot cancel it under us.
    let held_before = st.jobs.store.holds(Held::Job, &id, &p.owner)?;
    if !held_before {
        crate::http::auth::within_storage(&st, &p, 0)?;
    }
    crate::http::auth::hold_within_quota(&st, &p, &id)?;
    let submitted = blocking(move || Ok(jobs.submit(&id2, &spec2)?)).await;
    if submitted.is_err() && !held_before {
        let _ = st.jobs.store.release(Held::Job, &id, &p.owner);
    }
    submitted?;
    if let Some(k) = &key {
        st.jobs.store.put_idempotency(k, &hash, &id)?;
    }
    let v = job_view(&st, &id, JobKind::Bake, &p)?;
    let loc = format!("/v1/bakes/{id}");
    Ok(accepted(loc, v))
}

pub async fn get_bake(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
) -> Result<Json<JobView>, AppError> {
    Ok(Json(job_view(&st, &id, JobKind::Bake, &p)?))
}

pub async fn delete_bake(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    cancel_job(&st, &id, JobKind::Bake, &p).await
}

pub async fn get_bake_artifact(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Path(id): Path<String>,
    headers: axum::http::HeaderMap,
) -> Result<Response, AppError> {
    let r = load_job(&st, &id, JobKind::Bake, &p)?;
    if r.state != JobState::Succeeded {
        return Err(not_finished(JobKind::Bake, &id, r.state));
    }
    serve_artifact(&st, &r, &headers).await
}
