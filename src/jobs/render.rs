//! Render jobs: the request's scene edits (camera, lights, size) applied, the method's plan
//! made up front (so bad parameters are refused at submission), its frames made on the
//! method's lane, one image out (PNG tone-mapped, or EXR linear, optionally with every
//! component as a layer).

use super::job::{Artifact, Job, JobError, JobKind};
use super::worker::JobCtx;
use crate::encode::{self, PngSettings, ToneMap};
use crate::frame::Component;
use crate::methods::{Lane, Method, MethodArgs, ParamError, RenderPlan, from_value};
use crate::scene::types::{CameraDesc, LightDesc};
use crate::scene::{Limits, MapSource, World};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    #[default]
    Png,
    Exr,
}

/// Render parameters (everything of a render request but the scene and method).
#[derive(Clone, Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderParams {
    /// Image size; the camera's when absent.
    #[serde(default)]
    #[schemars(range(min = 1, max = 4096))]
    pub width: Option<u32>,
    #[serde(default)]
    #[schemars(range(min = 1, max = 4096))]
    pub height: Option<u32>,
    /// png (the default; tone-mapped 8-bit sRGB) or exr (linear radiance). Without it, an
    /// `Accept` header naming image types picks one.
    #[serde(default)]
    pub format: Format,
    /// The component written (default total).
    #[serde(default)]
    pub component: Component,
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
    /// reference and photons: light paths to trace in all (defaults 4,000,000 and
    /// 1,048,576).
    #[serde(default)]
    #[schemars(range(min = 1, max = 1_000_000_000))]
    pub photons: Option<u64>,
    /// reference only: camera samples per pixel.
    #[serde(default)]
    #[schemars(range(min = 1, max = 1024))]
    pub spp: Option<u32>,
    /// reference and photons: the random sequence's seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// reference only: scatterings in the scene's medium a light path may have (1: single
    /// scattering), 1..=1000 (default: unlimited).
    #[serde(default)]
    #[schemars(range(min = 1, max = 1000))]
    pub volume_bounces: Option<u32>,
    /// csl only: the bake's parameters, as for `POST /v1/bakes` (default: the paper's). With
    /// `dynamic: true` the render uses the static bake made for exactly the scene's light with
    /// the same preset and grid when the data directory keeps one (see `refine`), else the
    /// dynamic bake of these parameters (found in the data directory, e.g. made by a bake job,
    /// or baked now) and the set interpolated from it for the light's direction.
    #[serde(default)]
    #[schemars(with = "Option<crate::methods::csl::BakeParams>")]
    pub csl: Option<serde_json::Value>,
    /// csl with `dynamic` only: when the frame was served by sets interpolated from the
    /// dynamic bake, queue the static bake of each object for exactly this light (the same
    /// preset and grid; cached by content hash), so that the next frame at this light direction
    /// is served by it (default true). The render's `info.refine` names the bakes.
    #[serde(default)]
    pub refine: Option<bool>,
    /// pinhole only (Wand and Straßer 2003, no bake): sample points on the mirrors and glass
    /// project the environment and the lights onto the receivers every frame.
    #[serde(default)]
    #[schemars(with = "Option<crate::methods::pinhole::PinholeArgs>")]
    pub pinhole: Option<serde_json::Value>,
    /// water only: `physical` (the default: a refracted grid of sun rays, irradiance from the
    /// area ratio, converges to the reference) or `article` (the article's sun-map lookup).
    #[serde(default)]
    pub water_mode: Option<crate::render::water::Mode>,
    /// water only (Sánchez-Crespo 2003, no bake); see docs/methods/water.md.
    #[serde(default)]
    #[schemars(with = "Option<crate::methods::water::WaterArgs>")]
    pub water: Option<serde_json::Value>,
    /// beams only (Liktor and Dachsbacher 2010, no bake); see docs/methods/beams.md.
    #[serde(default)]
    #[schemars(with = "Option<crate::methods::beams::BeamsArgs>")]
    pub beams: Option<serde_json::Value>,
    /// photons only (progressive photon tracing, no bake); see docs/methods/photons.md.
    #[serde(default)]
    #[schemars(with = "Option<crate::methods::photons::ProgressiveArgs>")]
    pub progressive: Option<serde_json::Value>,
    /// Scenes with water: the waves' time in seconds (any method); the first frame's time of a
    /// sequence.
    #[serde(default)]
    pub time: Option<f32>,
    /// Scenes with water: a sequence of this many frames, 1..=240, answered as an animated PNG
    /// (format png only).
    #[serde(default)]
    #[schemars(range(min = 1, max = 240))]
    pub frames: Option<u32>,
    /// A sequence's frames per second, 0.1..=60 (default 24).
    #[serde(default)]
    #[schemars(range(min = 0.1, max = 60), extend("default" = 24))]
    pub fps: Option<f32>,
    /// Adds a diffuse ground plane under the scene's objects (`"ground": true` in a scene does
    /// the same): for a glass or mirror object uploaded alone, whose shadow and caustic
    /// otherwise fall on nothing.
    #[serde(default)]
    pub ground: bool,
    /// Runs the self-check, a short reference of the caustics compared with the frame on the
    /// receivers (its figures in `info.statistics.check`; about a second of CPU), or not.
    /// Default: on for csl and transport, and for `auto` where its rule is unsure; off
    /// otherwise.
    #[serde(default)]
    pub check: Option<bool>,
}

/// Most frames a sequence may ask for, and most pixels over all its frames (each kept as 8-bit
/// sRGB until the animation is encoded: 3 bytes a pixel).
pub const MAX_SEQUENCE_FRAMES: u32 = 240;
pub const MAX_SEQUENCE_PIXELS: u64 = 64 << 20;

/// Checks a sequence request (`frames`, `fps`) against `world`: the times of its frames from
/// `t0`, or None for a single frame.
pub fn sequence_times(
    world: &World,
    frames: Option<u32>,
    fps: Option<f32>,
    t0: f32,
) -> Result<Option<Vec<f32>>, ParamError> {
    if let Some(f) = fps
        && !(f.is_finite() && (0.1..=60.0).contains(&f))
    {
        return Err(ParamError::new("fps", "must lie in 0.1..=60"));
    }
    let Some(n) = frames else {
        if fps.is_some() {
            return Err(ParamError::new("fps", "only with frames (a sequence)"));
        }
        return Ok(None);
    };
    ParamError::range("frames", n, 1, MAX_SEQUENCE_FRAMES)?;
    let pixels = u64::from(n) * u64::from(world.camera.width) * u64::from(world.camera.height);
    if pixels > MAX_SEQUENCE_PIXELS {
        return Err(ParamError::new(
            "frames",
            format!(
                "frames × width × height is {pixels}, more than {MAX_SEQUENCE_PIXELS}: ask for \
                 fewer frames or a smaller image"
            ),
        ));
    }
    if world.water.is_empty() {
        return Err(ParamError::new(
            "frames",
            "a sequence animates water; the scene has no water shape",
        ));
    }
    let fps = fps.unwrap_or(24.0);
    let times: Vec<f32> = (0..n).map(|i| t0 + i as f32 / fps).collect();
    if times
        .iter()
        .any(|t| t.abs() > crate::scene::water::MAX_TIME)
    {
        return Err(ParamError::new(
            "frames",
            format!(
                "the sequence's times pass ±{} s",
                crate::scene::water::MAX_TIME
            ),
        ));
    }
    Ok(Some(times))
}

impl RenderParams {
    /// The method-specific part, for the method's parser.
    pub fn method_args(&self) -> MethodArgs {
        MethodArgs {
            photons: self.photons,
            spp: self.spp,
            seed: self.seed,
            volume_bounces: self.volume_bounces,
            csl: self.csl.clone(),
            pinhole: self.pinhole.clone(),
            beams: self.beams.clone(),
            progressive: self.progressive.clone(),
            check: self.check,
            water: match (&self.water, self.water_mode) {
                (w, None) => w.clone(),
                (w, Some(mode)) => {
                    let mut v = w.clone().unwrap_or_else(|| serde_json::json!({}));
                    if let Some(o) = v.as_object_mut() {
                        o.insert("mode".into(), mode.name().into());
                    }
                    Some(v)
                }
            },
            ..Default::default()
        }
    }
}

/// Applies a request's camera, size, light and ground overrides to `world` (the CLI's
/// `--width`, `--height` and `--ground` go through here too).
pub fn apply_overrides(
    world: &mut World,
    camera: Option<&CameraDesc>,
    size: (Option<u32>, Option<u32>),
    lights: Option<&[LightDesc]>,
    time: Option<f32>,
    ground: bool,
    limits: &Limits,
) -> Result<(), JobError> {
    if ground {
        crate::scene::ground::add_ground(world);
    }
    if let Some(t) = time {
        if !(t.is_finite() && t.abs() <= crate::scene::water::MAX_TIME) {
            return Err(ParamError::new(
                "time",
                format!(
                    "must be a number of seconds within ±{}",
                    crate::scene::water::MAX_TIME
                ),
            )
            .into());
        }
        if world.water.is_empty() {
            return Err(ParamError::new(
                "time",
                "the scene has no water shape: nothing moves with time",
            )
            .into());
        }
        crate::scene::water::set_time(world, t);
    }
    if let Some(c) = camera {
        world.camera = crate::scene::load::resolve_camera(c, limits)?;
    }
    for (name, v) in [("width", size.0), ("height", size.1)] {
        if let Some(v) = v {
            ParamError::range(name, v, 1, limits.max_image_side)?;
        }
    }
    world.camera.width = size.0.unwrap_or(world.camera.width);
    world.camera.height = size.1.unwrap_or(world.camera.height);
    if let Some(ls) = lights {
        if ls.len() > limits.max_lights {
            return Err(ParamError::new("lights", format!("at most {}", limits.max_lights)).into());
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
    Ok(())
}

/// Most pixels (over all frames) of a small render ([`Job::small`]), and most camera samples of
/// a small `reference` render.
pub const SMALL_PIXELS: u64 = 1 << 20;
/// Most photons of a small `reference` or `photons` render.
pub const SMALL_PHOTONS: u64 = 4_000_000;

pub struct RenderJob {
    world: World,
    /// The method asked for (`auto` stays `auto` here; the plan knows the chosen one).
    requested: Method,
    plan: Box<dyn RenderPlan>,
    p: RenderParams,
    /// A sequence's frame times.
    times: Option<Vec<f32>>,
}

impl RenderJob {
    /// Checks the parameters, applies the camera and light overrides and plans the frames; a
    /// progressive method traces for at most `budget` ([`super::job::build_job`]).
    pub fn new(
        world: Arc<World>,
        method: Method,
        v: &serde_json::Value,
        limits: &Limits,
        budget: Duration,
    ) -> Result<Self, JobError> {
        let p: RenderParams = from_value(v, "")?;
        if !p.exposure.is_finite() || p.exposure.abs() > 64.0 {
            return Err(ParamError::new("exposure", "must lie in [-64, 64]").into());
        }
        if p.layers && p.format != Format::Exr {
            return Err(ParamError::new("layers", "only with format exr").into());
        }
        let dynamic = p.csl.as_ref().and_then(|c| c.get("dynamic")) == Some(&true.into());
        if p.refine.is_some() && !(method == Method::Csl && dynamic) {
            return Err(ParamError::new(
                "refine",
                "only with method csl and a dynamic bake (\"csl\": {\"dynamic\": true})",
            )
            .into());
        }
        let mut world = (*world).clone();
        apply_overrides(
            &mut world,
            p.camera.as_ref(),
            (p.width, p.height),
            p.lights.as_deref(),
            p.time,
            p.ground,
            limits,
        )?;
        let first = world.water.first().map_or(0.0, |w| w.surface.time());
        let times = sequence_times(&world, p.frames, p.fps, first)?;
        if times.is_some() && p.format != Format::Png {
            return Err(
                ParamError::new("format", "a sequence is an animated PNG: format png").into(),
            );
        }
        let args = MethodArgs {
            time_budget: Some(budget.as_secs_f64()),
            ..p.method_args()
        };
        let plan = method.imp().plan(&world, &args)?;
        Ok(RenderJob {
            world,
            requested: method,
            plan,
            p,
            times,
        })
    }
}

impl Job for RenderJob {
    fn kind(&self) -> JobKind {
        JobKind::Render
    }

    fn method(&self) -> Method {
        self.plan.method()
    }

    fn lane(&self) -> Lane {
        self.plan.method().info().lane
    }

    /// The reference's estimate ([`crate::methods::reference::memory_estimate`]: pixels,
    /// stored photons, triangles); a GPU method's: ~384 bytes a pixel over all frames (its
    /// targets, layers and readback, which lavapipe keeps in host memory: measured 190 for
    /// `direct`, 278 for `photons`, 341 for `beams` at 640×480 to 1280×960), 256 bytes a
    /// triangle, 16 MiB, and the photon buffers of `photons` (320 MiB), the beams of `beams`
    /// (256 MiB) and the list of (pixel, volume) pairs, sums and culling depth of `transport`
    /// (156 bytes a pixel). An `auto` render that checks its `photons` frame holds the larger of
    /// that and its fallback reference's.
    fn memory(&self) -> u64 {
        let c = &self.world.camera;
        let frames = self.times.as_ref().map_or(1, |t| t.len() as u64);
        let pixels = c.width as u64 * c.height as u64 * frames;
        let method = self.plan.method();
        if method == Method::Reference {
            let d = crate::reference::ReferenceParams::default();
            let photons = self.p.photons.unwrap_or(d.photons);
            return crate::methods::reference::memory_estimate(&self.world, photons, pixels);
        }
        let fixed: u64 = match method {
            Method::Photons => 320 << 20,
            Method::Beams => 256 << 20,
            _ => 0,
        };
        let per_pixel = match method {
            Method::Transport => 384 + crate::render::transport::LIST_BYTES_PER_PIXEL,
            _ => 384,
        };
        let triangles = self.world.triangle_count() as u64;
        let own = (16 << 20) + fixed + pixels * per_pixel + triangles * 256;
        if self.requested == Method::Auto
            && method == Method::Photons
            && self.p.check != Some(false)
        {
            // `auto` may make the frame again with the reference (its fallback's photons).
            let photons = crate::methods::auto::fallback_photons(&self.world);
            return own.max(crate::methods::reference::memory_estimate(
                &self.world,
                photons,
                pixels,
            ));
        }
        own
    }

    /// Small: at most [`SMALL_PIXELS`] pixels over all frames, and for `reference` at most
    /// [`SMALL_PHOTONS`] photons and [`SMALL_PIXELS`] camera samples; a GPU method's frame, for
    /// `photons` (frames of photons until a count) at most [`SMALL_PHOTONS`] photons. The
    /// baked methods are not small: their frame may have to bake first.
    fn small(&self) -> bool {
        let c = &self.world.camera;
        let frames = self.times.as_ref().map_or(1, |t| t.len() as u64);
        let pixels = c.width as u64 * c.height as u64 * frames;
        if pixels > SMALL_PIXELS {
            return false;
        }
        match self.plan.method() {
            Method::Reference => {
                let d = crate::reference::ReferenceParams::default();
                let photons = self.p.photons.unwrap_or(d.photons);
                let spp = self.p.spp.unwrap_or(d.spp) as u64;
                photons <= SMALL_PHOTONS && pixels * spp <= SMALL_PIXELS
            }
            Method::Photons => {
                let photons = self
                    .p
                    .photons
                    .unwrap_or(crate::methods::photons::DEFAULT_PHOTONS);
                photons <= SMALL_PHOTONS
            }
            m => m.info().lane == Lane::Gpu,
        }
    }

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        if let Some(times) = &self.times {
            return self.run_sequence(ctx, times);
        }
        ctx.progress(0.0, "render");
        let mut frames = ctx
            .with_env(|env| {
                crate::methods::render(self.plan.as_ref(), &self.world, env, self.p.check)
            })
            .map_err(|e| ctx.method_error(e))?;
        ctx.check()?;
        ctx.progress(1.0, "encode");
        let mut timings = std::mem::take(&mut frames.timings);
        let t = Instant::now();
        let component = self.p.component;
        let main = frames.get(component);
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
            Format::Exr if self.p.layers => (
                "image/x-exr",
                "exr",
                encode::encode_exr_layers(&frames.named_first(component))?,
            ),
            Format::Exr => ("image/x-exr", "exr", encode::encode_exr(main)?),
        };
        timings.push(("encode".into(), t.elapsed()));
        let mut info = serde_json::json!({
            "adapter": frames.adapter,
            "method": frames.made_by.unwrap_or(self.plan.method()),
            "width": self.world.camera.width,
            "height": self.world.camera.height,
            "component": component,
        });
        if let Some(s) = frames.statistics {
            if self.p.refine != Some(false)
                && let Some(r) = self.refine(ctx, &s)
            {
                info["refine"] = r;
            }
            info["statistics"] = s;
        }
        if let Some(why) = self.plan.reason() {
            info["requested_method"] = self.requested.name().into();
            info["reason"] = why.into();
        }
        if !frames.warnings.is_empty() {
            info["warnings"] = frames.warnings.into();
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

impl RenderJob {
    /// A dynamic csl frame served by interpolated sets (its `statistics` say which): queues
    /// the static bakes of those objects for exactly this light, with the render's preset and
    /// grid, so that the next frame at this light is served by them. What to record of it:
    /// the bakes' ids, or why none was queued (the frame stands either way).
    fn refine(
        &self,
        ctx: &JobCtx<'_>,
        statistics: &serde_json::Value,
    ) -> Option<serde_json::Value> {
        let objects: Vec<String> = statistics["bakes"]
            .as_array()?
            .iter()
            .filter(|b| b["set"] == "interpolated")
            .filter_map(|b| b["object"].as_str().map(String::from))
            .collect();
        if objects.is_empty() {
            return None;
        }
        let empty = serde_json::json!({});
        let bp =
            crate::methods::csl::BakeParams::parse(self.p.csl.as_ref().unwrap_or(&empty), "csl")
                .ok()?;
        let params = serde_json::json!({ "preset": bp.preset, "grid": bp.grid });
        let queued = Method::Csl
            .imp()
            .bake_params(&params, "csl")
            .map_err(|e| e.to_string())
            .and_then(|params| {
                ctx.queue_bakes(self.p.lights.as_deref(), Method::Csl, &objects, &params)
            });
        Some(match queued {
            Ok(ids) => serde_json::json!({ "bakes": ids }),
            Err(e) => {
                tracing::warn!(error = %e, "the static bakes of a dynamic csl frame were not queued");
                serde_json::json!({ "error": e })
            }
        })
    }

    /// A sequence: the frames at `times`, one animated PNG.
    fn run_sequence(&self, ctx: &JobCtx<'_>, times: &[f32]) -> Result<Artifact, JobError> {
        let t = Instant::now();
        let component = self.p.component;
        let png = PngSettings {
            exposure: self.p.exposure,
            tone_map: self.p.tone_map.unwrap_or(ToneMap::Clamp),
        };
        // Only each frame's component, as 8-bit sRGB, is kept until the end.
        let mut images = Vec::with_capacity(times.len());
        let mut adapter = None;
        ctx.with_env(|env| {
            crate::methods::sequence(self.plan.as_ref(), &self.world, env, times, &mut |_, f| {
                adapter.get_or_insert_with(|| f.adapter.clone());
                images.push(encode::srgb8(f.get(component), png));
                Ok(())
            })
        })
        .map_err(|e| ctx.method_error(e))?;
        let rendered = t.elapsed();
        ctx.check()?;
        ctx.progress(1.0, "encode");
        let t = Instant::now();
        let fps = self.p.fps.unwrap_or(24.0);
        let cam = &self.world.camera;
        let bytes = encode::encode_apng(&images, (cam.width, cam.height), fps)?;
        let timings = vec![("frames".into(), rendered), ("encode".into(), t.elapsed())];
        let info = serde_json::json!({
            "adapter": adapter,
            "method": self.plan.method(),
            "width": self.world.camera.width,
            "height": self.world.camera.height,
            "component": component,
            "frames": times.len(),
            "fps": fps,
            "times": times,
            "ms_per_frame": rendered.as_secs_f64() * 1e3 / times.len() as f64,
        });
        Ok(Artifact {
            content_type: "image/apng",
            ext: "png",
            bytes,
            timings,
            info,
        })
    }
}
