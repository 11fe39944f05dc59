//! The `reference` bake: the CPU ground truth of the whole scene from its camera, every
//! component kept, as one multi-layer EXR (`total`, `direct`, `caustics`, `specular`,
//! `indirect`). Deterministic for a seed, so re-running it after a restart is safe.

use super::{Artifact, Job, JobCtx, JobError, Lane};
use crate::reference::{self, ReferenceParams};
use crate::scene::World;
use crate::trace::Accel;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Parameters of a reference bake; defaults filled in before the bake id is computed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ReferenceBakeParams {
    /// Photons (light paths) to trace, 1..=1e9.
    #[serde(default = "default_photons")]
    pub photons: u64,
    /// Camera samples per pixel, 1..=1024.
    #[serde(default = "default_spp")]
    pub spp: u32,
    #[serde(default = "one")]
    pub seed: u64,
    /// Image size; the scene camera's when absent.
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
}

fn default_photons() -> u64 {
    1_000_000
}
fn default_spp() -> u32 {
    4
}
fn one() -> u64 {
    1
}

impl ReferenceBakeParams {
    /// Parses and checks `v` (field paths in errors).
    pub fn from_value(v: &serde_json::Value) -> Result<Self, JobError> {
        let p: ReferenceBakeParams = serde_path_to_error::deserialize(v).map_err(|e| {
            let path = match e.path().to_string() {
                p if p == "." => "params".to_string(),
                p => format!("params.{p}"),
            };
            JobError::Params(format!("{path}: {}", e.into_inner()))
        })?;
        if !(1..=1_000_000_000).contains(&p.photons) {
            return Err(JobError::Params(
                "params.photons: must lie in 1..=1e9".into(),
            ));
        }
        if !(1..=1024).contains(&p.spp) {
            return Err(JobError::Params("params.spp: must lie in 1..=1024".into()));
        }
        Ok(p)
    }
}

pub struct ReferenceBake {
    world: World,
    object: String,
    params: ReferenceBakeParams,
}

impl ReferenceBake {
    pub fn new(
        world: Arc<World>,
        object: Option<&str>,
        params: &serde_json::Value,
        limits: &crate::scene::Limits,
    ) -> Result<Self, JobError> {
        let params = ReferenceBakeParams::from_value(params)?;
        let object = object.ok_or_else(|| JobError::Params("object: required".into()))?;
        if world.object(object).is_none() {
            return Err(JobError::UnknownObject(object.into()));
        }
        let mut world = (*world).clone();
        for (name, v) in [
            ("params.width", params.width),
            ("params.height", params.height),
        ] {
            if let Some(v) = v
                && (v == 0 || v > limits.max_image_side)
            {
                return Err(JobError::Params(format!(
                    "{name}: must lie in 1..={}",
                    limits.max_image_side
                )));
            }
        }
        world.camera.width = params.width.unwrap_or(world.camera.width);
        world.camera.height = params.height.unwrap_or(world.camera.height);
        Ok(ReferenceBake {
            world,
            object: object.into(),
            params,
        })
    }
}

impl Job for ReferenceBake {
    fn kind(&self) -> &'static str {
        "bake"
    }
    fn method(&self) -> &'static str {
        "reference"
    }
    fn lane(&self) -> Lane {
        Lane::Cpu
    }

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        let mut timings: Vec<(String, Duration)> = Vec::new();
        ctx.progress(0.0, "bvh");
        let t = Instant::now();
        let accel = Accel::build(&self.world);
        timings.push(("bvh".into(), t.elapsed()));
        ctx.check()?;
        let params = ReferenceParams {
            seed: self.params.seed,
            photons: self.params.photons,
            spp: self.params.spp,
            ..Default::default()
        };
        let (c, stats) = reference::render(&self.world, &accel, &params, &|f| {
            // The reference reports 0..0.8 while tracing photons, then 1.0 after the camera.
            ctx.progress(f, if f < 0.8 { "photons" } else { "camera" });
            ctx.keep_going()
        })
        .map_err(|_| ctx.check().err().unwrap_or(JobError::Canceled))?;
        timings.extend(stats.stages.iter().cloned());
        ctx.progress(1.0, "encode");
        let t = Instant::now();
        let total = c.total();
        let bytes = crate::encode::encode_exr_layers(&[
            ("total", &total),
            ("direct", &c.direct),
            ("caustics", &c.caustics),
            ("specular", &c.specular),
            ("indirect", &c.indirect),
        ])?;
        timings.push(("encode".into(), t.elapsed()));
        Ok(Artifact {
            content_type: "image/x-exr",
            ext: "exr",
            bytes,
            timings,
            info: serde_json::json!({
                "object": self.object,
                "width": self.world.camera.width,
                "height": self.world.camera.height,
                "layers": ["total", "direct", "caustics", "specular", "indirect"],
                "statistics": {
                    "photons_traced": stats.photons_traced,
                    "caustic_photons_stored": stats.caustic_photons_stored,
                    "camera_samples": stats.camera_samples,
                },
            }),
        })
    }
}
