//! The CSL sets a render needs, baked once and kept by content hash. A `csl` render of a scene
//! needs, for every caustic object (one with a glass or mirror part), the static CSL set of the
//! scene's directional light expressed in that object's rigid frame. [`sets_for_render`] looks
//! each up in a [`CslStore`] by [`super::csl_source_hash`] and bakes only what is missing, so a
//! moving receiver, a moving camera or the object moving rigidly with the light reuse the bake.
//! The CLI keeps its store in a folder ([`DirStore`]); the service in its data directory.
//! [`dynamic_sets_for_render`] does the same with dynamic bakes, which serve every light
//! direction: the set of the scene's light is interpolated from the kept bake.

use super::dynamic::{
    DynamicParams, DynamicProgress, DynamicSet, bake_dynamic, dynamic_source_hash,
};
use super::{CslParams, CslSet, bake_csl, csl_source_hash, scene_directional_light};
use crate::bake::{BakeError, Progress};
use crate::scene::World;
use glam::Vec3;
use std::path::PathBuf;

/// Where baked sets are kept between renders.
pub trait CslStore: Sync {
    /// The set whose source hash is `key`, if kept (and intact).
    fn load(&self, key: u64) -> Option<CslSet>;
    /// Keeps `set` under its source hash. Failing to keep it is not an error of the render.
    fn save(&self, set: &CslSet);
}

/// A store that keeps nothing: every render bakes.
pub struct NoStore;

impl CslStore for NoStore {
    fn load(&self, _: u64) -> Option<CslSet> {
        None
    }
    fn save(&self, _: &CslSet) {}
}

/// A folder of `csl-{hash:016x}.bin` artifacts, written atomically (temporary file, rename).
pub struct DirStore(pub PathBuf);

impl DirStore {
    pub fn path(&self, key: u64) -> PathBuf {
        self.0.join(format!("csl-{key:016x}.bin"))
    }
}

impl CslStore for DirStore {
    fn load(&self, key: u64) -> Option<CslSet> {
        let bytes = std::fs::read(self.path(key)).ok()?;
        CslSet::from_bytes(&bytes)
            .ok()
            .filter(|s| s.source_hash == key)
    }

    fn save(&self, set: &CslSet) {
        self.write(&self.path(set.source_hash), &set.to_bytes());
    }
}

impl DirStore {
    /// Where a dynamic bake (Liu et al. 2008 §4) of source hash `key` is kept.
    pub fn dynamic_path(&self, key: u64) -> PathBuf {
        self.0.join(format!("csl-dynamic-{key:016x}.bin"))
    }

    pub fn load_dynamic(&self, key: u64) -> Option<DynamicSet> {
        let bytes = std::fs::read(self.dynamic_path(key)).ok()?;
        DynamicSet::from_bytes(&bytes)
            .ok()
            .filter(|s| s.source_hash == key)
    }

    /// Keep `bytes`, the artifact of a dynamic bake whose source hash is `key`.
    pub fn save_dynamic(&self, key: u64, bytes: &[u8]) {
        self.write(&self.dynamic_path(key), bytes);
    }

    /// Atomic write: a temporary file, then a rename; failures are logged, not fatal (the
    /// caller has the bake in hand).
    fn write(&self, path: &std::path::Path, bytes: &[u8]) {
        // Unique per process and call: two renders saving the same set never share a file.
        static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = path.with_extension(format!("tmp{}-{n}", std::process::id()));
        let r = std::fs::create_dir_all(&self.0)
            .and_then(|_| std::fs::write(&tmp, bytes))
            .and_then(|_| std::fs::rename(&tmp, path));
        if let Err(e) = r {
            let _ = std::fs::remove_file(&tmp);
            tracing::warn!("could not keep the CSL bake in {}: {e}", path.display());
        }
    }
}

/// One caustic object's set, as a render uses it.
#[derive(Clone, Debug)]
pub struct ObjectSet {
    /// Index into `World::objects`.
    pub object: usize,
    pub set: CslSet,
    /// Whether it came from the store (false: baked now).
    pub cached: bool,
}

/// The sets of a render and the light they carry.
#[derive(Clone, Debug)]
pub struct RenderSets {
    pub sets: Vec<ObjectSet>,
    /// World travel direction and irradiance (W/m²) of the scene's directional light.
    pub light: (Vec3, Vec3),
}

/// Indices of the objects with a glass or mirror part: the caustic objects.
pub fn caustic_objects(world: &World) -> Vec<usize> {
    world
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| {
            o.parts
                .iter()
                .any(|p| world.materials[p.material as usize].is_specular())
        })
        .map(|(i, _)| i)
        .collect()
}

/// Why a CSL render cannot be prepared.
#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    #[error("CSLs need a directional light; the scene has none")]
    NoDirectionalLight,
    #[error(transparent)]
    Bake(#[from] BakeError),
}

/// For every caustic object of `world`, its CSL set for the scene's first directional light:
/// from `store` when kept, else baked (with `params`) and saved. `progress(object name, p)` sees
/// each bake's progress; returning false cancels. A scene without caustic objects gives no set.
pub fn sets_for_render(
    world: &World,
    params: &CslParams,
    store: &dyn CslStore,
    progress: &(dyn Fn(&str, Progress) -> bool + Sync),
) -> Result<RenderSets, PrepareError> {
    let light = scene_directional_light(world).ok_or(PrepareError::NoDirectionalLight)?;
    let mut sets = Vec::new();
    for oi in caustic_objects(world) {
        let o = &world.objects[oi];
        let dir = CslSet::light_in_object_frame(o, light.0);
        let key = csl_source_hash(world, &o.name, dir, params)?;
        if let Some(set) = store.load(key) {
            sets.push(ObjectSet {
                object: oi,
                set,
                cached: true,
            });
            continue;
        }
        let set = bake_csl(world, &o.name, dir, params, &|p| progress(&o.name, p))?;
        store.save(&set);
        sets.push(ObjectSet {
            object: oi,
            set,
            cached: false,
        });
    }
    Ok(RenderSets { sets, light })
}

/// As [`sets_for_render`] from dynamic bakes (Liu et al. 2008 §4): for every caustic object its dynamic
/// set from `store` when kept, else baked (with `params`) and saved, then the set for the
/// scene's directional light interpolated from it. `progress(object name, p)` sees each bake's
/// progress; returning false cancels.
pub fn dynamic_sets_for_render(
    world: &World,
    params: &DynamicParams,
    store: &DirStore,
    progress: &(dyn Fn(&str, DynamicProgress) -> bool + Sync),
) -> Result<RenderSets, PrepareError> {
    let light = scene_directional_light(world).ok_or(PrepareError::NoDirectionalLight)?;
    let mut sets = Vec::new();
    for oi in caustic_objects(world) {
        let o = &world.objects[oi];
        let key = dynamic_source_hash(world, &o.name, params)
            .ok_or_else(|| BakeError::UnknownObject(o.name.clone()))?;
        let (dynset, cached) = match store.load_dynamic(key) {
            Some(d) => (d, true),
            None => {
                let d = bake_dynamic(world, &o.name, params, &|p| progress(&o.name, p))?;
                store.save_dynamic(d.source_hash, &d.to_bytes());
                (d, false)
            }
        };
        sets.push(ObjectSet {
            object: oi,
            set: dynset.interpolate(CslSet::light_in_object_frame(o, light.0)),
            cached,
        });
    }
    Ok(RenderSets { sets, light })
}
