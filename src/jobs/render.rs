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
use std::time::Instant;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    #[default]
    Png,
    Exr,
}

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
    /// Pinhole: `{"samples": 1..=100000, "sampling": "random" | "grid" | "quantized" |
    /// "neighbourhood", "filter": bool, "shadows": bool, "sun_radius": degrees}`.
    #[serde(default)]
    pub pinhole: Option<serde_json::Value>,
}

impl RenderParams {
    /// The method-specific part, for the method's parser.
    pub fn method_args(&self) -> MethodArgs {
        MethodArgs {
            photons: self.photons,
            spp: self.spp,
            seed: self.seed,
            csl: self.csl.clone(),
            pinhole: self.pinhole.clone(),
            ..Default::default()
        }
    }
}

/// Applies a request's camera, size and light overrides to `world` (the CLI's `--width`
/// and `--height` go through here too).
pub fn apply_overrides(
    world: &mut World,
    camera: Option<&CameraDesc>,
    size: (Option<u32>, Option<u32>),
    lights: Option<&[LightDesc]>,
    limits: &Limits,
) -> Result<(), JobError> {
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

pub struct RenderJob {
    world: World,
    /// The method asked for (`auto` stays `auto` here; the plan knows the chosen one).
    requested: Method,
    plan: Box<dyn RenderPlan>,
    p: RenderParams,
}

impl RenderJob {
    /// Checks the parameters, applies the camera and light overrides and plans the frames.
    pub fn new(
        world: Arc<World>,
        method: Method,
        v: &serde_json::Value,
        limits: &Limits,
    ) -> Result<Self, JobError> {
        let p: RenderParams = from_value(v, "")?;
        if !p.exposure.is_finite() || p.exposure.abs() > 64.0 {
            return Err(ParamError::new("exposure", "must lie in [-64, 64]").into());
        }
        if p.layers && p.format != Format::Exr {
            return Err(ParamError::new("layers", "only with format exr").into());
        }
        let mut world = (*world).clone();
        apply_overrides(
            &mut world,
            p.camera.as_ref(),
            (p.width, p.height),
            p.lights.as_deref(),
            limits,
        )?;
        let plan = method.imp().plan(&world, &p.method_args())?;
        Ok(RenderJob {
            world,
            requested: method,
            plan,
            p,
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

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        ctx.progress(0.0, "render");
        let mut frames = ctx
            .with_env(|env| self.plan.frames(&self.world, env))
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
            "method": self.plan.method(),
            "width": self.world.camera.width,
            "height": self.world.camera.height,
            "component": component,
        });
        if let Some(s) = frames.statistics {
            info["statistics"] = s;
        }
        if let Some(why) = self.plan.reason() {
            info["requested_method"] = self.requested.name().into();
            info["reason"] = why.into();
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
