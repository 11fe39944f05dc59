//! Method `photons`: progressive photon tracing on the GPU with photon differentials (no bake;
//! [`crate::render::photons`]). The request's `photons` are all the photons of the render,
//! traced `progressive.photons_per_frame` at a time; `progressive.time_budget_ms` and
//! `progressive.error_target` stop it earlier.

use super::{
    Env, Frames, Json, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan, from_value,
};
use crate::render::RenderOptions;
use crate::render::photons::{MAX_FRAMES, MAX_PHOTONS, PhotonsLayer, PhotonsParams};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::time::{Duration, Instant};

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Photons,
    name: "photons",
    lane: Lane::Gpu,
    gpu: true,
    bake: false,
    args: &["photons", "seed", "time_budget", "progressive"],
    check: false,
};

pub struct Photons;

/// Photons of a render when the request gives none: 2 frames of the default.
pub const DEFAULT_PHOTONS: u64 = 2 << 19;

/// The `progressive` field of a render request (the CLI's `--photons-per-frame`,
/// `--time-budget`, `--error-target` and `--footprint`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "ProgressiveOptions")]
pub struct ProgressiveArgs {
    /// Photons traced per frame, 1024..=4194240 (default 524288).
    #[serde(default)]
    #[schemars(range(min = 1024, max = 4194240), extend("default" = 524288))]
    pub photons_per_frame: Option<u32>,
    /// Return the frame after this many milliseconds of photon frames, 1..=600000.
    #[serde(default)]
    #[schemars(range(min = 1, max = 600000))]
    pub time_budget_ms: Option<u64>,
    /// Return the frame once the estimated noise (relative L1 per pixel) is at most this,
    /// (0, 1).
    #[serde(default)]
    #[schemars(extend("exclusiveMinimum" = 0, "exclusiveMaximum" = 1))]
    pub error_target: Option<f32>,
    /// The first frame's kernel half-size in spacings of neighbouring photons, 0.5..=8
    /// (default 3).
    #[serde(default)]
    #[schemars(range(min = 0.5, max = 8), extend("default" = 3))]
    pub footprint: Option<f32>,
}

impl ProgressiveArgs {
    /// Parses and checks `v`, found at field `at` of a request.
    pub fn parse(v: &Json, at: &str) -> Result<ProgressiveArgs, ParamError> {
        let a: ProgressiveArgs = from_value(v, at)?;
        if let Some(n) = a.photons_per_frame {
            ParamError::range(&format!("{at}.photons_per_frame"), n, 1024, MAX_PHOTONS)?;
        }
        if let Some(n) = a.time_budget_ms {
            ParamError::range(&format!("{at}.time_budget_ms"), n, 1, 600_000)?;
        }
        if let Some(e) = a.error_target
            && !(e.is_finite() && e > 0.0 && e < 1.0)
        {
            return Err(ParamError::new(
                format!("{at}.error_target"),
                "must lie in (0, 1)",
            ));
        }
        if let Some(f) = a.footprint
            && !(f.is_finite() && (0.5..=8.0).contains(&f))
        {
            return Err(ParamError::new(
                format!("{at}.footprint"),
                "must lie in [0.5, 8]",
            ));
        }
        Ok(a)
    }
}

/// The parameters of a request: `photons` in all (frames of `photons_per_frame`), its seed,
/// its time budget (the least of `progressive.time_budget_ms` and `time_budget`: the CLI's
/// `--time-budget` seconds, or the server's budget for a job).
pub fn params(args: &MethodArgs) -> Result<PhotonsParams, ParamError> {
    let p = match &args.progressive {
        Some(v) => ProgressiveArgs::parse(v, "progressive")?,
        None => ProgressiveArgs::default(),
    };
    let d = PhotonsParams::default();
    let per_frame = p.photons_per_frame.unwrap_or(d.photons);
    let total = args.photons.unwrap_or(DEFAULT_PHOTONS);
    let frames = total.div_ceil(u64::from(per_frame)).max(1);
    if frames > u64::from(MAX_FRAMES) {
        return Err(ParamError::new(
            "photons",
            format!(
                "{total} photons would take {frames} frames of {per_frame}, more than \
                 {MAX_FRAMES}: ask for more progressive.photons_per_frame"
            ),
        ));
    }
    Ok(PhotonsParams {
        photons: per_frame,
        frames: frames as u32,
        // The request's budget, within the server's (a job's `time_budget`).
        time_budget: [
            p.time_budget_ms.map(Duration::from_millis),
            args.time_budget.map(Duration::from_secs_f64),
        ]
        .into_iter()
        .flatten()
        .min(),
        error_target: p.error_target,
        footprint: p.footprint.unwrap_or(d.footprint),
        seed: args.seed.unwrap_or(d.seed),
    })
}

impl MethodImpl for Photons {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        let params = params(args)?;
        if super::caustic_objects(world).is_empty() {
            return Err(ParamError::new(
                "scene.objects",
                "method photons traces light through glass and mirrors; the scene has none",
            ));
        }
        if !world.media.is_empty() {
            return Err(ParamError::new(
                "scene.media",
                "method photons has no participating media; render fog with method beams or \
                 reference",
            ));
        }
        if world.lights.is_empty() {
            return Err(ParamError::new("scene.lights", "the scene has no light"));
        }
        Ok(Box::new(Plan { params }))
    }
}

struct Plan {
    params: PhotonsParams,
}

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Photons
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        (env.progress)(0.0, "populations");
        // The splats blend into a 32-bit float layer, as transport's volumes.
        if let Some(why) = env.with_renderer(|r| Ok(r.transport_unsupported()))? {
            return Err(MethodError::NoGpu(why));
        }
        let t = Instant::now();
        let layer = PhotonsLayer::build(world, &self.params);
        timings.push(("populations".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.1, "render");
        let out = env.render(&mut timings, |r| {
            r.render_photons_while(world, &RenderOptions::default(), &layer, env.keep_going)
        })?;
        env.check()?;
        let run = out.photons.clone().unwrap_or_default();
        let p = &self.params;
        let mut frames = Frames::from_output(out, timings);
        frames.statistics = Some(serde_json::json!({
            "photons_per_frame": layer.photons_per_frame,
            "frames": run.frames,
            "frames_asked": p.frames,
            "photons": run.photons,
            "populations": layer.populations.len(),
            "triangles": layer.bvh.source.len(),
            "stopped_by": run.stopped_by,
            "error_estimate": run.error_estimate,
            "footprint": p.footprint,
            "time_photons_ms": run.time.as_secs_f64() * 1e3,
        }));
        frames.notes.push(format!(
            "{} photons in {} frames of {} ({} populations over {} triangles), stopped by {}{}",
            run.photons,
            run.frames,
            layer.photons_per_frame,
            layer.populations.len(),
            layer.bvh.source.len(),
            run.stopped_by,
            run.error_estimate
                .map(|e| format!("; estimated noise {e:.3}"))
                .unwrap_or_default(),
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
            (
                json!({"photons_per_frame": 10}),
                "progressive.photons_per_frame",
            ),
            (
                json!({"photons_per_frame": 5_000_000}),
                "progressive.photons_per_frame",
            ),
            (json!({"time_budget_ms": 0}), "progressive.time_budget_ms"),
            (json!({"error_target": 0}), "progressive.error_target"),
            (json!({"error_target": 1.5}), "progressive.error_target"),
            (json!({"footprint": 100}), "progressive.footprint"),
            (json!({"frames": 3}), "progressive.frames"),
        ] {
            let e = ProgressiveArgs::parse(&v, "progressive").unwrap_err();
            assert_eq!(e.field, field, "{v}: {e}");
        }
        let args = MethodArgs {
            photons: Some(1_000_000),
            progressive: Some(json!({"photons_per_frame": 250_000, "error_target": 0.02})),
            ..Default::default()
        };
        let p = params(&args).unwrap();
        assert_eq!(
            (p.photons, p.frames, p.error_target),
            (250_000, 4, Some(0.02))
        );
        let too_many = MethodArgs {
            photons: Some(1_000_000_000),
            progressive: Some(json!({"photons_per_frame": 1024})),
            ..Default::default()
        };
        assert_eq!(params(&too_many).unwrap_err().field, "photons");
    }

    #[test]
    fn the_time_budget_is_the_least_of_the_requests_and_the_servers() {
        let budget = |ms: Option<u64>, server: Option<f64>| {
            let args = MethodArgs {
                time_budget: server,
                progressive: ms.map(|ms| json!({ "time_budget_ms": ms })),
                ..Default::default()
            };
            params(&args).unwrap().time_budget
        };
        let s = Duration::from_secs;
        assert_eq!(budget(Some(600_000), Some(150.0)), Some(s(150)));
        assert_eq!(budget(Some(2_000), Some(150.0)), Some(s(2)));
        assert_eq!(budget(None, Some(150.0)), Some(s(150)));
        assert_eq!(budget(Some(2_000), None), Some(s(2)));
        assert_eq!(budget(None, None), None);
    }
}
