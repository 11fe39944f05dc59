//! Content-addressed scenes: uploads are validated (resolved once), canonicalised, hashed and
//! stored; jobs get the resolved [`World`] from a small in-memory cache.
//!
//! The id is the SHA-256 of the canonical scene JSON (the parsed scene written back by serde,
//! so whitespace and key order do not matter) followed by the name and SHA-256 of every file
//! uploaded with it: the same upload always gets the same id.

use super::JobError;
use super::store::Store;
use crate::scene::gltf::import_gltf;
use crate::scene::types::{CameraDesc, LightDesc, ObjectDesc, Rgb, SceneDesc, ShapeDesc};
use crate::scene::{Limits, MapSource, SceneError, World, parse_scene, resolve};
use serde::Serialize;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Arc, Mutex};

/// Resolved worlds kept in memory, at most (besides [`Scenes::new`]'s byte budget).
const CACHE_SIZE: usize = 32;

/// Resolved worlds by scene id, least recently used first out, bounded by count and by bytes
/// ([`World::heap_bytes`]); a world larger than the whole budget is not kept.
struct Cache {
    worlds: HashMap<String, (Arc<World>, u64, u64)>,
    bytes: u64,
    budget: u64,
    clock: u64,
}

impl Cache {
    fn get(&mut self, id: &str) -> Option<Arc<World>> {
        self.clock += 1;
        let e = self.worlds.get_mut(id)?;
        e.2 = self.clock;
        Some(e.0.clone())
    }

    fn insert(&mut self, id: &str, world: Arc<World>) {
        self.remove(id);
        let size = world.heap_bytes();
        if size > self.budget {
            return;
        }
        while self.worlds.len() >= CACHE_SIZE || self.bytes + size > self.budget {
            let Some(oldest) = self
                .worlds
                .iter()
                .min_by_key(|(_, e)| e.2)
                .map(|(k, _)| k.clone())
            else {
                break;
            };
            self.remove(&oldest);
        }
        self.clock += 1;
        self.bytes += size;
        self.worlds
            .insert(id.to_string(), (world, size, self.clock));
    }

    fn remove(&mut self, id: &str) {
        if let Some((_, size, _)) = self.worlds.remove(id) {
            self.bytes -= size;
        }
    }
}

/// A scene as uploaded.
pub enum SceneInput {
    /// Our scene JSON, with the files it names (multipart uploads).
    Json {
        scene: Vec<u8>,
        files: Vec<(String, Vec<u8>)>,
    },
    /// A glTF file (GLB or JSON with embedded data) as a whole scene.
    Gltf { bytes: Vec<u8>, binary: bool },
}

impl SceneInput {
    /// Bytes given: about what storing it takes.
    pub fn bytes(&self) -> u64 {
        match self {
            SceneInput::Json { scene, files } => {
                (scene.len() + files.iter().map(|(_, b)| b.len()).sum::<usize>()) as u64
            }
            SceneInput::Gltf { bytes, .. } => bytes.len() as u64,
        }
    }
}

/// What a client learns about a stored scene.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct SceneInfo {
    /// SHA-256 of the canonical scene and its files.
    pub id: String,
    pub name: String,
    pub objects: Vec<ObjectInfo>,
    pub lights: Vec<&'static str>,
    pub triangles: usize,
    /// What the upload left out or assumed (a glTF without a camera, say).
    pub warnings: Vec<String>,
    /// The files the scene names (multipart uploads).
    pub files: Vec<String>,
    /// Each method: whether it renders this scene, and why or why not.
    pub methods: Vec<crate::methods::MethodFit>,
    /// The canonical scene description.
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub scene: serde_json::Value,
}

#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct ObjectInfo {
    pub name: String,
    pub triangles: usize,
    /// Whether it carries caustics (glass or mirror parts): what bakes are for.
    pub specular: bool,
}

pub struct Scenes {
    store: Arc<Store>,
    limits: Limits,
    cache: Mutex<Cache>,
}

/// Lowercase hex of bytes (a digest).
pub(crate) fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Hex SHA-256 of bytes.
pub fn sha256_hex(b: &[u8]) -> String {
    hex(&Sha256::digest(b))
}

/// The id a scene JSON upload with `files` gets (that of its canonical form).
pub fn json_scene_id(scene: &[u8], files: &[(String, Vec<u8>)]) -> Result<String, SceneError> {
    let desc = parse_scene(scene)?;
    let canonical = serde_json::to_vec(&desc).expect("scene serialises");
    Ok(scene_id(&canonical, files))
}

/// The content id of a canonical scene and its files.
pub fn scene_id(canonical: &[u8], files: &[(String, Vec<u8>)]) -> String {
    let mut h = Sha256::new();
    h.update(b"caustica-scene-v1\n");
    h.update(canonical);
    let mut sorted: Vec<_> = files.iter().collect();
    sorted.sort_by(|a, b| a.0.cmp(&b.0));
    for (name, bytes) in sorted {
        h.update(b"\n");
        h.update(name.as_bytes());
        h.update(b"\0");
        h.update(Sha256::digest(bytes));
    }
    hex(&h.finalize())
}

fn contained<T>(what: &str, f: impl FnOnce() -> Result<T, SceneError>) -> Result<T, SceneError> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        Err(SceneError::Invalid {
            path: what.into(),
            message: format!(
                "the importer failed on this input: {}",
                super::panic_message(p)
            ),
        })
    })
}

/// A scene for a glTF uploaded alone: one object `model`, the file's first camera (or one
/// framing the model), the file's lights (or a default sun, with a warning).
fn gltf_scene(
    bytes: &[u8],
    binary: bool,
    limits: &Limits,
) -> Result<(SceneDesc, String, Vec<String>), SceneError> {
    let file = if binary { "model.glb" } else { "model.gltf" };
    let imp = import_gltf(bytes, &limits.gltf, None)
        .map_err(|e| SceneError::gltf("body".into(), file, e))?;
    if imp.parts.is_empty() {
        return Err(SceneError::Invalid {
            path: "body".into(),
            message: format!("{file}: the glTF has no triangle meshes to render"),
        });
    }
    let mut warnings = Vec::new();
    let camera = match imp.cameras.first() {
        Some(c) => CameraDesc {
            eye: c.eye.to_array(),
            target: c.target.to_array(),
            up: c.up.to_array(),
            fov_y: c.fov_y,
            width: c.width,
            height: c.height,
        },
        None => {
            let mut lo = glam::Vec3::splat(f32::INFINITY);
            let mut hi = glam::Vec3::splat(f32::NEG_INFINITY);
            for (m, _) in &imp.parts {
                let (a, b) = m.bounds();
                lo = lo.min(a);
                hi = hi.max(b);
            }
            let c = (lo + hi) * 0.5;
            let r = ((hi - lo).length() * 0.5).max(1e-3);
            let fov = 40.0f32;
            let dist = r / (fov.to_radians() * 0.5).sin() * 1.1;
            let eye = c + glam::Vec3::new(0.6, 0.5, 1.0).normalize() * dist;
            warnings.push("no camera in the file: one framing the model was added".into());
            CameraDesc {
                eye: eye.to_array(),
                target: c.to_array(),
                up: [0.0, 1.0, 0.0],
                fov_y: fov,
                width: 256,
                height: 256,
            }
        }
    };
    let lights = if imp.lights.is_empty() {
        warnings.push("no lights in the file: a default directional light was added".into());
        vec![LightDesc::Directional {
            direction: [-0.3, -1.0, -0.5],
            irradiance: Rgb::Grey(3.0),
            angular_radius: 0.0,
        }]
    } else {
        vec![]
    };
    let desc = SceneDesc {
        name: "glTF upload".into(),
        camera,
        lights,
        materials: Default::default(),
        objects: vec![ObjectDesc {
            name: "model".into(),
            shape: ShapeDesc::Gltf { path: file.into() },
            material: None,
            transform: Default::default(),
        }],
        media: Vec::new(),
        ground: false,
    };
    Ok((desc, file.to_string(), warnings))
}

impl Scenes {
    /// Scenes in `store`, resolved within `limits`, with at most `cache_bytes` of resolved
    /// worlds kept in memory.
    pub fn new(store: Arc<Store>, limits: Limits, cache_bytes: u64) -> Scenes {
        Scenes {
            store,
            limits,
            cache: Mutex::new(Cache {
                worlds: HashMap::new(),
                bytes: 0,
                budget: cache_bytes,
                clock: 0,
            }),
        }
    }

    /// Bytes of resolved worlds the cache holds.
    pub fn cache_bytes(&self) -> u64 {
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).bytes
    }

    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Validates, stores and caches an upload. Blocking (it imports meshes): call it from a
    /// blocking thread. Panics in parsers are contained and reported as errors.
    /// Stores a scene (held by `owner`, the API key's name) and resolves it.
    pub fn ingest(&self, input: SceneInput, owner: &str) -> Result<SceneInfo, IngestError> {
        let (desc, files, mut warnings) = match input {
            SceneInput::Json { scene, files } => (parse_scene(&scene)?, files, vec![]),
            SceneInput::Gltf { bytes, binary } => {
                let (desc, file, w) =
                    contained("body", || gltf_scene(&bytes, binary, &self.limits))?;
                (desc, vec![(file, bytes)], w)
            }
        };
        let canonical = serde_json::to_vec(&desc).expect("scene serialises");
        let id = scene_id(&canonical, &files);
        let world = self.resolve_desc(&desc, &files)?;
        warnings.extend(world.warnings.iter().cloned());
        self.store.put_scene(&id, &canonical, &files, owner)?;
        let world = Arc::new(world);
        let info = info_of(&id, &desc, &files, &world, warnings);
        self.remember(&id, world);
        Ok(info)
    }

    fn resolve_desc(
        &self,
        desc: &SceneDesc,
        files: &[(String, Vec<u8>)],
    ) -> Result<World, SceneError> {
        let src = MapSource(files.iter().cloned().collect());
        contained("scene", || resolve(desc, &src, &self.limits))
    }

    /// Drops a deleted scene's resolved world from the cache.
    pub fn forget(&self, id: &str) {
        self.cache
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
    }

    fn remember(&self, id: &str, world: Arc<World>) {
        let mut c = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        c.insert(id, world);
    }

    /// The resolved world of a stored scene.
    pub fn world(&self, id: &str) -> Result<Arc<World>, JobError> {
        if let Some(w) = self.cache.lock().unwrap_or_else(|e| e.into_inner()).get(id) {
            return Ok(w);
        }
        let s = self
            .store
            .get_scene(id)?
            .ok_or_else(|| JobError::UnknownScene(id.into()))?;
        let desc = parse_scene(&s.scene_json)?;
        let w = Arc::new(self.resolve_desc(&desc, &s.files)?);
        self.remember(id, w.clone());
        Ok(w)
    }

    /// What is known about a stored scene, or None.
    pub fn info(&self, id: &str) -> Result<Option<SceneInfo>, JobError> {
        let Some(s) = self.store.get_scene(id)? else {
            return Ok(None);
        };
        let desc = parse_scene(&s.scene_json)?;
        let world = self.world(id)?;
        Ok(Some(info_of(
            id,
            &desc,
            &s.files,
            &world,
            world.warnings.clone(),
        )))
    }
}

fn info_of(
    id: &str,
    desc: &SceneDesc,
    files: &[(String, Vec<u8>)],
    world: &World,
    warnings: Vec<String>,
) -> SceneInfo {
    SceneInfo {
        id: id.into(),
        name: desc.name.clone(),
        objects: world
            .objects
            .iter()
            .map(|o| ObjectInfo {
                name: o.name.clone(),
                triangles: o.triangle_count(),
                specular: o
                    .parts
                    .iter()
                    .any(|p| world.materials[p.material as usize].is_specular()),
            })
            .collect(),
        lights: world.lights.iter().map(|l| l.kind()).collect(),
        triangles: world.triangle_count(),
        warnings,
        files: files.iter().map(|f| f.0.clone()).collect(),
        methods: crate::methods::fits(world),
        scene: serde_json::to_value(desc).expect("scene serialises"),
    }
}

#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Store(#[from] super::store::StoreError),
}

/// A tiny lit plane for the GPU readiness probe.
pub fn probe_world() -> Result<World, SceneError> {
    let json = br#"{
        "camera": {"eye": [0, 2, 2], "target": [0, 0, 0], "width": 4, "height": 4},
        "lights": [{"type": "directional", "direction": [0, -1, 0], "irradiance": 1}],
        "materials": {"m": {"type": "diffuse", "albedo": 0.5}},
        "objects": [{"name": "p", "shape": {"type": "plane", "size": [2, 2]}, "material": "m"}]
    }"#;
    resolve(
        &parse_scene(json)?,
        &MapSource::default(),
        &Limits::default(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(segments: u32) -> SceneInput {
        let scene = serde_json::json!({
            "camera": {"eye": [0, 2, 3], "target": [0, 0, 0], "width": 8, "height": 8},
            "lights": [{"type": "directional", "direction": [0, -1, 0], "irradiance": 1.0}],
            "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
            "objects": [{"name": "s", "shape": {"type": "sphere", "radius": 0.5,
                                                 "segments": segments}, "material": "glass"}]
        });
        SceneInput::Json {
            scene: serde_json::to_vec(&scene).unwrap(),
            files: vec![],
        }
    }

    /// The cache of resolved scenes holds to its byte budget: distinct heavy scenes push the
    /// least recently used out, and a scene larger than the whole budget is not kept.
    #[test]
    fn the_scene_cache_is_bounded_by_bytes() {
        let dir = std::env::temp_dir().join(format!("caustica-scene-cache-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store = Arc::new(Store::open(&dir).unwrap());
        let budget = 4 << 20;
        let scenes = Scenes::new(store, Limits::default(), budget);
        let mut ids = vec![];
        for segments in [200, 201, 202, 203, 204, 205] {
            ids.push(scenes.ingest(sphere(segments), "").unwrap().id);
            assert!(scenes.cache_bytes() <= budget, "{}", scenes.cache_bytes());
        }
        assert!(scenes.cache_bytes() > budget / 2, "the cache is used");
        // The first was pushed out; it is resolved again from the store when asked for.
        let w = scenes.world(&ids[0]).unwrap();
        assert!(w.heap_bytes() > 512 << 10, "{}", w.heap_bytes());
        let big = scenes.ingest(sphere(800), "").unwrap().id;
        assert!(scenes.cache_bytes() <= budget);
        assert!(scenes.world(&big).unwrap().heap_bytes() > budget);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
