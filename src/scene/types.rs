//! The JSON scene description: what a user writes or POSTs.
//!
//! Units and conventions follow DESIGN.md §2: metres, right-handed, +Y up, linear Rec.709 RGB.
//! Lights use Mitsuba 3's definitions so that the same numbers give the same picture.
//! Field names here are the wire format; `api/scene.schema.json` documents the same shape.

use glam::{Mat4, Quat, Vec3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Rgb {
    Grey(f32),
    Rgb([f32; 3]),
}

impl Rgb {
    pub fn vec3(self) -> Vec3 {
        match self {
            Rgb::Grey(g) => Vec3::splat(g),
            Rgb::Rgb(c) => Vec3::from(c),
        }
    }
}

impl From<Vec3> for Rgb {
    fn from(v: Vec3) -> Self {
        Rgb::Rgb(v.to_array())
    }
}

/// A whole scene: one camera, the lights, named materials and objects.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(rename = "Scene")]
pub struct SceneDesc {
    /// Free text, shown in logs.
    #[serde(default)]
    pub name: String,
    pub camera: CameraDesc,
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// Materials by name; objects refer to them by that name.
    #[serde(default)]
    pub materials: std::collections::BTreeMap<String, MaterialDesc>,
    #[serde(default)]
    pub objects: Vec<ObjectDesc>,
    /// Participating media (fog): at most one, for now.
    #[serde(default)]
    pub media: Vec<MediumDesc>,
    /// Adds a diffuse ground plane (albedo 0.6, named `ground`) under the objects, touching
    /// their lowest point: for a glass or mirror object with nothing under it to receive its
    /// shadow and caustic (default false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub ground: bool,
}

/// A homogeneous participating medium: coefficients per metre and channel, a
/// Henyey-Greenstein phase function, and where it is.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    /// Scattering coefficient σs, per metre (a number or [r, g, b]), ≥ 0.
    pub sigma_s: Rgb,
    /// Absorption coefficient σa, per metre, ≥ 0 (default 0).
    #[serde(default)]
    pub sigma_a: Option<Rgb>,
    /// Henyey-Greenstein asymmetry, −1 < g < 1: 0 isotropic (default), > 0 forward.
    #[serde(default)]
    pub g: f32,
    /// Where the medium is (default: the whole scene).
    #[serde(default)]
    pub bounds: MediumBoundsDesc,
}

/// Where a medium is.
#[derive(Clone, Debug, Default, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MediumBoundsDesc {
    /// The whole scene: a box around every object, the camera and the lights, 1 % larger.
    #[default]
    Scene,
    /// A box of `size` (metres, centred on the origin), placed by `transform`.
    Box {
        size: [f32; 3],
        #[serde(default)]
        transform: TransformDesc,
    },
    /// The inside of a closed mesh: a `sphere`, `box`, `torus` or `cylinder` shape (as an
    /// object's), placed by `transform`. Only method `reference` renders it.
    Mesh {
        shape: ShapeDesc,
        #[serde(default)]
        transform: TransformDesc,
    },
}

/// Perspective pinhole camera.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, (0, 180).
    #[serde(default = "default_fov")]
    pub fov_y: f32,
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f32 {
    40.0
}
fn default_size() -> u32 {
    256
}

/// A light source. Delta lights (directional, point, spot) follow Mitsuba 3.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightDesc {
    /// Parallel light travelling along `direction`; `irradiance` in W/m² on a surface facing it.
    Directional {
        direction: [f32; 3],
        irradiance: Rgb,
        /// Angular radius of the source's disc in degrees, 0..=10 (default 0: a delta light;
        /// the sun is 0.265). `irradiance` is the whole disc's.
        #[serde(default)]
        angular_radius: f32,
    },
    /// Isotropic point light; `intensity` in W/sr.
    Point { position: [f32; 3], intensity: Rgb },
    /// Spot light at `position` aimed at `target`; `intensity` in W/sr on the axis, full
    /// intensity inside `beam_width` (degrees from the axis), falling linearly in angle to zero
    /// at `cutoff_angle` (Mitsuba's `spot`).
    Spot {
        position: [f32; 3],
        target: [f32; 3],
        intensity: Rgb,
        #[serde(default = "default_cutoff")]
        cutoff_angle: f32,
        #[serde(default = "default_beam")]
        beam_width: f32,
    },
    /// A segment of isotropic emitters from `start` to `end`; `intensity` (W/sr) is the total,
    /// spread uniformly along the segment (a point light of that intensity when the segment
    /// shrinks to a point).
    Line {
        start: [f32; 3],
        end: [f32; 3],
        intensity: Rgb,
    },
    /// Distant light from all directions: an equirectangular HDR image (`path`) or a constant
    /// `radiance`, multiplied by `scale`. Radiance in W/(m²·sr). The image is read as Mitsuba 3's
    /// `envmap`: the direction d towards the light is at u = atan2(d.x, -d.z)/2π (u = 0 at -Z,
    /// 1/4 at +X), v = acos(d.y)/π, looked up bilinearly between texel centres at u = (i + 0.5)/W
    /// and v = j/(H - 1) (rows 0 and H - 1 on the poles).
    Environment {
        #[serde(default)]
        path: Option<String>,
        #[serde(default)]
        radiance: Option<Rgb>,
        #[serde(default = "one")]
        scale: f32,
    },
}

fn default_cutoff() -> f32 {
    20.0
}
fn default_beam() -> f32 {
    15.0
}
fn one() -> f32 {
    1.0
}

/// Surface materials.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialDesc {
    /// Lambertian, BRDF albedo/π.
    Diffuse { albedo: Rgb },
    /// Diffuse base plus a GGX specular lobe: f = albedo/π + D·G2·F / (4 cosθi cosθo), with
    /// α = roughness², height-correlated Smith G2 and Schlick Fresnel from `specular` (F0).
    Glossy {
        albedo: Rgb,
        #[serde(default = "default_f0")]
        specular: Rgb,
        roughness: f32,
    },
    /// Smooth dielectric: index `ior` inside (1.0 outside), Fresnel-weighted reflection and
    /// refraction, and Beer-Lambert `absorption` (per metre, per channel) inside.
    Dielectric {
        #[serde(default = "default_ior")]
        ior: f32,
        #[serde(default = "zero_rgb")]
        absorption: Rgb,
    },
    /// Perfect specular reflector with reflectance `reflectance`.
    Mirror {
        #[serde(default = "one_rgb")]
        reflectance: Rgb,
    },
}

fn default_f0() -> Rgb {
    Rgb::Grey(0.04)
}
fn default_ior() -> f32 {
    1.5
}
fn zero_rgb() -> Rgb {
    Rgb::Grey(0.0)
}
fn one_rgb() -> Rgb {
    Rgb::Grey(1.0)
}

/// One object: a shape, a material and a transform.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectDesc {
    /// Unique name; bakes and renders refer to objects by it.
    pub name: String,
    pub shape: ShapeDesc,
    /// Name of an entry of `materials`. Required for procedural shapes; for glTF it overrides
    /// the file's materials when given.
    #[serde(default)]
    pub material: Option<String>,
    #[serde(default)]
    pub transform: TransformDesc,
}

/// Geometry. Procedural shapes are centred at the origin in their local frame.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeDesc {
    /// Rectangle in the local y=0 plane, normal +Y, `size` = [x extent, z extent].
    Plane { size: [f32; 2] },
    /// UV sphere with smooth normals; `segments` around the equator (rings = segments/2).
    Sphere {
        radius: f32,
        #[serde(default = "default_segments")]
        segments: u32,
    },
    /// Axis-aligned box with full extents `size`.
    Box { size: [f32; 3] },
    /// Torus around the local Y axis.
    Torus {
        major_radius: f32,
        minor_radius: f32,
        #[serde(default = "default_segments")]
        segments: u32,
    },
    /// Capped cylinder along the local Y axis, from y=-height/2 to y=height/2.
    Cylinder {
        radius: f32,
        height: f32,
        #[serde(default = "default_segments")]
        segments: u32,
    },
    /// A paraboloid dish y = r²/(4·focal_length) around the local Y axis, r ≤ `radius`, open
    /// at the rim, normals on the concave side: light along −Y meets at its focus (0,
    /// focal_length, 0). `segments` around (rings = segments/2).
    Paraboloid {
        focal_length: f32,
        radius: f32,
        #[serde(default = "default_segments")]
        segments: u32,
    },
    /// A glTF 2.0 file (`.glb` or `.gltf` with embedded data), resolved relative to the scene.
    Gltf { path: String },
    /// A procedural water surface over a rectangle (local y = 0 is the mean surface), the water
    /// body below it and optionally a floor. The object's transform may only translate it.
    Water(WaterDesc),
}

/// A water surface, its body and floor (`shape.type = "water"`).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WaterDesc {
    /// [x extent, z extent] of the rectangle, metres.
    pub size: [f32; 2],
    /// The wave function (default: the article preset).
    #[serde(default)]
    pub waves: super::water::WavesDesc,
    /// Seconds (default 0).
    #[serde(default)]
    pub time: f32,
    /// Index of refraction of the water (default 1.33).
    #[serde(default = "water_ior")]
    pub ior: f32,
    /// Beer-Lambert absorption per metre, per channel (default: 77, 78.5 and 80 % transmitted
    /// per metre in R, G, B).
    #[serde(default = "water_absorption")]
    pub absorption: Rgb,
    /// Metres from the mean surface down to the bottom of the body, > 0 (default 1).
    #[serde(default = "one")]
    pub depth: f32,
    /// Albedo of a diffuse floor at `depth` over the whole rectangle (an object named
    /// `<name>-floor`); none when absent.
    #[serde(default)]
    pub floor: Option<Rgb>,
    /// Quads per side of the surface's tessellation, 2..=1024 (default 256): what the
    /// reference and the direct pass see (normals come from the analytic gradient).
    #[serde(default = "water_resolution")]
    pub resolution: u32,
}

fn water_ior() -> f32 {
    1.33
}
fn water_absorption() -> Rgb {
    Rgb::Rgb(super::water::default_absorption())
}
fn water_resolution() -> u32 {
    256
}

fn default_segments() -> u32 {
    128
}

/// Translation, rotation and scale applied as T·R·S.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(default)]
    pub translation: Option<[f32; 3]>,
    /// Rotation as Euler angles in degrees, applied about X, then Y, then Z.
    #[serde(default)]
    pub rotation_deg: Option<[f32; 3]>,
    /// Uniform (one number) or per-axis scale.
    #[serde(default)]
    pub scale: Option<Rgb>,
}

impl TransformDesc {
    pub fn matrix(&self) -> Mat4 {
        let t = Vec3::from(self.translation.unwrap_or([0.0; 3]));
        let r = self.rotation_deg.unwrap_or([0.0; 3]);
        let q = Quat::from_euler(
            glam::EulerRot::ZYX,
            r[2].to_radians(),
            r[1].to_radians(),
            r[0].to_radians(),
        );
        let s = self.scale.map(Rgb::vec3).unwrap_or(Vec3::ONE);
        Mat4::from_scale_rotation_translation(s, q, t)
    }
}

/// The JSON Schema of [`SceneDesc`], as committed in `api/scene.schema.json`.
pub fn scene_schema() -> serde_json::Value {
    let mut v = serde_json::to_value(schemars::schema_for!(SceneDesc)).expect("schema serialises");
    if let Some(o) = v.as_object_mut() {
        o.insert(
            "$id".into(),
            "https://caustica.invalid/api/scene.schema.json".into(),
        );
    }
    v
}
