//! Method `water`: underwater caustics (Sánchez-Crespo 2003) from a procedural water surface
//! (a `water` shape) under directional lights (the sun, with its disc). The GPU renders the
//! direct and specular layers; the sunlight refracted by the waves onto everything under the
//! water (the caustics layer where the camera sees it directly, added to the specular layer
//! where it sees it through the waves) is computed by the GPU's water passes or on the CPU
//! ([`crate::render::water`]), in the article's mode or in a physical mode that converges to
//! the reference.

use super::{
    Env, Frames, Json, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan, from_value,
};
use crate::render::RenderOptions;
use crate::render::water::gpu::{MapSource, WaterGpuLayer};
use crate::render::water::{
    MAX_GRID, MAX_MAP, MAX_PIXEL_SAMPLES, MAX_POINTS, MAX_SUN_SAMPLES, Mode, Receivers, Variant,
    WaterParams, WaterStats, render_layer_with, suns,
};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex};
use std::time::Instant;

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Water,
    name: "water",
    lane: Lane::Cpu,
    gpu: true,
    bake: false,
    args: &["water"],
    check: false,
};

pub struct Water;

/// The `water` field of a render request (the API's `water_mode` is its `mode`; the CLI's
/// `--water-mode`, `--water-variant`, `--water-grid`, `--sun-samples`, `--map-resolution`,
/// `--mesh-resolution`, `--sun-map-width`, `--pixel-samples`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "WaterOptions")]
pub struct WaterArgs {
    /// physical (default) or article.
    #[serde(default)]
    pub mode: Option<Mode>,
    /// shader (per pixel) or shader_texture (a mipmapped light map) on the GPU; pixel,
    /// texture or vertex on the CPU. Default: shader where the scene has one water shape
    /// and one directional light and no pixel_samples are given, pixel otherwise.
    #[serde(default)]
    pub variant: Option<Variant>,
    /// Physical: sun rays per side of each water rectangle, 16..=2048 (default 512).
    #[serde(default)]
    #[schemars(range(min = 16, max = 2048), extend("default" = 512))]
    pub grid: Option<u32>,
    /// Physical: directions over the sun's disc, 1..=64 (default 4).
    #[serde(default)]
    #[schemars(range(min = 1, max = 64), extend("default" = 4))]
    pub sun_samples: Option<u32>,
    /// Texture, shader, shader_texture: texels per side of the light map, 16..=2048 (default
    /// 1024).
    #[serde(default)]
    #[schemars(range(min = 16, max = 2048), extend("default" = 1024))]
    pub map_resolution: Option<u32>,
    /// Vertex: quads per side of the receiver grid, 4..=2048 (default 128).
    #[serde(default)]
    #[schemars(range(min = 4, max = 2048), extend("default" = 128))]
    pub mesh_resolution: Option<u32>,
    /// Article: the sun map's width in degrees, 0.1..=45 (default 4).
    #[serde(default)]
    #[schemars(range(min = 0.1, max = 45), extend("default" = 4))]
    pub sun_map_width: Option<f32>,
    /// Receiver points per pixel side, 1..=8 (default 3: 9 a pixel, fewer where width ×
    /// height × 9 would pass 8 Mi points).
    #[serde(default)]
    #[schemars(range(min = 1, max = 8), extend("default" = 3))]
    pub pixel_samples: Option<u32>,
}

impl WaterArgs {
    /// Parses and checks `v`, found at field `at` of a request.
    pub fn parse(v: &Json, at: &str) -> Result<WaterArgs, ParamError> {
        let a: WaterArgs = from_value(v, at)?;
        let f = |n: &str| format!("{at}.{n}");
        if let Some(n) = a.grid {
            ParamError::range(&f("grid"), n, 16, MAX_GRID)?;
        }
        if let Some(n) = a.sun_samples {
            ParamError::range(&f("sun_samples"), n, 1, MAX_SUN_SAMPLES)?;
        }
        if let Some(n) = a.map_resolution {
            ParamError::range(&f("map_resolution"), n, 16, MAX_MAP)?;
        }
        if let Some(n) = a.mesh_resolution {
            ParamError::range(&f("mesh_resolution"), n, 4, MAX_MAP)?;
        }
        if let Some(n) = a.pixel_samples {
            ParamError::range(&f("pixel_samples"), n, 1, MAX_PIXEL_SAMPLES)?;
        }
        if let Some(w) = a.sun_map_width
            && !(w.is_finite() && (0.1..=45.0).contains(&w))
        {
            return Err(ParamError::new(
                f("sun_map_width"),
                "must lie in 0.1..=45 (degrees)",
            ));
        }
        Ok(a)
    }

    /// The settings, defaults filled in.
    pub fn params(&self) -> WaterParams {
        let d = WaterParams::default();
        WaterParams {
            mode: self.mode.unwrap_or(d.mode),
            variant: self.variant.unwrap_or(d.variant),
            grid: self.grid.unwrap_or(d.grid),
            sun_samples: self.sun_samples.unwrap_or(d.sun_samples),
            map_resolution: self.map_resolution.unwrap_or(d.map_resolution),
            mesh_resolution: self.mesh_resolution.unwrap_or(d.mesh_resolution),
            sun_map_width: self.sun_map_width.map_or(d.sun_map_width, f32::to_radians),
            pixel_samples: self.pixel_samples.unwrap_or(d.pixel_samples),
        }
    }
}

impl MethodImpl for Water {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        let a = match &args.water {
            Some(v) => WaterArgs::parse(v, "water")?,
            None => WaterArgs::default(),
        };
        check_scene(world)?;
        let mut params = a.params();
        if a.variant.is_none() && a.pixel_samples.is_none() {
            // The default: on the GPU (variant shader) where it takes the scene (one water
            // shape under one sun), per pixel on the CPU otherwise.
            let gpu = WaterParams {
                variant: Variant::Shader,
                ..params.clone()
            };
            if WaterGpuLayer::build(world, &gpu).is_ok() {
                params = gpu;
            }
        } else if params.variant.on_gpu() {
            WaterGpuLayer::build(world, &params)
                .map_err(|e| ParamError::new("water.variant", e))?;
        }
        let pixels = u64::from(world.camera.width) * u64::from(world.camera.height);
        let points = |k: u32| pixels * u64::from(k) * u64::from(k);
        if a.pixel_samples.is_none() {
            // The default: 3 × 3 a pixel, fewer where the image is too large for that.
            while params.pixel_samples > 1 && points(params.pixel_samples) > MAX_POINTS {
                params.pixel_samples -= 1;
            }
        }
        // The shaders take no CPU points.
        if !params.variant.on_gpu() && points(params.pixel_samples) > MAX_POINTS {
            return Err(ParamError::new(
                if a.pixel_samples.is_some() {
                    "water.pixel_samples"
                } else {
                    "width"
                },
                format!(
                    "width × height × pixel_samples² is {}, more than {MAX_POINTS} receiver \
                     points; ask for fewer pixel samples or a smaller image",
                    points(params.pixel_samples)
                ),
            ));
        }
        Ok(Box::new(Plan {
            params,
            receivers: Mutex::new(None),
        }))
    }
}

/// What method `water` needs of a scene: a water shape and a directional light.
pub fn check_scene(world: &World) -> Result<(), ParamError> {
    if world.water.is_empty() {
        return Err(ParamError::new(
            "scene.objects",
            "method water needs a water shape (an object with shape.type \"water\"); the scene \
             has none",
        ));
    }
    if suns(world).is_empty() {
        return Err(ParamError::new(
            "scene.lights",
            "method water needs a directional light (the sun); the scene has none",
        ));
    }
    Ok(())
}

struct Plan {
    params: WaterParams,
    /// The receivers of the last frame and what they were built from (each non-water part's
    /// mesh and transform): the frames of a sequence share them.
    receivers: Mutex<Option<(Vec<ReceiverKey>, Arc<Receivers>)>>,
}

/// A receiver part's identity: its mesh (by pointer) and its object's transform.
type ReceiverKey = (usize, [f32; 16]);

fn receiver_keys(world: &World) -> Vec<ReceiverKey> {
    world
        .objects
        .iter()
        .enumerate()
        .filter(|(i, _)| world.water_of(*i as u32).is_none())
        .flat_map(|(_, o)| {
            o.parts
                .iter()
                .map(move |p| (Arc::as_ptr(&p.mesh) as usize, o.transform.to_cols_array()))
        })
        .collect()
}

impl Plan {
    /// Variants `shader` and `shader_texture`: the water passes in the GPU's frame.
    fn frames_on_the_gpu(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        let t = Instant::now();
        let layer = WaterGpuLayer::build(world, &self.params)
            .map_err(|e| ParamError::new("water.variant", e))?;
        timings.push(("plan".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.2, "render");
        let out = env.render(&mut timings, |r| {
            r.render_water(world, &RenderOptions::default(), &layer)
        })?;
        let mut frames = Frames::from_output(out, timings);
        let p = &self.params;
        let map = layer.map.as_ref();
        // Sun rays the landing pass traced (physical mode).
        let rays = map.and_then(|m| match &m.source {
            MapSource::Splat { grid, dirs } => Some(u64::from(grid + 1).pow(2) * dirs.len() as u64),
            MapSource::Article => None,
        });
        frames.statistics = Some(serde_json::json!({
            "mode": p.mode.name(),
            "variant": p.variant.name(),
            "grid": (p.mode == Mode::Physical).then_some(p.grid),
            "sun_samples": (p.mode == Mode::Physical).then_some(p.sun_samples),
            "rays": rays,
            "map_resolution": map.map(|m| m.resolution),
            "map_levels": map.map(|m| m.levels),
            "sun_map_width_deg": p.sun_map_width.to_degrees(),
            "article_calibration": layer.calibration.map(|k| vec![k]).unwrap_or_default(),
        }));
        frames.notes.push(match (p.mode, map) {
            (Mode::Article, None) => format!(
                "water, article mode per pixel on the GPU, brightness calibration {:.4}",
                layer.calibration.unwrap_or(1.0)
            ),
            (Mode::Article, Some(m)) => format!(
                "water, article mode in a {0}×{0} light map on the GPU ({1} mip levels), \
                 brightness calibration {2:.4}",
                m.resolution,
                m.levels,
                layer.calibration.unwrap_or(1.0)
            ),
            (Mode::Physical, Some(m)) => format!(
                "water, physical mode on the GPU: a {0}×{0} grid of sun rays × {1} directions \
                 splatted into a {2}×{2} light map ({3} mip levels)",
                p.grid, p.sun_samples, m.resolution, m.levels
            ),
            (Mode::Physical, None) => unreachable!("the physical mode always has a map"),
        });
        Ok(frames)
    }

    /// The receivers of `world`, made again only when they changed; whether they were kept.
    fn receivers(&self, world: &World) -> (Arc<Receivers>, bool) {
        let key = receiver_keys(world);
        let mut cache = self.receivers.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((k, r)) = cache.as_ref()
            && *k == key
        {
            return (r.clone(), true);
        }
        let r = Arc::new(Receivers::build(world));
        *cache = Some((key, r.clone()));
        (r, false)
    }
}

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Water
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        if self.params.variant.on_gpu() {
            return self.frames_on_the_gpu(world, env);
        }
        let mut timings = Vec::new();
        (env.progress)(0.0, "receivers");
        let t = Instant::now();
        // The receivers' BVH build cannot be interrupted: asked right before and after it.
        env.check()?;
        let (recv, reused) = self.receivers(world);
        timings.push(("receivers".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.1, "caustics");
        let mut stats = WaterStats::default();
        let t = Instant::now();
        let layers = render_layer_with(world, &recv, &self.params, &mut stats, env.keep_going)?;
        timings.push(("caustics".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.8, "render");
        let mut out = env.render(&mut timings, |r| r.render(world, &RenderOptions::default()))?;
        out.caustics = Some(layers.caustics);
        out.specular = out.specular.add(&layers.specular);
        let mut frames = Frames::from_output(out, timings);
        let p = &self.params;
        let kept = if stats.flux_transmitted > 0.0 {
            stats.flux_splatted / stats.flux_transmitted
        } else {
            0.0
        };
        frames.statistics = Some(serde_json::json!({
            "mode": p.mode.name(),
            "variant": p.variant.name(),
            "grid": p.grid,
            "sun_samples": p.sun_samples,
            "map_resolution": p.map_resolution,
            "mesh_resolution": p.mesh_resolution,
            "sun_map_width_deg": p.sun_map_width.to_degrees(),
            "pixel_samples": p.pixel_samples,
            "points": stats.points,
            "receivers_reused": reused,
            "rays": stats.rays,
            "flux_splatted_fraction": kept,
            "article_calibration": stats.calibration,
            "stages_ms": stats.stages.iter().map(|(n, d)| (n.clone(), d.as_secs_f64() * 1e3))
                .collect::<std::collections::BTreeMap<_, _>>(),
        }));
        frames.notes.push(match p.mode {
            Mode::Physical => format!(
                "water, physical mode, {} variant: {} sun rays, {:.1} % of the transmitted flux \
                 landed on receivers, {} points",
                p.variant.name(),
                stats.rays,
                kept * 100.0,
                stats.points
            ),
            Mode::Article => format!(
                "water, article mode, {} variant: {} points, brightness calibration {:?}",
                p.variant.name(),
                stats.points,
                stats.calibration
            ),
        });
        Ok(frames)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn bad_parameters_name_their_field() {
        for (v, field) in [
            (json!({"grid": 1}), "water.grid"),
            (json!({"mode": "magic"}), "water.mode"),
            (json!({"variant": "voxel"}), "water.variant"),
            (json!({"sun_samples": 0}), "water.sun_samples"),
            (json!({"sun_map_width": 0}), "water.sun_map_width"),
            (json!({"gird": 10}), "water.gird"),
        ] {
            let e = WaterArgs::parse(&v, "water").unwrap_err();
            assert_eq!(e.field, field, "{v}: {e}");
        }
        let a = WaterArgs::parse(&json!({"mode": "article", "grid": 64}), "water").unwrap();
        assert_eq!((a.mode, a.grid), (Some(Mode::Article), Some(64)));
    }
}
