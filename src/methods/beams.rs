//! Method `beams`: volumetric caustics with projected light beams (Liktor and Dachsbacher
//! 2010). No bake: every frame a grid projected from each directional, spot or point light
//! onto the specular objects makes one caustic beam per grid triangle (on the CPU), and the GPU
//! intersects every pixel's view ray with the beams that cover it, evaluating the
//! single-scattering integral in the scene's medium ([`crate::render::beams`]). The same beams
//! give the surface caustics where they end on receivers; a ray-marched pass adds the fog the
//! lights light directly (`volume`).

use super::{
    Env, Frames, Json, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan, from_value,
};
use crate::render::RenderOptions;
use crate::render::beams::{BeamsLayer, BeamsParams, Bounds, GRIDS, MAX_REFINE, MAX_SAMPLES};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::time::Instant;

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Beams,
    name: "beams",
    lane: Lane::Gpu,
    gpu: true,
    bake: false,
    args: &["beams"],
    check: false,
};

pub struct Beams;

/// The `beams` field of a render request (the CLI's `--grid`, `--beam-samples`,
/// `--no-beam-shadows`, `--one-sided`, `--no-surface`, `--downsample`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "BeamsOptions")]
pub struct BeamsArgs {
    /// Grid cells a side: 32, 64, 128 (default) or 256.
    #[serde(default)]
    #[schemars(extend("enum" = [32, 64, 128, 256], "default" = 128))]
    pub grid: Option<u32>,
    /// Samples along a view ray per beam, 1..=16 (default 1, the paper's).
    #[serde(default)]
    #[schemars(range(min = 1, max = 16), extend("default" = 1))]
    pub samples: Option<u32>,
    /// Beams end at the first surface their photons meet, so occluders cut them (default
    /// true; false: the paper's beams, which run through everything).
    #[serde(default)]
    #[schemars(extend("default" = true))]
    pub shadows: Option<bool>,
    /// Refracted photons are traced through their glass object and the beams start where they
    /// leave it (default true; false: the paper's one-sided refraction).
    #[serde(default)]
    #[schemars(extend("default" = true))]
    pub two_sided: Option<bool>,
    /// The beams also light the receivers (surface caustics; default true).
    #[serde(default)]
    #[schemars(extend("default" = true))]
    pub surface: Option<bool>,
    /// The volume at 1/downsample of the resolution, upsampled edge-aware: 1 (default), 2 or 4.
    #[serde(default)]
    #[schemars(extend("enum" = [1, 2, 4], "default" = 1))]
    pub downsample: Option<u32>,
    /// Grid cells across a silhouette or a change of path are split refine × refine, 1..=8
    /// (default 4; 1: the paper's uniform grid).
    #[serde(default)]
    #[schemars(range(min = 1, max = 8), extend("default" = 4))]
    pub refine: Option<u32>,
    /// The bounding volume a beam is drawn with: hull (default) or touching_planes (the
    /// paper's prism).
    #[serde(default)]
    pub bounds: Option<Bounds>,
}

impl BeamsArgs {
    /// Parses and checks `v`, found at field `at` of a request.
    pub fn parse(v: &Json, at: &str) -> Result<BeamsArgs, ParamError> {
        let a: BeamsArgs = from_value(v, at)?;
        if let Some(n) = a.grid
            && !GRIDS.contains(&n)
        {
            return Err(ParamError::new(
                format!("{at}.grid"),
                "must be 32, 64, 128 or 256",
            ));
        }
        if let Some(n) = a.samples {
            ParamError::range(&format!("{at}.samples"), n, 1, MAX_SAMPLES)?;
        }
        if let Some(n) = a.downsample
            && ![1, 2, 4].contains(&n)
        {
            return Err(ParamError::new(
                format!("{at}.downsample"),
                "must be 1, 2 or 4",
            ));
        }
        if let Some(n) = a.refine {
            ParamError::range(&format!("{at}.refine"), n, 1, MAX_REFINE)?;
        }
        Ok(a)
    }

    /// The parameters asked for, defaults filled in.
    pub fn params(&self) -> BeamsParams {
        let d = BeamsParams::default();
        BeamsParams {
            grid: self.grid.unwrap_or(d.grid),
            samples: self.samples.unwrap_or(d.samples),
            shadows: self.shadows.unwrap_or(d.shadows),
            two_sided: self.two_sided.unwrap_or(d.two_sided),
            surface: self.surface.unwrap_or(d.surface),
            downsample: self.downsample.unwrap_or(d.downsample),
            refine: self.refine.unwrap_or(d.refine),
            bounds: self.bounds.unwrap_or(d.bounds),
        }
    }
}

impl MethodImpl for Beams {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        let a = match &args.beams {
            Some(v) => BeamsArgs::parse(v, "beams")?,
            None => BeamsArgs::default(),
        };
        if super::caustic_objects(world).is_empty() {
            return Err(ParamError::new(
                "scene.objects",
                "method beams needs a glass or mirror object to cast beams; the scene has none",
            ));
        }
        if world.media.iter().any(|m| m.has_boundary_mesh()) {
            return Err(ParamError::new(
                "scene.media",
                "method beams takes a medium in a box or the whole scene; one inside a mesh \
                 renders with method reference",
            ));
        }
        if !world.lights.iter().any(|l| {
            matches!(
                l,
                crate::scene::Light::Directional { .. }
                    | crate::scene::Light::Spot { .. }
                    | crate::scene::Light::Point { .. }
            )
        }) {
            return Err(ParamError::new(
                "scene.lights",
                "method beams needs a directional, spot or point light",
            ));
        }
        Ok(Box::new(Plan { params: a.params() }))
    }
}

struct Plan {
    params: BeamsParams,
}

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Beams
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        (env.progress)(0.0, "beams");
        let t = Instant::now();
        let layer = BeamsLayer::build_with(world, &self.params, env.keep_going)
            .ok_or(MethodError::Canceled)?;
        timings.push(("beams".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.3, "render");
        let out = env.render(&mut timings, |r| {
            r.render_beams(world, &RenderOptions::default(), &layer)
        })?;
        let s = &layer.stats;
        let p = &self.params;
        let mut frames = Frames::from_output(out, timings);
        frames.statistics = Some(serde_json::json!({
            "grid": p.grid,
            "samples": p.samples,
            "shadows": p.shadows,
            "two_sided": p.two_sided,
            "surface": p.surface,
            "downsample": p.downsample,
            "lights": s.lights,
            "skipped_lights": s.skipped_lights,
            "vertices_on_generators": s.vertices_on_generators,
            "triangles": s.triangles,
            "beams": s.beams,
            "reflective_beams": s.reflective_beams,
            "refractive_beams": s.refractive_beams,
            "dropped_invalid": s.dropped_invalid,
            "dropped_paths": s.dropped_paths,
            "dropped_false": s.dropped_false,
            "dropped_twisted": s.dropped_twisted,
            "refine": p.refine,
            "bounds": p.bounds,
            "refined_cells": s.refined_cells,
            "has_medium": !world.media.is_empty(),
            "time_build_ms": s.time_build.as_secs_f64() * 1e3,
        }));
        frames.notes.push(format!(
            "{} beams ({} reflective, {} refractive) from a {}² grid per light over {} lights; \
             dropped: {} off the generators, {} across paths, {} false, {} twisted",
            s.beams,
            s.reflective_beams,
            s.refractive_beams,
            p.grid,
            s.lights,
            s.dropped_invalid,
            s.dropped_paths,
            s.dropped_false,
            s.dropped_twisted,
        ));
        if world.media.is_empty() {
            frames
                .notes
                .push("the scene has no medium: only the surface caustics are drawn".into());
        }
        for k in &s.skipped_lights {
            frames.notes.push(format!(
                "a {k} light casts no beams (directional, spot and point do)"
            ));
        }
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
            (json!({"grid": 100}), "beams.grid"),
            (json!({"samples": 0}), "beams.samples"),
            (json!({"samples": 17}), "beams.samples"),
            (json!({"downsample": 3}), "beams.downsample"),
            (json!({"refine": 9}), "beams.refine"),
            (json!({"bounds": "sphere"}), "beams.bounds"),
            (json!({"shadows": "no"}), "beams.shadows"),
            (json!({"gird": 64}), "beams.gird"),
        ] {
            let e = BeamsArgs::parse(&v, "beams").unwrap_err();
            assert_eq!(e.field, field, "{v}: {e}");
        }
        let a = BeamsArgs::parse(&json!({"grid": 64, "two_sided": false}), "beams").unwrap();
        let p = a.params();
        assert_eq!((p.grid, p.two_sided, p.shadows), (64, false, true));
    }
}
