//! Method `pinhole`: pinhole caustics (Wand and Straßer 2003). No bake: every frame the
//! reflecting surfaces (mirrors, glass by its Fresnel reflection) are covered with sample
//! points, each a pinhole camera that projects the light it receives onto the receivers, and
//! the GPU sums the projections per pixel, filtered by the points' curvature
//! ([`crate::render::pinhole`]). One specular bounce; lit by the environment (map or constant)
//! and by directional, point, spot and line lights.

use super::{
    Env, Frames, Json, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan, from_value,
};
use crate::render::RenderOptions;
use crate::render::pinhole::{
    MAX_CLUSTER, MAX_SAMPLES, PinholeLayer, PinholeParams, Strategy, reflecting_objects,
};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::time::Instant;

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Pinhole,
    name: "pinhole",
    lane: Lane::Gpu,
    gpu: true,
    bake: false,
    args: &["pinhole", "line_points"],
    check: false,
};

pub struct Pinhole;

/// The `pinhole` field of a render request (the CLI's `--samples`, `--sampling`,
/// `--no-filter`, `--shadows`, `--transmit`, `--cluster`, `--sun-radius`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "PinholeOptions")]
pub struct PinholeArgs {
    /// Sample points over all reflectors, 1..=100000 (default 2000).
    #[serde(default)]
    #[schemars(range(min = 1, max = 100000), extend("default" = 2000))]
    pub samples: Option<u32>,
    /// random, grid, quantized or neighbourhood (default).
    #[serde(default)]
    pub sampling: Option<Strategy>,
    /// Curvature-based anti-aliasing (default true).
    #[serde(default)]
    #[schemars(extend("default" = true))]
    pub filter: Option<bool>,
    /// Occlusion of the reflected light by the scene's objects (default false: 12–19× the
    /// time on lavapipe; needed where a mirror faces the table or itself, see
    /// docs/methods/pinhole.md).
    #[serde(default)]
    #[schemars(extend("default" = false))]
    pub shadows: Option<bool>,
    /// Points per cluster, 1..=64 (default 16; 1: every pixel takes every point): a receiver
    /// farther than 6 cluster radii takes a cluster as one pinhole.
    #[serde(default)]
    #[schemars(range(min = 1, max = 64), extend("default" = 16))]
    pub cluster: Option<u32>,
    /// Open glass surfaces (meshes with a boundary: a water surface, a sheet) also transmit,
    /// as one refracting interface (the paper's §5; default false, since a glass solid whose
    /// mesh has holes would count as open too).
    #[serde(default)]
    #[schemars(extend("default" = false))]
    pub transmit: Option<bool>,
    /// Angular radius in degrees of the disc a directional, point or spot light appears as,
    /// 0.01..=10 (default 0.27, the sun's).
    #[serde(default)]
    #[schemars(range(min = 0.01, max = 10), extend("default" = 0.27))]
    pub sun_radius: Option<f32>,
}

impl PinholeArgs {
    /// Parses and checks `v`, found at field `at` of a request.
    pub fn parse(v: &Json, at: &str) -> Result<PinholeArgs, ParamError> {
        let a: PinholeArgs = from_value(v, at)?;
        if let Some(n) = a.samples {
            ParamError::range(&format!("{at}.samples"), n, 1, MAX_SAMPLES)?;
        }
        if let Some(n) = a.cluster {
            ParamError::range(&format!("{at}.cluster"), n, 1, MAX_CLUSTER)?;
        }
        if let Some(r) = a.sun_radius
            && !(r.is_finite() && (0.01..=10.0).contains(&r))
        {
            return Err(ParamError::new(
                format!("{at}.sun_radius"),
                "must lie in 0.01..=10 (degrees)",
            ));
        }
        Ok(a)
    }
}

impl MethodImpl for Pinhole {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        let a = match &args.pinhole {
            Some(v) => PinholeArgs::parse(v, "pinhole")?,
            None => PinholeArgs::default(),
        };
        if reflecting_objects(world).is_empty() {
            return Err(ParamError::new(
                "scene.objects",
                "method pinhole needs a reflecting (mirror or glass) object; the scene has none",
            ));
        }
        let d = PinholeParams::default();
        Ok(Box::new(Plan {
            params: PinholeParams {
                samples: a.samples.unwrap_or(d.samples),
                strategy: a.sampling.unwrap_or(d.strategy),
                filter: a.filter.unwrap_or(d.filter),
                shadows: a.shadows.unwrap_or(d.shadows),
                transmit: a.transmit.unwrap_or(d.transmit),
                sun_radius: a.sun_radius.map_or(d.sun_radius, f32::to_radians),
                seed: args.seed.unwrap_or(d.seed),
                line_points: args.line_points.unwrap_or(d.line_points),
                cluster: a.cluster.unwrap_or(d.cluster),
            },
        }))
    }
}

struct Plan {
    params: PinholeParams,
}

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Pinhole
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        (env.progress)(0.0, "sampling");
        let t = Instant::now();
        let layer = PinholeLayer::build_with(world, &self.params, env.keep_going)?
            .map_err(|e| ParamError::new("scene.lights", e))?;
        timings.push(("sampling".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.2, "render");
        let out = env.render(&mut timings, |r| {
            r.render_pinhole(world, &RenderOptions::default(), &layer)
        })?;
        let s = &layer.stats;
        let p = &self.params;
        let mut frames = Frames::from_output(out, timings);
        frames.statistics = Some(serde_json::json!({
            "samples": s.samples,
            "samples_asked": p.samples,
            "sampling": p.strategy.name(),
            "filter": p.filter,
            "shadows": p.shadows,
            "transmit": p.transmit,
            "cluster": p.cluster,
            "reflector_area_m2": s.area,
            "reflector_parts": s.parts,
            "transmitting_parts": s.transmitting_parts,
            "delta_sources": s.delta_sources,
            "samples_shadowed": s.shadowed,
            "time_sampling_ms": s.time_sampling.as_secs_f64() * 1e3,
            "time_lights_ms": s.time_lights.as_secs_f64() * 1e3,
        }));
        frames.notes.push(format!(
            "{} points ({}, {}filtered) on {} reflector parts ({} transmitting) of {:.3} m², {} \
             delta sources",
            s.samples,
            p.strategy.name(),
            if p.filter { "" } else { "not " },
            s.parts,
            s.transmitting_parts,
            s.area,
            s.delta_sources,
        ));
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
            (json!({"samples": 0}), "pinhole.samples"),
            (json!({"samples": 100_000_000}), "pinhole.samples"),
            (json!({"sampling": "hexagonal"}), "pinhole.sampling"),
            (json!({"sun_radius": 0}), "pinhole.sun_radius"),
            (json!({"filter": "yes"}), "pinhole.filter"),
            (json!({"sample": 10}), "pinhole.sample"),
        ] {
            let e = PinholeArgs::parse(&v, "pinhole").unwrap_err();
            assert_eq!(e.field, field, "{v}: {e}");
        }
        let a = PinholeArgs::parse(&json!({"samples": 10, "sampling": "grid"}), "pinhole").unwrap();
        assert_eq!((a.samples, a.sampling), (Some(10), Some(Strategy::Grid)));
    }
}
