//! The `transport` bake: the light transport table of one glass object (Iwasaki et al. 2005 §4, §6), the
//! same checksummed bytes as `caustica bake transport`. Deterministic, so re-running it after
//! a restart is safe. Renders with method `transport` bake what they need themselves (cached by
//! content hash under the data directory, [`table_for_render`]).

use super::{Artifact, Job, JobCtx, JobError, Lane};
use crate::bake::transport::{TransportParams, TransportTable, bake_transport, source_hash};
use crate::bake::{BakeError, Progress};
use crate::scene::World;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

/// Parameters of a transport bake; defaults filled in before the bake id is computed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TransportBakeParams {
    /// Rings of sampling directions between the pole and the horizon, 1..=64 (default 8).
    #[serde(default)]
    pub rings: Option<u32>,
    /// Directions per ring, 4..=256 (default 16; with 8 rings the paper's 129 directions).
    #[serde(default)]
    pub azimuths: Option<u32>,
}

impl TransportBakeParams {
    /// Parses and checks `v` (field paths in errors), filling the defaults.
    pub fn from_value(v: &serde_json::Value) -> Result<Self, JobError> {
        let mut p: TransportBakeParams = serde_path_to_error::deserialize(v).map_err(|e| {
            let path = match e.path().to_string() {
                p if p == "." => "params".to_string(),
                p => format!("params.{p}"),
            };
            JobError::Params(format!("{path}: {}", e.into_inner()))
        })?;
        let d = TransportParams::paper();
        p.rings = Some(p.rings.unwrap_or(d.rings));
        p.azimuths = Some(p.azimuths.unwrap_or(d.azimuths));
        p.params()
            .validate()
            .map_err(|e| JobError::Params(format!("params: {e}")))?;
        Ok(p)
    }

    pub fn params(&self) -> TransportParams {
        let d = TransportParams::paper();
        TransportParams {
            rings: self.rings.unwrap_or(d.rings),
            azimuths: self.azimuths.unwrap_or(d.azimuths),
            ..d
        }
    }
}

pub struct TransportBake {
    world: Arc<World>,
    object: String,
    params: TransportBakeParams,
}

impl TransportBake {
    pub fn new(
        world: Arc<World>,
        object: Option<&str>,
        params: &serde_json::Value,
    ) -> Result<Self, JobError> {
        let params = TransportBakeParams::from_value(params)?;
        let object = object.ok_or_else(|| JobError::Params("object: required".into()))?;
        let oi = world
            .objects
            .iter()
            .position(|o| o.name == object)
            .ok_or_else(|| JobError::UnknownObject(object.into()))?;
        if !crate::bake::transport::refractive_objects(&world).contains(&oi) {
            return Err(JobError::Params(format!(
                "object: '{object}' has no glass (dielectric) part; a transport table is for \
                 refractive objects"
            )));
        }
        let vertices = crate::bake::transport::table_vertices(&world, &world.objects[oi]).len();
        crate::bake::transport::check_table_size(vertices, &params.params())
            .map_err(|e| JobError::Params(format!("params: {e}")))?;
        Ok(TransportBake {
            world,
            object: object.into(),
            params,
        })
    }
}

impl Job for TransportBake {
    fn kind(&self) -> &'static str {
        "bake"
    }
    fn method(&self) -> &'static str {
        "transport"
    }
    fn lane(&self) -> Lane {
        Lane::Cpu
    }

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        let table = bake_transport(
            &self.world,
            &self.object,
            &self.params.params(),
            &|p: Progress| {
                ctx.progress(p.fraction, p.stage);
                ctx.keep_going()
            },
        )
        .map_err(|e| ctx.bake_error(e))?;
        let bytes = table.to_bytes();
        let (s, e) = (&table.stats, &table.errors);
        let info = serde_json::json!({
            "object": self.object,
            "source_hash": format!("{:016x}", table.source_hash),
            "statistics": {
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
        Ok(Artifact {
            content_type: "application/octet-stream",
            ext: "ltt",
            bytes,
            timings: vec![
                ("trace".into(), s.time_trace),
                ("quantise".into(), s.time_quantise),
            ],
            info,
        })
    }
}

/// The table of object `oi` for a render: read from `cache_dir` by content hash, or baked
/// (paper settings) and stored there. Returns the table and whether it came from the cache. A
/// damaged cache file is baked over.
pub fn table_for_render(
    world: &World,
    oi: usize,
    cache_dir: &Path,
    progress: &(dyn Fn(Progress) -> bool + Sync),
) -> Result<(TransportTable, bool), BakeError> {
    let params = TransportParams::paper();
    let object = &world.objects[oi];
    let hash = source_hash(world, object, &params);
    let path = cache_dir.join(format!("{hash:016x}.ltt"));
    if let Ok(bytes) = std::fs::read(&path)
        && let Ok(t) = TransportTable::from_bytes(&bytes)
        && t.source_hash == hash
    {
        return Ok((t, true));
    }
    let table = bake_transport(world, &object.name, &params, progress)?;
    // Best effort: a cache that cannot be written costs a bake next time, nothing else.
    let _ = std::fs::create_dir_all(cache_dir);
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    if std::fs::write(&tmp, table.to_bytes()).is_ok() {
        let _ = std::fs::rename(&tmp, &path);
    }
    Ok((table, false))
}
