//! Method `csl`: caustic spot lights (Liu et al. 2008). The bake traces rays through each
//! caustic object for the scene's directional light and fits radially symmetric spot lights
//! to the bundles of rays leaving it ([`crate::bake::csl`]); a dynamic bake does so for the
//! directions of a subdivided icosahedron and matches them (§4), so that the set of any light
//! direction is interpolated per frame ([`crate::render::csl`]). The frame evaluates the CSLs
//! per pixel in the GPU's direct pass.
//!
//! Sets are found or baked through the [`ArtifactStore`] by content hash: a moving receiver,
//! camera, or the object moving rigidly with the light reuse the bake.

use super::{
    ArtifactKind, ArtifactStore, BakePlan, BakeRequest, Baked, Env, Frames, Json, Lane, Method,
    MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError, RenderPlan, bake_object,
    canonical, caustic_objects, from_value, scaled_progress,
};
use crate::bake::csl::dynamic::{self, DynamicParams, DynamicProgress, DynamicSet, bake_dynamic};
use crate::bake::csl::{CslParams, CslSet, bake_csl, csl_source_hash, scene_directional_light};
use crate::bake::{BakeError, Progress};
use crate::render::{CslLayer, RenderOptions};
use crate::scene::World;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Csl,
    name: "csl",
    lane: Lane::Cpu,
    gpu: true,
    bake: true,
    args: &["csl", "bake"],
    // Its renders check themselves against a short reference (`methods::check`).
    check: true,
};

pub struct Csl;

impl MethodImpl for Csl {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        let params = BakeParams::parse(args.csl.as_ref().unwrap_or(&serde_json::json!({})), "csl")?;
        let light = scene_directional_light(world).ok_or_else(no_light)?;
        Ok(Box::new(Plan {
            params,
            light,
            given: args.bake.clone(),
        }))
    }

    fn bake_params(&self, v: &Json, at: &str) -> Result<Json, ParamError> {
        Ok(canonical(BakeParams::parse(v, at)?))
    }

    fn plan_bake(&self, req: BakeRequest) -> Result<Box<dyn BakePlan>, MethodError> {
        let params = BakeParams::parse(req.params, "params")?;
        let (world, object) = (req.world, req.object);
        let oi = bake_object(
            &world,
            object,
            &caustic_objects(&world),
            "glass or mirror object",
        )?;
        let obj = &world.objects[oi];
        let object = obj.name.clone();
        // A static bake is for the scene's light, in the object's rigid frame; a dynamic bake
        // serves every direction.
        let light = if params.dynamic {
            None
        } else {
            let (dir, _) = scene_directional_light(&world).ok_or_else(|| {
                ParamError::new(
                    "scene.lights",
                    "a csl bake needs a directional light; the scene has none (a dynamic bake \
                     does not)",
                )
            })?;
            Some(obj.to_rigid_frame(dir))
        };
        Ok(Box::new(Bake {
            world,
            object,
            light,
            params,
        }))
    }
}

fn no_light() -> ParamError {
    ParamError::new(
        "scene.lights",
        "method csl needs a directional light; the scene has none",
    )
}

/// Parameters of a CSL bake (the `params` of a `csl` bake, the `csl` field of a `csl` render);
/// defaults filled in before the bake id is computed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "CslParams")]
pub struct BakeParams {
    /// `paper` (the paper's settings) or `fast` (coarser cells and images, for previews).
    #[serde(default = "default_preset")]
    #[schemars(extend("enum" = ["paper", "fast"]))]
    pub preset: String,
    /// Rays per side of the ray grid over the silhouette, 16..=4096 (the paper: 1280).
    #[serde(default)]
    #[schemars(range(min = 16, max = 4096))]
    pub grid: Option<u32>,
    /// Dynamic lighting (Liu et al. 2008 §4): a set per direction of a subdivided icosahedron,
    /// matched into triples; serves every directional light. Omitted when false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub dynamic: bool,
    /// Dynamic: icosahedron subdivisions, 0..=3 (default 2: 162 directions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(max = 3), extend("default" = 2))]
    pub subdivisions: Option<u32>,
    /// Dynamic: rays per side of the grid traced at each tracking step, 16..=1024 (default 96).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 16, max = 1024), extend("default" = 96))]
    pub track_grid: Option<u32>,
    /// Dynamic: tracking steps along an icosahedron edge, 1..=100 (default 20).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 1, max = 100), extend("default" = 20))]
    pub steps: Option<u32>,
    /// Dynamic: the largest axis distance of a match, in bounding-sphere radii, (0, 10]
    /// (default 0.5). Omitted when not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0, "maximum" = 10, "default" = 0.5))]
    pub match_threshold: Option<f32>,
}

fn default_preset() -> String {
    "paper".into()
}

impl Default for BakeParams {
    /// The paper's static bake.
    fn default() -> Self {
        BakeParams::parse(&serde_json::json!({}), "params").expect("the defaults are valid")
    }
}

impl BakeParams {
    /// Parses and checks `v`, found at field `at` of a request, filling the preset's grid and,
    /// for a dynamic bake, the paper's subdivisions, tracking grid and steps.
    pub fn parse(v: &serde_json::Value, at: &str) -> Result<Self, ParamError> {
        let mut p: BakeParams = from_value(v, at)?;
        let base = match p.preset.as_str() {
            "paper" => CslParams::paper(),
            "fast" => CslParams::fast(),
            other => {
                return Err(ParamError::new(
                    format!("{at}.preset"),
                    format!("'{other}' is not one of paper, fast"),
                ));
            }
        };
        let grid = p.grid.unwrap_or(base.grid);
        ParamError::range(&format!("{at}.grid"), grid, 16, 4096)?;
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
                ParamError::range(&format!("{at}.{name}"), x, *range.start(), *range.end())?;
                *v = Some(x);
            }
            if let Some(t) = p.match_threshold
                && !(t > 0.0 && t <= 10.0)
            {
                return Err(ParamError::new(
                    format!("{at}.match_threshold"),
                    "must lie in (0, 10]",
                ));
            }
        } else {
            for (name, set) in [
                ("subdivisions", p.subdivisions.is_some()),
                ("track_grid", p.track_grid.is_some()),
                ("steps", p.steps.is_some()),
                ("match_threshold", p.match_threshold.is_some()),
            ] {
                if set {
                    return Err(ParamError::new(
                        format!("{at}.{name}"),
                        "only for a dynamic bake (\"dynamic\": true)",
                    ));
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
            match_threshold: self.match_threshold.unwrap_or(d.match_threshold),
            csl: self.csl_params(),
        }
    }

    /// The parameters of a static bake (of each direction, for a dynamic one).
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

/// One caustic object's set, as a render uses it.
#[derive(Clone, Debug)]
pub struct ObjectSet {
    /// Index into `World::objects`.
    pub object: usize,
    /// Shared with the store's decoded artifacts (a static set).
    pub set: Arc<CslSet>,
    /// Whether its bake came from the store (false: baked now).
    pub cached: bool,
    /// Where the bake is kept in the store, if it is.
    pub path: Option<PathBuf>,
    /// Interpolated from a dynamic bake (false: a static bake for exactly this light, found
    /// or made).
    pub interpolated: bool,
}

/// For every caustic object of `world`, its CSL set for the scene's directional light
/// (`light`, world travel direction): from `store` when kept, else baked with `params` and
/// kept. With a dynamic `params` the static set made for exactly this light with the same
/// preset and grid is used when the store keeps one (a bake job made it, e.g. the refinement
/// a dynamic render queues); otherwise the dynamic bake is found or made and the set of the
/// light interpolated from it. `progress(f)` sees the bakes' progress in 0..1; returning
/// false cancels.
pub fn sets_for_render(
    world: &World,
    params: &BakeParams,
    light: Vec3,
    store: &ArtifactStore,
    progress: &(dyn Fn(f32) -> bool + Sync),
) -> Result<Vec<ObjectSet>, MethodError> {
    let objects = caustic_objects(world);
    let n = objects.len().max(1) as f32;
    let mut sets = Vec::new();
    for (k, oi) in objects.into_iter().enumerate() {
        let o = &world.objects[oi];
        let part = |f: f32| progress((k as f32 + f) / n);
        let dir = o.to_rigid_frame(light);
        let exact = if params.dynamic {
            let cp = params.csl_params();
            let key = csl_source_hash(world, &o.name, dir, &cp)?;
            store
                .find(
                    ArtifactKind::Csl,
                    key,
                    |b| CslSet::from_bytes(b).ok().filter(|s| s.source_hash == key),
                    CslSet::heap_bytes,
                )
                .map(|s| (s, store.path(ArtifactKind::Csl, key)))
        } else {
            None
        };
        let interpolated = params.dynamic && exact.is_none();
        let (set, cached, path) = if let Some((set, path)) = exact {
            (set, true, path)
        } else if params.dynamic {
            let dp = params.dynamic_params();
            let key = dynamic::dynamic_source_hash(world, &o.name, &dp)
                .ok_or_else(|| BakeError::UnknownObject(o.name.clone()))?;
            let kind = ArtifactKind::CslDynamic;
            let (d, cached) = store.find_or_bake(
                kind,
                key,
                |b| {
                    DynamicSet::from_bytes(b)
                        .ok()
                        .filter(|d| d.source_hash == key)
                },
                || bake_dynamic(world, &o.name, &dp, &|p: DynamicProgress| part(p.fraction)),
                DynamicSet::to_bytes,
                DynamicSet::heap_bytes,
            )?;
            (Arc::new(d.interpolate(dir)), cached, store.path(kind, key))
        } else {
            let cp = params.csl_params();
            let key = csl_source_hash(world, &o.name, dir, &cp)?;
            let kind = ArtifactKind::Csl;
            let (set, cached) = store.find_or_bake(
                kind,
                key,
                |b| CslSet::from_bytes(b).ok().filter(|s| s.source_hash == key),
                || bake_csl(world, &o.name, dir, &cp, &|p: Progress| part(p.fraction)),
                CslSet::to_bytes,
                CslSet::heap_bytes,
            )?;
            (set, cached, store.path(kind, key))
        };
        sets.push(ObjectSet {
            object: oi,
            set,
            cached,
            path,
            interpolated,
        });
    }
    Ok(sets)
}

/// The set of a bake given to the render (`--bake FILE`, static or dynamic), for the scene's
/// first caustic object; loading (and interpolating) it are stages of `timings`.
fn given_set(
    world: &World,
    path: &std::path::Path,
    light: Vec3,
    timings: &mut Vec<(String, Duration)>,
) -> Result<ObjectSet, MethodError> {
    let given = |m: String| MethodError::GivenBake(format!("{}: {m}", path.display()));
    let object = *caustic_objects(world)
        .first()
        .ok_or_else(|| given("the scene has no glass or mirror object for it".into()))?;
    let o = &world.objects[object];
    let t = Instant::now();
    let bytes = std::fs::read(path).map_err(|e| given(e.to_string()))?;
    let interpolated = bytes.starts_with(&dynamic::MAGIC);
    let set = if interpolated {
        // A dynamic bake: the set for this light direction, interpolated (§4.1).
        let d = DynamicSet::from_bytes(&bytes).map_err(|e| given(e.to_string()))?;
        if !d.is_for(world, o) {
            return Err(given(format!(
                "a dynamic bake of another object than '{}' (meshes, materials or scale differ)",
                o.name
            )));
        }
        timings.push(("csl load".into(), t.elapsed()));
        let t = Instant::now();
        let set = d.interpolate(o.to_rigid_frame(light));
        timings.push(("csl interpolate".into(), t.elapsed()));
        set
    } else {
        let set = CslSet::from_bytes(&bytes).map_err(|e| given(e.to_string()))?;
        timings.push(("csl load".into(), t.elapsed()));
        set
    };
    Ok(ObjectSet {
        object,
        set: Arc::new(set),
        cached: true,
        path: None,
        interpolated,
    })
}

/// The sentence the CLI prints for a static set baked now.
fn bake_note(name: &str, set: &CslSet) -> String {
    let s = &set.stats;
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    format!(
        "{name}: {} rays traced, {} hit, {} caustic rays, {} CSLs covering {:.1}% of the energy, \
         stopped by {} (trace {:.0} ms, raster {:.0} ms, bundles {:.0} ms, fit {:.0} ms, images \
         {:.0} ms, total {:.0} ms)",
        s.rays_traced,
        s.rays_hit,
        s.caustic_rays,
        set.csls.len(),
        100.0 * s.coverage(),
        s.stopped_by,
        ms(s.time_trace),
        ms(s.time_raster),
        ms(s.time_bundles),
        ms(s.time_fit),
        ms(s.time_image),
        ms(s.time_total),
    )
}

/// Over this self-check error (`methods::check`) a bake's or a render's caustics are poor: it
/// says so and names `photons` (the bar of `auto`, `methods::POOR_CHECK`).
pub const POOR_FIT: f64 = super::POOR_CHECK as f64;

/// `world` lit only by a directional light travelling along `direction` (world frame) with
/// `irradiance`: the light a CSL set models, for its check.
fn lit_only_by(world: &World, direction: Vec3, irradiance: Vec3) -> World {
    let mut w = world.clone();
    w.lights = vec![crate::scene::Light::Directional {
        direction,
        irradiance,
        angular_radius: 0.0,
    }];
    w
}

struct Plan {
    params: BakeParams,
    /// World travel direction and irradiance (W/m²) of the scene's directional light.
    light: (Vec3, Vec3),
    given: Option<PathBuf>,
}

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Csl
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        (env.progress)(0.0, "render");
        let sets = match &self.given {
            Some(path) => vec![given_set(world, path, self.light.0, &mut timings)?],
            None => {
                let t = Instant::now();
                let progress = scaled_progress(env, 0.0, 0.9, "bake");
                let sets =
                    sets_for_render(world, &self.params, self.light.0, env.store, &progress)?;
                timings.push(("bake".into(), t.elapsed()));
                sets
            }
        };
        env.check()?;
        (env.progress)(0.9, "render");
        let placed: Vec<(usize, &CslSet)> = sets.iter().map(|s| (s.object, &*s.set)).collect();
        let layer = CslLayer::new(world, &placed, self.light.1);
        let out = env.render(&mut timings, |r| {
            r.render_csl(world, &RenderOptions::default(), Some(&layer))
        })?;
        // How well the frame fits the reference on this scene's receivers is the render's
        // self-check (`methods::render`), run after the frame.
        let mut notes = Vec::new();
        for s in &sets {
            let name = &world.objects[s.object].name;
            match (&s.path, s.cached) {
                (Some(p), true) => notes.push(format!("{name}: cached bake {}", p.display())),
                (_, false) if s.set.stats.energy_traced > 0.0 => {
                    notes.push(bake_note(name, &s.set))
                }
                _ => {}
            }
        }
        let statistics = serde_json::json!({
            "csls": layer.csls.len(),
            "bakes": sets.iter().map(|s| serde_json::json!({
                "object": world.objects[s.object].name,
                "cached": s.cached,
                // Which set served the frame: `static` (a static render's bake), `exact` (a
                // dynamic render's, baked for exactly this light) or `interpolated` (from the
                // dynamic bake).
                "set": if s.interpolated {
                    "interpolated"
                } else if self.params.dynamic {
                    "exact"
                } else {
                    "static"
                },
                "source_hash": format!("{:016x}", s.set.source_hash),
                "csls": s.set.csls.len(),
                // An interpolated (dynamic) set has no coverage of its own.
                "energy_covered": (s.set.stats.energy_traced > 0.0)
                    .then(|| s.set.stats.coverage()),
            })).collect::<Vec<_>>(),
        });
        let mut frames = Frames::from_output(out, timings);
        frames.statistics = Some(statistics);
        frames.notes.extend(notes);
        Ok(frames)
    }
}

struct Bake {
    world: Arc<World>,
    object: String,
    /// Light travel direction in the object's rigid frame; None for a dynamic bake (it serves
    /// every direction).
    light: Option<Vec3>,
    params: BakeParams,
}

impl BakePlan for Bake {
    fn object(&self) -> &str {
        &self.object
    }

    /// ~384 bytes a ray of the grid (the traced paths, the bundles and the images fitted to
    /// them; measured ~310 on the glass sphere at 1280²) and 64 MiB; a dynamic bake three
    /// times that (its directions' work, the tracking and the sets of all directions: 0.97 GB
    /// at 12 directions, 1.5 GB at the paper's 162 on the sphere).
    fn memory(&self) -> u64 {
        let grid = self.params.grid.unwrap_or(1280) as u64;
        let one = (64 << 20) + grid * grid * 384;
        if self.light.is_some() { one } else { one * 3 }
    }

    fn run(&self, env: &Env) -> Result<Baked, MethodError> {
        match self.light {
            Some(light) => self.run_static(light, env),
            None => self.run_dynamic(env),
        }
    }
}

impl Bake {
    fn run_static(&self, light: Vec3, env: &Env) -> Result<Baked, MethodError> {
        let set = bake_csl(
            &self.world,
            &self.object,
            light,
            &self.params.csl_params(),
            &|p: Progress| {
                (env.progress)(p.fraction, p.stage);
                (env.keep_going)()
            },
        )?;
        let bytes = set.to_bytes();
        // Renders of the same object, light and parameters find it.
        env.store.save(ArtifactKind::Csl, set.source_hash, &bytes);
        let s = &set.stats;
        // The check: the set on this scene's receivers, lit by the scene's light alone,
        // against a short reference of the object's light (`methods::check`).
        let t = Instant::now();
        (env.progress)(0.99, "check");
        let oi = self.index();
        let obj = &self.world.objects[oi];
        let irradiance = scene_directional_light(&self.world).map_or(Vec3::ONE, |l| l.1);
        let lit = lit_only_by(
            &self.world,
            obj.rigid_transform().transform_vector3(light),
            irradiance,
        );
        let check = super::check::check_csl_set(&lit, oi, &set, irradiance, env.keep_going)?;
        let fit = check.map(|c| f64::from(c.error));
        let mut notes = vec![bake_note(&self.object, &set)];
        notes.push(fit_sentence(&self.object, check.as_ref(), "the CSLs"));
        Ok(Baked {
            bytes,
            ext: ArtifactKind::Csl.ext(),
            content_type: "application/octet-stream",
            timings: vec![
                ("trace".into(), s.time_trace),
                ("raster".into(), s.time_raster),
                ("bundles".into(), s.time_bundles),
                ("fit".into(), s.time_fit),
                ("images".into(), s.time_image),
                ("check".into(), t.elapsed()),
            ],
            info: serde_json::json!({
                "object": self.object,
                "light_dir_object_frame": light.to_array(),
                "statistics": {
                    "rays_traced": s.rays_traced,
                    "rays_hit": s.rays_hit,
                    "caustic_rays": s.caustic_rays,
                    "csls": set.csls.len(),
                    "energy_covered": s.coverage(),
                    "stopped_by": s.stopped_by,
                    // The estimated relative L1 of the set's caustics against the reference
                    // on the scene's receivers, and the whole check (`methods::check`).
                    "fit_error": fit,
                    "poor_fit": fit.is_some_and(|e| e > POOR_FIT),
                    "check": check,
                },
            }),
            notes,
        })
    }

    /// Progress per direction, then per edge; the artifact is also kept in the store, where
    /// `csl` renders with the same parameters find it.
    fn run_dynamic(&self, env: &Env) -> Result<Baked, MethodError> {
        let params = self.params.dynamic_params();
        let set = bake_dynamic(&self.world, &self.object, &params, &|p: DynamicProgress| {
            let stage = match p.stage {
                "directions" => format!("directions {}/{}", p.done, p.total),
                "tracking" => format!("tracking edges {}/{}", p.done, p.total),
                s => s.to_string(),
            };
            (env.progress)(p.fraction, &stage);
            (env.keep_going)()
        })?;
        let s = &set.stats;
        let bytes = set.to_bytes();
        env.store
            .save(ArtifactKind::CslDynamic, set.source_hash, &bytes);
        // The check where interpolation does the most: the light at the centres of three
        // faces, between three bake directions, each interpolated set on this scene's
        // receivers against a short reference (`methods::check`); the worst is reported.
        let t = Instant::now();
        (env.progress)(0.99, "check");
        let oi = self.index();
        let rigid = self.world.objects[oi].rigid_transform();
        let irradiance = scene_directional_light(&self.world).map_or(Vec3::ONE, |l| l.1);
        let mut worst: Option<super::check::Check> = None;
        {
            let ico = set.icosphere();
            let n = ico.faces.len();
            for fi in [0, n / 3, 2 * n / 3] {
                env.check()?;
                let d = ico.faces[fi]
                    .iter()
                    .map(|&v| ico.vertices[v as usize])
                    .sum::<glam::Vec3>()
                    .normalize();
                let lit = lit_only_by(&self.world, rigid.transform_vector3(d), irradiance);
                let c = super::check::check_csl_set(
                    &lit,
                    oi,
                    &set.interpolate(d),
                    irradiance,
                    env.keep_going,
                )?;
                if let Some(c) = c
                    && worst.is_none_or(|w| c.error > w.error)
                {
                    worst = Some(c);
                }
            }
        }
        let fit = worst.map(|c| f64::from(c.error));
        let time_verify = t.elapsed();
        let note = format!(
            "{}: {} directions, {} CSLs ({:.1} per direction), {} edges: {} pairs matched, {} \
             black partners; {} triples ({:.2} per face, {} matched on all three edges); {} \
             tracking rays; bakes {:.1} s, tracking {:.1} s, total {:.1} s; {:.1} MB",
            self.object,
            s.directions,
            s.csls,
            s.csls as f64 / s.directions.max(1) as f64,
            s.edges,
            s.matched,
            s.blacks,
            s.triples,
            s.triples as f64 / set.triples.len().max(1) as f64,
            s.consistent_triples,
            s.tracking_rays,
            s.time_bakes.as_secs_f64(),
            s.time_tracking.as_secs_f64(),
            s.time_total.as_secs_f64(),
            bytes.len() as f64 / 1e6,
        );
        Ok(Baked {
            info: serde_json::json!({
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
                    // The worst estimated relative L1 of interpolated sets against the
                    // reference on the scene's receivers, the light at the centres of three
                    // faces (`methods::check`), and that check.
                    "fit_error": fit,
                    "poor_fit": fit.is_some_and(|e| e > POOR_FIT),
                    "check": worst,
                },
            }),
            timings: vec![
                ("bakes".into(), s.time_bakes),
                ("tracking".into(), s.time_tracking),
                ("triples".into(), s.time_triples),
                ("check".into(), time_verify),
            ],
            bytes,
            ext: ArtifactKind::CslDynamic.ext(),
            content_type: "application/octet-stream",
            notes: vec![
                note,
                fit_sentence(
                    &self.object,
                    worst.as_ref(),
                    "sets interpolated between bake directions",
                ),
            ],
        })
    }

    /// The baked object's index.
    fn index(&self) -> usize {
        self.world
            .object_index(&self.object)
            .expect("the plan found the object")
    }
}

/// What a bake's check says of `what` (`the CSLs`…) of `object`.
fn fit_sentence(object: &str, c: Option<&super::check::Check>, what: &str) -> String {
    match c {
        Some(c) => format!(
            "{object}: {what} are an estimated {:.2} relative L1 from the reference on the \
             scene's receivers (flux {:.2}){}",
            c.error,
            c.flux,
            if f64::from(c.error) > POOR_FIT {
                ": poorly (render it with method photons)"
            } else {
                ""
            }
        ),
        None => format!(
            "{object}: no caustic light on the receivers the camera sees to check {what} against"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bake_params_fill_defaults_and_name_fields() {
        let p = BakeParams::parse(&serde_json::json!({}), "params").unwrap();
        assert_eq!(p.grid, Some(CslParams::paper().grid));
        assert_eq!(p.subdivisions, None);
        let p = BakeParams::parse(&serde_json::json!({"dynamic": true}), "csl").unwrap();
        assert_eq!(p.dynamic_params(), {
            let mut d = DynamicParams::paper();
            d.csl = p.csl_params();
            d
        });
        // The canonical form of a default bake (bake ids are computed from it).
        assert_eq!(
            serde_json::to_value(BakeParams::parse(&serde_json::json!({}), "params").unwrap())
                .unwrap(),
            serde_json::json!({"preset": "paper", "grid": 1280})
        );
        let e = BakeParams::parse(&serde_json::json!({"grid": 8}), "csl").unwrap_err();
        assert_eq!(e.to_string(), "csl.grid: must lie in 16..=4096");
        let e = BakeParams::parse(&serde_json::json!({"steps": 3}), "params").unwrap_err();
        assert_eq!(e.field, "params.steps");
        let e = BakeParams::parse(&serde_json::json!({"preset": "x"}), "params").unwrap_err();
        assert_eq!(e.field, "params.preset");
        let e = BakeParams::parse(
            &serde_json::json!({"dynamic": true, "match_threshold": 0}),
            "params",
        )
        .unwrap_err();
        assert_eq!(e.field, "params.match_threshold");
    }
}
