//! Method `reference`: the CPU ground truth (light tracing for caustics and diffuse
//! interreflection, a caustic photon map for caustics seen through glass, camera paths for
//! direct light and specular chains; see [`crate::reference`]). Every component, deterministic
//! for a seed. Its bake is the same render kept as a multi-layer EXR of every component.

use super::{
    BakePlan, BakeRequest, Baked, Component, Env, Frames, Json, Lane, Method, MethodArgs,
    MethodError, MethodImpl, MethodInfo, ParamError, RenderPlan, canonical, from_value,
};
use crate::reference::{self, Components, ReferenceParams, ReferenceStats};
use crate::scene::World;
use crate::trace::Accel;
use serde::{Deserialize, Serialize};
use std::time::{Duration, Instant};

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Reference,
    name: "reference",
    lane: Lane::Cpu,
    gpu: false,
    bake: true,
    args: &["photons", "spp", "seed", "time_budget", "volume_bounces"],
    check: false,
};

pub struct Reference;

impl MethodImpl for Reference {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, _: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        let d = ReferenceParams::default();
        Ok(Box::new(Plan(ReferenceParams {
            seed: args.seed.unwrap_or(d.seed),
            photons: args.photons.unwrap_or(d.photons),
            spp: args.spp.unwrap_or(d.spp),
            time_budget: args.time_budget.map(Duration::from_secs_f64),
            volume_bounces: args.volume_bounces.unwrap_or(d.volume_bounces),
            ..d
        })))
    }

    fn bake_params(&self, v: &Json, at: &str) -> Result<Json, ParamError> {
        Ok(canonical(BakeParams::parse(v, at)?))
    }

    fn plan_bake(&self, req: BakeRequest) -> Result<Box<dyn BakePlan>, MethodError> {
        let params = BakeParams::parse(req.params, "params")?;
        let (world, object) = (req.world, req.object);
        let object = object.ok_or_else(|| ParamError::new("object", "required"))?;
        if world.object(object).is_none() {
            return Err(MethodError::UnknownObject(object.into()));
        }
        let mut world = (*world).clone();
        for (name, v) in [
            ("params.width", params.width),
            ("params.height", params.height),
        ] {
            if let Some(v) = v {
                ParamError::range(name, v, 1, req.limits.max_image_side)?;
            }
        }
        world.camera.width = params.width.unwrap_or(world.camera.width);
        world.camera.height = params.height.unwrap_or(world.camera.height);
        Ok(Box::new(Bake {
            world,
            object: object.into(),
            params,
        }))
    }
}

/// A generous estimate of a reference run's memory, bytes, for the job memory budget: ~256
/// bytes a pixel over all frames (its layers in f64 and splat buffers; measured 217–229 on the
/// glass sphere at 640×480 and 1280×960), 40 bytes a photon when the scene has glass, mirrors
/// or water (the stored caustic photons and their map; measured 31 at 4 M photons), 256 bytes
/// a triangle (the BVH) and 16 MiB.
pub fn memory_estimate(world: &World, photons: u64, pixels: u64) -> u64 {
    let specular = !world.objects_with(|m| m.is_specular()).is_empty() || !world.water.is_empty();
    let stored = if specular { photons } else { 0 };
    (16 << 20)
        + pixels.saturating_mul(256)
        + stored.saturating_mul(40)
        + world.triangle_count() as u64 * 256
}

/// The reference's run: every component of the frame.
fn run(
    world: &World,
    params: &ReferenceParams,
    env: &Env,
    timings: &mut Vec<(String, Duration)>,
) -> Result<(Components, ReferenceStats), MethodError> {
    let t = Instant::now();
    let accel = Accel::build(world);
    timings.push(("bvh".into(), t.elapsed()));
    env.check()?;
    let (c, stats) = reference::render(world, &accel, params, &|f| {
        // The reference reports 0..0.8 while tracing photons, then 1.0 after the camera.
        (env.progress)(f, if f < 0.8 { "photons" } else { "camera" });
        (env.keep_going)()
    })
    .map_err(|_| MethodError::Canceled)?;
    timings.extend(stats.stages.iter().cloned());
    Ok((c, stats))
}

fn statistics(stats: &ReferenceStats) -> serde_json::Value {
    serde_json::json!({
        "photons_traced": stats.photons_traced,
        "stopped_by": if stats.stopped_by_time { "time budget" } else { "photons" },
        "caustic_photons_stored": stats.caustic_photons_stored,
        "camera_samples": stats.camera_samples,
    })
}

fn note(stats: &ReferenceStats) -> String {
    format!(
        "photons traced: {}, caustic photons stored: {}, camera samples: {}",
        stats.photons_traced, stats.caustic_photons_stored, stats.camera_samples
    )
}

struct Plan(ReferenceParams);

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Reference
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        let (c, stats) = run(world, &self.0, env, &mut timings)?;
        Ok(Frames {
            layers: Component::ALL.map(|n| (n, c.get(n))).to_vec(),
            timings,
            adapter: "cpu".into(),
            statistics: Some(statistics(&stats)),
            notes: vec![note(&stats)],
            warnings: stats
                .stopped_by_time
                .then(|| {
                    format!(
                        "tracing stopped at its time budget after {} of {} photons: the \
                         caustics are noisier than asked",
                        stats.photons_traced, self.0.photons
                    )
                })
                .into_iter()
                .collect(),
            made_by: None,
        })
    }
}

/// Parameters of a reference bake; defaults filled in before the bake id is computed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "ReferenceParams")]
pub struct BakeParams {
    /// Photons (light paths) to trace, 1..=1e9.
    #[serde(default = "default_photons")]
    #[schemars(range(min = 1, max = 1_000_000_000))]
    pub photons: u64,
    /// Camera samples per pixel, 1..=1024.
    #[serde(default = "default_spp")]
    #[schemars(range(min = 1, max = 1024))]
    pub spp: u32,
    #[serde(default = "one")]
    pub seed: u64,
    /// Image size; the scene camera's when absent.
    #[serde(default)]
    #[schemars(range(min = 1, max = 4096))]
    pub width: Option<u32>,
    #[serde(default)]
    #[schemars(range(min = 1, max = 4096))]
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

impl BakeParams {
    /// Parses and checks `v`, found at field `at` of a request.
    pub fn parse(v: &serde_json::Value, at: &str) -> Result<Self, ParamError> {
        let p: BakeParams = from_value(v, at)?;
        if !(1..=1_000_000_000).contains(&p.photons) {
            return Err(ParamError::new(
                format!("{at}.photons"),
                "must lie in 1..=1e9",
            ));
        }
        ParamError::range(&format!("{at}.spp"), p.spp, 1, 1024)?;
        Ok(p)
    }
}

struct Bake {
    world: World,
    object: String,
    params: BakeParams,
}

impl BakePlan for Bake {
    fn object(&self) -> &str {
        &self.object
    }

    fn memory(&self) -> u64 {
        let c = &self.world.camera;
        memory_estimate(
            &self.world,
            self.params.photons,
            c.width as u64 * c.height as u64,
        )
    }

    fn run(&self, env: &Env) -> Result<Baked, MethodError> {
        let mut timings = Vec::new();
        (env.progress)(0.0, "bvh");
        let params = ReferenceParams {
            seed: self.params.seed,
            photons: self.params.photons,
            spp: self.params.spp,
            ..Default::default()
        };
        let (c, stats) = run(&self.world, &params, env, &mut timings)?;
        (env.progress)(1.0, "encode");
        let t = Instant::now();
        let layers = Component::ALL.map(|n| (n.name(), c.get(n)));
        let refs: Vec<(&str, &crate::frame::Frame)> = layers.iter().map(|(n, f)| (*n, f)).collect();
        let bytes = crate::encode::encode_exr_layers(&refs)
            .map_err(|e| MethodError::Render(format!("encoding the EXR: {e}")))?;
        timings.push(("encode".into(), t.elapsed()));
        Ok(Baked {
            bytes,
            ext: "exr",
            content_type: "image/x-exr",
            timings,
            info: serde_json::json!({
                "object": self.object,
                "width": self.world.camera.width,
                "height": self.world.camera.height,
                "layers": Component::ALL.map(Component::name),
                "statistics": statistics(&stats),
            }),
            notes: vec![note(&stats)],
        })
    }
}
