//! `POST /v1/compare`: two finished EXR renders compared as `caustica compare` does (relative
//! L1 and flux ratio after a 3×3 blur, over the pixels that see one object), so that a client
//! (the viewer) can measure a fast method against the reference without downloading either.

use super::jobs::{load_job, not_finished};
use super::{blocking, json_body, principal};
use crate::frame::Frame;
use crate::http::{AppError, AppState};
use crate::jobs::store::JobRecord;
use crate::jobs::{JobKind, JobState, SubmitError};
use crate::reference::compare;
use axum::Json;
use axum::extract::{Request, State};

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct CompareRequest {
    /// The render measured.
    a: String,
    /// The render it is measured against (the reference).
    b: String,
    /// The object whose pixels count (default `floor`, the receiver of the example scenes).
    #[serde(default = "floor")]
    object: String,
}

fn floor() -> String {
    "floor".into()
}

/// The linear frame of a finished EXR render.
fn exr_frame(st: &AppState, r: &JobRecord, field: &str) -> Result<Frame, AppError> {
    use std::os::unix::fs::FileExt;
    if r.artifact_type.as_deref() != Some("image/x-exr") {
        return Err(AppError::invalid(
            field,
            format!(
                "{field}: render {} is not an EXR (render with format exr: compare needs linear \
                 radiance)",
                r.id
            ),
        ));
    }
    let (file, len) = st.jobs.artifact(r).map_err(|e| AppError::artifact(r, e))?;
    let mut bytes = vec![0u8; len as usize];
    file.read_exact_at(&mut bytes, 0)
        .map_err(|e| AppError::internal(format!("reading render {}: {e}", r.id)))?;
    crate::encode::decode_frame(&bytes)
        .map_err(|e| AppError::internal(format!("render {}: {e}", r.id)))
}

/// Bytes a comparison holds for render `r`: its file, and its decoded frame with the
/// decoder's and the blur's working copies (~160 B a pixel, from the size the render
/// recorded; else eight times the file).
fn compare_memory(r: &JobRecord) -> u64 {
    let file = r.artifact_len.unwrap_or(0);
    let px = r.info["width"].as_u64().zip(r.info["height"].as_u64());
    file + px.map_or(file * 8, |(w, h)| w * h * 160)
}

pub async fn post_compare(
    State(st): State<AppState>,
    req: Request,
) -> Result<Json<serde_json::Value>, AppError> {
    let p = principal(&req);
    let c: CompareRequest = json_body(&st, req).await?;
    let (ra, rb) = (
        load_job(&st, &c.a, JobKind::Render, &p)?,
        load_job(&st, &c.b, JobKind::Render, &p)?,
    );
    for r in [&ra, &rb] {
        if r.state != JobState::Succeeded {
            return Err(not_finished(JobKind::Render, &r.id, r.state));
        }
    }
    // Both files and both decoded frames are held at once: counted against the job memory
    // budget, so that parallel comparisons of large renders wait their turn (503) instead of
    // taking memory the jobs were promised.
    let held = st
        .jobs
        .hold_request_memory(compare_memory(&ra) + compare_memory(&rb))
        .map_err(|e| match e {
            SubmitError::TooBig { need, total } => AppError::new(
                axum::http::StatusCode::UNPROCESSABLE_ENTITY,
                "too-big",
                "Job too big",
                format!(
                    "comparing these renders holds about {need} MiB, more than the {total} MiB \
                     this server gives jobs: compare smaller renders"
                ),
            ),
            e => e.into(),
        })?;
    blocking(move || {
        let _held = held;
        let (fa, fb) = (exr_frame(&st, &ra, "a")?, exr_frame(&st, &rb, "b")?);
        if (fa.width, fa.height) != (fb.width, fb.height) {
            return Err(AppError::invalid(
                "b",
                format!(
                    "b: {}x{} differs from a's {}x{}",
                    fb.width, fb.height, fa.width, fa.height
                ),
            ));
        }
        // The pixels that see the object, through render a's camera (its request's camera
        // when it gave one) at the frames' size.
        let world = st
            .jobs
            .scenes
            .world(&ra.scene_id)
            .map_err(|e| AppError::internal(format!("scene of render {}: {e}", ra.id)))?;
        let mut w = (*world).clone();
        if let Some(cam) = ra.params.get("camera").filter(|v| !v.is_null()) {
            let desc: crate::scene::types::CameraDesc = serde_json::from_value(cam.clone())
                .map_err(|e| AppError::internal(format!("camera of render {}: {e}", ra.id)))?;
            w.camera = crate::scene::load::resolve_camera(&desc, &Default::default())?;
        }
        if !w.objects.iter().any(|o| o.name == c.object) {
            return Err(AppError::invalid(
                "object",
                format!("object: the scene has no object '{}'", c.object),
            ));
        }
        let m = compare::compare_on(w, &c.object, &fa, &fb);
        Ok(Json(serde_json::json!({
            "relative_l1": m.rel_l1,
            "flux_ratio": m.flux_ratio,
            "pixels": m.pixels,
            "object": c.object,
        })))
    })
    .await
}
