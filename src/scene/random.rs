//! Scenes nobody tuned a method on, for fidelity fuzzing (`tests/it/fuzz_fidelity.rs`,
//! `examples/fuzz_fidelity.rs`): a glass or mirror object (one of the repository's glTF assets
//! with its materials replaced, or a procedural shape) at a random size and rotation resting
//! on a diffuse floor, lit by a random light (directional, spot, point, or a sky map with a
//! sun), seen by a random camera looking at the floor around the object and its shadow.
//! Deterministic for a seed. Also the procedural sun-and-sky maps (`examples/make_sky.rs`
//! writes the repository's two from [`sky_map`]).

use super::load::{DirSource, Limits, SceneError};
use super::world::{EnvMap, Light, World};
use crate::sampling::Pcg;
use glam::{Mat4, Quat, Vec3};
use std::f64::consts::PI;
use std::path::Path;
use std::sync::Arc;

/// The objects drawn from: (name, shape JSON); the glTF paths are relative to `scenes/`.
pub const SHAPES: [(&str, &str); 9] = [
    (
        "teapot",
        r#"{"type": "gltf", "path": "assets/teapot-glass.glb"}"#,
    ),
    ("blob", r#"{"type": "gltf", "path": "assets/blob.glb"}"#),
    ("cup", r#"{"type": "gltf", "path": "assets/cup.glb"}"#),
    (
        "suzanne",
        r#"{"type": "gltf", "path": "assets/Suzanne-glTF/Suzanne.gltf"}"#,
    ),
    (
        "sphere",
        r#"{"type": "sphere", "radius": 1, "segments": 96}"#,
    ),
    (
        "torus",
        r#"{"type": "torus", "major_radius": 1, "minor_radius": 0.3, "segments": 96}"#,
    ),
    ("box", r#"{"type": "box", "size": [1, 1.4, 0.8]}"#),
    (
        "cylinder",
        r#"{"type": "cylinder", "radius": 0.6, "height": 1.2, "segments": 64}"#,
    ),
    (
        "dish",
        r#"{"type": "paraboloid", "focal_length": 0.6, "radius": 1, "segments": 64}"#,
    ),
];

/// What a random scene is, in a line (for the fuzz table).
#[derive(Clone, Debug, PartialEq)]
pub struct Drawn {
    pub seed: u64,
    pub shape: &'static str,
    /// `glass ior 1.52` or `mirror 0.91`.
    pub material: String,
    /// `directional 34°`, `spot`, `point`, `sky, sun 52°`.
    pub light: String,
}

impl std::fmt::Display for Drawn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "seed {}: {} of {} under {}",
            self.seed, self.shape, self.material, self.light
        )
    }
}

fn uniform(rng: &mut Pcg, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * rng.f32()
}

/// A direction at `elevation` (radians above the horizon) and `azimuth` (radians about +Y).
fn towards(elevation: f32, azimuth: f32) -> Vec3 {
    Vec3::new(
        elevation.cos() * azimuth.cos(),
        elevation.sin(),
        elevation.cos() * azimuth.sin(),
    )
}

/// The random scene of `seed` at `size`² pixels; `scenes` is the repository's `scenes/`
/// folder (its glTF assets).
pub fn random_scene(seed: u64, scenes: &Path, size: u32) -> Result<(World, Drawn), SceneError> {
    let mut rng = Pcg::new(seed, 0xf022);
    let (shape_name, shape) = SHAPES[(rng.next_u32() as usize) % SHAPES.len()];
    let glass = rng.f32() < 0.6;
    let (material, what) = if glass {
        let ior = uniform(&mut rng, 1.3, 1.8);
        (
            format!(r#"{{"type": "dielectric", "ior": {ior}}}"#),
            format!("glass ior {ior:.2}"),
        )
    } else {
        let r = uniform(&mut rng, 0.8, 0.95);
        (
            format!(r#"{{"type": "mirror", "reflectance": {r}}}"#),
            format!("mirror {r:.2}"),
        )
    };
    let albedo = uniform(&mut rng, 0.4, 0.8);
    let json = format!(
        r#"{{"camera": {{"eye": [0, 2, 2], "target": [0, 0, 0], "width": {size}, "height": {size}}},
            "lights": [{{"type": "directional", "direction": [0, -1, 0], "irradiance": 3}}],
            "materials": {{"floor": {{"type": "diffuse", "albedo": {albedo}}}, "thing": {material}}},
            "objects": [
              {{"name": "floor", "shape": {{"type": "plane", "size": [1, 1]}}, "material": "floor"}},
              {{"name": "{shape_name}", "shape": {shape}, "material": "thing"}}]}}"#
    );
    let desc = super::parse_scene(json.as_bytes())?;
    let mut world = super::resolve(&desc, &DirSource(scenes.to_path_buf()), &Limits::default())?;
    // The object: a random rotation, scaled to a bounding radius of 0.3–0.8 m, resting on the
    // floor at the origin.
    let radius = uniform(&mut rng, 0.3, 0.8);
    let axis = crate::sampling::uniform_sphere(rng.vec2());
    let rotation = Quat::from_axis_angle(axis, uniform(&mut rng, 0.0, std::f32::consts::TAU));
    let (lo, hi) = super::world::objects_extent(&world.objects[1..]);
    let scale = radius / ((hi - lo).length() * 0.5).max(1e-6);
    let centre = (lo + hi) * 0.5;
    world.objects[1].transform = Mat4::from_scale_rotation_translation(
        Vec3::splat(scale),
        rotation,
        -rotation * centre * scale,
    );
    let (lo, hi) = super::world::objects_extent(&world.objects[1..]);
    let lift = Vec3::new(-(lo.x + hi.x) * 0.5, -lo.y, -(lo.z + hi.z) * 0.5);
    world.objects[1].transform = Mat4::from_translation(lift) * world.objects[1].transform;
    let height = hi.y - lo.y;
    let middle = Vec3::new(0.0, height * 0.5, 0.0);
    // The light: its direction towards the object, 25–75° above the horizon.
    let elevation = uniform(&mut rng, 25f32.to_radians(), 75f32.to_radians());
    let azimuth = uniform(&mut rng, 0.0, std::f32::consts::TAU);
    let to_light = towards(elevation, azimuth);
    let kind = rng.next_u32() % 4;
    let distance = uniform(&mut rng, 4.0, 7.0) * radius;
    let at = middle + to_light * distance;
    let (light, named) = match kind {
        0 => (
            Light::Directional {
                direction: -to_light,
                irradiance: Vec3::splat(3.0),
                angular_radius: 0.0,
            },
            format!("directional {:.0}°", elevation.to_degrees()),
        ),
        1 => {
            let cutoff = uniform(&mut rng, 20.0, 40.0);
            (
                Light::Spot {
                    position: at,
                    direction: -to_light,
                    intensity: Vec3::splat(3.0 * distance * distance),
                    cutoff: cutoff.to_radians(),
                    beam_width: (0.75 * cutoff).to_radians(),
                },
                format!("spot {:.0}°, cutoff {cutoff:.0}°", elevation.to_degrees()),
            )
        }
        2 => (
            Light::Point {
                position: at,
                intensity: Vec3::splat(3.0 * distance * distance),
            },
            format!("point {:.0}°", elevation.to_degrees()),
        ),
        _ => (
            Light::Environment {
                map: Some(Arc::new(sky_map(
                    Some(to_light.as_dvec3().to_array()),
                    256,
                    128,
                ))),
                radiance: Vec3::ONE,
            },
            format!("sky, sun {:.0}°", elevation.to_degrees()),
        ),
    };
    world.lights = vec![light];
    // The floor: wide enough for the shadow of the lowest light, on every side.
    let floor = 2.0 * (radius + height / 25f32.to_radians().tan()) + 2.0 * distance;
    world.objects[0].transform = Mat4::from_scale(Vec3::new(floor, 1.0, floor));
    // The camera: 30–70° above the floor, looking at the middle of the object and its shadow.
    let shadow = Vec3::new(-to_light.x, 0.0, -to_light.z).normalize_or_zero() * (height * 0.5)
        / elevation.tan();
    let target = Vec3::new(shadow.x * 0.5, 0.0, shadow.z * 0.5);
    let seen = radius + shadow.length() * 0.5 + 0.3 * radius;
    let fov = 45f32;
    let back = seen / (fov.to_radians() * 0.5).tan() * 1.2;
    let eye = target
        + towards(
            uniform(&mut rng, 30f32.to_radians(), 70f32.to_radians()),
            uniform(&mut rng, 0.0, std::f32::consts::TAU),
        ) * back;
    world.camera.eye = eye;
    world.camera.target = target;
    world.camera.up = Vec3::Y;
    world.camera.fov_y = fov;
    world.name = format!("random scene {seed}");
    Ok((
        world,
        Drawn {
            seed,
            shape: shape_name,
            material: what,
            light: named,
        },
    ))
}

/// Sky radiance by elevation (radians): blue at the zenith, paler and brighter at the horizon,
/// a dim dark-grey ground below it (blended over the first 3° below the horizon).
fn sky_radiance(elevation: f64) -> [f64; 3] {
    let zenith = [0.10, 0.18, 0.40];
    let horizon = [0.45, 0.50, 0.55];
    let ground = [0.05, 0.05, 0.05];
    if elevation >= 0.0 {
        let t = (1.0 - elevation / (0.5 * PI)).powf(3.0);
        mix(zenith, horizon, t)
    } else {
        let t = (-elevation / 3f64.to_radians()).min(1.0);
        mix(horizon, ground, t * t * (3.0 - 2.0 * t))
    }
}

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t)
}

/// Unit direction towards (u, v) of an equirectangular map, as [`EnvMap::direction`].
fn uv_direction(u: f64, v: f64) -> [f64; 3] {
    let (st, ct) = (PI * v).sin_cos();
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    [sp * st, ct, -cp * st]
}

/// A sun's angular size: 4π/8000 sr (1.28° radius), 3 W/m² facing it, a warm white.
const SUN_SOLID_ANGLE: f64 = 4.0 * PI / 8000.0;
const SUN_IRRADIANCE: f64 = 3.0;
const SUN_COLOUR: [f64; 3] = [1.0, 0.95, 0.86];

/// The procedural clear sky, `width` × `height` (laid out as Mitsuba's `envmap` reads it,
/// design.md §2), with a sun disc towards `sun` (unit) when given: each texel is the sun's
/// radiance × the fraction of its footprint the disc covers (16 × 16 sub-samples weighted by
/// sin θ), so the disc's power survives sampling.
pub fn sky_map(sun: Option<[f64; 3]>, width: usize, height: usize) -> EnvMap {
    let cos_radius = 1.0 - SUN_SOLID_ANGLE / (2.0 * PI);
    let sun_radiance = SUN_IRRADIANCE / SUN_SOLID_ANGLE;
    let (w, h) = (width as f64, height as f64);
    const SUB: usize = 16;
    let mut texels = Vec::with_capacity(width * height);
    for j in 0..height {
        let v = j as f64 / (h - 1.0);
        let base = sky_radiance(0.5 * PI - PI * v);
        for i in 0..width {
            let u = (i as f64 + 0.5) / w;
            let mut covered = 0.0;
            let mut total = 0.0;
            if let Some(sun) = sun {
                for a in 0..SUB {
                    for b in 0..SUB {
                        let su = u + ((a as f64 + 0.5) / SUB as f64 - 0.5) / w;
                        let sv = v + ((b as f64 + 0.5) / SUB as f64 - 0.5) / (h - 1.0);
                        if !(0.0..=1.0).contains(&sv) {
                            continue;
                        }
                        let d = uv_direction(su, sv);
                        let weight = (PI * sv).sin();
                        total += weight;
                        if d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] >= cos_radius {
                            covered += weight;
                        }
                    }
                }
            }
            let f = if total > 0.0 { covered / total } else { 0.0 };
            let c = mix(base, SUN_COLOUR.map(|c| c * sun_radiance), f);
            texels.push(Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32));
        }
    }
    EnvMap {
        width: width as u32,
        height: height as u32,
        texels,
    }
}

/// The sun of `scenes/assets/sky-sun.hdr`: towards +X at 50° elevation.
pub fn repository_sun() -> [f64; 3] {
    uv_direction(0.25, 0.5 - 50f64.to_radians() / PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_scenes_are_deterministic_and_see_their_object_on_the_floor() {
        let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        for seed in 0..12 {
            let (a, da) = random_scene(seed, &scenes, 32).unwrap();
            let (b, db) = random_scene(seed, &scenes, 32).unwrap();
            assert_eq!(da, db);
            assert_eq!(a.camera.eye, b.camera.eye);
            let (lo, _) = super::super::world::objects_extent(&a.objects[1..]);
            assert!(lo.y.abs() < 1e-4, "{da}: rests on the floor ({lo})");
            // The camera looks down at the floor.
            assert!(a.camera.eye.y > 0.0 && a.camera.target.y == 0.0, "{da}");
        }
    }
}
