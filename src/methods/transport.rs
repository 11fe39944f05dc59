//! Method `transport`: light transport tables (Iwasaki et al. 2005). The bake records, per
//! vertex of a glass object and per sampling direction of its hemisphere, where light entering
//! there leaves the glass ([`crate::bake::transport`]); no light is needed, so one table serves
//! every light and every light position. Per frame the tables are interpolated for each
//! directional, point, spot and line light, lit triangles sweep illumination volumes
//! ([`crate::render::transport`]) and the GPU draws them over a G-buffer of the receivers.
//!
//! Tables are found or baked through the [`super::ArtifactStore`] by content hash, so the object may
//! move or turn between frames.

use super::{
    ArtifactKind, BakePlan, BakeRequest, Baked, Env, Frames, Json, Lane, Method, MethodArgs,
    MethodError, MethodImpl, MethodInfo, ParamError, RenderPlan, bake_object, canonical,
    from_value, scaled_progress,
};
use crate::bake::Progress;
use crate::bake::transport::{
    TransportParams, TransportTable, bake_transport, check_table_size, refractive_objects,
    source_hash, table_vertices,
};
use crate::render::transport::volumes::{DEFAULT_LINE_POINTS, EvalError};
use crate::render::{RenderOptions, TransportLayer};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Transport,
    name: "transport",
    lane: Lane::Cpu,
    gpu: true,
    bake: true,
    args: &["bake", "line_points"],
    // Its renders check themselves against a short reference (`methods::check`).
    check: true,
};

pub struct Transport;

impl MethodImpl for Transport {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        if refractive_objects(world).is_empty() {
            return Err(ParamError::new(
                "scene.objects",
                "method transport needs a glass (dielectric) object; the scene has none",
            ));
        }
        Ok(Box::new(Plan {
            line_points: args.line_points.unwrap_or(DEFAULT_LINE_POINTS),
            given: args.bake.clone(),
        }))
    }

    fn bake_params(&self, v: &Json, at: &str) -> Result<Json, ParamError> {
        Ok(canonical(BakeParams::parse(v, at)?))
    }

    fn plan_bake(&self, req: BakeRequest) -> Result<Box<dyn BakePlan>, MethodError> {
        let params = BakeParams::parse(req.params, "params")?;
        let (world, object) = (req.world, req.object);
        let glass = refractive_objects(&world);
        let oi = bake_object(&world, object, &glass, "glass object")?;
        let object = world.objects[oi].name.clone();
        if !glass.contains(&oi) {
            return Err(ParamError::new(
                "object",
                format!(
                    "'{object}' has no glass (dielectric) part; a transport table is for \
                     refractive objects"
                ),
            )
            .into());
        }
        let vertices = table_vertices(&world, &world.objects[oi]).len();
        check_table_size(vertices, &params.params())
            .map_err(|e| ParamError::new("params", e.to_string()))?;
        Ok(Box::new(Bake {
            world,
            object,
            params,
        }))
    }
}

/// Parameters of a transport bake; defaults filled in before the bake id is computed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "TransportParams")]
pub struct BakeParams {
    /// Rings of sampling directions between the pole and the horizon, 1..=64 (default 12).
    #[serde(default)]
    #[schemars(range(min = 1, max = 64), extend("default" = 12))]
    pub rings: Option<u32>,
    /// Directions per ring, 4..=256 (default 24: 289 directions; 8 rings of 16 are the paper's
    /// 129).
    #[serde(default)]
    #[schemars(range(min = 4, max = 256), extend("default" = 24))]
    pub azimuths: Option<u32>,
}

impl BakeParams {
    /// Parses and checks `v`, found at field `at` of a request, filling the defaults.
    pub fn parse(v: &serde_json::Value, at: &str) -> Result<Self, ParamError> {
        let mut p: BakeParams = from_value(v, at)?;
        let d = TransportParams::standard();
        p.rings = Some(p.rings.unwrap_or(d.rings));
        p.azimuths = Some(p.azimuths.unwrap_or(d.azimuths));
        p.params()
            .validate()
            .map_err(|e| ParamError::new(at, e.to_string()))?;
        Ok(p)
    }

    pub fn params(&self) -> TransportParams {
        let d = TransportParams::standard();
        TransportParams {
            rings: self.rings.unwrap_or(d.rings),
            azimuths: self.azimuths.unwrap_or(d.azimuths),
            ..d
        }
    }
}

/// A glass object's table as a render uses it.
pub struct ObjectTable {
    /// Index into `World::objects`.
    pub object: usize,
    /// Shared with the store's decoded artifacts.
    pub table: Arc<TransportTable>,
    /// Whether it came from the store or was given (false: baked now).
    pub cached: bool,
}

/// The table of every glass object of `world` for a render: `given` (a table made beforehand)
/// for the glass object whose content hash it carries, every other one found in the store or
/// baked at [`TransportParams::standard`] and kept. `progress(f)` sees the bakes' progress in 0..1;
/// returning false cancels.
pub fn tables_for_render(
    world: &World,
    given: Option<TransportTable>,
    env: &Env,
    progress: &(dyn Fn(f32) -> bool + Sync),
) -> Result<Vec<ObjectTable>, MethodError> {
    let objects = refractive_objects(world);
    // The given table serves the glass object whose content hash it carries.
    let mut given = match given {
        Some(t) => {
            let fits =
                |&&i: &&usize| source_hash(world, &world.objects[i], &t.params) == t.source_hash;
            let oi = *objects.iter().find(fits).ok_or_else(|| {
                MethodError::GivenBake(
                    "the table fits no glass object of this scene (baked for another mesh, \
                     material or scale)"
                        .into(),
                )
            })?;
            Some((oi, t))
        }
        None => None,
    };
    let n = objects.len().max(1) as f32;
    let mut out = Vec::new();
    for (k, &oi) in objects.iter().enumerate() {
        if let Some((_, table)) = given.take_if(|g| g.0 == oi) {
            out.push(ObjectTable {
                object: oi,
                table: Arc::new(table),
                cached: true,
            });
            continue;
        }
        let object = &world.objects[oi];
        // The standard table where it fits the table's sample cap, else the paper's coarser
        // one (a mesh of 110k to 248k vertices), so that a render does not refuse what it
        // rendered at 129 directions.
        let vertices: usize = object
            .parts
            .iter()
            .filter(|p| {
                matches!(
                    world.materials[p.material as usize],
                    crate::scene::Material::Dielectric { .. }
                )
            })
            .map(|p| p.mesh.positions.len())
            .sum();
        let params = [TransportParams::standard(), TransportParams::paper()]
            .into_iter()
            .find(|p| crate::bake::transport::check_table_size(vertices, p).is_ok())
            .unwrap_or(TransportParams::standard());
        let key = source_hash(world, object, &params);
        let (table, cached) = env.store.find_or_bake(
            ArtifactKind::Transport,
            key,
            |b| {
                TransportTable::from_bytes(b)
                    .ok()
                    .filter(|t| t.source_hash == key)
            },
            || {
                bake_transport(world, &object.name, &params, &|p: Progress| {
                    progress((k as f32 + p.fraction) / n)
                })
            },
            TransportTable::to_bytes,
            TransportTable::heap_bytes,
        )?;
        out.push(ObjectTable {
            object: oi,
            table,
            cached,
        });
    }
    Ok(out)
}

impl From<EvalError> for MethodError {
    fn from(e: EvalError) -> Self {
        match e {
            EvalError::Canceled => MethodError::Canceled,
            EvalError::UnknownObject(o) => MethodError::UnknownObject(o),
            EvalError::Mismatch { .. } => MethodError::GivenBake(e.to_string()),
            EvalError::TooManyVolumes { .. } => {
                ParamError::new("scene.lights", e.to_string()).into()
            }
        }
    }
}

struct Plan {
    line_points: u32,
    given: Option<PathBuf>,
}

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Transport
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut timings = Vec::new();
        (env.progress)(0.0, "render");
        // An adapter that cannot draw the volumes fails the render before any bake.
        if let Some(why) = env.with_renderer(|r| Ok(r.transport_unsupported()))? {
            return Err(MethodError::NoGpu(why));
        }
        let given = match &self.given {
            Some(path) => {
                let given = |m: String| MethodError::GivenBake(format!("{}: {m}", path.display()));
                let bytes = std::fs::read(path).map_err(|e| given(e.to_string()))?;
                Some(TransportTable::from_bytes(&bytes).map_err(|e| given(e.to_string()))?)
            }
            None => None,
        };
        let t = Instant::now();
        let progress = scaled_progress(env, 0.0, 0.8, "bake");
        let tables = tables_for_render(world, given, env, &progress).map_err(|e| {
            match (e, &self.given) {
                (MethodError::GivenBake(m), Some(p)) => {
                    MethodError::GivenBake(format!("{}: {m}", p.display()))
                }
                (e, _) => e,
            }
        })?;
        timings.push(("bake".into(), t.elapsed()));
        env.check()?;
        (env.progress)(0.8, "volumes");
        let t = Instant::now();
        let refs: Vec<(usize, &TransportTable)> =
            tables.iter().map(|t| (t.object, &*t.table)).collect();
        let layer = TransportLayer::build_with(world, &refs, self.line_points, env.keep_going)?;
        timings.push(("volumes".into(), t.elapsed()));
        (env.progress)(0.9, "render");
        let out = env.render(&mut timings, |r| {
            r.render_transport(world, &RenderOptions::default(), &layer)
        })?;
        let s = &layer.stats;
        let statistics = serde_json::json!({
            "volumes": s.volumes,
            "lit_vertices": s.lit_vertices,
            "flux_leaving_w": s.flux.to_array(),
            "reflection_volumes": s.reflection_volumes,
            "flux_reflected_w": s.reflected_flux.to_array(),
            "bakes": tables.iter().map(|t| serde_json::json!({
                "object": world.objects[t.object].name,
                "cached": t.cached,
                "source_hash": format!("{:016x}", t.table.source_hash),
                "vertices": t.table.vertex_count,
                "directions": t.table.params.directions(),
                // The share of the light left out where its paths split, from the table's
                // check against fresh photons (`bake::transport::verify`), stored with it.
                "split_loss": t.table.fit.map(|f| f.split_loss),
            })).collect::<Vec<_>>(),
            "flux_split_w": s.split_flux.to_array(),
        });
        let mut frames = Frames::from_output(out, timings);
        frames.statistics = Some(statistics);
        // How well the frame fits the reference on this scene's receivers is the render's
        // self-check (`methods::render`), run after the frame.
        frames.notes.push(format!(
            "{} illumination volumes ({} of reflected light) from {} lit vertices, {:.3} W \
             leaving the glass, {:.3} W reflected",
            s.volumes,
            s.reflection_volumes,
            s.lit_vertices,
            s.flux.element_sum() / 3.0,
            s.reflected_flux.element_sum() / 3.0
        ));
        Ok(frames)
    }
}

/// Over this self-check error (`methods::check`) a bake's or a render's caustics are poor: it
/// says so and names `photons` (the bar of `auto`, `methods::POOR_CHECK`).
pub const POOR_FIT: f32 = super::POOR_CHECK;

/// What a bake's check says of the table of `object`.
fn fit_note(object: &str, c: Option<&super::check::Check>, split_loss: Option<f32>) -> String {
    let split = split_loss.map_or(String::new(), |l| {
        format!(
            " ({:.0} % of the light left out where its paths split)",
            100.0 * l
        )
    });
    match c {
        Some(c) => format!(
            "{object}: the transport table's caustics are an estimated {:.2} relative L1 from \
             the reference on the scene's receivers (flux {:.2}){split}{}",
            c.error,
            c.flux,
            if c.error > POOR_FIT {
                ": a poor fit, render it with method photons"
            } else {
                ""
            }
        ),
        None => format!(
            "{object}: no caustic light on the receivers the camera sees to check the transport \
             table against{split}"
        ),
    }
}

struct Bake {
    world: Arc<World>,
    object: String,
    params: BakeParams,
}

impl BakePlan for Bake {
    fn object(&self) -> &str {
        &self.object
    }

    /// ~96 bytes a sample (direction × vertex: the traced samples, the table and its fit
    /// check; measured 75 on the 33k-vertex sphere at 129 directions) and 64 MiB.
    fn memory(&self) -> u64 {
        let vertices: usize = self
            .world
            .object(&self.object)
            .map_or(0, |o| o.parts.iter().map(|p| p.mesh.positions.len()).sum());
        let samples = (self.params.params().directions() * vertices) as u64;
        (64 << 20) + samples * 96
    }

    fn run(&self, env: &Env) -> Result<Baked, MethodError> {
        let params = self.params.params();
        let table = bake_transport(&self.world, &self.object, &params, &|p: Progress| {
            (env.progress)(p.fraction, p.stage);
            (env.keep_going)()
        })?;
        let bytes = table.to_bytes();
        // Renders find it when it was baked at their settings.
        env.store
            .save(ArtifactKind::Transport, table.source_hash, &bytes);
        let (s, e) = (&table.stats, &table.errors);
        let mut notes = vec![
            format!(
                "{}: {} vertices × {} directions = {} samples ({} self-occluded, {} trapped), \
                 {} rays, trace {:.0} ms, total {:.0} ms",
                self.object,
                s.vertices,
                params.directions(),
                s.samples,
                s.occluded,
                s.trapped,
                s.rays,
                s.time_trace.as_secs_f64() * 1e3,
                s.time_total.as_secs_f64() * 1e3,
            ),
            format!(
                "size {:.2} MB ({} bytes a sample; {:.2} MB unquantised, {:.0} %); largest \
                 quantisation errors: position {:.4} % of the box diagonal, direction {:.4} %, \
                 transmittance {:.1e}",
                bytes.len() as f64 / 1e6,
                table.bytes_per_sample(),
                table.uncompressed_bytes() as f64 / 1e6,
                100.0 * bytes.len() as f64 / table.uncompressed_bytes() as f64,
                100.0 * e.position,
                100.0 * e.direction,
                e.transmittance,
            ),
        ];
        // The check: the table's caustics for this scene's lights on its receivers against a
        // short reference of the object's light (`methods::check`).
        let t = std::time::Instant::now();
        (env.progress)(0.99, "check");
        let oi = self
            .world
            .object_index(&self.object)
            .expect("the plan found the object");
        let check = super::check::check_transport_table(&self.world, oi, &table, env.keep_going)?;
        let time_check = t.elapsed();
        let split_loss = table.fit.map(|f| f.split_loss);
        notes.push(fit_note(&self.object, check.as_ref(), split_loss));
        let fit = check.map(|c| c.error);
        let info = serde_json::json!({
            "object": self.object,
            "source_hash": format!("{:016x}", table.source_hash),
            "statistics": {
                // The estimated relative L1 of the table's caustics against the reference on
                // the scene's receivers, and the whole check (`methods::check`).
                "fit_error": fit,
                "poor_fit": fit.is_some_and(|e| e > POOR_FIT),
                "check": check,
                // The share of the light left out where paths split (`bake::transport::verify`).
                "split_loss": split_loss,
                "vertices": s.vertices,
                "directions": table.params.directions(),
                "samples": s.samples,
                "self_occluded": s.occluded,
                "trapped": s.trapped,
                "rays": s.rays,
                "bytes": bytes.len(),
                "bytes_per_sample": table.bytes_per_sample(),
                "uncompressed_bytes": table.uncompressed_bytes(),
                "max_error_position": e.position,
                "max_error_direction": e.direction,
                "max_error_transmittance": e.transmittance,
            },
        });
        Ok(Baked {
            bytes,
            ext: ArtifactKind::Transport.ext(),
            content_type: "application/octet-stream",
            timings: vec![
                ("trace".into(), s.time_trace),
                ("quantise".into(), s.time_quantise),
                ("verify".into(), s.time_verify),
                ("check".into(), time_check),
            ],
            info,
            notes,
        })
    }
}
