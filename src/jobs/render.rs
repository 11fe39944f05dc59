//! Render jobs: `direct` on the GPU worker, `reference` on the CPU pool, `csl` on the CPU pool
//! for its bake (cached by content hash under the data directory, so only the first render of
//! an object and light bakes) and then one frame on the shared renderer; one image out (PNG
//! tone-mapped, or EXR linear, optionally with every component as a layer).

use super::csl_bake::CslBakeParams;
use super::{Artifact, Job, JobCtx, JobError, Lane};
use crate::bake::BakeError;
use crate::bake::csl::cache as csl_cache;
use crate::encode::{self, Frame, PngSettings, ToneMap};
use crate::reference::{self, ReferenceParams};
use crate::render::{CslLayer, RenderError, RenderOptions, RenderOutput, Renderer};
use crate::scene::types::{CameraDesc, LightDesc};
use crate::scene::{Limits, MapSource, World};
use crate::trace::Accel;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    #[default]
    Png,
    Exr,
}

pub const COMPONENTS: &[&str] = &["total", "direct", "caustics", "specular", "indirect"];

/// Render parameters (everything of a render request but the scene and method).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderParams {
    /// Image size; the camera's when absent.
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
    #[serde(default)]
    pub format: Format,
    /// The component written: total, direct, caustics, specular or indirect.
    #[serde(default = "total")]
    pub component: String,
    /// EXR only: every component as a layer (the chosen one first).
    #[serde(default)]
    pub layers: bool,
    /// PNG exposure in stops.
    #[serde(default)]
    pub exposure: f32,
    /// PNG tone map (clamp by default, as the CLI).
    #[serde(default)]
    pub tone_map: Option<ToneMap>,
    /// Replaces the scene's camera.
    #[serde(default)]
    pub camera: Option<CameraDesc>,
    /// Replaces the scene's lights (lights inside glTF files stay).
    #[serde(default)]
    pub lights: Option<Vec<LightDesc>>,
    /// Reference: photons, 1..=1e9.
    #[serde(default)]
    pub photons: Option<u64>,
    /// Reference: camera samples per pixel, 1..=1024.
    #[serde(default)]
    pub spp: Option<u32>,
    #[serde(default)]
    pub seed: Option<u64>,
    /// CSL: the bake's parameters, `{"preset": "paper" | "fast", "grid": 16..=4096}` as for
    /// `POST /v1/bakes` (default: the paper's).
    #[serde(default)]
    pub csl: Option<serde_json::Value>,
}

fn total() -> String {
    "total".into()
}

impl RenderParams {
    pub fn from_value(v: &serde_json::Value) -> Result<Self, JobError> {
        serde_path_to_error::deserialize(v).map_err(|e| {
            let path = match e.path().to_string() {
                p if p == "." => "body".to_string(),
                p => p,
            };
            JobError::Params(format!("{path}: {}", e.into_inner()))
        })
    }
}

/// The component frames of one render and what it reports (adapter, statistics).
type Frames = (Vec<(&'static str, Frame)>, serde_json::Value);

pub struct RenderJob {
    world: World,
    method: &'static str,
    p: RenderParams,
    /// Method `csl`: the bake parameters.
    csl: Option<CslBakeParams>,
}

/// The "total" entry of a renderer's timings (zero when absent).
fn total_of(t: &[(String, Duration)]) -> Duration {
    t.iter()
        .find(|(n, _)| n == "total")
        .map_or(Duration::ZERO, |(_, d)| *d)
}

/// Runs `render` on the shared renderer: the wait for it shows as the `gpu_lock` stage, then
/// the render's own stages.
fn on_gpu(
    ctx: &JobCtx<'_>,
    timings: &mut Vec<(String, Duration)>,
    render: impl FnOnce(&mut Renderer) -> Result<RenderOutput, RenderError>,
) -> Result<RenderOutput, JobError> {
    let t = Instant::now();
    let out = ctx.with_renderer(|r| render(r).map_err(|e| JobError::Render(e.to_string())))?;
    timings.push((
        "gpu_lock".into(),
        t.elapsed().saturating_sub(total_of(&out.timings)),
    ));
    timings.extend(out.timings.iter().cloned());
    Ok(out)
}

impl RenderJob {
    /// Checks the parameters and applies the camera and light overrides.
    pub fn new(
        world: Arc<World>,
        method: &str,
        v: &serde_json::Value,
        limits: &Limits,
    ) -> Result<Self, JobError> {
        let method = match method {
            "direct" => "direct",
            "reference" => "reference",
            "csl" => "csl",
            "transport" => "transport",
            m => {
                return Err(JobError::Params(format!(
                    "method: unknown render method '{m}' (available: direct, reference, csl, \
                     transport)"
                )));
            }
        };
        let p = RenderParams::from_value(v)?;
        let csl = match (&p.csl, method) {
            (Some(_), m) if m != "csl" => {
                return Err(JobError::Params("csl: only with method csl".into()));
            }
            (Some(v), _) => Some(CslBakeParams::parse(v, "csl")?),
            (None, "csl") => Some(CslBakeParams::parse(&serde_json::json!({}), "csl")?),
            (None, _) => None,
        };
        if !COMPONENTS.contains(&p.component.as_str()) {
            return Err(JobError::Params(format!(
                "component: '{}' is not one of {COMPONENTS:?}",
                p.component
            )));
        }
        if !p.exposure.is_finite() || p.exposure.abs() > 64.0 {
            return Err(JobError::Params("exposure: must lie in [-64, 64]".into()));
        }
        if p.photons.is_some_and(|n| !(1..=1_000_000_000).contains(&n)) {
            return Err(JobError::Params("photons: must lie in 1..=1e9".into()));
        }
        if p.spp.is_some_and(|n| !(1..=1024).contains(&n)) {
            return Err(JobError::Params("spp: must lie in 1..=1024".into()));
        }
        if p.layers && p.format != Format::Exr {
            return Err(JobError::Params("layers: only with format exr".into()));
        }
        let mut world = (*world).clone();
        if let Some(c) = &p.camera {
            world.camera = crate::scene::load::resolve_camera(c, limits)?;
        }
        for (name, v) in [("width", p.width), ("height", p.height)] {
            if let Some(v) = v
                && (v == 0 || v > limits.max_image_side)
            {
                return Err(JobError::Params(format!(
                    "{name}: must lie in 1..={}",
                    limits.max_image_side
                )));
            }
        }
        world.camera.width = p.width.unwrap_or(world.camera.width);
        world.camera.height = p.height.unwrap_or(world.camera.height);
        if let Some(ls) = &p.lights {
            if ls.len() > limits.max_lights {
                return Err(JobError::Params(format!(
                    "lights: at most {}",
                    limits.max_lights
                )));
            }
            let none = MapSource::default();
            world.lights = ls
                .iter()
                .enumerate()
                .map(|(i, l)| {
                    crate::scene::load::resolve_light(&format!("lights[{i}]"), l, &none, limits)
                })
                .collect::<Result<_, _>>()?;
        }
        if method == "csl" && crate::bake::csl::scene_directional_light(&world).is_none() {
            return Err(JobError::Params(
                "scene.lights: method csl needs a directional light; the scene has none".into(),
            ));
        }
        if method == "transport" && crate::bake::transport::refractive_objects(&world).is_empty() {
            return Err(JobError::Params(
                "scene.objects: method transport needs a glass (dielectric) object; the scene \
                 has none"
                    .into(),
            ));
        }
        Ok(RenderJob {
            world,
            method,
            p,
            csl,
        })
    }

    /// Finds (or bakes) the transport table of every glass object on this CPU worker, builds
    /// the frame's illumination volumes, then renders on the shared renderer.
    fn frames_transport(
        &self,
        ctx: &JobCtx<'_>,
        timings: &mut Vec<(String, Duration)>,
    ) -> Result<Frames, JobError> {
        use crate::jobs::transport_bake::table_for_render;
        // An adapter that cannot draw the volumes fails the render before any bake.
        ctx.with_renderer(|r| match r.transport_unsupported() {
            Some(why) => Err(JobError::NoGpu(why)),
            None => Ok(()),
        })?;
        let cache = ctx.data_dir().join("transport-cache");
        let objects = crate::bake::transport::refractive_objects(&self.world);
        let t = Instant::now();
        let mut tables = Vec::new();
        for (k, &oi) in objects.iter().enumerate() {
            let (table, cached) = table_for_render(&self.world, oi, &cache, &|p| {
                ctx.progress(0.8 * (k as f32 + p.fraction) / objects.len() as f32, "bake");
                ctx.keep_going()
            })
            .map_err(|e| match e {
                BakeError::Canceled => ctx.check().err().unwrap_or(JobError::Canceled),
                other => JobError::Params(other.to_string()),
            })?;
            tables.push((oi, table, cached));
        }
        timings.push(("bake".into(), t.elapsed()));
        ctx.check()?;
        ctx.progress(0.8, "volumes");
        let t = Instant::now();
        let refs: Vec<(usize, &crate::bake::transport::TransportTable)> =
            tables.iter().map(|(i, t, _)| (*i, t)).collect();
        let layer = crate::render::TransportLayer::build_with(
            &self.world,
            &refs,
            crate::bake::transport::eval::DEFAULT_LINE_POINTS,
            &|| ctx.keep_going(),
        )
        .map_err(|e| match e {
            crate::bake::transport::eval::EvalError::Canceled => {
                ctx.check().err().unwrap_or(JobError::Canceled)
            }
            other => JobError::Params(other.to_string()),
        })?;
        timings.push(("volumes".into(), t.elapsed()));
        ctx.progress(0.9, "render");
        let out = on_gpu(ctx, timings, |r| {
            r.render_transport(&self.world, &RenderOptions::default(), &layer)
        })?;
        let info = serde_json::json!({
            "adapter": out.adapter,
            "statistics": {
                "volumes": layer.stats.volumes,
                "lit_vertices": layer.stats.lit_vertices,
                "flux_leaving_w": layer.stats.flux.to_array(),
                "reflection_volumes": layer.stats.reflection_volumes,
                "flux_reflected_w": layer.stats.reflected_flux.to_array(),
                "bakes": tables.iter().map(|(oi, t, cached)| serde_json::json!({
                    "object": self.world.objects[*oi].name,
                    "cached": cached,
                    "source_hash": format!("{:016x}", t.source_hash),
                    "vertices": t.vertex_count,
                    "directions": t.params.directions(),
                })).collect::<Vec<_>>(),
            },
        });
        Ok((out.components(), info))
    }

    /// Bakes (or finds) the CSL sets on this CPU worker, then renders on the shared renderer.
    fn frames_csl(
        &self,
        ctx: &JobCtx<'_>,
        timings: &mut Vec<(String, Duration)>,
    ) -> Result<Frames, JobError> {
        let csl = self.csl.as_ref().expect("set for csl");
        let params = csl.csl_params();
        let store = csl_cache::DirStore(ctx.data_dir().join("csl-cache"));
        let t = Instant::now();
        let sets = if csl.dynamic {
            // The dynamic bake (a bake job with the same parameters keeps it), interpolated for
            // the scene's light.
            csl_cache::dynamic_sets_for_render(
                &self.world,
                &csl.dynamic_params(),
                &store,
                &|_, p| {
                    ctx.progress(0.9 * p.fraction, "bake");
                    ctx.keep_going()
                },
            )
        } else {
            csl_cache::sets_for_render(&self.world, &params, &store, &|_, p| {
                ctx.progress(0.9 * p.fraction, "bake");
                ctx.keep_going()
            })
        }
        .map_err(|e| match e {
            csl_cache::PrepareError::Bake(BakeError::Canceled) => {
                ctx.check().err().unwrap_or(JobError::Canceled)
            }
            other => JobError::Params(other.to_string()),
        })?;
        timings.push(("bake".into(), t.elapsed()));
        ctx.check()?;
        ctx.progress(0.9, "render");
        let layer = CslLayer::from_sets(&self.world, &sets);
        let out = on_gpu(ctx, timings, |r| {
            r.render_csl(&self.world, &RenderOptions::default(), Some(&layer))
        })?;
        let info = serde_json::json!({
            "adapter": out.adapter,
            "statistics": {
                "csls": layer.csls.len(),
                "bakes": sets.sets.iter().map(|s| serde_json::json!({
                    "object": self.world.objects[s.object].name,
                    "cached": s.cached,
                    "source_hash": format!("{:016x}", s.set.source_hash),
                    "csls": s.set.csls.len(),
                    // An interpolated (dynamic) set has no coverage of its own.
                    "energy_covered": (s.set.stats.energy_traced > 0.0)
                        .then(|| s.set.stats.coverage()),
                })).collect::<Vec<_>>(),
            },
        });
        Ok((out.components(), info))
    }

    fn frames_direct(
        &self,
        r: &mut Renderer,
        timings: &mut Vec<(String, Duration)>,
    ) -> Result<Frames, JobError> {
        let out = r
            .render(&self.world, &RenderOptions::default())
            .map_err(|e| JobError::Render(e.to_string()))?;
        timings.extend(out.timings.iter().cloned());
        let info = serde_json::json!({ "adapter": out.adapter });
        Ok((out.components(), info))
    }

    fn frames_reference(
        &self,
        ctx: &JobCtx<'_>,
        timings: &mut Vec<(String, Duration)>,
    ) -> Result<Frames, JobError> {
        let t = Instant::now();
        let accel = Accel::build(&self.world);
        timings.push(("bvh".into(), t.elapsed()));
        ctx.check()?;
        let d = ReferenceParams::default();
        let params = ReferenceParams {
            seed: self.p.seed.unwrap_or(d.seed),
            photons: self.p.photons.unwrap_or(d.photons),
            spp: self.p.spp.unwrap_or(d.spp),
            ..d
        };
        let (c, stats) = reference::render(&self.world, &accel, &params, &|f| {
            ctx.progress(f, if f < 0.8 { "photons" } else { "camera" });
            ctx.keep_going()
        })
        .map_err(|_| ctx.check().err().unwrap_or(JobError::Canceled))?;
        timings.extend(stats.stages.iter().cloned());
        let info = serde_json::json!({
            "adapter": "cpu",
            "statistics": {
                "photons_traced": stats.photons_traced,
                "caustic_photons_stored": stats.caustic_photons_stored,
                "camera_samples": stats.camera_samples,
            },
        });
        Ok((
            COMPONENTS
                .iter()
                .map(|n| (*n, c.get(n).expect("known component")))
                .collect(),
            info,
        ))
    }
}

impl Job for RenderJob {
    fn kind(&self) -> &'static str {
        "render"
    }
    fn method(&self) -> &'static str {
        self.method
    }
    fn lane(&self) -> Lane {
        if self.method == "direct" {
            Lane::Gpu
        } else {
            Lane::Cpu
        }
    }

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        let mut timings = Vec::new();
        ctx.progress(0.0, "render");
        let (frames, mut info) = match self.method {
            "direct" => ctx.with_renderer(|r| self.frames_direct(r, &mut timings))?,
            "csl" => self.frames_csl(ctx, &mut timings)?,
            "transport" => self.frames_transport(ctx, &mut timings)?,
            _ => self.frames_reference(ctx, &mut timings)?,
        };
        ctx.check()?;
        ctx.progress(1.0, "encode");
        let t = Instant::now();
        let main = frames
            .iter()
            .find(|(n, _)| *n == self.p.component)
            .map(|(_, f)| f)
            .expect("component checked in new()");
        let (content_type, ext, bytes) = match self.p.format {
            Format::Png => (
                "image/png",
                "png",
                encode::encode_png(
                    main,
                    PngSettings {
                        exposure: self.p.exposure,
                        tone_map: self.p.tone_map.unwrap_or(ToneMap::Clamp),
                    },
                )?,
            ),
            Format::Exr if self.p.layers => {
                let mut list = vec![(self.p.component.as_str(), main)];
                list.extend(
                    frames
                        .iter()
                        .filter(|(n, _)| *n != self.p.component)
                        .map(|(n, f)| (*n, f)),
                );
                ("image/x-exr", "exr", encode::encode_exr_layers(&list)?)
            }
            Format::Exr => ("image/x-exr", "exr", encode::encode_exr(main)?),
        };
        timings.push(("encode".into(), t.elapsed()));
        if let Some(o) = info.as_object_mut() {
            o.insert("method".into(), self.method.into());
            o.insert("width".into(), self.world.camera.width.into());
            o.insert("height".into(), self.world.camera.height.into());
            o.insert("component".into(), self.p.component.clone().into());
        }
        Ok(Artifact {
            content_type,
            ext,
            bytes,
            timings,
            info,
        })
    }
}
