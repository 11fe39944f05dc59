//! The `csl` bake: caustic spot lights of one object for the scene's (first) directional light,
//! as the versioned, checksummed CSL set artifact of `bake::csl` (the same bytes as
//! `caustica bake csl`). Deterministic, so re-running it after a restart is safe.

use super::{Artifact, Job, JobCtx, JobError, Lane};
use crate::bake::Progress;
use crate::bake::csl::cache::DirStore;
use crate::bake::csl::dynamic::{DynamicParams, DynamicProgress, bake_dynamic};
use crate::bake::csl::{CslParams, CslSet, bake_csl, scene_directional_light};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;

/// Parameters of a CSL bake; defaults filled in before the bake id is computed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CslBakeParams {
    /// `paper` (the paper's settings) or `fast` (coarser cells and images, for previews).
    #[serde(default = "default_preset")]
    pub preset: String,
    /// Rays per side of the ray grid over the silhouette, 16..=4096 (the paper: 1280).
    #[serde(default)]
    pub grid: Option<u32>,
    /// Dynamic lighting (Liu et al. 2008 §4): a set per direction of a subdivided icosahedron,
    /// matched into triples; serves every directional light. Omitted when false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub dynamic: bool,
    /// Dynamic: icosahedron subdivisions, 0..=3 (default 2: 162 directions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subdivisions: Option<u32>,
    /// Dynamic: rays per side of the grid traced at each tracking step, 16..=1024 (default 128).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub track_grid: Option<u32>,
    /// Dynamic: tracking steps along an icosahedron edge, 1..=100 (default 20).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<u32>,
}

fn default_preset() -> String {
    "paper".into()
}

impl CslBakeParams {
    /// Parses and checks `v` (field paths in errors), filling the preset's grid.
    pub fn from_value(v: &serde_json::Value) -> Result<Self, JobError> {
        Self::parse(v, "params")
    }

    /// As [`Self::from_value`] for parameters found at field `at` of a request.
    pub fn parse(v: &serde_json::Value, at: &str) -> Result<Self, JobError> {
        let mut p: CslBakeParams = serde_path_to_error::deserialize(v).map_err(|e| {
            let path = match e.path().to_string() {
                p if p == "." => at.to_string(),
                p => format!("{at}.{p}"),
            };
            JobError::Params(format!("{path}: {}", e.into_inner()))
        })?;
        let base = match p.preset.as_str() {
            "paper" => CslParams::paper(),
            "fast" => CslParams::fast(),
            other => {
                return Err(JobError::Params(format!(
                    "{at}.preset: '{other}' is not one of paper, fast"
                )));
            }
        };
        let grid = p.grid.unwrap_or(base.grid);
        if !(16..=4096).contains(&grid) {
            return Err(JobError::Params(format!(
                "{at}.grid: must lie in 16..=4096"
            )));
        }
        p.grid = Some(grid);
        if p.dynamic {
            let d = DynamicParams::paper();
            let fields = [
                ("subdivisions", &mut p.subdivisions, d.subdivisions, 0..=3),
                ("track_grid", &mut p.track_grid, d.track_grid, 16..=1024),
                ("steps", &mut p.steps, d.steps, 1..=100),
            ];
            for (name, v, default, range) in fields {
                let x = v.unwrap_or(default);
                if !range.contains(&x) {
                    return Err(JobError::Params(format!(
                        "{at}.{name}: must lie in {}..={}",
                        range.start(),
                        range.end()
                    )));
                }
                *v = Some(x);
            }
        } else {
            for (name, set) in [
                ("subdivisions", p.subdivisions.is_some()),
                ("track_grid", p.track_grid.is_some()),
                ("steps", p.steps.is_some()),
            ] {
                if set {
                    return Err(JobError::Params(format!(
                        "{at}.{name}: only for a dynamic bake (\"dynamic\": true)"
                    )));
                }
            }
        }
        Ok(p)
    }

    /// The parameters of a dynamic bake (meaningful when `dynamic`).
    pub fn dynamic_params(&self) -> DynamicParams {
        let d = DynamicParams::paper();
        DynamicParams {
            subdivisions: self.subdivisions.unwrap_or(d.subdivisions),
            track_grid: self.track_grid.unwrap_or(d.track_grid),
            steps: self.steps.unwrap_or(d.steps),
            csl: self.csl_params(),
            ..d
        }
    }

    pub fn csl_params(&self) -> CslParams {
        let base = if self.preset == "fast" {
            CslParams::fast()
        } else {
            CslParams::paper()
        };
        CslParams {
            grid: self.grid.unwrap_or(base.grid),
            ..base
        }
    }
}

pub struct CslBake {
    world: Arc<World>,
    object: String,
    /// Light travel direction in the object's rigid frame; None for a dynamic bake (it serves
    /// every direction).
    light: Option<glam::Vec3>,
    params: CslBakeParams,
}

impl CslBake {
    pub fn new(
        world: Arc<World>,
        object: Option<&str>,
        params: &serde_json::Value,
    ) -> Result<Self, JobError> {
        let params = CslBakeParams::from_value(params)?;
        let object = object.ok_or_else(|| JobError::Params("object: required".into()))?;
        let obj = world
            .object(object)
            .ok_or_else(|| JobError::UnknownObject(object.into()))?;
        let light = scene_directional_light(&world)
            .map(|(dir, _)| CslSet::light_in_object_frame(obj, dir))
            .filter(|_| !params.dynamic);
        if light.is_none() && !params.dynamic {
            return Err(JobError::Params(
                "scene.lights: a csl bake needs a directional light; the scene has none \
                 (a dynamic bake does not)"
                    .into(),
            ));
        }
        Ok(CslBake {
            object: object.into(),
            world,
            light,
            params,
        })
    }
}

impl CslBake {
    /// A dynamic bake: progress per direction, then per edge; the artifact is also kept in the
    /// data directory's bake cache, where `csl` renders with the same parameters find it.
    fn run_dynamic(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        let params = self.params.dynamic_params();
        let set = bake_dynamic(&self.world, &self.object, &params, &|p: DynamicProgress| {
            let stage = match p.stage {
                "directions" => format!("directions {}/{}", p.done, p.total),
                "tracking" => format!("tracking edges {}/{}", p.done, p.total),
                s => s.to_string(),
            };
            ctx.progress(p.fraction, &stage);
            ctx.keep_going()
        })
        .map_err(|e| ctx.bake_error(e))?;
        let s = &set.stats;
        let bytes = set.to_bytes();
        DirStore(ctx.data_dir().join("csl-cache")).save_dynamic(set.source_hash, &bytes);
        let info = serde_json::json!({
            "object": self.object,
            "statistics": {
                "directions": s.directions,
                "csls": s.csls,
                "black_partners": s.blacks,
                "matched_pairs": s.matched,
                "edges": s.edges,
                "triples": s.triples,
                "matched_triples": s.consistent_triples,
                "tracking_rays": s.tracking_rays,
                "bytes": bytes.len(),
                "source_hash": format!("{:016x}", set.source_hash),
            },
        });
        Ok(Artifact {
            content_type: "application/octet-stream",
            ext: "csld",
            bytes,
            timings: vec![
                ("bakes".into(), s.time_bakes),
                ("tracking".into(), s.time_tracking),
                ("triples".into(), s.time_triples),
            ],
            info,
        })
    }
}

impl Job for CslBake {
    fn kind(&self) -> &'static str {
        "bake"
    }
    fn method(&self) -> &'static str {
        "csl"
    }
    fn lane(&self) -> Lane {
        Lane::Cpu
    }

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        let Some(light) = self.light else {
            return self.run_dynamic(ctx);
        };
        let set = bake_csl(
            &self.world,
            &self.object,
            light,
            &self.params.csl_params(),
            &|p: Progress| {
                ctx.progress(p.fraction, p.stage);
                ctx.keep_going()
            },
        )
        .map_err(|e| ctx.bake_error(e))?;
        let s = &set.stats;
        let timings: Vec<(String, Duration)> = vec![
            ("trace".into(), s.time_trace),
            ("raster".into(), s.time_raster),
            ("bundles".into(), s.time_bundles),
            ("fit".into(), s.time_fit),
            ("images".into(), s.time_image),
        ];
        let info = serde_json::json!({
            "object": self.object,
            "light_dir_object_frame": light.to_array(),
            "statistics": {
                "rays_traced": s.rays_traced,
                "rays_hit": s.rays_hit,
                "caustic_rays": s.caustic_rays,
                "csls": set.csls.len(),
                "energy_covered": s.coverage(),
            },
        });
        Ok(Artifact {
            content_type: "application/octet-stream",
            ext: "csl",
            bytes: set.to_bytes(),
            timings,
            info,
        })
    }
}
