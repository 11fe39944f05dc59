//! Parse, validate and resolve a JSON scene into a [`World`].
//!
//! Every error names the offending field path (`objects[1].shape.radius`), so that the CLI and
//! the HTTP API can tell a user exactly what to fix.

use super::gltf::{self as gltf_import, GltfLimits};
use super::shapes;
use super::types::*;
use super::water::{WaterBody, WaterSurface, Waves};
use super::world::*;
use glam::Vec3;
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The bytes are not JSON (a syntax error, or they end early).
    #[error("scene is not valid JSON: {message}")]
    Syntax { message: String },
    /// The JSON does not have the scene's shape.
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    /// A value is out of its allowed range or refers to something missing.
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
    /// A referenced file could not be read.
    #[error("{path}: cannot read '{file}': {message}")]
    Asset {
        path: String,
        file: String,
        message: String,
    },
    /// A limit (triangles, texture size, ...) was exceeded.
    #[error("{path}: {message}")]
    Limit { path: String, message: String },
    /// The process had no room to decode an image in time; the same input may load later.
    #[error("{path}: {message}")]
    Busy { path: String, message: String },
}

impl SceneError {
    /// The error for a glTF import of `file` at `path` that failed.
    pub fn gltf(path: String, file: &str, e: crate::scene::gltf::GltfError) -> SceneError {
        match e {
            crate::scene::gltf::GltfError::Busy(message) => SceneError::Busy {
                path,
                message: format!("{file}: {message}"),
            },
            e => SceneError::Asset {
                path,
                file: file.to_string(),
                message: e.to_string(),
            },
        }
    }
}

impl SceneError {
    fn invalid(path: impl Into<String>, message: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }

    /// The field path the error is about.
    pub fn field(&self) -> &str {
        match self {
            SceneError::Syntax { .. } => "scene",
            SceneError::Parse { path, .. }
            | SceneError::Invalid { path, .. }
            | SceneError::Asset { path, .. }
            | SceneError::Limit { path, .. }
            | SceneError::Busy { path, .. } => path,
        }
    }
}

/// Caps that keep a hostile or mistaken scene from exhausting the machine.
#[derive(Clone, Debug)]
pub struct Limits {
    /// Largest image width or height a camera may ask for, pixels.
    pub max_image_side: u32,
    /// Most triangles in the whole resolved scene.
    pub max_triangles: usize,
    /// Largest tessellation `segments` of a procedural shape.
    pub max_segments: u32,
    /// Largest asset file, bytes.
    pub max_asset_bytes: usize,
    pub max_objects: usize,
    pub max_lights: usize,
    pub gltf: GltfLimits,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_image_side: 8192,
            max_triangles: 4_000_000,
            max_segments: 2048,
            max_asset_bytes: 256 << 20,
            max_objects: 10_000,
            max_lights: 64,
            gltf: GltfLimits::default(),
        }
    }
}

/// Where files named by a scene come from.
pub trait AssetSource: Send + Sync {
    /// The bytes of `name` (a relative path as written in the scene), at most `max_bytes`.
    fn read(&self, name: &str, max_bytes: usize) -> Result<Vec<u8>, String>;
}

/// Files under one directory; absolute paths and `..` are refused.
pub struct DirSource(pub PathBuf);

impl AssetSource for DirSource {
    fn read(&self, name: &str, max_bytes: usize) -> Result<Vec<u8>, String> {
        let rel = Path::new(name);
        if rel
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
        {
            return Err("only relative paths inside the scene's directory are allowed".into());
        }
        let full = self.0.join(rel);
        let len = std::fs::metadata(&full).map_err(|e| e.to_string())?.len();
        if len > max_bytes as u64 {
            return Err(format!("file is {len} bytes, the limit is {max_bytes}"));
        }
        std::fs::read(&full).map_err(|e| e.to_string())
    }
}

/// Files held in memory by name (uploads).
#[derive(Default)]
pub struct MapSource(pub HashMap<String, Vec<u8>>);

impl AssetSource for MapSource {
    fn read(&self, name: &str, max_bytes: usize) -> Result<Vec<u8>, String> {
        let b = self
            .0
            .get(name)
            .ok_or_else(|| "no file of that name was uploaded with the scene".to_string())?;
        if b.len() > max_bytes {
            return Err(format!(
                "file is {} bytes, the limit is {max_bytes}",
                b.len()
            ));
        }
        Ok(b.clone())
    }
}

/// Parse scene JSON; errors carry the JSON path of the field at fault.
pub fn parse_scene(json: &[u8]) -> Result<SceneDesc, SceneError> {
    // Refuse a hostile shape before building anything from it.
    super::shape::check_shape(json, &Default::default()).map_err(|e| SceneError::Parse {
        path: if e.path == "." {
            "scene".into()
        } else {
            e.path
        },
        message: e.message,
    })?;
    let de = &mut serde_json::Deserializer::from_slice(json);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        match inner.classify() {
            serde_json::error::Category::Data => SceneError::Parse {
                path: if path == "." { "scene".into() } else { path },
                message: inner.to_string(),
            },
            _ => SceneError::Syntax {
                message: inner.to_string(),
            },
        }
    })
}

/// Parse and resolve scene JSON that refers to no asset files (procedural shapes only), with
/// the default limits.
pub fn load_scene_json(json: &[u8]) -> Result<World, SceneError> {
    resolve(
        &parse_scene(json)?,
        &MapSource::default(),
        &Limits::default(),
    )
}

/// Read a scene file from disk and resolve it, assets relative to its directory.
pub fn load_scene_file(path: &Path, limits: &Limits) -> Result<World, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::Asset {
        path: "scene".into(),
        file: path.display().to_string(),
        message: e.to_string(),
    })?;
    let desc = parse_scene(&bytes)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    resolve(&desc, &DirSource(dir), limits)
}

fn finite3(path: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vec3::from(v))
    } else {
        Err(SceneError::invalid(path, "must be finite numbers"))
    }
}

fn unit3(path: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
    let d = finite3(path, v)?;
    if d.length() < 1e-8 {
        return Err(SceneError::invalid(path, "must be a non-zero vector"));
    }
    Ok(d.normalize())
}

fn nonneg_rgb(path: &str, c: Rgb) -> Result<Vec3, SceneError> {
    let v = c.vec3();
    if !v.is_finite() || v.min_element() < 0.0 {
        return Err(SceneError::invalid(
            path,
            "must be finite and non-negative (a number or [r, g, b])",
        ));
    }
    Ok(v)
}

fn albedo(path: &str, c: Rgb) -> Result<Vec3, SceneError> {
    let v = nonneg_rgb(path, c)?;
    if v.max_element() > 1.0 {
        return Err(SceneError::invalid(path, "must lie in [0, 1]"));
    }
    Ok(v)
}

fn positive(path: &str, x: f32) -> Result<f32, SceneError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(SceneError::invalid(path, "must be a finite number > 0"))
    }
}

/// Check the camera and turn it into its resolved form.
pub fn resolve_camera(c: &CameraDesc, limits: &Limits) -> Result<Camera, SceneError> {
    let eye = finite3("camera.eye", c.eye)?;
    let target = finite3("camera.target", c.target)?;
    let up = unit3("camera.up", c.up)?;
    if (target - eye).length() < 1e-6 {
        return Err(SceneError::invalid(
            "camera.target",
            "must differ from camera.eye",
        ));
    }
    if (target - eye).normalize().cross(up).length() < 1e-4 {
        return Err(SceneError::invalid(
            "camera.up",
            "must not be parallel to the viewing direction",
        ));
    }
    if !(c.fov_y > 0.5 && c.fov_y < 179.0) {
        return Err(SceneError::invalid(
            "camera.fov_y",
            "vertical field of view must lie in (0.5, 179) degrees",
        ));
    }
    for (name, v) in [("camera.width", c.width), ("camera.height", c.height)] {
        if v == 0 || v > limits.max_image_side {
            return Err(SceneError::Limit {
                path: name.into(),
                message: format!("must lie in 1..={}", limits.max_image_side),
            });
        }
    }
    Ok(Camera {
        eye,
        target,
        up,
        fov_y: c.fov_y,
        width: c.width,
        height: c.height,
    })
}

/// Check a light and turn it into its resolved form.
pub fn resolve_light(
    path: &str,
    l: &LightDesc,
    assets: &dyn AssetSource,
    limits: &Limits,
) -> Result<Light, SceneError> {
    let p = |f: &str| format!("{path}.{f}");
    Ok(match l {
        LightDesc::Directional {
            direction,
            irradiance,
            angular_radius,
        } => {
            if !(angular_radius.is_finite() && (0.0..=10.0).contains(angular_radius)) {
                return Err(SceneError::invalid(
                    p("angular_radius"),
                    "must lie in 0..=10 (degrees)",
                ));
            }
            Light::Directional {
                direction: unit3(&p("direction"), *direction)?,
                irradiance: nonneg_rgb(&p("irradiance"), *irradiance)?,
                angular_radius: angular_radius.to_radians(),
            }
        }
        LightDesc::Point {
            position,
            intensity,
        } => Light::Point {
            position: finite3(&p("position"), *position)?,
            intensity: nonneg_rgb(&p("intensity"), *intensity)?,
        },
        LightDesc::Spot {
            position,
            target,
            intensity,
            cutoff_angle,
            beam_width,
        } => {
            let pos = finite3(&p("position"), *position)?;
            let tgt = finite3(&p("target"), *target)?;
            if (tgt - pos).length() < 1e-6 {
                return Err(SceneError::invalid(
                    p("target"),
                    "must differ from position",
                ));
            }
            if !(*cutoff_angle > 0.0 && *cutoff_angle < 90.0) {
                return Err(SceneError::invalid(
                    p("cutoff_angle"),
                    "must lie in (0, 90) degrees",
                ));
            }
            if !(*beam_width > 0.0 && *beam_width <= *cutoff_angle) {
                return Err(SceneError::invalid(
                    p("beam_width"),
                    "must lie in (0, cutoff_angle] degrees",
                ));
            }
            Light::Spot {
                position: pos,
                direction: (tgt - pos).normalize(),
                intensity: nonneg_rgb(&p("intensity"), *intensity)?,
                cutoff: cutoff_angle.to_radians(),
                beam_width: beam_width.to_radians(),
            }
        }
        LightDesc::Line {
            start,
            end,
            intensity,
        } => Light::Line {
            start: finite3(&p("start"), *start)?,
            end: finite3(&p("end"), *end)?,
            intensity: nonneg_rgb(&p("intensity"), *intensity)?,
        },
        LightDesc::Environment {
            path: file,
            radiance,
            scale,
        } => {
            if !(scale.is_finite() && *scale >= 0.0) {
                return Err(SceneError::invalid(p("scale"), "must be finite and >= 0"));
            }
            let base = match radiance {
                Some(c) => nonneg_rgb(&p("radiance"), *c)?,
                None => Vec3::ONE,
            };
            let map = match file {
                Some(f) => Some(Arc::new(load_env_map(&p("path"), f, assets, limits)?)),
                None if radiance.is_none() => {
                    return Err(SceneError::invalid(
                        path.to_string(),
                        "an environment light needs `path` or `radiance`",
                    ));
                }
                None => None,
            };
            Light::Environment {
                map,
                radiance: base * *scale,
            }
        }
    })
}

fn load_env_map(
    path: &str,
    file: &str,
    assets: &dyn AssetSource,
    limits: &Limits,
) -> Result<EnvMap, SceneError> {
    let bytes = assets
        .read(file, limits.max_asset_bytes)
        .map_err(|message| SceneError::Asset {
            path: path.into(),
            file: file.into(),
            message,
        })?;
    let img = super::image::decode_image_limited(&bytes, limits.gltf.max_texture_side).map_err(
        |message| SceneError::Asset {
            path: path.into(),
            file: file.into(),
            message,
        },
    )?;
    let rgb = img.to_rgb32f();
    let (width, height) = rgb.dimensions();
    Ok(EnvMap {
        width,
        height,
        texels: rgb.pixels().map(|p| Vec3::from(p.0)).collect(),
    })
}

fn resolve_material(path: &str, m: &MaterialDesc) -> Result<Material, SceneError> {
    let p = |f: &str| format!("{path}.{f}");
    Ok(match m {
        MaterialDesc::Diffuse { albedo: a } => Material::Diffuse {
            albedo: albedo(&p("albedo"), *a)?,
        },
        MaterialDesc::Glossy {
            albedo: a,
            specular,
            roughness,
        } => {
            if !(*roughness >= 0.02 && *roughness <= 1.0) {
                return Err(SceneError::invalid(
                    p("roughness"),
                    "must lie in [0.02, 1] (use a mirror for smoother surfaces)",
                ));
            }
            Material::Glossy {
                albedo: albedo(&p("albedo"), *a)?,
                specular: albedo(&p("specular"), *specular)?,
                roughness: *roughness,
            }
        }
        MaterialDesc::Dielectric { ior, absorption } => {
            if !(ior.is_finite() && *ior >= 1.0 && *ior <= 4.0) {
                return Err(SceneError::invalid(p("ior"), "must lie in [1, 4]"));
            }
            Material::Dielectric {
                ior: *ior,
                absorption: nonneg_rgb(&p("absorption"), *absorption)?,
            }
        }
        MaterialDesc::Mirror { reflectance } => Material::Mirror {
            reflectance: albedo(&p("reflectance"), *reflectance)?,
        },
    })
}

fn check_segments(path: &str, s: u32, limits: &Limits) -> Result<u32, SceneError> {
    if s < 3 || s > limits.max_segments {
        return Err(SceneError::Limit {
            path: path.into(),
            message: format!("must lie in 3..={}", limits.max_segments),
        });
    }
    Ok(s)
}

/// Validate `desc` and build the [`World`]: meshes generated or imported, every reference
/// checked, every limit enforced.
pub fn resolve(
    desc: &SceneDesc,
    assets: &dyn AssetSource,
    limits: &Limits,
) -> Result<World, SceneError> {
    let camera = resolve_camera(&desc.camera, limits)?;
    if desc.lights.len() > limits.max_lights {
        return Err(SceneError::Limit {
            path: "lights".into(),
            message: format!("at most {} lights", limits.max_lights),
        });
    }
    if desc.objects.len() > limits.max_objects {
        return Err(SceneError::Limit {
            path: "objects".into(),
            message: format!("at most {} objects", limits.max_objects),
        });
    }
    let mut lights = desc
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| resolve_light(&format!("lights[{i}]"), l, assets, limits))
        .collect::<Result<Vec<_>, _>>()?;

    let mut materials = Vec::new();
    let mut by_name = HashMap::new();
    for (name, m) in &desc.materials {
        by_name.insert(name.as_str(), materials.len() as u32);
        materials.push(resolve_material(&format!("materials.{name}"), m)?);
    }

    let mut objects = Vec::new();
    let mut warnings = Vec::new();
    let mut names = std::collections::HashSet::new();
    let mut triangles = 0usize;
    let mut water = Vec::new();
    let mut floors: Vec<(usize, Mesh, u32)> = Vec::new();
    for (i, o) in desc.objects.iter().enumerate() {
        let path = format!("objects[{i}]");
        if o.name.is_empty() || !names.insert(o.name.clone()) {
            return Err(SceneError::invalid(
                format!("{path}.name"),
                format!("'{}' must be non-empty and unique", o.name),
            ));
        }
        let material = match &o.material {
            Some(m) => Some(*by_name.get(m.as_str()).ok_or_else(|| {
                SceneError::invalid(
                    format!("{path}.material"),
                    format!("no material named '{m}' in `materials`"),
                )
            })?),
            None => None,
        };
        let tr = &o.transform;
        if let Some(t) = tr.translation {
            finite3(&format!("{path}.transform.translation"), t)?;
        }
        if let Some(r) = tr.rotation_deg {
            finite3(&format!("{path}.transform.rotation_deg"), r)?;
        }
        if let Some(s) = tr.scale {
            let v = s.vec3();
            if !v.is_finite() || v.abs().min_element() < 1e-6 {
                return Err(SceneError::invalid(
                    format!("{path}.transform.scale"),
                    "must be finite and non-zero",
                ));
            }
        }
        let need_material = || {
            material.ok_or_else(|| {
                SceneError::invalid(
                    format!("{path}.material"),
                    "procedural shapes need a material",
                )
            })
        };
        let sp = |f: &str| format!("{path}.shape.{f}");
        let parts = match &o.shape {
            ShapeDesc::Plane { size } => vec![(
                shapes::plane(
                    positive(&sp("size[0]"), size[0])?,
                    positive(&sp("size[1]"), size[1])?,
                ),
                need_material()?,
            )],
            ShapeDesc::Sphere { radius, segments } => vec![(
                shapes::sphere(
                    positive(&sp("radius"), *radius)?,
                    check_segments(&sp("segments"), *segments, limits)?,
                ),
                need_material()?,
            )],
            ShapeDesc::Box { size } => {
                for (k, s) in size.iter().enumerate() {
                    positive(&sp(&format!("size[{k}]")), *s)?;
                }
                vec![(shapes::cuboid(Vec3::from(*size)), need_material()?)]
            }
            ShapeDesc::Torus {
                major_radius,
                minor_radius,
                segments,
            } => vec![(
                shapes::torus(
                    positive(&sp("major_radius"), *major_radius)?,
                    positive(&sp("minor_radius"), *minor_radius)?,
                    check_segments(&sp("segments"), *segments, limits)?,
                ),
                need_material()?,
            )],
            ShapeDesc::Paraboloid {
                focal_length,
                radius,
                segments,
            } => vec![(
                shapes::paraboloid(
                    positive(&sp("focal_length"), *focal_length)?,
                    positive(&sp("radius"), *radius)?,
                    check_segments(&sp("segments"), *segments, limits)?,
                ),
                need_material()?,
            )],
            ShapeDesc::Cylinder {
                radius,
                height,
                segments,
            } => vec![(
                shapes::cylinder(
                    positive(&sp("radius"), *radius)?,
                    positive(&sp("height"), *height)?,
                    check_segments(&sp("segments"), *segments, limits)?,
                ),
                need_material()?,
            )],
            ShapeDesc::Water(wd) => {
                if material.is_some() {
                    return Err(SceneError::invalid(
                        format!("{path}.material"),
                        "a water shape sets its own material (shape.ior, shape.absorption)",
                    ));
                }
                if tr.rotation_deg.is_some_and(|r| r != [0.0; 3]) || tr.scale.is_some() {
                    return Err(SceneError::invalid(
                        format!("{path}.transform"),
                        "a water shape may only be translated (waves are horizontal)",
                    ));
                }
                let (body, meshes) = resolve_water(&path, wd, tr, objects.len(), limits)?;
                materials.push(Material::Dielectric {
                    ior: body.ior,
                    // The body's medium absorbs (World::medium_transmittance), not the surface.
                    absorption: Vec3::ZERO,
                });
                let surface_material = materials.len() as u32 - 1;
                if let (Some(floor), Some(albedo)) = (meshes.1, wd.floor) {
                    // The floor is an object of its own (`<name>-floor`), after the surface.
                    materials.push(resolve_material(
                        &sp("floor"),
                        &MaterialDesc::Diffuse { albedo },
                    )?);
                    floors.push((objects.len(), floor, materials.len() as u32 - 1));
                }
                water.push(body);
                vec![(meshes.0, surface_material)]
            }
            ShapeDesc::Gltf { path: file } => {
                let bytes = assets
                    .read(file, limits.max_asset_bytes)
                    .map_err(|message| SceneError::Asset {
                        path: sp("path"),
                        file: file.clone(),
                        message,
                    })?;
                // Relative URIs inside a .gltf resolve next to it, not next to the scene.
                let beside = gltf_import::PrefixedSource::beside(assets, file);
                let imported = gltf_import::import_gltf(&bytes, &limits.gltf, Some(&beside))
                    .map_err(|e| SceneError::gltf(sp("path"), file, e))?;
                warnings.extend(imported.warnings.iter().map(|w| format!("{file}: {w}")));
                let m = o.transform.matrix();
                // Lights inside the file move with the object.
                for l in imported.lights {
                    lights.push(transform_light(l, m));
                }
                // glTF absorption is per unit of the file; the object's scale changes the
                // distances light travels inside, so rescale it to per metre.
                let scale = m.determinant().abs().cbrt().max(1e-6);
                imported
                    .parts
                    .into_iter()
                    .map(|(mesh, mat)| {
                        let mat = match mat {
                            Material::Dielectric { ior, absorption } => Material::Dielectric {
                                ior,
                                absorption: absorption / scale,
                            },
                            other => other,
                        };
                        let id = material.unwrap_or_else(|| {
                            materials.push(mat);
                            materials.len() as u32 - 1
                        });
                        (mesh, id)
                    })
                    .collect()
            }
        };
        let n: usize = parts.iter().map(|(m, _)| m.triangle_count()).sum();
        triangles += n;
        if triangles > limits.max_triangles {
            return Err(SceneError::Limit {
                path: format!("{path}.shape"),
                message: format!(
                    "the scene has more than {} triangles (limit)",
                    limits.max_triangles
                ),
            });
        }
        objects.push(Object {
            name: o.name.clone(),
            parts: parts
                .into_iter()
                .map(|(mesh, material)| Part {
                    mesh: Arc::new(mesh),
                    material,
                })
                .collect(),
            transform: o.transform.matrix(),
        });
        // A water's floor follows its surface.
        if let Some(&(surface, ref mesh, material)) = floors.last()
            && surface == objects.len() - 1
        {
            let name = format!("{}-floor", o.name);
            if !names.insert(name.clone()) {
                return Err(SceneError::invalid(
                    format!("{path}.name"),
                    format!("the water's floor would be named '{name}', which is taken"),
                ));
            }
            if let Some(w) = water.last_mut() {
                w.floor = Some(objects.len());
            }
            objects.push(Object {
                name,
                parts: vec![Part {
                    mesh: Arc::new(mesh.clone()),
                    material,
                }],
                transform: o.transform.matrix(),
            });
        }
    }
    if lights.len() > limits.max_lights {
        return Err(SceneError::Limit {
            path: "lights".into(),
            message: format!(
                "at most {} lights (counting glTF lights)",
                limits.max_lights
            ),
        });
    }
    check_extent(&camera, &lights, &objects)?;
    let media = resolve_media(&desc.media, &objects, &camera, &lights, limits)?;
    if !media.is_empty() {
        warnings.push(
            "the scene's medium is rendered by method reference (all of it) and method beams \
             (single scattering); the other methods ignore it"
                .into(),
        );
    }
    let mut world = World {
        name: desc.name.clone(),
        camera,
        lights,
        materials,
        objects,
        warnings,
        water,
        media,
        has_ground: false,
    };
    if desc.ground {
        super::ground::add_ground(&mut world);
    }
    Ok(world)
}

/// How far from the origin (metres, along any axis) a scene may reach: every object's
/// transformed bounds, the camera's eye and target and the lights' positions. Beyond it single
/// precision cannot place a ray on a surface (at 10⁵ m a float's step is 8 mm), and extreme
/// values (a radius of 3·10³⁸) made the tracers index out of bounds or run on forever.
pub const WORLD_EXTENT: f32 = 1.0e5;

/// The smallest an object may be, relative to its distance from the origin (and absolute,
/// in metres, within a metre of it): about a hundred single-precision steps.
pub const MIN_SPAN: f32 = 1.0e-5;

/// Refuses a scene that reaches past [`WORLD_EXTENT`], whose transformed geometry is not
/// finite, or with an object smaller than [`MIN_SPAN`] allows, naming the object, light or
/// camera field.
fn check_extent(camera: &Camera, lights: &[Light], objects: &[Object]) -> Result<(), SceneError> {
    let within = |p: Vec3| p.is_finite() && p.abs().max_element() <= WORLD_EXTENT;
    let far = |what: &str| {
        format!(
            "{what} reaches beyond the world's extent: every coordinate must be finite and within \
             ±{WORLD_EXTENT} m of the origin"
        )
    };
    for (field, p) in [("camera.eye", camera.eye), ("camera.target", camera.target)] {
        if !within(p) {
            return Err(SceneError::invalid(field, far("the camera")));
        }
    }
    for (i, l) in lights.iter().enumerate() {
        let points: Vec<Vec3> = match *l {
            Light::Point { position, .. } | Light::Spot { position, .. } => vec![position],
            Light::Line { start, end, .. } => vec![start, end],
            _ => Vec::new(),
        };
        if !points.into_iter().all(within) {
            return Err(SceneError::invalid(
                format!("lights[{i}]"),
                far("the light"),
            ));
        }
    }
    for o in objects {
        for part in &o.parts {
            let (lo, hi) = part.mesh.bounds();
            if part.mesh.positions.is_empty() {
                continue;
            }
            let corners = (0..8).map(|k| {
                Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                )
            });
            let world: Vec<Vec3> = corners.map(|c| o.transform.transform_point3(c)).collect();
            if !(lo.is_finite() && hi.is_finite() && world.iter().all(|&c| within(c))) {
                return Err(SceneError::invalid(
                    "objects",
                    far(&format!("object '{}'", o.name)),
                ));
            }
            // Smaller than about a hundred float steps at its place, its triangles collapse
            // onto each other (a sphere of 10⁻¹² m made the BVH builder fail).
            let (wlo, whi) = world
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), &c| {
                    (a.min(c), b.max(c))
                });
            let span = (whi - wlo).length();
            let need = MIN_SPAN * (wlo.abs().max(whi.abs()).max_element()).max(1.0);
            if span < need {
                return Err(SceneError::invalid(
                    "objects",
                    format!(
                        "object '{}' spans {span:.1e} m, too small to trace where it is: at \
                         least {need:.1e} m ({MIN_SPAN:.0e} of its distance from the origin, \
                         and 10 µm near it)",
                        o.name
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Checks the scene's media and places them: a box, or the whole scene (every object, the
/// camera's eye and the lights' positions, 1 % larger and at least 1 cm more on each side).
fn resolve_media(
    media: &[MediumDesc],
    objects: &[Object],
    camera: &Camera,
    lights: &[Light],
    limits: &Limits,
) -> Result<Vec<crate::scene::Medium>, SceneError> {
    if media.len() > 1 {
        return Err(SceneError::invalid(
            "media",
            "at most one medium a scene, for now",
        ));
    }
    let mut out = Vec::new();
    for (i, m) in media.iter().enumerate() {
        let p = |f: &str| format!("media[{i}].{f}");
        let sigma_s = nonneg_rgb(&p("sigma_s"), m.sigma_s)?;
        let sigma_a = match m.sigma_a {
            Some(c) => nonneg_rgb(&p("sigma_a"), c)?,
            None => Vec3::ZERO,
        };
        if !(m.g.is_finite() && m.g.abs() < 1.0) {
            return Err(SceneError::invalid(p("g"), "must lie in (-1, 1)"));
        }
        if (sigma_s + sigma_a).max_element() > 1e6 {
            return Err(SceneError::invalid(
                p("sigma_s"),
                "sigma_s + sigma_a must be at most 1e6 per metre",
            ));
        }
        let (transform, half) = match &m.bounds {
            MediumBoundsDesc::Mesh { shape, transform } => {
                let t = transform.matrix();
                if !t.is_finite() || t.determinant().abs() < 1e-12 {
                    return Err(SceneError::invalid(
                        p("bounds.transform"),
                        "must be finite and invertible",
                    ));
                }
                let sp = |f: &str| p(&format!("bounds.shape.{f}"));
                let mesh = match shape {
                    ShapeDesc::Sphere { radius, segments } => shapes::sphere(
                        positive(&sp("radius"), *radius)?,
                        check_segments(&sp("segments"), *segments, limits)?,
                    ),
                    ShapeDesc::Box { size } => {
                        for (k, s) in size.iter().enumerate() {
                            positive(&sp(&format!("size[{k}]")), *s)?;
                        }
                        shapes::cuboid(Vec3::from(*size))
                    }
                    ShapeDesc::Torus {
                        major_radius,
                        minor_radius,
                        segments,
                    } => shapes::torus(
                        positive(&sp("major_radius"), *major_radius)?,
                        positive(&sp("minor_radius"), *minor_radius)?,
                        check_segments(&sp("segments"), *segments, limits)?,
                    ),
                    ShapeDesc::Cylinder {
                        radius,
                        height,
                        segments,
                    } => shapes::cylinder(
                        positive(&sp("radius"), *radius)?,
                        positive(&sp("height"), *height)?,
                        check_segments(&sp("segments"), *segments, limits)?,
                    ),
                    _ => {
                        return Err(SceneError::invalid(
                            sp("type"),
                            "a medium's mesh must be a closed shape: sphere, box, torus or \
                             cylinder",
                        ));
                    }
                }
                .transformed(t);
                if !crate::scene::medium::is_closed(&mesh) {
                    return Err(SceneError::invalid(
                        p("bounds.shape"),
                        "the mesh is not closed",
                    ));
                }
                out.push(crate::scene::Medium::inside_mesh(
                    sigma_s, sigma_a, m.g, &mesh,
                ));
                continue;
            }
            MediumBoundsDesc::Box { size, transform } => {
                let s = finite3(&p("bounds.size"), *size)?;
                if s.min_element() <= 0.0 {
                    return Err(SceneError::invalid(
                        p("bounds.size"),
                        "must be three finite numbers > 0",
                    ));
                }
                let t = transform.matrix();
                if !t.is_finite() || t.determinant().abs() < 1e-12 {
                    return Err(SceneError::invalid(
                        p("bounds.transform"),
                        "must be finite and invertible",
                    ));
                }
                (t, s * 0.5)
            }
            MediumBoundsDesc::Scene => {
                let (lo, hi) = objects_extent(objects);
                let (mut lo, mut hi) = (lo.min(camera.eye), hi.max(camera.eye));
                for l in lights {
                    let points: &[Vec3] = match l {
                        Light::Point { position, .. } | Light::Spot { position, .. } => {
                            std::slice::from_ref(position)
                        }
                        Light::Line { start, end, .. } => &[*start, *end],
                        _ => &[],
                    };
                    for p in points {
                        lo = lo.min(*p);
                        hi = hi.max(*p);
                    }
                }
                let pad = Vec3::splat(0.01) + (hi - lo) * 0.01;
                (
                    glam::Mat4::from_translation((lo + hi) * 0.5),
                    (hi - lo) * 0.5 + pad,
                )
            }
        };
        out.push(crate::scene::Medium::new(
            sigma_s, sigma_a, m.g, transform, half,
        ));
    }
    Ok(out)
}

/// Checks a water shape and builds its body, its surface mesh and its floor's mesh (in the
/// object's frame).
fn resolve_water(
    path: &str,
    wd: &WaterDesc,
    tr: &TransformDesc,
    object: usize,
    limits: &Limits,
) -> Result<(WaterBody, (Mesh, Option<Mesh>)), SceneError> {
    let sp = |f: &str| format!("{path}.shape.{f}");
    let size = glam::Vec2::new(
        positive(&sp("size[0]"), wd.size[0])?,
        positive(&sp("size[1]"), wd.size[1])?,
    );
    if !(wd.time.is_finite() && wd.time.abs() <= super::water::MAX_TIME) {
        return Err(SceneError::invalid(
            sp("time"),
            format!(
                "must be a number of seconds within ±{}",
                super::water::MAX_TIME
            ),
        ));
    }
    if !(wd.ior.is_finite() && wd.ior > 1.0 && wd.ior <= 3.0) {
        return Err(SceneError::invalid(sp("ior"), "must lie in (1, 3]"));
    }
    let absorption = nonneg_rgb(&sp("absorption"), wd.absorption)?;
    let depth = positive(&sp("depth"), wd.depth)?;
    if let Some(a) = wd.floor {
        nonneg_rgb(&sp("floor"), a)?;
    }
    if !(2..=1024).contains(&wd.resolution) {
        return Err(SceneError::Limit {
            path: sp("resolution"),
            message: "must lie in 2..=1024".into(),
        });
    }
    if (wd.resolution as usize).pow(2) * 2 > limits.max_triangles {
        return Err(SceneError::Limit {
            path: sp("resolution"),
            message: format!("more than {} triangles (limit)", limits.max_triangles),
        });
    }
    let waves = Waves::resolve(&wd.waves, &sp("waves"))
        .map_err(|(field, message)| SceneError::invalid(field, message))?;
    let surface = WaterSurface::new(
        Vec3::from(tr.translation.unwrap_or([0.0; 3])),
        size,
        waves,
        wd.time,
    );
    if surface.amplitude_bound() >= depth {
        return Err(SceneError::invalid(
            sp("depth"),
            format!(
                "must exceed the waves' height ({:.3} m), so that the floor stays under water",
                surface.amplitude_bound()
            ),
        ));
    }
    let mesh = surface.mesh(wd.resolution);
    let floor = wd.floor.map(|_| {
        let mut m = shapes::plane(size.x, size.y);
        for p in &mut m.positions {
            p.y = -depth;
        }
        m
    });
    Ok((
        WaterBody {
            object,
            surface,
            depth,
            ior: wd.ior,
            absorption,
            floor: None,
            resolution: wd.resolution,
        },
        (mesh, floor),
    ))
}

/// Move a light by an object's transform.
pub fn transform_light(l: Light, m: glam::Mat4) -> Light {
    match l {
        Light::Directional {
            direction,
            irradiance,
            angular_radius,
        } => Light::Directional {
            direction: m.transform_vector3(direction).normalize(),
            irradiance,
            angular_radius,
        },
        Light::Point {
            position,
            intensity,
        } => Light::Point {
            position: m.transform_point3(position),
            intensity,
        },
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff,
            beam_width,
        } => Light::Spot {
            position: m.transform_point3(position),
            direction: m.transform_vector3(direction).normalize(),
            intensity,
            cutoff,
            beam_width,
        },
        Light::Line {
            start,
            end,
            intensity,
        } => Light::Line {
            start: m.transform_point3(start),
            end: m.transform_point3(end),
            intensity,
        },
        env @ Light::Environment { .. } => env,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPHERE: &str = r#"{
        "camera": {"eye": [0, 3.2, 3.2], "target": [0.35, 0, 0], "fov_y": 40},
        "lights": [{"type": "directional", "direction": [1, -1.2, 0], "irradiance": 3.0}],
        "materials": {"floor": {"type": "diffuse", "albedo": 0.6},
                      "glass": {"type": "dielectric", "ior": 1.5}},
        "objects": [
            {"name": "floor", "shape": {"type": "plane", "size": [8, 8]}, "material": "floor"},
            {"name": "glass", "shape": {"type": "sphere", "radius": 0.5}, "material": "glass",
             "transform": {"translation": [0, 0.58, 0]}}
        ]
    }"#;

    fn load(json: &str) -> Result<World, SceneError> {
        resolve(
            &parse_scene(json.as_bytes())?,
            &MapSource::default(),
            &Limits::default(),
        )
    }

    #[test]
    fn loads_canonical_scene() {
        let w = load(SPHERE).unwrap();
        assert_eq!(w.objects.len(), 2);
        assert_eq!(w.camera.width, 256);
        let (lo, hi) = w.bounds();
        assert!((hi.y - 1.08).abs() < 1e-4 && (lo.x + 4.0).abs() < 1e-5);
    }

    #[test]
    fn errors_name_the_field() {
        let bad = SPHERE.replace("\"radius\": 0.5", "\"radius\": -1");
        assert_eq!(load(&bad).unwrap_err().field(), "objects[1].shape.radius");
        let bad = SPHERE.replace("\"ior\": 1.5", "\"ior\": \"x\"");
        // serde reports inside internally tagged enums at the enum's path; the message names
        // the type expected.
        let e = load(&bad).unwrap_err();
        assert_eq!(e.field(), "materials.glass", "{e}");
        assert!(e.to_string().contains("expected f32"), "{e}");
        let bad = SPHERE.replace("\"material\": \"glass\"", "\"material\": \"gold\"");
        assert_eq!(load(&bad).unwrap_err().field(), "objects[1].material");
        let bad = SPHERE.replace("\"irradiance\": 3.0", "\"irradiance\": [1, -2, 3]");
        assert_eq!(load(&bad).unwrap_err().field(), "lights[0].irradiance");
        let bad = SPHERE.replace("\"fov_y\": 40", "\"fov_y\": 40, \"width\": 100000");
        assert_eq!(load(&bad).unwrap_err().field(), "camera.width");
        let bad = SPHERE.replace("\"radius\": 0.5", "\"radius\": 0.5, \"segments\": 1000000");
        assert_eq!(load(&bad).unwrap_err().field(), "objects[1].shape.segments");
    }

    #[test]
    fn dir_source_refuses_escapes() {
        let s = DirSource(PathBuf::from("."));
        assert!(s.read("../etc/passwd", 1 << 20).is_err());
        assert!(s.read("/etc/passwd", 1 << 20).is_err());
    }
}
